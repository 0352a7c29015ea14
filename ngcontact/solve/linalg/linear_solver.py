"""The linear solvers of the Newton correction: a sparse direct factorisation, and GMRES
preconditioned by a factorisation kept from an earlier Jacobian.

NGSolve's pip wheel factorises with "sparsecholesky" (LDLᵀ; only for a symmetric matrix:
a non-symmetric one is factored as if it were symmetric, silently) or "umfpack"
("pardiso" needs the mkl package). Factorising the same matrix object again (new values,
same sparsity pattern) calls NGSolve's ``Update()``, which reuses the symbolic analysis, as
``ngsolve.solvers.NewtonSolver`` does.

Between Newton iterations, and between the steps of one time step size, the Jacobian of
the step changes only in its Γ3 terms (``system``): the factorisation of an earlier one is
then a good preconditioner, and ``KeptFactorization`` solves with GMRES (``krylov``: numpy
serially, PETSc's KSP on a distributed mesh with MUMPS; NGSolve's ``GMResSolver`` reported
breakdowns that were none with Newton's weighted inner product) instead of factorising
again, until the Krylov iterations cost more than a factorisation would. Its serial
Gram–Schmidt is numpy (BLAS) on a kept basis: NGSolve's C++ ``la.GMRESSolver`` would spend its
time in the same products and preconditioner solves (docs/speed.md), and would need a Python
callback for Newton's inner product.

Both solvers have ``solve(matrix, freedofs, r, w, generation=..., timer=..., weights=...)``
(w = A⁻¹ r on the free DOFs; ``generation`` changes when the matrix changed beyond the Γ3
terms, e.g. a new time step size; ``weights`` per DOF for GMRES's inner product) and count
``factorizations``, ``krylov_iterations`` and ``krylov_failures``.

A resumed run continues bitwise: ``KeptFactorization.save``/``load`` keep what its next
decision reads (``solver_restart``; compared in docs/time.md).
"""
from contextlib import contextmanager, nullcontext

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.solve.linalg import petsc_solver
from ngcontact.solve.linalg.krylov import Gmres, distributed


NAMES = tuple(dict.fromkeys(("sparsecholesky", "umfpack") + tuple(sorted(ngs.la.GetAvailableSolvers()))
                            + petsc_solver.NAMES))
"""The direct solvers by name: every name of this NGSolve's ``la.GetAvailableSolvers()`` (some need
a package of their own: "pardiso" the ``mkl`` wheel, "cudss" nvmath-python; a factorisation
that NGSolve cannot make here is refused at the first one, by name) and PETSc's MUMPS
(``petsc_solver``; serial and distributed, where PETSc is installed)."""
PARALLEL_NAMES = ("masterinverse",)
"""The direct solver of a ParallelMatrix on a distributed mesh: NGSolve gathers the matrix on
rank 0 and factorises it there (exact for non-symmetric matrices; "umfpack" and
"sparsecholesky" are not parallel, the PyPI wheel has no MUMPS)."""


def factorization_worth(ndof, dim):
    """How many GMRES iterations preconditioned by a kept factorisation cost as much as one
    factorisation, for a step system of ``ndof`` DOFs in ``dim`` D: a power of ``ndof`` per
    dimension, fitted to the ratio factorisation time / GMRES iteration time found on the
    reference scene (docs/measurements.md, section ngcontact/solve/linalg/linear_solver.py),
    clamped to [4, 40] (the kept factorisation's ``max_budget``). A rule, not a clock: the
    solver's decisions, and so its results, are the same in every run (the wall-time ratio it
    replaces made identical runs differ at Newton's tolerance)."""
    worth = 30 * (8_500 / ndof) ** 1.3 if dim == 2 else 32 * (4_000 / ndof) ** 0.6
    return int(min(40, max(4, worth)))


@contextmanager
def reproducible():
    """Outside a TaskManager, run NGSolve's factorisations and solves on one thread.

    NGSolve's "sparsecholesky" starts threads of its own (``ngsglobals.numthreads``, 2 on the
    project's machines) even when no TaskManager is active, and adds their contributions in
    the order the threads finish: the same matrix then gave solutions that differ at round-off
    from one process to another. On one thread it is as fast at the sizes of the project's runs
    (docs/measurements.md, section ngcontact/solve/linalg/linear_solver.py). Inside a TaskManager
    (``ngsolve.GetNumThreads() > 1``) nothing changes: the user asked for threads, and results
    there are reproducible only to round-off."""
    if ngs.GetNumThreads() > 1:
        yield
        return
    configured = ngs.ngsglobals.numthreads
    ngs.SetNumThreads(1)
    try:
        yield
    finally:
        ngs.SetNumThreads(configured)


def untimed(phase):
    """A ``timer`` that times nothing."""
    return nullcontext()


