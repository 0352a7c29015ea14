"""BDF2 with variable steps: a second-order scheme beside the paper's backward Euler.

Step n of length k_n after a step of length k_{n−1}, with the step ratio ω = k_n/k_{n−1}:

  δu_n ≈ c (u_n − û),  c = (1 + 2ω)/((1 + ω) k_n),  û = ((1 + ω)² u_{n−1} − ω² u_{n−2})/(1 + 2ω),

the variable-step BDF2 derivative (exact for quadratics in t); the electric equation and the
contact conditions hold at t_n, as in backward Euler. Why BDF2 (and not TR-BDF2 or a
Runge–Kutta pair): a step is one Newton solve of the same system R(x) = K_el x +
c K_A (x − x̂) − f(t_n) + R_Γ3(x) as backward Euler (``coefficients``), with the same cost
and the same solvers; it is A-stable and stiffly accurate (the algebraic parts — φ, the
Signorini conditions, the layer — are met at t_n exactly, no intermediate stage sees them
half-way), and it is zero-stable for step ratios ω < 1 + √2 (Grigorieff): ``MAX_RATIO``.

The bonding field (2.9), β̇ = −[β γ_ν R_ν(u_ν)² − ε_a]_+, by BDF2 as well, semi-implicit:

  β_n = β̂ − (1/c) [β_n a − ε_a]_+,  β̂ = ((1 + ω)² β_{n−1} − ω² β_{n−2})/(1 + 2ω),
  a = P_B(γ_ν R_ν(ũ_ν)²),  ũ = (1 + ω) u_{n−1} − ω u_{n−2}  (linear extrapolation to t_n),

solved exactly per facet (``adhesion.BondingField.solve``) before (u_n, φ_n), so that Γ3's
β_n is known in the Newton solve as in the paper's (4.5); the extrapolation keeps the
update second order, and the implicit β_n keeps it stable for any step (no k γ_ν L² < 1).
``Contact.beta_update`` chooses between backward Euler's two updates and is not used here.

The first step, and a step whose ratio exceeds ``MAX_RATIO``, are backward Euler steps
(BDF1: c = 1/k_n, û = u_{n−1}, β by the implicit update from u_{n−1}): one first-order step
costs O(k²) locally and keeps the global order 2. ``orders`` lists the formula's order of
every step (1 or 2).
"""
import math

import numpy as np
from ngsolve import GridFunction

from .backward_euler import BackwardEuler

MAX_RATIO = 1 + math.sqrt(2) - 1e-3
"""The largest step ratio k_n/k_{n−1} taken as a BDF2 step (zero-stability: ω < 1 + √2);
beyond it the step restarts with backward Euler."""


class BDF2(BackwardEuler):
    """Variable-step BDF2 (module docstring); the parameters are backward Euler's."""

    name = "bdf2"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._memory = None             # (u_{n−2}, β_{n−2}, k_{n−1}) after step n − 1, or None
        self.orders = []
        u = self.state.components[0]
        self._u_tilde = GridFunction(u.space, name="u_extrapolated")
        self._u_tilde_normal = self._u_tilde * self._normal

    def advance(self, dt, *, step=None, timer=None, start=None):
        """One BDF2 step of length dt (s) (or a backward Euler one: module docstring)."""
        u = self.state.components[0]
        before_u = u.vec.FV().NumPy().copy()
        before_beta = None if self.beta is None else self.beta.values.copy()
        memory = self._memory
        ratio = None if memory is None else dt / memory[2]
        second = ratio is not None and ratio <= MAX_RATIO
        if second:
            w = ratio
            u_old2, beta_old2, _ = memory
            c = (1 + 2 * w) / ((1 + w) * dt)
            hat = ((1 + w) ** 2 * before_u - w ** 2 * u_old2) / (1 + 2 * w)
            if self.beta is not None:
                self._u_tilde.vec.FV().NumPy()[:] = (1 + w) * before_u - w * u_old2
                beta_hat = ((1 + w) ** 2 * before_beta - w ** 2 * beta_old2) / (1 + 2 * w)
                self.beta.solve(self._u_tilde_normal, 1.0 / c, beta_hat)
        else:
            c, hat = 1.0 / dt, before_u
            if self.beta is not None:
                self.beta.solve(self._u_normal, dt, before_beta)       # the implicit update from u_{n−1}
        self.coefficients.anchor.vec.FV().NumPy()[:] = hat
        if self.predictor:
            self._predict(dt)
        before_t, self.t = self.t, self.t + dt
        self.coefficients.set(self.t, c)
        self.system.begin_step(self.state)
        if start is not None:
            start(u, before_t, self.t)
        result = self.newton.solve(step=step, time=self.t, timer=timer)
        self._memory = (before_u, before_beta, dt)
        self.orders.append(2 if second else 1)
        return result

    def checkpoint(self):
        return (super().checkpoint(), self._memory, len(self.orders))

    def restore(self, saved):
        base, self._memory, count = saved
        del self.orders[count:]
        super().restore(base)

    def save(self):
        arrays = super().save()
        if self._memory is not None:
            u_old2, beta_old2, k = self._memory
            arrays.update(bdf2_u_before=u_old2, bdf2_dt_before=np.asarray(k))
            if beta_old2 is not None:
                arrays["bdf2_beta_before"] = beta_old2
        return arrays

    def load(self, arrays):
        super().load(arrays)
        self.orders = []
        self._memory = None
        if "bdf2_u_before" in arrays:
            self._memory = (np.asarray(arrays["bdf2_u_before"]).copy(), None if "bdf2_beta_before" not in arrays
                            else np.asarray(arrays["bdf2_beta_before"]).copy(), float(arrays["bdf2_dt_before"]))
