"""Newton's linear solves on PETSc: MUMPS factorisations through ngsPETSc (issue 27).

``Simulation(inverse="mumps")`` factorises the step's Jacobian with MUMPS (LU for a
non-symmetric Jacobian, LDLᵀ for a symmetric one), serially or on a mesh distributed over MPI
ranks, where it replaces NGSolve's "masterinverse" (which gathers the whole matrix on rank 0).
The factorisation is an NGSolve ``BaseMatrix`` (``MumpsFactorization``), so the kept
factorisation of ``linear_solver.KeptFactorization`` reuses it as GMRES's preconditioner
across Newton iterations serially, as it does NGSolve's own factorisations.

Why ngsPETSc: it maps NGSolve's (parallel) sparse matrices and vectors to PETSc's, DOFs shared
by ranks included (``ngsPETSc.Matrix``, ``VectorMapping``); the factorisation itself is
petsc4py's ``PC`` (type lu/cholesky, solver package mumps), kept across updates of the values
so that MUMPS reuses its analysis (symbolic factorisation and ordering).

Installing PETSc: PyPI has no binary petsc4py; on Python ≥ 3.12 the ``dolfinx-solver-real``
wheel ships PETSc 3.25 with MUMPS and its own petsc4py (``INSTALL``); on a cluster, build
petsc4py against the site's PETSc (docs/cluster.md). Without PETSc, ``inverse="mumps"`` is an
error that says how to install it, before any work.
"""
import os

import ngsolve as ngs
import numpy as np

NAMES = ("mumps",)
"""The ``inverse=`` names of the PETSc engine."""
INSTALL = ('on Python >= 3.12: pip install --no-deps dolfinx-solver-real ngsPETSc && pip install packaging '
           '(or petsc4py built against a PETSc with MUMPS, and ngsPETSc; docs/cluster.md)')
"""How to install what ``inverse="mumps"`` needs."""

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
"""Set to 1 when PETSc is loaded, unless the user set them: the wheel's MUMPS and BLAS start
OpenMP threads on every rank, which on the project's 2 cores fought NGSolve's and the other
ranks' (mpiexec -n 2, 34 749 DOFs: 18 factorisations 27-47 s, 5.1 s with one thread each)."""

_modules = None


def load():
    """(petsc4py.PETSc, ngsPETSc), imported in the order the wheel needs (mpi4py's MPI first,
    so that PETSc finds the MPI library); ImportError with ``INSTALL`` if missing."""
    global _modules
    if _modules is None:
        for name in THREAD_VARIABLES:              # before the libraries load (read once there)
            os.environ.setdefault(name, "1")
        try:
            from mpi4py import MPI  # noqa: F401  (loads libmpi for petsc4py)
            from petsc4py import PETSc
            import ngsPETSc
        except ImportError as err:
            raise ImportError(f'inverse="mumps" needs PETSc (petsc4py with MUMPS) and ngsPETSc, which are not '
                              f'installed ({err}); {INSTALL}') from None
        _modules = PETSc, ngsPETSc
    return _modules


def available():
    """True if ``inverse="mumps"`` can run here."""
    try:
        load()
    except ImportError:
        return False
    return True


class MumpsFactorization(ngs.BaseMatrix):
    """The MUMPS factorisation of an NGSolve (parallel) sparse matrix on its free DOFs, as a
    BaseMatrix: ``Mult`` solves; ``update()`` factorises the matrix's new values reusing the
    analysis (the sparsity pattern must be the same).

    Parameters
    ----------
    matrix : ngsolve SparseMatrix or ParallelMatrix.
    freedofs : BitArray of the free DOFs.
    symmetric : LDLᵀ (PETSc "cholesky") instead of LU; only for a symmetric matrix.
    """

    def __init__(self, matrix, freedofs, symmetric=False):
        super().__init__()
        PETSc, ngsPETSc = load()
        self.matrix, self.freedofs, self.symmetric = matrix, freedofs, symmetric
        dofs = getattr(matrix, "row_pardofs", None)
        self._description = (dofs, freedofs, {"bsize": matrix.local_mat.entrysizes})
        self._map = ngsPETSc.VectorMapping(self._description)
        self._petsc = ngsPETSc.Matrix(matrix, self._description, "aij").mat
        self._local_pattern(matrix.local_mat, freedofs)
        if symmetric:
            self._petsc.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        self._pc = PETSc.PC().create(comm=self._petsc.getComm())
        self._pc.setOperators(self._petsc)
        self._pc.setType("cholesky" if symmetric else "lu")
        self._pc.setFactorSolverType("mumps")
        self._pc.setFromOptions()                   # PETSC_OPTIONS, e.g. -mat_mumps_icntl_4 2
        self._pc.setUp()
        self._x, self._y = self._petsc.createVecs()

    def update(self):
        """Factorise the matrix's current values (same pattern): MUMPS's analysis is kept."""
        PETSc, _ = load()
        values = self.matrix.local_mat.AsVector().FV().NumPy()[self._kept]
        if self._petsc.getComm().getSize() > 1:        # the ranks' parts add up on shared DOFs
            self._petsc.zeroEntries()
            self._petsc.setValuesLocalCSR(self._ptr, self._cols, values, addv=PETSc.InsertMode.ADD_VALUES)
        else:
            self._petsc.setValuesCSR(self._ptr, self._cols, values)
        self._petsc.assemble()
        if self.symmetric:
            self._petsc.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        self._pc.setOperators(self._petsc)
        self._pc.setUp()

    def _local_pattern(self, local, freedofs):
        """The rank's matrix restricted to its free DOFs as CSR in the free DOFs' local
        numbering (that of ngsPETSc's submatrix and local-to-global map): ``_kept`` picks its
        values out of the local matrix's, so that ``update`` refills the PETSc matrix without
        converting it again (the conversion through PETSc's MATIS cost 0.2 s of every 0.28 s
        factorisation at 34 749 DOFs on 2 ranks)."""
        PETSc, _ = load()
        _, cols, ptr = local.CSR()
        cols, ptr = np.asarray(cols, dtype=np.int64), np.asarray(ptr, dtype=np.int64)
        rows = np.repeat(np.arange(local.height), np.diff(ptr))
        free = np.array([freedofs[i] for i in range(len(freedofs))], dtype=bool) if freedofs is not None \
            else np.ones(local.height, dtype=bool)
        number = np.full(local.height, -1, dtype=np.int64)
        number[free] = np.arange(int(free.sum()))
        self._kept = np.flatnonzero(free[rows] & free[cols])
        counts = np.bincount(number[rows[self._kept]], minlength=int(free.sum()))
        self._ptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
        self._cols = number[cols[self._kept]].astype(PETSc.IntType)

    @property
    def reason(self):
        """PETSc's reason for a failed factorisation ("" if it did not fail)."""
        reason = self._pc.getFailedReason()
        return "" if not reason else str(reason)

    def Height(self):
        return self.matrix.height

    def Width(self):
        return self.matrix.width

    def CreateRowVector(self):
        return self.matrix.CreateColVector()

    def CreateColVector(self):
        return self.matrix.CreateRowVector()

    def Mult(self, x, y):
        """y = A⁻¹ x on the free DOFs, 0 elsewhere (y cumulated on a distributed mesh)."""
        self._map.petscVec(x, self._x)
        self._pc.apply(self._x, self._y)
        self._map.ngsVec(self._y, y)
