"""The linear solver of the Newton correction: a sparse direct factorisation, kept and reused.

NGSolve's pip wheel factorises with "sparsecholesky" (LDLᵀ; only for a symmetric matrix:
a non-symmetric one is factored as if it were symmetric, silently) or "umfpack"
("pardiso" needs the mkl package). A ``DirectSolver`` keeps its factorisation: factorising
the same matrix object again (new values, same sparsity pattern) calls NGSolve's
``Update()``, which reuses the symbolic analysis, as ``ngsolve.solvers.NewtonSolver`` does.
"""
NAMES = ("sparsecholesky", "umfpack", "pardiso")
"""The direct solvers ``DirectSolver`` accepts (NGSolve's ``inverse=`` names)."""


class DirectSolver:
    """w = A⁻¹ r for a sparse matrix A on a set of free DOFs.

    Parameters
    ----------
    name : one of ``NAMES``.

    ``factorizations`` counts the factorisations (numeric ones, updates included).
    """

    def __init__(self, name):
        if name not in NAMES:
            raise ValueError(f"inverse must be one of {', '.join(map(repr, NAMES))}, got {name!r}")
        self.name = name
        self.factorizations = 0
        self._inverse = self._matrix = self._freedofs = None

    def factor(self, matrix, freedofs):
        """Factorise ``matrix`` restricted to ``freedofs`` (a BitArray); the same matrix
        object and free DOFs as last time: update the factorisation in place."""
        if self._inverse is not None and matrix is self._matrix and freedofs is self._freedofs:
            try:
                self._inverse.Update()
                self.factorizations += 1
                return
            except Exception:                     # an inverse without Update: factorise anew
                pass
        self._inverse = matrix.Inverse(freedofs, inverse=self.name)
        self._matrix, self._freedofs = matrix, freedofs
        self.factorizations += 1

    def solve(self, r, w):
        """w = A⁻¹ r with the last factorisation (zero on the other DOFs)."""
        w.data = self._inverse * r

    def __repr__(self):
        return f"DirectSolver({self.name!r})"

