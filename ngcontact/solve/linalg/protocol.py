"""The protocol of the linear solver of a Newton correction, what ``Simulation(solver=...)`` takes
as an object (``LinearSolver``), and the checks a solver from outside the package goes through.

Newton hands the solver the Jacobian (an NGSolve matrix, the same object while its sparsity
stays), the free DOFs, the residual r and a vector w for the correction w = J⁻¹ r. The built-in
solvers (``linear_solver.DirectSolver``, ``KeptFactorization``, ``multigrid.MultigridSolver``,
``petsc_iterative.GamgSolver``) follow it; ``solver_choice.resolve``
makes them from a name.

A solver of the user's is checked twice. When the simulation is built (``check_object``): an
instance, not its class, whose ``solve`` takes Newton's arguments (a TypeError naming
``solver``). At every correction (``Watched``): w is set to 0 before its ``solve``, and what it
wrote is refused at once, naming the solver, where it is not a correction: non-finite entries,
nothing written (w still 0), entries written outside the free DOFs (they would move the
supports' prescribed values), or a w that does not solve J w = r, ‖J w − r‖ > ``LINEARISED`` ‖r‖
in Newton's scaled norm (one product with J: the wrong sign gives 2); an exception it raises is
reported with its name. These are faults of the solver, not of the model: the solve fails
(``newton.NewtonError``, not retried with smaller time steps) before a cut-back could blame the
time step. The package's own solvers are not watched (their corrections are exact
factorisations, or GMRES to a tolerance Newton sets): the default path costs nothing more.
"""
import inspect
from typing import Protocol, runtime_checkable

import numpy as np

from ngcontact import parallel

LINEARISED = 0.9
"""The largest ‖J w − r‖ / ‖r‖ (scaled dual norms on the solve's free DOFs) of a correction w
of a user's solver: w = 0 gives 1, the opposite sign 2; an inexact Newton method needs it below
1, and 0.9 is Eisenstat and Walker's largest forcing term (an iterative solver asked for less
accuracy than that is still taken)."""


@runtime_checkable
class LinearSolver(Protocol):
    """w = J⁻¹ r for Newton's corrections.

    ``name``: what it is, for messages and records.

    Optional, read where present: ``factorizations``, ``krylov_iterations``, ``krylov_failures``
    (its work so far, ints: Newton reports their growth per solve and per step), ``margin`` and
    ``forcing`` (an iterative solver's accuracy: ``inexact``), ``forget()`` (drop what is kept
    between solves), ``save``/``load`` (a kept factorisation's restart state: ``solver_restart``).
    """

    name: str

    def solve(self, matrix, freedofs, r, w, generation=None, timer=None, weights=None, tol=None,
              changing=None) -> None:
        """w = J⁻¹ r on ``freedofs`` (an NGSolve BitArray; w's other entries are left as they are
        or set to 0). ``matrix``: J (``matrix.mat`` of an NGSolve form; ``CSR()`` gives scipy's
        arrays); ``generation``: changes when J changed beyond the Γ3 terms (a new time step
        size); ``timer(phase)``: a context manager per phase ("factorization", "solve");
        ``weights``: per DOF, the scaled inner product of Newton's norm; ``tol``: the relative
        accuracy an iterative solver is asked for (None: its own); ``changing``: the DOFs whose
        rows change between iterations (the Γ3 layer), or None."""


ARGUMENTS = "(matrix, freedofs, r, w, generation=, timer=, weights=, tol=, changing=)"
"""How Newton calls ``solve``, in words."""


def label(solver):
    """The solver as messages name it: its class, and its ``name`` where that says more."""
    kind, name = type(solver).__name__, getattr(solver, "name", None)
    return f"{kind} ({name!r})" if isinstance(name, str) and name and name != kind else kind


def check_object(solver):
    """Raise a TypeError naming ``solver`` if it is a class (an instance is needed) or its
    ``solve`` cannot take Newton's arguments; ``solver`` has a ``solve`` and a ``name``."""
    if isinstance(solver, type):
        raise TypeError(f"solver: got the class {solver.__name__}, not a solver: pass an instance, "
                        f"solver={solver.__name__}(...)")
    try:
        signature = inspect.signature(solver.solve)
    except (TypeError, ValueError):                  # (a builtin without a signature: called as it is)
        return
    try:
        signature.bind(None, None, None, None, generation=None, timer=None, weights=None, tol=None, changing=None)
    except TypeError as err:
        raise TypeError(f"solver: {label(solver)}.solve{signature} cannot take Newton's arguments {ARGUMENTS} "
                        f"(ngcontact.solve.linalg.protocol.LinearSolver): {err}") from None


