"""A manufactured solution with contact and nonlinear laws (issue 26): the contact case of
docs/convergence.md on scaled PZT-5A with fibre laws F(ε) = ℰε + ζ_F ψ(ε_xx) e_x ⊗ e_x and
A(ε̇) = τℰε̇ + ζ_A ψ(ε̇_xx) e_x ⊗ e_x (``scenes.manufactured.fiber_law``), Nitsche θ = 1, a
known contact set, glue and layer (adhesive) or viscosity and conduction (viscous); the
energy-norm errors of u and φ converge at the rates of the linear case, p at P1-P3."""
import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.scenes.manufactured import ContactManufactured, t as t_symbol
from ngcontact.studies.convergence import scaled_pzt

FIBERS = {"viscous": (10.0, 3.0), "adhesive": (10.0, 0.0)}   # ζ_F, ζ_A against c ≈ 12, τc ≈ 3.6
LEVELS = (1, 2, 3)


def _material(case):
    if case == "viscous":
        return scaled_pzt(0.3), 0.3
    m = ngc.pzt5a()
    return ngc.Material(m.c / 1e10, m.e, m.eps / 1e-9, name="scaled PZT-5A, elastic"), 0.0


def _errors(case, order, level, with_laws=True):
    """(‖ε(u − u_h)‖, ‖∇(φ − φ_h)‖) at T = 0.5 (two backward Euler steps, exact in time for the
    linear time profile) on the plate refined ``level`` times."""
    base, tau = _material(case)
    mms = ContactManufactured(base.tensors(2), case=case, time_profile="linear", smoothness=6, tau=tau,
                              fibers=FIBERS[case], fiber_width=0.1)
    material = mms.with_laws(base) if with_laws else base
    body = ngc.Body(plate(1.0, 0.5, maxh=0.25, refine=level), material, clamped="left", grounded="top",
                    contact_side="bottom", order=order)
    time = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, mms.loads(body, time), contact=mms.contact(time, 1, 10.0), time=time,
                         u0=mms.cf(mms.u.subs(t_symbol, 0), time), keep_states=False, physical_checks=False)
    sim.run(dt=0.25, T=0.5)
    return np.array(mms.errors(sim))


@pytest.mark.parametrize("order, case", [(1, "viscous"), (1, "adhesive"), pytest.param(2, "viscous", marks=pytest.mark.long),
                                         pytest.param(2, "adhesive", marks=pytest.mark.long),
                                         pytest.param(3, "viscous", marks=pytest.mark.slow),
                                         pytest.param(3, "adhesive", marks=pytest.mark.long)])
def test_a_manufactured_solution_with_contact_and_laws_converges_at_order_p(case, order):
    """Fitted rates (least squares over three levels) of u and φ ≥ p − 0.2 (measured: viscous
    1.00/2.00/3.2, adhesive 1.00/2.01/3.2); solved with the linear material instead, the same
    data miss the solution by more than 10× the law's error (the laws matter here)."""
    errors = np.array([_errors(case, order, level) for level in LEVELS])
    h = 0.25 / 2.0 ** np.array(LEVELS)
    rates = [np.polyfit(np.log(h), np.log(errors[:, i]), 1)[0] for i in range(2)]
    assert min(rates) >= order - 0.2, (rates, errors)
    if order == 2:
        linear = _errors(case, order, LEVELS[-1], with_laws=False)
        assert linear[0] > 10 * errors[-1, 0], (linear, errors[-1])
