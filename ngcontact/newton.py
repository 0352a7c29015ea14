"""Semismooth Newton for the monolithic (u, φ) step, with a relative tolerance.

Forces (N) and charges (C) are not comparable, so residuals are measured in the norm
‖r‖² = ‖r_u‖²/s_u + ‖r_φ‖²/s_φ, where s_u, s_φ are the mean diagonal entries of the two
blocks of the Jacobian (N/m and C/V): each term is an energy, in J.
The step has converged when ‖r‖ ≤ rtol ‖r_0‖ (r_0: residual at the start of the step)
or when ‖r‖ ≤ 1e-13 ‖x‖_s, ‖x‖²_s = s_u‖x_u‖² + s_φ‖x_φ‖² (round-off level).

Unlike ``ngsolve.solvers.Newton`` this raises ``NewtonError`` when it fails. Each solve
reports its wall time split into residual evaluation, assembly of the Jacobian,
factorisation and solve (``NewtonResult.timings``, s).
"""
import time as wallclock
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp


class NewtonError(RuntimeError):
    """Newton failed: says where (step, time, iteration) and gives the residual history.

    ``history`` holds the steps computed before the failure (set by the simulation).
    """

    def __init__(self, reason, *, iteration, residuals, step=None, time=None, hint=""):
        self.reason, self.iteration, self.residuals = reason, iteration, residuals
        self.step, self.time, self.history = step, time, None
        where = f"step {step} (t = {time:.6g} s), " if step is not None else ""
        hist = ", ".join(f"{r:.3e}" for r in residuals)
        super().__init__(f"Newton {reason} at {where}iteration {iteration}; scaled residual "
                         f"history [J^1/2]: [{hist}]" + (f". Try: {hint}" if hint else ""))


@dataclass
class NewtonResult:
    iterations: int
    residuals: list = field(default_factory=list)
    residual_vector: object = None
    timings: dict = field(default_factory=dict)


class Timings(dict):
    """Wall time (s) per phase: ``with timings("assembly"): ...`` adds to timings["assembly"]."""

    PHASES = ("residual", "assembly", "factorization", "solve")

    def __init__(self):
        super().__init__((phase, 0.0) for phase in self.PHASES)

    @contextmanager
    def __call__(self, phase):
        start = wallclock.perf_counter()
        yield
        self[phase] += wallclock.perf_counter() - start


class Newton:
    """Newton on ``form`` (a BilinearForm, nonlinear in the trial function) for ``gfu``.

    Parameters
    ----------
    form : ngsolve.BilinearForm, the residual R(x; ·).
    gfu : GridFunction on the product space V × W (components u, φ).
    freedofs : BitArray of the unknowns (default: the space's free DOFs).
    inverse : str, direct solver of ``Mat.Inverse`` ("sparsecholesky" only for a symmetric
        Jacobian, "umfpack" or "pardiso" otherwise).
    rtol : relative residual reduction per step.
    maxit : maximum number of linear solves per step.
    condense : solve with the statically condensed Jacobian (``form`` must be a condensing
        ``StepSystem``); default ``form.condense`` when it exists.
    """

    def __init__(self, form, gfu, *, freedofs=None, inverse="umfpack", rtol=1e-10, maxit=50,
                 condense=None):
        if not rtol > 0:
            raise ValueError(f"rtol must be > 0, got {rtol}")
        if int(maxit) != maxit or maxit < 1:
            raise ValueError(f"maxit must be an integer >= 1, got {maxit}")
        self.form, self.gfu, self.inverse = form, gfu, inverse
        self.rtol, self.maxit = rtol, int(maxit)
        space = gfu.space
        self.freedofs = freedofs or space.FreeDofs()
        free = np.array(list(self.freedofs), dtype=bool)
        self.blocks = [np.flatnonzero(free[space.Range(i).start:space.Range(i).stop]) + space.Range(i).start
                       for i in range(2)]
        self.scales = None
        self.r = gfu.vec.CreateVector()
        self.w = gfu.vec.CreateVector()
        self.condense = getattr(form, "condense", False) if condense is None else condense
        if self.condense:
            self.coupling = self.freedofs & space.FreeDofs(coupling=True)
            self.r_condensed = gfu.vec.CreateVector()

    def _norm(self, vec, power):
        a = vec.FV().NumPy()
        return float(np.sqrt(sum(s ** power * np.dot(a[b], a[b]) for b, s in zip(self.blocks, self.scales))))

    def _set_scales(self):
        vals, cols, ptr = self.form.mat.CSR()
        diag = np.abs(sp.csr_matrix((vals, cols, ptr)).diagonal())
        self.scales = [float(diag[b].mean()) if len(b) and diag[b].mean() > 0 else 1.0
                       for b in self.blocks]

    def _residual(self, x, clock):
        """r = R(x), timed; the block scales are set from the first Jacobian."""
        with clock("residual"):
            self.form.Apply(x, self.r)
        if self.scales is None:
            self.form.AssembleLinearization(x)
            self._set_scales()

    def solve(self, *, step=None, time=None):
        """Iterate from the current ``gfu`` until converged; raise ``NewtonError`` otherwise."""
        x, r, w = self.gfu.vec, self.r, self.w
        residuals, clock = [], Timings()
        for it in range(self.maxit + 1):
            self._residual(x, clock)
            norm = self._norm(r, -1)
            residuals.append(norm)
            if not np.isfinite(norm):
                raise NewtonError("diverged (non-finite residual)", iteration=it, residuals=residuals,
                                  step=step, time=time, hint="a smaller time step")
            if norm <= self.rtol * residuals[0] or norm <= 1e-13 * self._norm(x, 1):
                return NewtonResult(it, residuals, r, clock)
            if it == self.maxit:
                break
            self.linear_solve(x, clock)
            x.data -= w
        raise NewtonError(f"did not converge in {self.maxit} iterations", iteration=self.maxit,
                          residuals=residuals, step=step, time=time,
                          hint="a smaller time step, a larger Nitsche parameter gamma0, theta = -1, "
                               "or a larger maxit")

    def linear_solve(self, x, clock):
        """One Newton correction w = R'(x)⁻¹ r (``self.w``, ``self.r``): assembly, factorisation
        and solve, timed into ``clock``."""
        if self.condense:
            return self._condensed_solve(x, clock)
        with clock("assembly"):
            self.form.AssembleLinearization(x)
        with clock("factorization"):
            inverse = self.form.mat.Inverse(self.freedofs, inverse=self.inverse)
        with clock("solve"):
            self.w.data = inverse * self.r

    def _condensed_solve(self, x, clock):
        """w = R'(x)⁻¹ r through the Schur complement on the coupling DOFs."""
        r, w, rc, K = self.r, self.w, self.r_condensed, self.form.K_condensed
        with clock("assembly"):
            self.form.AssembleLinearization(x, condensed=True)
        with clock("factorization"):
            inverse = self.form.condensed_mat.Inverse(self.coupling, inverse=self.inverse)
        with clock("solve"):
            rc.data = r + K.harmonic_extension_trans * r
            w.data = inverse * rc
            w.data += K.harmonic_extension * w
            w.data += K.inner_solve * r
