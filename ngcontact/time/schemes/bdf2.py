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

solved exactly per facet (``adhesion.BondingField.solve``) before (u_n, φ_n), then again with
a from u_n itself and (u_n, φ_n) solved again while β_n changes by more than
``beta_tolerance``: the extrapolation alone overshoots across a pull-off (β 0.12 instead of
0.86 at k = T/16 on the reference plate), the passes make the update implicit in u where it
matters. Where the extrapolation is good, β from ũ and from u_n differ by O(k³) (ũ − u_n =
O(k²), times κ = O(k)), the order of the step's own local error, and no pass is needed. The
implicit β_n keeps it stable for any step (no k γ_ν L² < 1).
``Contact.beta_update`` chooses between backward Euler's two updates and is not used here.

The first step, and a step whose ratio exceeds ``MAX_RATIO``, are backward Euler steps
(BDF1: c = 1/k_n, û = u_{n−1}, β by the implicit update from u_{n−1}): one first-order step
costs O(k²) locally and keeps the global order 2. ``orders`` lists the formula's order of
every step (1 or 2). After each BDF2 step that follows two more, ``estimate`` holds its local
error by Milne's device (``local_error``), for the error-controlled step size (``stepping``).
"""
import math

from dataclasses import replace

import numpy as np
from ngsolve import GridFunction

from ngcontact import parallel
from ngcontact.solve.newton import NewtonError

from .backward_euler import BackwardEuler

BETA_TOL, BETA_PASSES = 1e-6, 20
"""β_n is taken as consistent with u_n when another pass changes it by at most BETA_TOL (the
default ``beta_tolerance``; an error-controlled run lowers it to its rtol). Fitted to measurements
against a tolerance of 1e-10 on the soft column and the reference plate (docs/measurements.md,
section ngcontact/time/schemes/bdf2.py): the same errors with fewer Newton iterations, as each
pass is a Newton solve."""
MAX_RATIO = 1 + math.sqrt(2) - 1e-3
"""The largest step ratio k_n/k_{n−1} taken as a BDF2 step (zero-stability: ω < 1 + √2);
beyond it the step restarts with backward Euler."""


class BDF2(BackwardEuler):
    """Variable-step BDF2 (module docstring); the parameters are backward Euler's.

    ``estimate``: after a step, the relative local error of the step by Milne's device, or None
    (``local_error``); ``orders``: the formula's order of every step."""

    name = "bdf2"
    estimates_error = True
    """After each BDF2 step that follows two more, ``estimate`` holds its local error (``local_error``)."""
    beta_tolerance = BETA_TOL
    """Another pass of β_n from u_n is made while β_n changes by more than this (β ∈ [0, 1])."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._past = []                 # [(x_{n−1}, β_{n−1}, k_n), (x_{n−2}, β_{n−2}, k_{n−1})] after step n
        self.orders, self.estimate = [], None
        self._scales = {"u": 0.0, "phi": 0.0}        # the largest |u|, |φ| of the run so far
        u = self.state.components[0]
        self._n_u = u.space.ndof
        self._mesh = u.space.mesh
        self._u_tilde = GridFunction(u.space, name="u_extrapolated")
        self._u_tilde_normal = self._u_tilde * self._normal

    @property
    def last_order(self):
        """The order of the formula of the last step (1 or 2)."""
        return self.orders[-1] if self.orders else 1

    def restart(self):
        """Forget the earlier states: the next step is a backward Euler one (after an event,
        a kink in time that a second-order formula would straddle)."""
        self._past = []

    def control(self, rtol):
        """β consistent with u_n to the level the error test asks: ``beta_tolerance`` at most rtol."""
        self.beta_tolerance = min(self.beta_tolerance, rtol)

    def advance(self, dt, *, step=None, timer=None, start=None, target=None):
        """One BDF2 step of length dt (s) to ``target`` (default t + dt), or a backward Euler one
        (module docstring)."""
        u = self.state.components[0]
        before = self.state.vec.FV().NumPy().copy()
        before_u = before[:self._n_u]
        before_beta = None if self.beta is None else self.beta.values.copy()
        past = self._past
        ratio = dt / past[0][2] if past else None
        second = ratio is not None and ratio <= MAX_RATIO
        if second:
            w = ratio
            u_old2, beta_old2 = past[0][0][:self._n_u], past[0][1]
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
        before_t, self.t = self.t, self.t + dt if target is None else target
        self.coefficients.set(self.t, c)
        self.system.begin_step(self.state)
        if start is not None:
            start(u, before_t, self.t)
        result = self.newton.solve(step=step, time=self.t, timer=timer)
        if second and self.beta is not None:
            result = self._consistent_beta(result, 1.0 / c, beta_hat, step, timer)
        self.estimate = self.local_error(dt, before, before_beta) if second and len(past) == 2 else None
        x = self.state.vec.FV().NumPy()
        for name, part in self._parts(len(x)):          # over all ranks: every rank takes the same steps
            self._scales[name] = max(self._scales[name], parallel.maximum(self._mesh, np.abs(x[part]), 0.0))
        self._past = [(before, before_beta, dt)] + ([past[0]] if second else [])
        self.orders.append(2 if second else 1)
        return result

    def _consistent_beta(self, result, kappa, beta_hat, step, timer):
        """β_n by BDF2 with γ_ν R_ν² at u_n itself, not at the extrapolation: β_n from u_n,
        (u_n, φ_n) again with that β_n, until β_n changes by at most ``beta_tolerance`` (at most
        ``BETA_PASSES`` passes; else a NewtonError, and the cut-back policy halves the step).
        Across a pull-off the extrapolated u_ν overshoots into tension, and β from it falls far
        below its value at u_n (docs/measurements.md, section ngcontact/time/schemes/bdf2.py).
        On a distributed mesh the change is the largest over all ranks' facets: every rank makes the
        same passes (a rank that stopped on its own facets alone recorded the step while the others
        waited in the next Newton solve)."""
        passes = [result]
        for _ in range(BETA_PASSES):
            used = self.beta.values.copy()
            self.beta.solve(self._u_normal, kappa, beta_hat)
            if parallel.maximum(self._mesh, np.abs(self.beta.values - used), 0.0) <= self.beta_tolerance:
                break
            passes.append(self.newton.solve(step=step, time=self.t, timer=timer))
        else:
            raise NewtonError(f"did not reach a bonding field consistent with u_n in {BETA_PASSES} passes",
                              iteration=sum(r.iterations for r in passes), residuals=passes[-1].residuals,
                              step=step, time=self.t, hint="a shorter time step")
        last = passes[-1]
        return replace(last, iterations=sum(r.iterations for r in passes),
                       residuals=[x for r in passes for x in r.residuals],
                       factorizations=sum(r.factorizations for r in passes),
                       krylov_iterations=sum(r.krylov_iterations for r in passes),
                       krylov_failures=sum(r.krylov_failures for r in passes),
                       discarded=sum(r.discarded for r in passes))

    def local_error(self, dt, before, before_beta):
        """The local error of the step just made, by Milne's device: with P the quadratic
        through the last three states extrapolated to t_n, δ = r/(1 + r) (x_n − P), r =
        (1 + ω) k_n/((1 + 2ω)(k_n + k_{n−1} + k_{n−2})) (the ratio of BDF2's error constant to
        the extrapolation's; 2/11 at constant steps). Returns {"u": ‖δ_u‖∞/s_u, "phi":
        ‖δ_φ‖∞/s_φ, "beta": ‖δ_β‖∞} with s the largest ‖·‖∞ of the field in the run so far
        (a field that is 0 throughout is left out), over all ranks on a distributed mesh (the same
        estimate on every rank). The max norm, not a root mean square: the
        error of a contact problem sits at the few DOFs near Γ3, which a mean over all DOFs
        dilutes (with the root mean square, the final error on the reference plate did not
        fall with rtol: 6.2e-4, 8.0e-4, 3.1e-4 at rtol 1e-3, 1e-4, 1e-5)."""
        (x1, b1, k1), (x2, b2, k0) = self._past
        taus = np.array([-dt, -dt - k1, -dt - k1 - k0])      # t_{n−1}, t_{n−2}, t_{n−3} − t_n
        weights = [np.prod([-taus[j] / (taus[i] - taus[j]) for j in range(3) if j != i]) for i in range(3)]
        w = dt / k1
        r = (1 + w) * dt / ((1 + 2 * w) * (dt + k1 + k0))
        x = self.state.vec.FV().NumPy()
        delta = r / (1 + r) * (x - sum(a * v for a, v in zip(weights, (before, x1, x2))))
        errors, mesh = {}, self._mesh
        for name, part in self._parts(len(x)):
            scale = max([parallel.maximum(mesh, np.abs(v[part]), 0.0) for v in (x, before, x1, x2)] +
                        [self._scales[name]])
            if scale > 0:                       # (an empty part has scale 0: its largest |x| is 0)
                errors[name] = float(_largest(mesh, delta[part]) / scale)
        if self.beta is not None:
            P = sum(a * v for a, v in zip(weights, (before_beta, b1, b2)))
            errors["beta"] = float(r / (1 + r) * _largest(mesh, self.beta.values - P))
        return errors

    def _parts(self, n):
        return (("u", slice(0, self._n_u)), ("phi", slice(self._n_u, n)))

    def checkpoint(self):
        return (super().checkpoint(), list(self._past), len(self.orders), self.estimate, dict(self._scales))

    def restore(self, saved):
        base, past, count, self.estimate, scales = saved
        self._scales = dict(scales)
        self._past = list(past)
        del self.orders[count:]
        super().restore(base)

    def save(self):
        arrays = super().save()
        arrays.update(bdf2_scale_u=np.asarray(self._scales["u"]), bdf2_scale_phi=np.asarray(self._scales["phi"]))
        for i, (x, beta, k) in enumerate(self._past):
            arrays.update({f"bdf2_state_{i}": x, f"bdf2_dt_{i}": np.asarray(k)})
            if beta is not None:
                arrays[f"bdf2_beta_{i}"] = beta
        return arrays

    def load(self, arrays):
        super().load(arrays)
        self.orders, self.estimate, self._past = [], None, []
        self._scales = {"u": float(arrays.get("bdf2_scale_u", 0.0)), "phi": float(arrays.get("bdf2_scale_phi", 0.0))}
        for i in range(2):
            if f"bdf2_state_{i}" in arrays:
                beta = arrays.get(f"bdf2_beta_{i}")
                self._past.append((np.array(arrays[f"bdf2_state_{i}"]), None if beta is None else np.array(beta),
                                   float(arrays[f"bdf2_dt_{i}"])))


def _largest(mesh, values):
    """max |values| over the ranks of ``mesh`` (0 for none)."""
    return parallel.maximum(mesh, np.abs(values), 0.0)
