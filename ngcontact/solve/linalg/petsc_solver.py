"""Newton's linear solves on PETSc: MUMPS factorisations through ngsPETSc.

``Simulation(solver="mumps")`` factorises the step's Jacobian with MUMPS (LU for a
non-symmetric Jacobian, LDLᵀ for a symmetric one), serially or on a mesh distributed over MPI
ranks, where it replaces NGSolve's "masterinverse" (which gathers the whole matrix on rank 0).
The factorisation is an NGSolve ``BaseMatrix`` (``MumpsFactorization``), so the kept
factorisation of ``linear_solver.KeptFactorization`` reuses it as GMRES's preconditioner
across Newton iterations as it does NGSolve's own factorisations, serially and (through
PETSc's GMRES, ``krylov``) on a distributed mesh.

Why ngsPETSc: it maps NGSolve's (parallel) sparse matrices and vectors to PETSc's, DOFs shared
by ranks included (``ngsPETSc.Matrix``, ``VectorMapping``); the factorisation itself is
petsc4py's ``PC`` (type lu/cholesky, solver package mumps), kept across updates of the values
so that MUMPS reuses its analysis (symbolic factorisation and ordering).

Installing PETSc (``petsc_modules``: ``INSTALL``, ``load``, ``available``, names of this module
too): without it, ``solver="mumps"`` is an error that says how to install it, before any work
(``PetscMissing``). PETSc's options (``PETSC_OPTIONS``) reach the factorisation; what they
cannot do is named (``petsc_options``).
"""
import ngsolve as ngs
import numpy as np

from ngcontact.solve.linalg.petsc_modules import INSTALL, PetscMissing, available, load  # noqa: F401 (its names)
from ngcontact.solve.linalg.petsc_options import check_factorisation, given_options, reading_options

NAMES = ("mumps",)
"""The ``inverse=`` names of the PETSc engine."""
WORKSPACE_RELAXATION = 30
"""MUMPS's ICNTL(14): the workspace beyond the analysis's estimate, in % (MUMPS's default 20 for
LU, 30 for LDLᵀ of an indefinite matrix)."""
MAX_RELAXATION = 640
"""The largest ICNTL(14) a factorisation that ran out of workspace is retried with (%)."""

class PetscMatrix:
    """An NGSolve (parallel) sparse matrix restricted to its free DOFs as a PETSc AIJ matrix
    (``mat``), with the vector mapping (``vectors``) of ngsPETSc, converted once (distributed by
    ngsPETSc, serially straight from the free block's CSR arrays); ``refill()``
    copies the NGSolve matrix's current values in (same pattern) without converting again:
    the conversion through PETSc's MATIS cost most of every factorisation (docs/measurements.md,
    section ngcontact/solve/linalg/petsc_solver.py)."""

    def __init__(self, matrix, freedofs):
        PETSc, ngsPETSc = load()
        self.matrix, self.freedofs = matrix, freedofs
        local = matrix.local_mat
        pardofs = getattr(matrix, "row_pardofs", None)
        description = (pardofs, freedofs, {"bsize": local.entrysizes})
        self.vectors = ngsPETSc.VectorMapping(description)
        self.distributed = pardofs is not None and pardofs.comm.size > 1
        direct = not self.distributed and tuple(local.entrysizes) == (1, 1)
        if not direct:
            self.mat = ngsPETSc.Matrix(matrix, description, "aij").mat
        _, cols, ptr = local.CSR()                       # the free block in the free DOFs' local numbering
        cols, ptr = np.asarray(cols, dtype=np.int64), np.asarray(ptr, dtype=np.int64)
        rows = np.repeat(np.arange(local.height), np.diff(ptr))
        free = np.array(freedofs, dtype=bool) if freedofs is not None else np.ones(local.height, dtype=bool)
        number = np.full(local.height, -1, dtype=np.int64)
        number[free] = np.arange(int(free.sum()))
        self._kept = np.flatnonzero(free[rows] & free[cols])
        counts = np.bincount(number[rows[self._kept]], minlength=int(free.sum()))
        self._ptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
        self._cols = number[cols[self._kept]].astype(PETSc.IntType)
        if direct:               # serially, the free block straight from these arrays: ngsPETSc's way
            size = len(self._ptr) - 1      # (AIJ, its free submatrix, a conversion) took 0.45–1.2 s at
            self.mat = PETSc.Mat().createAIJ(size=(size, size), csr=(self._ptr, self._cols, self._values()),
                                             comm=PETSc.COMM_SELF)   # 137 600 free DOFs (3D P2): 0.12 s

    def _values(self):
        """The NGSolve matrix's current values on the free block, in ``_ptr``/``_cols`` order."""
        return self.matrix.local_mat.AsVector().FV().NumPy()[self._kept]

    def refill(self):
        """The NGSolve matrix's current values into ``mat``."""
        PETSc, _ = load()
        values = self._values()
        if self.distributed:                             # the ranks' parts add up on shared DOFs
            self.mat.zeroEntries()
            self.mat.setValuesLocalCSR(self._ptr, self._cols, values, addv=PETSc.InsertMode.ADD_VALUES)
        else:
            self.mat.setValuesCSR(self._ptr, self._cols, values)
        self.mat.assemble()


