"""Semismooth Newton for one step: one loop for every enforcement method.

Forces (N) and charges (C) are not comparable, so residuals are compared in the norm
‖r‖² = ‖r_u‖²/s_u + ‖r_φ‖²/s_φ (``residual_norm.ResidualNorm``), where s_u, s_φ are the mean diagonal
entries of the two blocks of the bulk's K at the first step (N/m and C/V; the Γ3 terms left out,
so that a stiff contact term cannot set the units): each term is an energy, in J.
When a solve may stop is decided by ``stopping.ConvergenceTest``: the residual against the
step's force scale (loads and bulk forces, never the contact terms or the size of the state),
or against its round-off floor where that floor is small; a residual stuck at a floor above
that fails as "cannot be certified".

A correction w that is not finite, or much larger than the residual r it answers
(‖r‖/‖w‖ < ``SINGULAR_RATIO`` in the scaled norms), comes from a singular Jacobian (a body
held only by the contact, whose rigid motion nothing fixes while the contact is open): the
solve fails at once and says so. Such failures, and an uncertifiable residual, are not
``recoverable``: a smaller time step would fail the same way, so the cut-back policy of
``Simulation.advance`` does not retry them.

A solver of the user's (``Simulation(solver=<object>)``) has each correction checked
(``protocol.Watched``): one that is not finite, not written, or does not solve the linear system,
and an exception the solver raises, fail at once naming the solver and what it returned, not the
model.

Every enforcement method runs in this one loop; a method with unknowns of its own (the nodal
multipliers of the active set method) takes part through an ``enforcement.NewtonHook``, and a
``step_length`` callback may shorten a correction (``step_length``). Wall time goes to a ``timer``
callback per phase ("residual", "assembly", "factorization", "solve"); a failure raises ``NewtonError``.
"""
import time as wallclock
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
from netgen.libngpy._meshing import NgException

from ngcontact import parallel
from ngcontact.solve.linalg.linear_solver import DirectSolver, untimed
from ngcontact.solve.linalg.protocol import SolverFault, Watched, built_in
from ngcontact.solve.linalg.residual_norm import ResidualNorm
from ngcontact.solve.stopping import ConvergenceTest
from ngcontact.solve.cycles import CycleWatch
from ngcontact.solve.line_search import LineSearch
from ngcontact.solve.inexact import correction_tolerance

LINEAR_COUNTS = ("factorizations", "krylov_iterations", "krylov_failures")
"""The linear solver's counters that a solve reports."""
SINGULAR_RATIO = 1e-12
"""A correction w with ‖r‖/‖w‖ below this (scaled dual over primal norm: the smallest singular
value of the scaled Jacobian it reveals, orders of magnitude above this on the meshes of the
test suite: docs/measurements.md, section ngcontact/solve/newton.py) comes from a singular
Jacobian: the factorisation divided by a pivot at round-off."""
SINGULAR = "stopped: the system is singular (the Jacobian has no unique solution)"
NOT_FINITE = "stopped: the Jacobian has entries that are not finite (NaN or inf)"
NOT_FINITE_HINT = ("a law or datum whose derivative is not finite at the state: NGSolve differentiates a "
                   "CoefficientFunction as written, so e.g. sqrt(InnerProduct(eps, eps)) has an infinite "
                   "derivative at eps = 0 (write |eps| as sqrt(InnerProduct(eps, eps) + s**2) with a small s, "
                   "or use a form that is differentiable there), and NaN in the data propagates")
SINGULAR_HINT = ("supports that hold the body: a body held only by the contact has no unique displacement "
                 "while the contact is open; or a start u0 that touches the obstacle")