class DirectSolver:
    """w = A⁻¹ r by a sparse direct factorisation of A at every solve.

    Parameters
    ----------
    name : one of ``NAMES``, or of ``PARALLEL_NAMES`` for a distributed mesh.
    symmetric : for "mumps": LDLᵀ (the matrix is symmetric) instead of LU.
    options : for "mumps": the ``petsc_options.SolverOptions`` of ``Simulation(solver={...})``
        (their ``database`` reaches the factorisation), or None.
    """

    def __init__(self, name, symmetric=False, options=None):
        if name not in NAMES + PARALLEL_NAMES:
            raise ValueError(f"inverse must be one of {', '.join(map(repr, NAMES + PARALLEL_NAMES))}, "
                             f"got {name!r}")
        if name in petsc_solver.NAMES:
            petsc_solver.load()                       # missing PETSc: the install line, before any work
        self.name, self.symmetric, self.options = name, symmetric, options
        self.factorizations = 0
        self._inverse = self._matrix = self._freedofs = None

    @property
    def inverse(self):
        """The last factorisation (an NGSolve inverse), or None."""
        return self._inverse

    def factor(self, matrix, freedofs):
        """Factorise ``matrix`` restricted to ``freedofs`` (a BitArray); the same matrix
        object and free DOFs as last time: update the factorisation in place."""
        with reproducible():
            if self._inverse is not None and matrix is self._matrix and freedofs is self._freedofs:
                try:
                    self._inverse.Update()
                    self.factorizations += 1
                    return
                except Exception:                     # an inverse without Update: factorise anew
                    pass
            if self.name in petsc_solver.NAMES:
                self._inverse = petsc_solver.MumpsFactorization(matrix, freedofs, self.symmetric,
                                                                self.options.database if self.options else None)
            else:
                try:
                    self._inverse = matrix.Inverse(freedofs, inverse=self.name)
                except Exception as err:            # a solver NGSolve lists but cannot load here
                    raise ValueError(f"solver {self.name!r}: NGSolve cannot factorise with it here: {err}") from None
        self._matrix, self._freedofs = matrix, freedofs
        self.factorizations += 1

    def solve(self, matrix, freedofs, r, w, generation=None, timer=untimed, weights=None, tol=None, changing=None):
        """w = A⁻¹ r with a new factorisation of A (exact: ``weights``, ``tol`` and ``changing``
        are not used)."""
        with timer("factorization"):
            self.factor(matrix, freedofs)
        with timer("solve"), reproducible():
            w.data = self._inverse * r

    def __repr__(self):
        return f"DirectSolver({self.name!r}{', symmetric=True' if self.symmetric else ''})"


