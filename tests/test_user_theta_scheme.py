"""A θ-scheme of the user's, written here through ``schemes.TimeScheme`` and handed to
``Simulation(scheme=...)`` with no edit of the package.

The step system of the protocol is R(x) = K_el x + c K_A (x − x̂) − f(t) + R_Γ3(x) at one time t
with one rate coefficient c and anchor û (``schemes.coefficients``): a combination
θ R(u_n, t_n) + (1 − θ) R(u_{n−1}, t_{n−1}) with an explicit part is not one of its forms, the
one-leg θ-method is. Step n of length k solves for y = u_{n−1+θ} at t_{n−1+θ} = t_{n−1} + θ k with
c = 1/(θ k) and û = u_{n−1} (A ε((y − u_{n−1})/(θ k)) + R(y, t_{n−1+θ}) = 0), then extrapolates
x_n = (x_{n−1+θ} − (1 − θ) x_{n−1})/θ (the scheme owns the state: the protocol lets it change it
after Newton). β by the same one-leg form, implicit in β (``BondingField.solve``) at u linearly
extrapolated to the stage from the last two steps with weight 1 − θ (= θ at θ = 1/2; u_{n−1}
at θ = 1: the built-in backward Euler with ``beta_update="implicit"``). θ = 1/2 is the implicit
midpoint rule, second order where the solution is smooth in time.
"""

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact import schemes
from ngcontact.scenes import reference
from ngcontact.studies import column_order

COARSE = 0.01


class Theta(schemes.TimeScheme):
    """The one-leg θ-method (module docstring); θ is the class's (``theta_scheme``). Nitsche
    only (no enforcement unknowns), no predictor."""
    name, theta = "theta_1", 1.0

    def __init__(self, coefficients, system, newton, state, beta=None, predictor=False, normal=None):
        if predictor or newton.hook is not None:
            raise ValueError("this θ-scheme has no predictor and no enforcement unknowns")
        self.coefficients, self.system, self.newton, self.state = coefficients, system, newton, state
        self.beta, self.predictor, self.t = beta, predictor, 0.0
        self.last_order = 2 if self.theta == 0.5 else 1
        u = state.components[0]
        self.n_u, self.u_tilde = u.space.ndof, ngs.GridFunction(u.space)
        self.u_tilde_normal = self.u_tilde * (ngs.specialcf.normal(u.space.mesh.dim) if normal is None else normal)
        self.past = None                            # (x_{n−2}, k_{n−1}) before step n

    def start(self):
        self.coefficients.set(0.0, 1.0, self.state.components[0].vec)
        self.system.begin_step(self.state)

    def advance(self, dt, *, step=None, timer=None, start=None, target=None):
        th, x = self.theta, self.state.vec.FV().NumPy()
        before, t0 = x.copy(), self.t
        target = t0 + dt if target is None else target
        if self.beta is not None:                   # β_{n−1+θ} from u extrapolated to the stage
            beta0, u0 = self.beta.values.copy(), before[:self.n_u]
            slope = 0.0 if self.past is None else dt / self.past[1] * (u0 - self.past[0][:self.n_u])
            self.u_tilde.vec.FV().NumPy()[:] = u0 + (1 - th) * slope
            self.beta.solve(self.u_tilde_normal, th * dt, beta0)
        stage = target - (1 - th) * (target - t0)
        self.coefficients.set(stage, 1.0 / (th * dt), self.state.components[0].vec)   # c, û = u_{n−1}
        self.system.begin_step(self.state)
        if start is not None:
            start(self.state.components[0], t0, stage)
        result = self.newton.solve(step=step, time=stage, timer=timer)
        x[:] = (x - (1 - th) * before) / th         # x_n from the stage
        if self.beta is not None:
            self.beta.unclipped = (self.beta.values - (1 - th) * beta0) / th
            self.beta.values[:] = np.clip(self.beta.unclipped, 0, 1)
        self.t, self.past = target, (before, dt)
        self.coefficients.set(target, 1.0 / dt)     # the record's rate: (u_n − u_{n−1})/k at t_n
        return result

    def restart(self):
        self.past = None

    def checkpoint(self):
        saved = dict(t=np.asarray(self.t), state=self.state.vec.FV().NumPy().copy())
        if self.beta is not None:
            saved.update(beta=self.beta.values.copy(), unclipped=self.beta.unclipped.copy())
        if self.past is not None:
            saved.update(past_state=self.past[0].copy(), past_dt=np.asarray(self.past[1]))
        return saved

    def restore(self, saved):
        self.t = float(saved["t"])
        self.state.vec.FV().NumPy()[:] = saved["state"]
        if self.beta is not None:
            self.beta.values[:] = saved["beta"]
            self.beta.unclipped = np.array(saved["unclipped"])
        self.past = (np.array(saved["past_state"]), float(saved["past_dt"])) if "past_state" in saved else None
        self.coefficients.set(self.t)

    save, load = checkpoint, restore


