"""The one GMRES of Newton's corrections (``Gmres``), used by every solver of the layer that
iterates: the kept factorisation (``linear_solver.KeptFactorization``), multigrid
(``multigrid``) and GAMG (``petsc_iterative``).

GMRES is left-preconditioned, not restarted within its iteration cap, and measures the
preconditioned residual in Newton's weighted norm (u in m and φ in V differ by orders of
magnitude: in the Euclidean norm the potential's entries swamp the displacement's and Newton
diverges). Two back-ends run it:

* numpy (``gmres.gmres``) on one rank's NGSolve vectors, with an NGSolve preconditioner;
* PETSc's KSP (``PetscGmres``) on PETSc vectors: on a distributed mesh (numpy's inner products
  would be one rank's; a MUMPS factorisation then preconditions by its ``petsc_apply``), and
  wherever the preconditioner is a function on PETSc vectors (GAMG's). Serially with an
  NGSolve preconditioner (a MUMPS factorisation is one) the numpy back-end runs even where
  PETSc is installed, so that a serial run gives the same numbers with and without PETSc.
"""
import ngsolve as ngs
import numpy as np

from ngcontact.solve.linalg.gmres import gmres


def distributed(matrix):
    """True for a ParallelMatrix over several MPI ranks."""
    pardofs = getattr(matrix, "row_pardofs", None)
    return pardofs is not None and pardofs.comm.size > 1


class Gmres:
    """GMRES for J w = r (module docstring); holds the PETSc operator and KSP between solves of
    the same matrix object and free DOFs."""

    def __init__(self):
        self._petsc = self._key = None

    def operator(self, matrix, freedofs):
        """J (``matrix`` on ``freedofs``) as a ``petsc_solver.PetscMatrix``: converted once per
        matrix object and free DOFs, its current values copied in at every call."""
        from ngcontact.solve.linalg.petsc_solver import PetscMatrix
        if self._key is None or self._key[0] is not matrix or self._key[1] is not freedofs:
            self._petsc, self._key = PetscGmres(PetscMatrix(matrix, freedofs)), (matrix, freedofs)
        else:
            self._petsc.matrix.refill()
        return self._petsc.matrix

    def solve(self, matrix, freedofs, preconditioner, r, w, weights, tol, maxiter, current=False):
        """w ≈ J⁻¹ r to the relative accuracy ``tol`` in at most ``maxiter`` iterations, from w = 0;
        ``preconditioner``: an NGSolve BaseMatrix (on a distributed mesh one with ``petsc_apply(x,
        y)`` on PETSc vectors, as MUMPS's), or a function y = M x on PETSc vectors; ``current``:
        ``operator`` was just called for this solve (its values are J's). Returns (converged, iterations, PETSc's converged reason or None)."""
        native = not isinstance(preconditioner, ngs.BaseMatrix)
        if not native and not distributed(matrix):
            converged, iterations = gmres(matrix, preconditioner, r, w, weights, tol, maxiter)
            return converged, iterations, None
        if not current:
            self.operator(matrix, freedofs)
        self._petsc.precondition = preconditioner if native else preconditioner.petsc_apply
        return self._petsc.solve(r, w, weights, tol, maxiter)


class PetscGmres:
    """PETSc's GMRES (left-preconditioned, no restart within ``maxiter``) for A w = r in
    Newton's weighted norm, as ``gmres.gmres``: it runs on S A S⁻¹ (a shell operator over the
    ``petsc_solver.PetscMatrix`` ``matrix``, whose values the caller keeps current) with the
    preconditioner S M S⁻¹, S = diag(weights)^½, M given by ``precondition(x, y)`` (y = M x on
    PETSc vectors of A's layout)."""

    def __init__(self, matrix):
        from ngcontact.solve.linalg.petsc_modules import load
        PETSc, _ = load()
        self.matrix, self.precondition = matrix, None
        A = matrix.mat
        comm = A.getComm()
        self._x, self._b = A.createVecs()
        self._scale, self._inverse_scale, self._t, self._s = (self._x.duplicate() for _ in range(4))
        self._weighted = False
        self._scale.set(1.0)
        self._inverse_scale.set(1.0)
        operator = PETSc.Mat().createPython(A.getSizes(), context=_ScaledOperator(self), comm=comm)
        operator.setUp()
        self.ksp = PETSc.KSP().create(comm=comm)
        self.ksp.setType("gmres")
        self.ksp.setOperators(operator)
        pc = self.ksp.getPC()
        pc.setType("python")
        pc.setPythonContext(_ScaledPreconditioner(self))

    def _weights(self, template, weights):
        """S and S⁻¹ as PETSc vectors (ones without weights); made again only for new weights
        (Newton's norm keeps its array within a step)."""
        if weights is self._weighted:
            return
        self._weighted = weights
        if weights is None:
            self._scale.set(1.0)
        else:
            cumulated = template.CreateVector()
            cumulated.FV().NumPy()[:] = np.sqrt(weights)
            if hasattr(cumulated, "SetParallelStatus"):
                cumulated.SetParallelStatus(ngs.la.PARALLEL_STATUS.CUMULATED)
            self.matrix.vectors.petscVec(cumulated, self._scale)
        self._inverse_scale.set(1.0)
        self._inverse_scale.pointwiseDivide(self._inverse_scale, self._scale)

    def solve(self, r, w, weights, tol, maxiter):
        """w ≈ A⁻¹ r (NGSolve vectors) to ``tol`` in ``maxiter`` iterations at most: returns
        (converged, iterations, PETSc's converged reason)."""
        self._weights(r, weights)
        self.matrix.vectors.petscVec(r, self._b)
        self._b.pointwiseMult(self._b, self._scale)                         # S r
        self.ksp.setGMRESRestart(max(1, int(maxiter)))
        self.ksp.setTolerances(rtol=tol, atol=0.0, max_it=max(1, int(maxiter)))
        self.ksp.solve(self._b, self._x)
        self._x.pointwiseMult(self._x, self._inverse_scale)                 # w = S⁻¹ y
        self.matrix.vectors.ngsVec(self._x, w)
        reason = self.ksp.getConvergedReason()
        return reason > 0, self.ksp.getIterationNumber(), reason


class _ScaledOperator:
    """The PETSc python matrix S A S⁻¹ of ``PetscGmres``."""

    def __init__(self, gmres):
        self.gmres = gmres

    def mult(self, mat, x, y):
        g = self.gmres
        g._t.pointwiseMult(x, g._inverse_scale)
        g.matrix.mat.mult(g._t, y)
        y.pointwiseMult(y, g._scale)


class _ScaledPreconditioner:
    """The PETSc python PC S M S⁻¹ of ``PetscGmres``."""

    def __init__(self, gmres):
        self.gmres = gmres

    def apply(self, pc, x, y):
        g = self.gmres
        g._s.pointwiseMult(x, g._inverse_scale)
        g.precondition(g._s, y)
        y.pointwiseMult(y, g._scale)
