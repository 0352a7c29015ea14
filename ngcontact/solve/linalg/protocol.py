"""The protocol of the linear solver of a Newton correction, what ``Simulation(solver=...)`` takes
as an object (``LinearSolver``).

Newton hands the solver the Jacobian (an NGSolve matrix, the same object while its sparsity
stays), the free DOFs, the residual r and a vector w for the correction w = J⁻¹ r. The built-in
solvers (``linear_solver.DirectSolver``, ``KeptFactorization``, ``multigrid.MultigridSolver``,
``petsc_iterative.GamgSolver``) follow it; ``solver_choice.resolve``
makes them from a name.
"""
from typing import Protocol, runtime_checkable


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