class KeptFactorization:
    """w = A⁻¹ r by GMRES, preconditioned by the factorisation of an earlier matrix.

    The factorisation is made anew (``DirectSolver.factor``) when there is none, when
    ``generation`` or the free DOFs changed, when the matrix changed in more rows than the
    ``budget`` since it was factorised (``changed_rows``: GMRES preconditioned by the
    factorisation of A − E converges in at most rank(E) + 1 iterations, so a change in m rows
    costs up to m iterations; at first contact the Γ3 terms change far more rows between
    iterations than the budget, and GMRES would run into its cap), when the last solve needed more than half of the
    ``budget`` of GMRES iterations that one factorisation costs (``factorization_worth``)
    beyond what the first solve after the last factorisation needed
    for the same accuracy (what a new one would need; per decade of ``tol``: with the
    symmetric part that is never 1 iteration), or when GMRES with the kept factorisation does
    not reach ``tol`` within that count plus the budget (``krylov_failures`` counts those
    solves). If GMRES does not converge even right after a factorisation, a factorisation of
    A itself (UMFPACK; MUMPS's LU on a distributed mesh) solves, and ``fallbacks`` counts it.

    On a distributed mesh (``direct`` MUMPS) the same policy runs on every rank alike: GMRES is
    PETSc's, the changed rows are summed over the ranks, and ``save`` keeps nothing (a resumed
    run factorises at its first solve).

    Parameters
    ----------
    direct : DirectSolver whose factorisations precondition GMRES.
    symmetric : factorise the symmetric part (A + Aᵀ)/2 instead of A (with "sparsecholesky",
        for a Jacobian that is nearly symmetric: the non-symmetric terms live on Γ3 only).
    tol : relative reduction of the preconditioned residual in GMRES, taken in the
        ``weights`` inner product of ``solve`` when given.
    budget : the GMRES iterations that cost one factorisation (``factorization_worth``).
    max_budget : the most GMRES iterations allowed before refactorising.

    ``margin`` (1e-3): Newton asks GMRES for ``margin`` × (its target / its residual)
    (``newton.Newton``): its accuracy is that of the preconditioned norm, where the true
    residual falls less (on the demo looser margins cost Newton iterations, a tighter one gains
    none: docs/measurements.md, section ngcontact/solve/linalg/linear_solver.py).
    """

    margin = 1e-3

    def __init__(self, direct, *, symmetric=False, tol=1e-8, budget=20, max_budget=40):
        self.direct, self.symmetric, self.tol, self.max_budget = direct, symmetric, tol, max_budget
        self.budget = int(min(max_budget, max(1, budget)))
        self.krylov_iterations = self.krylov_failures = self.fallbacks = 0
        self._generation = self._freedofs = self._symmetric_part = self._source = None
        self._stale, self._baseline = True, None
        self._factored = self._rows = self._pattern = None     # the values factorised, per entry its row
        self._changing = None            # the positions that may change within the generation, at the factorisation
        self._restored = None            # a factorisation to make again at the first solve (``load``)
        self._krylov = Gmres()

    @property
    def name(self):
        what = "symmetric part" if self.symmetric else "Jacobian"
        return f"GMRES preconditioned by a kept {self.direct.name} factorisation of an earlier {what}"

    @property
    def factorizations(self):
        return self.direct.factorizations + self.fallbacks

    CHANGE = 1e-3
    """A row counts as changed where an entry moved by more than CHANGE times the row's largest
    entry at the factorisation."""

    def changed_rows(self, matrix, changing=None):
        """The rows of ``matrix`` that changed (``CHANGE``) since its values were factorised;
        ``changing``: the positions among its values that may have changed (all if None)."""
        where = slice(None) if changing is None else changing
        local = parallel.local_matrix(matrix)
        values = local.AsVector().FV().NumPy()[where]
        moved = np.abs(values - self._factored[where]) > self.CHANGE * self._scale[where]
        changed = np.zeros(local.height, dtype=bool)
        changed[self._rows[where][moved]] = True
        count = int(changed.sum())
        return matrix.row_pardofs.comm.mpi4py.allreduce(count) if distributed(matrix) else count

    def _keep_values(self, matrix):
        """The values of ``matrix`` as factorised, with each entry's row and row scale."""
        local = parallel.local_matrix(matrix)
        if matrix is not self._pattern:
            _, _, ptr = local.CSR()
            self._pattern, self._ptr = matrix, np.asarray(ptr, dtype=np.int64)
            self._rows = np.repeat(np.arange(local.height), np.diff(self._ptr))
        self._factored = local.AsVector().FV().NumPy().copy()
        largest, filled = np.zeros(local.height), np.diff(self._ptr) > 0
        largest[filled] = np.maximum.reduceat(np.abs(self._factored), self._ptr[:-1][filled])
        self._scale = largest[self._rows]

    def _factor(self, matrix, freedofs, timer, changing=None):
        self._changing = None if changing is None else np.array(changing)
        self._keep_values(matrix)
        with timer("factorization"):
            if self.symmetric:
                if matrix is not self._source:                 # a new matrix: its own pattern
                    self._source, self._symmetric_part = matrix, matrix.CreateMatrix()
                    self._transpose = _transposed_positions(matrix)
                values = matrix.AsVector().FV().NumPy()
                self._symmetric_part.AsVector().FV().NumPy()[:] = 0.5 * (values + values[self._transpose])
                self.direct.factor(self._symmetric_part, freedofs)
            else:
                self.direct.factor(matrix, freedofs)
        self._stale, self._baseline = False, None

    def _gmres(self, matrix, freedofs, r, w, maxiter, weights, tol, timer):
        with timer("solve"), reproducible():
            converged, iterations, _ = self._krylov.solve(matrix, freedofs, self.direct.inverse, r, w, weights,
                                                          tol, maxiter)
        self.krylov_iterations += iterations
        return converged, iterations

    def solve(self, matrix, freedofs, r, w, generation=None, timer=untimed, weights=None, tol=None, changing=None):
        """w = A⁻¹ r to the relative accuracy ``tol`` (default: the solver's ``tol``) in the
        ``weights`` norm of the preconditioned residual; ``changing``: the positions among the
        matrix's values that may change within one ``generation`` (the Γ3 terms'), or None."""
        tol = self.tol if tol is None else tol
        decades = max(1.0, -np.log10(tol))                # GMRES iterations grow with the accuracy asked
        if self._restored is not None:
            self._rebuild(matrix, freedofs, generation, changing, timer)
        fresh = self._stale or generation != self._generation or freedofs is not self._freedofs \
            or matrix is not self._pattern or self.changed_rows(matrix, changing) > self.budget
        if fresh:
            self._generation, self._freedofs = generation, freedofs
            self._factor(matrix, freedofs, timer, changing)
            if not self.symmetric:                      # the factorisation of A itself: exact
                with timer("solve"), reproducible():
                    w.data = self.direct.inverse * r
                self._baseline = 1.0 / decades
                return
        budget = self.budget
        # a kept factorisation gets what a fresh one would need, plus what a factorisation costs
        cap = self.max_budget if fresh else min(self.max_budget, int(np.ceil(self._baseline * decades)) + budget)
        converged, iterations = self._gmres(matrix, freedofs, r, w, cap, weights, tol, timer)
        if not converged and not fresh:                 # a factorisation pays: make it
            self.krylov_failures += 1
            self._factor(matrix, freedofs, timer, changing)
            fresh = True
            converged, iterations = self._gmres(matrix, freedofs, r, w, self.max_budget, weights, tol, timer)
        if not converged:                               # the preconditioner does not fit A
            self.krylov_failures += 1
            self.fallbacks += 1
            with timer("factorization"), reproducible():
                exact = petsc_solver.MumpsFactorization(matrix, freedofs) if distributed(matrix) else \
                    matrix.Inverse(freedofs, inverse="umfpack")
            with timer("solve"), reproducible():
                w.data = exact * r
            self._stale = True
            return
        if fresh:
            self._baseline = iterations / decades
        self._stale = iterations - self._baseline * decades > budget / 2   # next time, a factorisation pays

    def forget(self):
        """Factorise anew at the next solve (Newton's last try of a step starts afresh)."""
        self._stale = True

    def save(self, generation, whole=False):
        """What the next solve's decision needs of the factorisation, as named arrays (for a
        restart from disk): none when the next solve factorises anyway (none made, marked
        stale, or made in another ``generation`` than the system's now); else GMRES's baseline
        and the values factorised: at the positions that may change within a generation
        (``changing`` of the solve that factorised: the Γ3 terms'), the rest being the system's
        bulk, which the resumed run assembles again bitwise; with ``whole`` (laws change the
        bulk's tangent too) or without such positions, every value."""
        if self._stale or self._factored is None or generation != self._generation or distributed(self._pattern):
            return {}
        arrays = dict(kept_baseline=np.asarray(self._baseline))
        if whole or self._changing is None:
            arrays["kept_values"] = self._factored.copy()
        else:
            arrays.update(kept_positions=self._changing.copy(), kept_values=self._factored[self._changing])
        return arrays

    def load(self, arrays, generation):
        """Put back the arrays of ``save`` for a system now in ``generation``: the first solve
        in that generation factorises the values saved again (``_rebuild``) and goes on as the
        run that saved them would have; a first solve in another generation factorises anew,
        as that run would have too."""
        self._stale, self._factored, self._restored = True, None, None
        if "kept_values" in arrays:
            self._restored = dict(generation=generation, baseline=float(arrays["kept_baseline"]),
                                  values=np.array(arrays["kept_values"]), positions=arrays.get("kept_positions"))

    def _rebuild(self, matrix, freedofs, generation, changing, timer):
        """The factorisation of ``load``, made again of the values saved: ``matrix``'s values
        with the saved ones at their positions (all of them without positions), factorised
        with the matrix holding them for the moment; not counted in ``factorizations`` (the run
        that saved it made it once)."""
        restored, self._restored = self._restored, None
        if generation != restored["generation"] or freedofs is None:
            return
        values = matrix.AsVector().FV().NumPy()
        current = values.copy()
        positions = restored["positions"]
        if positions is None:
            if len(restored["values"]) != len(current):
                return
            factored = restored["values"]
        else:
            factored = current.copy()
            factored[positions] = restored["values"]
        counted = self.direct.factorizations
        values[:] = factored
        try:
            self._factor(matrix, freedofs, timer, positions if positions is not None else changing)
        finally:
            values[:] = current
        self.direct.factorizations = counted
        self._generation, self._freedofs = generation, freedofs
        self._stale, self._baseline = False, restored["baseline"]

    def __repr__(self):
        return f"KeptFactorization({self.direct!r}, symmetric={self.symmetric})"


def _transposed_positions(matrix):
    """For each stored entry (i, j) of a structurally symmetric sparse matrix, the position
    of (j, i) among its stored values."""
    _, cols, ptr = matrix.CSR()
    cols, ptr = np.asarray(cols, dtype=np.int64), np.asarray(ptr, dtype=np.int64)
    rows = np.repeat(np.arange(matrix.height, dtype=np.int64), np.diff(ptr))
    keys = rows * matrix.width + cols
    transposed = cols * matrix.width + rows
    where = np.searchsorted(keys, transposed)
    if not np.array_equal(keys[np.clip(where, 0, len(keys) - 1)], transposed):
        raise ValueError("the matrix is not structurally symmetric")
    return where