def built_in(solver):
    """Whether ``solver`` is one of the package's own (not watched)."""
    from ngcontact.solve.linalg.linear_solver import DirectSolver, KeptFactorization
    from ngcontact.solve.linalg.multigrid import MultigridSolver
    from ngcontact.solve.linalg.petsc_iterative import GamgSolver
    return type(solver) in (DirectSolver, KeptFactorization, MultigridSolver, GamgSolver)


HINT = (f"a solve() that writes w = J⁻¹ r into its argument w on the free DOFs and returns None; Newton calls "
        f"it as solve{ARGUMENTS} (ngcontact.solve.linalg.protocol.LinearSolver)")
"""What to fix where the correction is wrong, for ``newton.NewtonError``."""
RAISED_HINT = "the solver's own error: its exception, with its traceback, is the cause of this one"
"""What to fix where the solver raised."""


class SolverFault(RuntimeError):
    """A user's solver returned what is not a correction, or raised (the message says which);
    ``hint``: what to fix."""

    def __init__(self, message, hint=HINT):
        super().__init__(message)
        self.hint = hint


class Watched:
    """Calls a user's ``solver`` for Newton and checks each correction (see the module); ``norm``
    is Newton's ``residual_norm.ResidualNorm``."""

    def __init__(self, solver, norm):
        self.solver, self.norm, self.name = solver, norm, label(solver)

    def solve(self, matrix, freedofs, r, w, **options):
        """``solver.solve`` with w = 0 before it; raise ``SolverFault`` if it raised or its w is
        not a correction of J w = r on ``freedofs``."""
        w[:] = 0.0
        try:
            returned = self.solver.solve(matrix, freedofs, r, w, **options)
        except Exception as err:
            raise SolverFault(f"stopped: the linear solver {self.name} raised {type(err).__name__}: "
                              f"{' '.join(str(err).split())[:300]}", RAISED_HINT) from err
        problem = self._problem(matrix, freedofs, r, w)
        if problem is not None:
            if returned is not None:
                problem += (f" (its solve() returned {_what(returned)}: the correction is written into its "
                            "argument w)")
            raise SolverFault(f"stopped: the linear solver {self.name} {problem}")

    def _values(self, v):
        return parallel.cumulated(v) if self.norm.distributed else v.FV().NumPy()

    def _problem(self, matrix, freedofs, r, w):
        """What is wrong with the correction w (words), or None."""
        mesh, free = self.norm.mesh, np.array(list(freedofs), dtype=bool)
        values = self._values(w)
        bad = int(parallel.sum(mesh, np.count_nonzero(~np.isfinite(values[free]))))
        if bad:
            kind = "NaN" if parallel.any_rank(mesh, np.isnan(values[free]).any()) else "infinite"
            return f"returned a correction with {kind} entries ({bad} of the free DOFs)"
        outside = int(parallel.sum(mesh, np.count_nonzero(values[~free])))
        if outside:
            return (f"wrote into w outside the free DOFs ({outside} entries): the prescribed values of the "
                    "supports would move")
        rhs = np.where(free, self._values(r), 0.0)
        size = self.norm.dual(rhs)
        if size == 0:
            return None
        if not parallel.any_rank(mesh, np.any(values[free])):
            return "returned no correction (w is 0 at every free DOF after its solve)"
        product = w.CreateVector()
        product.data = matrix * w
        ratio = self.norm.dual(np.where(free, self._values(product) - rhs, 0.0)) / size
        if not ratio <= LINEARISED:
            return (f"returned a correction w that does not solve J w = r: ‖J w − r‖ = {ratio:.3g} ‖r‖ in "
                    f"Newton's scaled norm (at most {LINEARISED:g} is a correction; the opposite sign gives 2)")
        return None


def _what(value):
    """A returned value in a few words."""
    shape = getattr(value, "shape", None)
    if shape is not None:
        return f"a {type(value).__name__} of shape {tuple(shape)}"
    if hasattr(value, "__len__"):
        return f"a {type(value).__name__} of length {len(value)}"
    return f"{value!r:.40}"