class MumpsFactorization(ngs.BaseMatrix):
    """The MUMPS factorisation of an NGSolve (parallel) sparse matrix on its free DOFs, as a
    BaseMatrix: ``Mult`` solves; ``update()`` factorises the matrix's new values reusing the
    analysis (the sparsity pattern must be the same).

    Parameters
    ----------
    matrix : ngsolve SparseMatrix or ParallelMatrix.
    freedofs : BitArray of the free DOFs.
    symmetric : LDLᵀ (PETSc "cholesky") instead of LU; only for a symmetric matrix.
    options : PETSc options of the factorisation (``mat_mumps_*``, names without the dash) from
        ``Simulation(solver={...})``, set while it reads them (``petsc_options.given_options``).

    ``relaxation``: MUMPS's workspace relaxation ICNTL(14) (%) the last factorisation needed.
    """

    def __init__(self, matrix, freedofs, symmetric=False, options=None):
        super().__init__()
        PETSc, _ = load()
        self.matrix, self.freedofs, self.symmetric, self.options = matrix, freedofs, symmetric, options or {}
        self.petsc = PetscMatrix(matrix, freedofs)
        self._mark_symmetric()
        self.pc = PETSc.PC().create(comm=self.petsc.mat.getComm())
        self.pc.setOperators(self.petsc.mat)
        self.pc.setType("cholesky" if symmetric else "lu")
        self.pc.setFactorSolverType("mumps")
        self.pc.setFactorSetUpSolverType()
        self.relaxation = WORKSPACE_RELAXATION
        self.pc.getFactorMatrix().setMumpsIcntl(14, self.relaxation)
        with reading_options('the MUMPS factorisation of solver="mumps"'), \
                given_options("", self.options, "the MUMPS factorisation"):
            self.pc.setFromOptions()                # PETSC_OPTIONS, e.g. -mat_mumps_icntl_4 2
            check_factorisation(self.pc, self.symmetric, 'solver="mumps"')
            self._factorise()                       # MUMPS reads its -mat_mumps_* options here
        self._x, self._y = self.petsc.mat.createVecs()

    def _factorise(self):
        """PCSetUp. A factorisation that ran out of its workspace (MUMPS's INFOG(1) = −9, PETSc's
        FACTOR_OUTMEMORY: pivots delayed beyond the analysis's estimate, as in the symmetric
        indefinite Jacobian of a 3D indentation, LDLᵀ on 2 ranks) is made again with twice the
        relaxation ICNTL(14), up to ``MAX_RELAXATION`` %; any other failure raises with PETSc's
        reason and MUMPS's INFOG(1), INFOG(2)."""
        PETSc, _ = load()
        while True:
            self.pc.setUp()
            reason = self.pc.getFailedReason()
            if not reason:
                return
            factor = self.pc.getFactorMatrix()
            info = factor.getMumpsInfog(1), factor.getMumpsInfog(2)
            if reason == PETSc.PC.FailedReason.FACTOR_OUTMEMORY and 2 * self.relaxation <= MAX_RELAXATION:
                self.relaxation *= 2
                factor.setMumpsIcntl(14, self.relaxation)
                self.pc.reset()
                self.pc.setOperators(self.petsc.mat)
                self.pc.setType("cholesky" if self.symmetric else "lu")
                self.pc.setFactorSolverType("mumps")
                self.pc.setFactorSetUpSolverType()
                self.pc.getFactorMatrix().setMumpsIcntl(14, self.relaxation)
                continue
            names = {v: k for k, v in vars(PETSc.PC.FailedReason).items() if not k.startswith("_")}
            raise ArithmeticError(f"the MUMPS factorisation failed (PETSc's reason: {names.get(reason, reason)}; "
                                  f"MUMPS's INFOG(1) = {info[0]}, INFOG(2) = {info[1]}; "
                                  f"{'LDLᵀ' if self.symmetric else 'LU'} of {self.petsc.mat.getSize()[0]} rows, "
                                  f"workspace relaxation ICNTL(14) = {self.relaxation} %)")

    def _mark_symmetric(self):
        if self.symmetric:
            PETSc, _ = load()
            self.petsc.mat.setOption(PETSc.Mat.Option.SYMMETRIC, True)

    def Update(self):
        """Factorise the matrix's current values (same pattern): MUMPS's analysis is kept
        (the name of NGSolve's inverses' method, so that ``DirectSolver`` treats both alike)."""
        self.petsc.refill()
        self._mark_symmetric()
        self.pc.setOperators(self.petsc.mat)
        with given_options("", self.options):         # a factorisation made again reads them again
            self._factorise()

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
        self.petsc.vectors.petscVec(x, self._x)
        self.pc.apply(self._x, self._y)
        self.petsc.vectors.ngsVec(self._y, y)

    def petsc_apply(self, x, y):
        """y = A⁻¹ x on PETSc vectors of the free DOFs' layout (``krylov.Gmres``'s preconditioner)."""
        self.pc.apply(x, y)