class NewtonError(RuntimeError):
    """Newton failed: says where (step, time, iteration) and gives the residual history.

    ``history`` holds the steps computed before the failure (set by the simulation);
    ``factorizations``, ``krylov_iterations``, ``krylov_failures``: the linear solver's work
    in the failed solve, ``linear_history`` the same per Newton iteration (dicts);
    ``residuals_limited``: the residual history of a first try with shortened steps, if any;
    ``recoverable``: whether a smaller time step may succeed (False for a singular Jacobian and
    a residual that cannot be certified: the cut-back policy does not retry those); ``hint``:
    what to try; ``tried``: the time steps tried for the step (s, ``Simulation.advance``)."""

    def __init__(self, reason, *, iteration, residuals, step=None, time=None, hint="", recoverable=True):
        self.reason, self.iteration, self.residuals = reason, iteration, residuals
        self.step, self.time, self.history = step, time, None
        self.recoverable, self.hint, self.tried = recoverable, hint, []
        self.early = False               # a line search given up: the continuation or full steps follow
        self.residuals_limited = None    # the history of a first try with shortened steps
        self.factorizations = self.krylov_iterations = self.krylov_failures = 0   # the linear solver's work
        self.linear_history = []    # per Newton iteration: the linear solver's counts (LINEAR_COUNTS)
        where = f"step {step} (t = {time:.6g} s), " if step is not None else ""
        hist = ", ".join(f"{r:.3e}" for r in residuals)
        super().__init__(f"Newton {reason} at {where}iteration {iteration}; scaled residual "
                         f"history [J^1/2]: [{hist}]" + (f". Try: {hint}" if hint else ""))


@dataclass
class NewtonResult:
    """A converged solve: ``iterations`` (linear solves), ``residuals`` (scaled norms, one
    per residual evaluation, J^1/2), ``residual``, the final residual vector R(x), and the
    linear solver's ``factorizations``, ``krylov_iterations`` and ``krylov_failures`` (GMRES
    solves that did not converge and were followed by a fresh factorisation) during the solve (both tries
    of a repeated solve), ``discarded``: the linear solves of a first try that was repeated;
    ``stopped``: "tolerance" (the convergence test of ``stopping``), "estimate" (the last
    correction's energy below ``Newton.energy_target``: adaptive stopping) or "reduction" (the
    residual below ``Newton.reduction`` of the solve's first: a path's intermediate stage)."""
    iterations: int
    residuals: list = field(default_factory=list)
    residual: object = None
    factorizations: int = 0
    krylov_iterations: int = 0
    krylov_failures: int = 0
    discarded: int = 0
    stopped: str = "tolerance"


class Timings(dict):
    """Wall time (s) per phase: ``with timings("assembly"): ...`` adds to timings["assembly"];
    a ``timer`` for ``Newton.solve``."""

    PHASES = ("residual", "assembly", "factorization", "solve")

    def __init__(self):
        super().__init__((phase, 0.0) for phase in self.PHASES)

    @contextmanager
    def __call__(self, phase):
        start = wallclock.perf_counter()
        yield
        self[phase] += wallclock.perf_counter() - start


