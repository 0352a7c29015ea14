"""Scales that make no sense are refused before the work; a converged state balances each field
(forces and charges) against its own scale, so that one field's scale cannot hide the other's
residual."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.solve import stopping
from ngcontact.model.materials import EPS0, isotropic_stiffness, transversely_isotropic_piezo
from ngcontact.scenes import reference as scene


@pytest.mark.parametrize("permittivity", [1e-30, 1e-15, 0.999 * EPS0])
def test_a_permittivity_below_the_vacuum_is_refused(permittivity):
    with pytest.raises(ValueError, match=r"permittivity.*8\.85\d*e-12 F/m"):
        ngc.Material.isotropic(60e9, 0.3, permittivity=permittivity, e33=10.0)
    eps = np.diag([1e-8, 1e-8, permittivity])        # one direction below ε0 is enough
    with pytest.raises(ValueError, match=r"permittivity eps.*smallest eigenvalue is \S+ F/m"):
        ngc.Material(isotropic_stiffness(60e9, 0.3), transversely_isotropic_piezo(0, 1e-3, 0), eps)


def test_the_vacuum_permittivity_itself_is_accepted():
    material = ngc.Material.isotropic(60e9, 0.3, permittivity=EPS0)
    assert material.eps[0, 0] == EPS0


def _stiffening(c, e, eps):
    """λ_max(c^-½ eᵀ ε⁻¹ e c^-½), written here apart from the library's check."""
    from scipy.linalg import sqrtm
    root = np.linalg.inv(np.real(sqrtm(c)))
    return np.linalg.eigvalsh(root @ e.T @ np.linalg.inv(eps) @ e @ root).max()


def test_a_coupling_that_swamps_the_mechanics_is_refused_and_real_ones_are_not():
    c = isotropic_stiffness(60e9, 0.3)
    for preset in (ngc.pzt5a(), ngc.batio3(), ngc.academic()):
        assert 0.2 < _stiffening(preset.c, preset.e, preset.eps) < 1.1      # real ceramics: about 1
    e = transversely_isotropic_piezo(0.0, 1e4, 0.0)
    assert _stiffening(c, e, 1e-11 * np.eye(3)) > 1e8
    with pytest.raises(ValueError, match=r"stiffens the body 1\.\d+e\+08-fold.*allowed <= 1e\+08"):
        ngc.Material(c, e, 1e-11 * np.eye(3))
    ngc.Material(c, e, 1e-9 * np.eye(3))              # 1.3e6-fold: strong, accepted


@pytest.mark.parametrize("method", ["penalty", "active_set"])
@pytest.mark.parametrize("theta", [0, -1])
def test_theta_is_refused_outside_nitsche(method, theta):
    with pytest.raises(ValueError, match=rf"Contact\.theta = {theta} means nothing with method '{method}'"):
        ngc.Contact(method=method, theta=theta)
    ngc.Contact(method=method)                        # its default θ = 1 is not a choice


def test_a_beta0_that_depends_on_time_is_refused():
    t = ngs.Parameter(0.0)
    with pytest.raises(ValueError, match=r"Contact\.beta0 depends on an ngsolve\.Parameter"):
        ngc.Contact(beta0=1 - t)
    ngc.Contact(beta0=0.5 + 0.5 * ngs.x / scene.L1)  # a field in space is fine


def _field_residuals(sim):
    """‖R_b‖ / S_b of each field at the current state (forces, charges)."""
    r = sim.gfu.vec.CreateVector()
    sim.system.Apply(sim.gfu.vec, r)
    norm = sim.newton.norm
    return [v / s for v, s in zip(norm.block_duals(r), sim.system.block_force_scales(norm))]


def _strongly_coupled(rtol):
    """The coarse reference plate of a material whose charges outweigh its forces about 10³-fold
    in Newton's scaled norm (e33 = 1000 C/m², ε = 1e-11 F/m: stiffened 10⁶-fold), pushed with a
    loose Newton tolerance by plain corrections (where Newton stops then is what is measured)."""
    material = ngc.Material.isotropic(60e9, 0.3, permittivity=1e-11, e33=1000.0)
    return scene.simulation(1, 0.01, material=material, rtol=rtol, switch_loop=False)


