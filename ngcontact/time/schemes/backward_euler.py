"""Backward Euler in time, as in the paper's scheme (4.3)-(4.5): the default scheme.

Step n, from t_{n−1} to t_n = t_{n−1} + k: first β_n from u_{n−1} by the bonding update
(4.5) (or its implicit variant, ``adhesion``), then (u_n, φ_n) together from the mechanical
and the (negated) electric equation at t_n, with δu_n = (u_n − u_{n−1})/k, by Newton on
the ``StepSystem``: the step coefficients (``coefficients``) are c = 1/k and û = u_{n−1}.
The scheme owns what changes from step to step: t, the state (u, φ), β, the multipliers of
an enforcement method with unknowns of its own, and the predictor's memory; ``checkpoint``
and ``restore`` save and put back all of it, bitwise, and ``save`` and ``load`` do the same
through named numpy arrays (a restart from disk).
"""
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.solve.linalg.solver_restart import load_restart_state, restart_state


@dataclass(frozen=True)
class Checkpoint:
    """Everything a step changes: the time t (s), the state vector, β (and its value before
    clipping), the enforcement hook's unknowns, and the predictor's memory."""
    t: float
    state: object
    beta: object
    beta_unclipped: object
    hook: object
    last: object


class BackwardEuler:
    """The backward Euler step of a simulation (the protocol ``protocol.TimeScheme``).

    Parameters
    ----------
    coefficients : StepCoefficients, written by this scheme only.
    system : StepSystem.  newton : Newton on it, for ``state``.
    state : GridFunction (u, φ), the state x_n, changed in place.
    beta : BondingField, or None without a contact law.
    normal : the contact normal of Γ3 (ν or an obstacle's n_o), for u_ν in the β update.
    predictor : start Newton from the linear extrapolation x_n + (dt/dt_n)(x_n − x_{n−1})
        instead of x_n (the default warm start).
    """

    name = "backward_euler"
    last_order = 1
    """The order of the formula of the last step."""
    estimates_error = False
    """No local error estimate (``stepping`` needs one to choose steps: "bdf2" has it)."""
    estimate = None

    def __init__(self, coefficients, system, newton, state, beta=None, predictor=False, normal=None):
        self.coefficients, self.system, self.newton, self.state, self.beta = coefficients, system, newton, state, beta
        self.hook = newton.hook
        self.predictor = predictor
        self.t = 0.0
        self._normal = ngs.specialcf.normal(state.space.mesh.dim) if normal is None else normal
        self._u_normal = state.components[0] * self._normal
        self._last = None                                   # (x_{n−1}, dt_n) for the predictor

    def start(self):
        """Step 0 at t = 0 (u held at u0, for the potential φ0): the terms of a step of unit length
        from u0 (c = 1 per second, û = u0)."""
        self.coefficients.set(0.0, 1.0, self.state.components[0].vec)
        self.system.begin_step(self.state)

    def advance(self, dt, *, step=None, timer=None, start=None, target=None):
        """One step of length dt (s) from the current state to ``target`` (s; default t + dt: a
        run's steps reach n·dt, their c = 1/dt is one number); returns the NewtonResult.
        ``start(u, t_{n−1}, t_n)``, if given, changes Newton's start: the displacement u after
        u_{n−1} is kept and the supports' values at t_n are set (``starts``).
        Not transactional: on failure the state is part-way (``checkpoint``/``restore``)."""
        if self.beta is not None:
            self.beta.update(self._u_normal, dt)            # (4.5), from u_{n−1}
        self.coefficients.anchor.vec.data = self.state.components[0].vec        # û = u_{n−1}
        if self.predictor:
            self._predict(dt)
        before, self.t = self.t, self.t + dt if target is None else target
        self.coefficients.set(self.t, 1.0 / dt)             # c = 1/k
        self.system.begin_step(self.state)
        if start is not None:
            start(self.state.components[0], before, self.t)
        return self.newton.solve(step=step, time=self.t, timer=timer)

    def restart(self):
        """Nothing to forget: every step is a one-step backward Euler step."""

    def control(self, rtol):
        """Nothing to tighten: a step is one Newton solve to Newton's own tolerance."""

    def _predict(self, dt):
        """x_n -> x_n + (dt / dt_n)(x_n − x_{n−1}), the start of Newton for step n + 1."""
        x = self.state.vec.FV().NumPy()
        last, self._last = self._last, (x.copy(), dt)
        if last is not None:
            x += (dt / last[1]) * (x - last[0])

    def checkpoint(self):
        """A copy of everything ``advance`` changes."""
        beta = self.beta
        return Checkpoint(self.t, parallel.cumulated(self.state.vec).copy(),
                          None if beta is None else beta.values.copy(),
                          None if beta is None else beta.unclipped.copy(),
                          None if self.hook is None else self.hook.save(), self._last)

    def restore(self, saved):
        """Put back a checkpoint, bitwise; the time Parameter is set to its t."""
        self.t, self._last = saved.t, saved.last
        parallel.set_cumulated(self.state.vec, saved.state)
        if self.beta is not None:
            self.beta.values[:] = saved.beta
            self.beta.unclipped = saved.beta_unclipped.copy()
        if self.hook is not None:
            self.hook.restore(saved.hook)
        self.coefficients.set(saved.t)

    def save(self):
        """The checkpoint as named arrays (the restart state of a step archive): ``t``,
        ``state``, ``beta``, ``beta_unclipped``, ``hook``, ``last_state``, ``last_dt``, and what
        Newton's next solve decides by (``solver_restart.restart_state``: a resume is bitwise)."""
        saved = BackwardEuler.checkpoint(self)             # this class's part (a subclass adds its own)
        arrays = dict(t=np.asarray(saved.t), state=saved.state)
        if saved.beta is not None:
            arrays.update(beta=saved.beta, beta_unclipped=saved.beta_unclipped)
        if saved.hook is not None:
            arrays["hook"] = np.asarray(saved.hook)
        if saved.last is not None:
            arrays.update(last_state=saved.last[0], last_dt=np.asarray(saved.last[1]))
        arrays.update(restart_state(self.newton))
        return arrays

    def load(self, arrays):
        """Put back the arrays of ``save``, bitwise; a ValueError names what is missing."""
        missing = {"t", "state"} - set(arrays)
        if missing:
            raise ValueError(f"the restart state lacks {', '.join(sorted(missing))}")
        last = (arrays["last_state"], float(arrays["last_dt"])) if "last_state" in arrays else None
        BackwardEuler.restore(self, Checkpoint(float(arrays["t"]), arrays["state"], arrays.get("beta"),
                                               arrays.get("beta_unclipped"), arrays.get("hook"), last))
        if "solver_rate" in arrays:          # the step system as last assembled: the kept factorisation's c
            self.coefficients.set(self.coefficients.t, float(arrays["solver_rate"]))
            self.newton.system.begin_step(self.newton.gfu)
        load_restart_state(self.newton, arrays)