class Newton:
    """Newton on ``system`` for the state ``gfu``, solved in place.

    Parameters
    ----------
    system : the residual R: a BilinearForm (nonlinear in the trial function) or a
        ``StepSystem``: ``Apply``, ``AssembleLinearization``, ``mat`` and ``condense`` (with
        ``harmonic_extension``, ``harmonic_extension_trans``, ``inner_solve``); the optional
        ``bulk_diagonal()`` (for the scales of the norms, without the Γ3 terms),
        ``force_scale(norm)`` and ``magnitude(x)`` (for ``stopping.ConvergenceTest``).
    gfu : GridFunction on the product space V × W (components u, φ).
    solver : the linear solver of the corrections, ``linear_solver.DirectSolver`` (default:
        UMFPACK) or ``KeptFactorization``, or a user's object of ``protocol.LinearSolver``, whose
        corrections are checked (``protocol.Watched``); an iterative one is asked for ``margin`` (its
        attribute, default 0.1) × (the target residual / the current one), inexact Newton,
        and, if it has a ``forcing`` γ, for no more than ``inexact.forcing_term`` (Eisenstat and
        Walker's γ (‖r_k‖ / ‖r_{k−1}‖)² after a correction that made the residual fall; γ
        ‖r_{k−1}‖ / ‖r_k‖ after one that made it rise); at most 1e-3 either way.
    freedofs : BitArray of the unknowns (default: the space's free DOFs).
    rtol : the residual to reach, relative to the step's force scale (``stopping``).
    maxit : maximum number of linear solves per solve.
    hook : an ``enforcement.NewtonHook`` of the enforcement method, or None.
    step_length : None, or a callable w ↦ α ∈ (0, 1]: the correction is x − α w (with
        optional ``start()``, called when a solve begins, and ``cut``, whether the solve
        shortened a step).

    ``energy_target`` (J^½, None by default): adaptive stopping. A solve also stops, with
    ``NewtonResult.stopped = "estimate"``, at the first residual after a full (not shortened)
    correction whose energy ``|||w|||`` (``_energy``) was at most the target, if that residual
    fell: the linearisation error is then below a share of the discretisation error the target
    stands for (``adapt`` sets it from the estimate). The linear solver is then asked for no
    more than ``inexact.ALGEBRAIC`` of the target. The convergence test of ``stopping`` still
    stops a solve first where it holds. ``estimate_stops`` counts the solves the target stopped.
    ``reduction`` (None by default): a solve also stops ("reduction") at the first residual at
    most this fraction of its first (``continuation``'s stages before the last).
    ``switch_loop`` (None by default): a ``switch_loop.SwitchLoop`` that replaces each correction
    by the solution of the linear model whose Signorini contact set is its own.
    """

    def __init__(self, system, gfu, *, solver=None, freedofs=None, rtol=1e-10, maxit=50, hook=None,
                 step_length=None):
        if not rtol > 0:
            raise ValueError(f"rtol must be > 0, got {rtol}")
        if int(maxit) != maxit or maxit < 1:
            raise ValueError(f"maxit must be an integer >= 1, got {maxit}")
        self.system, self.gfu, self.hook, self.step_length = system, gfu, hook, step_length
        self.on_iteration = None       # called with (iteration, scaled residual): progress output
        self.energy_target = None      # J^½: stop once the last correction's energy is below it (``adapt``)
        self.estimate_stops = 0        # solves stopped by ``energy_target`` (NewtonResult.stopped = "estimate")
        self.switches = None           # the laws' pieces at the state (``switches.Switches``): a cycle's account
        self.line_search = LineSearch()   # engaged when full steps stop making progress; None: full steps only
        self.continuation = None       # ``continuation.Continuation``: the path a solve without progress follows
        self.reduction = None          # stop at this fraction of the first residual (a path's stage)
        self.switch_loop = None        # ``switch_loop.SwitchLoop``: the Signorini switch settled in each correction
        self._best = None              # [the iterate of least residual of a first try, that residual]
        self.solver = solver if solver is not None else DirectSolver("umfpack")
        self.rtol, self.maxit = rtol, int(maxit)
        space = gfu.space
        self.freedofs = freedofs if freedofs is not None else space.FreeDofs()
        self.norm = ResidualNorm(space, self.freedofs)
        # a solver from outside the package: each correction checked (``protocol.Watched``)
        self._watch = None if built_in(self.solver) else Watched(self.solver, self.norm)
        self.test = ConvergenceTest(system, self.norm)
        self.r = gfu.vec.CreateVector()
        self.w = gfu.vec.CreateVector()
        self.condense = bool(getattr(system, "condense", False))
        if self.condense:
            self.coupling = self.freedofs & space.FreeDofs(coupling=True)
            self.r_condensed = gfu.vec.CreateVector()

    @property
    def solver_name(self):
        """The linear solver actually used for the corrections."""
        return self.hook.solver if self.hook is not None else self.solver.name

    def solve(self, *, step=None, time=None, timer=None):
        """Iterate from the current ``gfu`` until converged; raise ``NewtonError`` otherwise.
        ``step`` and ``time`` (s) are for the error message; ``timer(phase)`` returns a
        context manager that times a phase (e.g. a ``Timings``). A solve whose shortened
        steps did not converge is repeated from its start with full steps. Where full steps stop
        making progress (``line_search`` not None), the ``continuation`` follows its path from the
        try's iterate of least residual where its laws flip, else the line search takes over; last come
        full steps from the start without the search (a step solved without globalisation is never
        lost to it). The result's ``discarded`` counts the iterations of every try given up.
        With a ``switch_loop``, a solve that fails is made again from its start without it (the
        loop's model keeps the other laws of Γ3 at their pieces, which an extreme conduction
        can make far off), and a failure then is the one reported."""
        if self.switch_loop is None:
            return self._globalised(step, time, timer)
        start = self.gfu.vec.CreateVector()
        start.data = self.gfu.vec
        try:
            return self._globalised(step, time, timer)
        except NewtonError as failure:
            spent = failure.iteration + getattr(failure, "spent", 0)
        self.gfu.vec.data = start
        loop, self.switch_loop = self.switch_loop, None
        getattr(self.solver, "forget", lambda: None)()
        try:
            result = self._globalised(step, time, timer)
        finally:
            self.switch_loop = loop
        result.discarded += spent
        return result

    def _globalised(self, step, time, timer):
        """``solve`` without the retry that leaves the ``switch_loop`` out."""
        if self.line_search is None:
            return self.tries(step, time, timer)
        start = self.gfu.vec.CreateVector()
        start.data = self.gfu.vec
        self._best = [start.CreateVector(), np.inf] if self.continuation else None
        try:
            return self.tries(step, time, timer)
        except NewtonError as first:
            if not first.early:             # (a try out of iterations while it progressed: a shorter step may do)
                raise
            spent, failure = first.iteration, first
        finally:
            best, self._best = self._best, None
        if self.continuation:
            try:
                return self.continuation.solve(self, failure, start, best[0], step, time, timer)
            except NewtonError as err:
                spent, failure = spent + err.spent, err
        self.gfu.vec.data = start
        search, self.line_search = self.line_search, None
        getattr(self.solver, "forget", lambda: None)()    # (a fresh factorisation, as the step's first)
        try:
            result = self.tries(step, time, timer)
        except NewtonError:
            raise failure from None
        finally:
            self.line_search = search
        result.discarded += spent
        return result

    def tries(self, step, time, timer):
        """``solve`` without what follows a search given up (``NewtonError.early``)."""
        if self.step_length is None:
            return self._solve(step, time, timer, limit=False)
        start = self.gfu.vec.CreateVector()
        start.data = self.gfu.vec
        try:
            return self._solve(step, time, timer, limit=True)
        except NewtonError as limited:
            if not getattr(self.step_length, "cut", True) or limited.early:
                raise
            self.gfu.vec.data = start
            try:
                result = self._solve(step, time, timer, limit=False)
                result.discarded = limited.iteration
                for name in LINEAR_COUNTS:
                    setattr(result, name, getattr(result, name) + getattr(limited, name))
                return result
            except NewtonError as full:
                full.residuals_limited = limited.residuals
                full.args = (f"{full.args[0]} (with full steps; with shortened steps: {limited.reason}, "
                             f"residual history [{', '.join(f'{r:.3e}' for r in limited.residuals)}])",)
                raise full from None

    def _solve(self, step, time, timer, limit):
        timer = timer or untimed
        x, r, hook = self.gfu.vec, self.r, self.hook
        residuals, linear = [], []
        counts = self._linear_counts()
        if hook is not None:
            hook.start()
        if limit and hasattr(self.step_length, "start"):
            self.step_length.start()

        def fail(reason, it, hint, recoverable=True, early=False, laws=True):
            if laws and getattr(self.system, "laws", None) is not None:   # a nonlinear law the cause? (``law_terms``)
                reason, hint = self.system.laws.explain(x, reason, hint)
            error = NewtonError(reason, iteration=it, residuals=residuals, step=step, time=time, hint=hint,
                                recoverable=recoverable)
            error.early = early
            for name, value in self._linear_counts(since=counts).items():
                setattr(error, name, value)
            error.linear_history = linear
            return error

        correction = None                # the energy of the last correction (J^½), for the adaptive stop
        cycling = CycleWatch(self.switches)   # iterates that repeat: a cycle, named by the laws that flip
        search = self.line_search if hook is None else None
        if search is not None:
            search.start()
        ready = False                    # r = R(x) already (the line search evaluated it)
        pieces = []                      # the laws' pieces where the line search began (``switches``)
        for it in range(self.maxit + 1):
            if not ready:
                with timer("residual"):
                    self.system.Apply(x, r)
            ready = False
            if self.norm.scales is None:
                self.norm.set_scales(self._diagonal(x))
            value, settled = hook.residual(x, r, self.norm) if hook is not None else (self.norm.dual(r), True)
            residuals.append(value)
            if self._best is not None and value < self._best[1]:     # (where a path would start)
                self._best[0].data, self._best[1] = x, value
            if self.on_iteration is not None:
                self.on_iteration(it, value)
            if not np.isfinite(value):
                raise fail("diverged (non-finite residual)", it, "a smaller time step")
            verdict = self.test(x, residuals, self.rtol, r)
            adaptive = (self.energy_target is not None and correction is not None and correction <= self.energy_target
                        and value < residuals[-2])
            reduced = self.reduction is not None and value <= self.reduction * residuals[0]
            if settled and (verdict.converged or adaptive or reduced):
                if hook is not None:
                    hook.finish()
                stopped = "tolerance" if verdict.converged else "estimate" if adaptive else "reduction"
                self.estimate_stops += stopped == "estimate"
                return NewtonResult(it, residuals, r, **self._linear_counts(since=counts), stopped=stopped)
            if verdict.uncertifiable:
                reason, hint = verdict.explain()
                raise fail(reason, it, hint, recoverable=False)
            engaged = search is not None and search.engaged
            if search is not None:
                search.observe(residuals, self.switches, self.continuation or None)
                if search.engaged and not engaged and self.switches is not None:
                    pieces = search.window[-1:] or [self.switches()]   # the laws' pieces where it began
                if search.exhausted:
                    reason, hint = search.explain("made no progress with full steps", self.switches, pieces)
                    raise fail(reason, it, hint, early=True)
            cycle = cycling(residuals) if search is None or engaged else None   # (else ``observe`` looked)
            if cycle is not None:
                raise fail(cycle[0], it, cycle[1])
            if it == self.maxit:
                break
            if hook is not None:
                with timer("assembly"):
                    self.system.AssembleLinearization(x)
                hook.correct(self.system, x, r, timer)
                if not np.all(np.isfinite(x.FV().NumPy())):
                    raise fail(SINGULAR + " (the correction is not finite)", it + 1, SINGULAR_HINT, False)
            else:
                before = self._linear_counts()
                tol = correction_tolerance(self.solver, verdict.target, residuals, self.energy_target, correction)
                try:
                    self.linear_solve(x, timer, tol=tol)
                except SolverFault as fault:
                    raise fail(str(fault), it + 1, fault.hint, False, laws=False) from fault.__cause__
                except NgException as err:           # a factorisation that failed (a pivot of 0 or NaN)
                    if not self._jacobian_finite():
                        raise fail(NOT_FINITE, it + 1, NOT_FINITE_HINT, False) from err
                    raise fail(f"{SINGULAR} (the factorisation failed: {err})", it + 1, SINGULAR_HINT,
                               False) from err
                linear.append(self._linear_counts(since=before))
                if self.switch_loop is not None:
                    with timer("solve"):
                        self.switch_loop(self, x, residuals, tol)
                self._check_correction(fail, it)
                alpha = self.step_length(self.w) if limit else 1.0
                # a shortened correction says nothing of the error left: no adaptive stop after it
                correction = self._energy(self.w, r) if alpha == 1.0 else None
                if search is not None and search.engaged:
                    alpha, _ = search.search(x, self.w, alpha, value, lambda: self._merit(x, timer))
                    correction, ready = correction if alpha == 1.0 else None, True
                else:
                    x.data -= alpha * self.w
        if search is not None and search.engaged:
            reason, hint = search.explain(f"did not converge in {self.maxit} iterations", self.switches, pieces)
            raise fail(reason, self.maxit, hint)
        raise fail(f"did not converge in {self.maxit} iterations", self.maxit,
                   "a smaller time step, a larger Nitsche parameter gamma0, theta = -1, or a larger maxit")

    def _merit(self, x, timer):
        """R(x) into ``self.r``; returns its scaled norm (the line search's merit)."""
        with timer("residual"):
            self.system.Apply(x, self.r)
        return self.norm.dual(self.r)

    def _energy(self, w, r):
        """|||w||| = |w_u·r_u − w_φ·r_φ|^½ (J^½) of the correction w that answers the residual r
        (r = R'(x) w: the energy of the linearised step, the electric equation negated in R so
        that the piezoelectric cross terms cancel): the linearisation error Newton leaves when it
        stops before applying w."""
        a, b = self._values(w), self._values(r)
        u, phi = self.norm.blocks
        return float(np.sqrt(abs(parallel.sum(self.norm.mesh, np.dot(a[u], b[u]) - np.dot(a[phi], b[phi])))))

    def _values(self, v):
        return parallel.cumulated(v) if self.norm.distributed else v.FV().NumPy()

    def _check_correction(self, fail, it):
        """Raise (through ``fail``) if the correction w is not finite or far larger than the
        residual it answers: the Jacobian is singular."""
        w = parallel.cumulated(self.w) if self.norm.distributed else self.w.FV().NumPy()
        if parallel.any_rank(self.norm.mesh, not np.all(np.isfinite(w))):
            if not self._jacobian_finite():
                raise fail(NOT_FINITE, it + 1, NOT_FINITE_HINT, False)
            raise fail(SINGULAR + " (the correction is not finite)", it + 1, SINGULAR_HINT, False)
        size = self.norm.primal(w)
        if size > 0 and self.norm.dual(self.r) < SINGULAR_RATIO * size:
            raise fail(f"{SINGULAR}: the correction is {size / self.norm.dual(self.r):.3g} times larger than the "
                       "residual it answers (scaled norms)", it + 1, SINGULAR_HINT, False)

    def _jacobian_finite(self):
        """Whether the assembled Jacobian's entries are all finite, on every rank (True for a
        matrix that does not show its entries)."""
        matrix = getattr(self.system, "mat", None)
        try:
            values = getattr(matrix, "local_mat", matrix).AsVector().FV().NumPy()
        except (AttributeError, TypeError, NgException):
            values = np.zeros(0)
        return not parallel.any_rank(self.norm.mesh, not np.all(np.isfinite(values)))

    def _linear_counts(self, since=None):
        """The linear solver's counters (``LINEAR_COUNTS``), minus ``since``."""
        now = {name: getattr(self.solver, name, 0) for name in LINEAR_COUNTS}
        return now if since is None else {name: now[name] - since[name] for name in LINEAR_COUNTS}

    def _diagonal(self, x):
        if hasattr(self.system, "bulk_diagonal"):
            return self.system.bulk_diagonal()
        import scipy.sparse as sp                       # (here: SciPy loads when a system has no bulk_diagonal)
        self.system.AssembleLinearization(x)
        return sp.csr_matrix(self.system.mat.CSR()).diagonal()

    def linear_solve(self, x, timer=None, tol=None):
        """One Newton correction w = R'(x)⁻¹ r (``self.w``, ``self.r``): assembly,
        factorisation and solve, each timed by ``timer``; ``tol``: the relative accuracy an
        iterative solver needs (None: its own)."""
        timer = timer or untimed
        system, r, w = self.system, self.r, self.w
        with timer("assembly"):
            system.AssembleLinearization(x)
        generation = getattr(system, "generation", None)
        changing = system.changing_entries() if hasattr(system, "changing_entries") else None
        if self.condense:                                  # through the Schur complement
            rc = self.r_condensed
            with timer("solve"):
                rc.data = r + system.harmonic_extension_trans * r
            (self._watch or self.solver).solve(system.mat, self.coupling, rc, w, generation=generation,
                                               timer=timer, weights=self.norm.weights, tol=tol, changing=changing)
            with timer("solve"):
                w.data += system.harmonic_extension * w
                w.data += system.inner_solve * r
        else:
            (self._watch or self.solver).solve(system.mat, self.freedofs, r, w, generation=generation,
                                               timer=timer, weights=self.norm.weights, tol=tol, changing=changing)