def theta_scheme(theta):
    """The class of the θ-scheme of ``theta`` (a class, as ``Simulation(scheme=...)`` takes it)."""
    theta = float(theta)
    return type(f"Theta{theta}", (Theta,), dict(name=f"theta_{theta}", theta=theta))


def _reference(scheme, dt, T):
    """The reference plate (coarse, P1) of ``scheme`` run to T (s) in steps of dt, the implicit β
    update (the built-in backward Euler's that θ = 1 is)."""
    sim = reference.simulation(1, COARSE, scheme=scheme, contact=reference.contact(beta_update="implicit"),
                               solver={"ksp_type": "preonly"})
    sim.run(dt, T)
    return sim


def test_theta_1_gives_backward_euler_s_steps_on_the_reference_plate():
    """θ = 1 makes the built-in backward Euler's steps (β implicit) to round-off on the reference
    plate through contact (from step 1 on) and the start of the pull (t = 0.2 s), and a step off
    the run's grid."""
    runs = {}
    for scheme in (theta_scheme(1), "backward_euler"):
        sim = _reference(scheme, 1e-2, 0.25)
        sim.advance(0.255, max_cutbacks=2)
        runs[scheme if isinstance(scheme, str) else "theta"] = sim
    mine, built_in = runs["theta"], runs["backward_euler"]
    assert [r.time for r in mine.history] == [r.time for r in built_in.history] and len(mine.history) == 27
    assert max(r.contact.contact_area for r in built_in.history[1:]) > 0          # contact is in the run
    for a, b in zip(mine.history, built_in.history):
        assert np.allclose(a.state, b.state, rtol=0, atol=1e-12 * np.abs(b.state).max()), a.step
        assert np.allclose(a.contact.beta, b.contact.beta, rtol=0, atol=1e-12), a.step
    assert {r.scheme for r in mine.history} == {"theta_1.0"} and {r.order for r in mine.history[1:]} == {1}


@pytest.mark.long
def test_theta_half_is_second_order_where_the_solution_is_smooth():
    """On the glued column lifted off an open Γ3 ("lift" of ``studies.column_order``: smooth in
    time, Nitsche's θ = 0 so that the step is the semi-discrete system's), the errors at T of 8,
    16 and 32 equal steps against Radau (rtol 1e-8: 1e-11 from rtol 1e-10, far below the errors)
    fall at the observed order log2(e_k/e_{k/2}) >= 1.8 in u, β and φ for θ = 1/2, and within
    [0.8, 1.2] for θ = 1 (first order, as backward Euler)."""
    F0, T = column_order.HISTORIES["lift"]
    system = column_order.semidiscrete(F0, column_order.NGCONTACT_QUADRATURE)
    u, beta, _ = system.radau(T, rtol=1e-8)
    U, P = system.full(u)
    orders = {}
    for theta in (0.5, 1):
        found = []
        for steps in (8, 16, 32):
            sim, info = column_order.run(F0, T, theta_scheme(theta), steps)
            assert info["max_contact_area"] == 0 and info["max_multiplier"] == 0     # Γ3 open: smooth
            found.append(column_order.errors(column_order._fields(sim, system), (U, beta, P)))
        orders[theta] = {f: [np.log2(a[f] / b[f]) for a, b in zip(found, found[1:])]
                         for f in ("error_u", "error_beta", "error_phi")}
    assert beta.min() < 0.95                        # β changes: its update is tested too
    assert min(min(o) for o in orders[0.5].values()) >= 1.8, orders
    assert all(0.8 <= r <= 1.2 for o in orders[1].values() for r in o), orders


@pytest.mark.long
def test_theta_half_runs_the_reference_plate():
    """θ = 1/2 runs the whole reference plate (push, hold, pull to 0.5 s) with no edit of the
    package: 51 records at n·dt, each of the scheme's name and order 2, through contact and the
    pull-off (β falls below 0.5, Γ3 open at the end). The extrapolation x_n = 2 x_{n−1/2} − x_{n−1}
    keeps neither the contact conditions nor β in [0, 1]: in contact u_n penetrates beyond the
    physical checks' bound, at the pull-off β_n falls below 0 and is clipped (PhysicsWarnings
    naming these two, on no other ground)."""
    with pytest.warns(ngc.PhysicsWarning, match="penetration|update of β left"):
        sim = _reference(theta_scheme(0.5), 1e-2, 0.5)
    h = sim.history
    assert len(h) == 51 and np.allclose([r.time for r in h], 1e-2 * np.arange(51), rtol=0, atol=1e-12)
    assert {r.scheme for r in h} == {"theta_0.5"} and {r.order for r in h[1:]} == {2}
    assert max(r.contact.contact_area for r in h[1:]) > 0 and h[-1].contact.contact_area == 0
    assert min(r.contact.beta.min() for r in h[1:]) < 0.5
    assert sim.flags and all("penetration" in flag or "update of β left [0, 1]" in flag for flag in sim.flags)