def test_each_field_is_balanced_against_its_own_scale(monkeypatch):
    """With rtol = 1e-4 the test on ‖R‖ alone accepts a state whose charges are out of balance
    by 7e-4 of their own scale at the second step (the forces' scale hides them); with the test
    of each field, no field of any step is off by more than rtol."""
    rtol = 1e-4
    sim = _strongly_coupled(rtol)
    for _ in range(3):
        sim.step(0.025)
        assert max(_field_residuals(sim)) <= rtol
    monkeypatch.setattr(stopping.ConvergenceTest, "_fields", lambda *args: None)
    alone = _strongly_coupled(rtol)
    worst = 0.0
    for _ in range(3):
        alone.step(0.025)
        worst = max(worst, *_field_residuals(alone))
    assert worst > 2 * rtol                           # what the test on ‖R‖ alone lets through


def test_a_field_out_of_balance_that_newton_cannot_reduce_is_named():
    """The explanation names the field, its residual and its own scale."""
    verdict = stopping.Verdict(False, 1e-3, 1e-2, scale=1e2, uncertifiable=True,
                               unbalanced=("charges", 3e-4, 1.0, 1e-6))
    reason, hint = verdict.explain()
    assert "charges stay out of balance by 3.000e-04, more than 1e-06 of their own scale 1.000e+00" in reason
    assert "coupling" in hint and "permittivity" in hint


def test_a_cycle_is_recognised_by_its_period_only():
    from ngcontact.solve.cycles import repeating
    cycle = [1.0, 5.0, 3.0, 2.7558e+01, 3.2603e+02, 3.6085e+01, 7.8993e+01]
    assert repeating(cycle + cycle[3:] + cycle[3:4]) == 4
    assert repeating(cycle + cycle[3:]) is None                 # one period only: not yet
    assert repeating([3.0, 1.0, 3.0, 1.0, 3.0]) == 2
    assert repeating([3.0, 1.0, 3.0, 1.0, 3.0 * (1 + 1e-6)]) is None
    assert repeating([1.0] * 10) is None                        # a stall is not a cycle
    assert repeating(list(np.geomspace(1, 1e-10, 20))) is None


def test_newton_names_the_laws_that_flip_when_it_cycles():
    """The plate grounded at its clamped end (the reference contact, ψ of the gap), full Newton
    steps only (no step-length limit, no globalisation): Newton cycles between four iterates; the error
    says so after a few periods, not at maxit, names the laws of Γ3 that change piece between
    them (the contact set and the conduction among them) with their remedies. (Globalised, the
    scene converges: ``test_globalisation``.)"""
    from ngcontact.geometries import plate
    t = ngs.Parameter(0.0)
    body = ngc.Body(plate(maxh=0.01, maxh_contact=0.005), ngc.pzt5a(2e-3), clamped="left", grounded="left",
                    contact_side="bottom")
    sim = ngc.Simulation(body, scene.loads(t), contact=scene.contact(gating="gap"), time=t, limit_steps=False,
                         globalise=False, maxit=50)
    sim.step(0.00625)
    with pytest.raises(ngc.NewtonError) as caught:
        sim.step(0.00625)
    error = caught.value
    message = str(error)
    assert "cycles: the iterates repeat with period" in message, message
    assert error.iteration < 50                                     # before maxit
    for law in ("the contact set changes on", "the conduction ψ changes on"):
        assert law in message, message
    assert "ramp_width" in error.hint and "theta = -1" in error.hint
    assert len(sim.history) == 2 and sim.t == pytest.approx(0.00625)      # the step before is kept


def test_the_load_cannot_hide_under_the_charges_scale():
    """A permittivity of 1e-30 F/m with e33 = 10 C/m² (what the material check now refuses,
    forced in here): before, every step after the first converged in 0 iterations while the
    load grew, the tip frozen. Each field balanced on its own, a step either ends with both
    fields balanced (the second after iterating) or fails by name after iterating: Newton
    cannot balance such a material, and where it gives up (the first or the second step)
    depends on the machine's round-off."""
    material = ngc.Material.isotropic(60e9, 0.3, permittivity=1e-8, e33=10.0)
    object.__setattr__(material, "eps", 1e-30 * np.eye(3))
    # plain corrections: with the switch loop the first step converges, and the second is accepted
    # at its start, the forces out of balance by 1e-6 of their own scale (the per-field tolerance)
    sim = scene.simulation(1, 0.01, material=material, switch_loop=False)
    for n in (1, 2):
        try:
            sim.step(0.025)
        except ngc.NewtonError as error:
            assert error.iteration > 0 and len(sim.history) == n      # the steps before are kept
            return
        assert sim.history[-1].newton_iterations > 0
        assert max(_field_residuals(sim)) <= 1e-6
