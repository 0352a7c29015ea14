"""NGSolve sparse matrices seen from numpy and scipy: CSR views and copies, where one pattern's entries
sit in another's, and the step Jacobian on the free DOFs (``Simulation.jacobian``)."""
import numpy as np

from ngcontact import parallel
from ngcontact.solve.linalg.residual_norm import ResidualNorm


def free_jacobian(system, x, space, scaled=True):
    """R'(x) of ``system`` (full Jacobian protocol) on the free DOFs of ``space`` as a scipy
    CSR matrix; ``scaled``: S J S with S = diag(s_u^-½, s_φ^-½), s_b the mean of |diagonal|
    over block b (the scaling of Newton's norms). Serial meshes only."""
    import scipy.sparse as sp                           # (here: SciPy loads when first used)
    parallel.serial_only(space.mesh, "the Jacobian as a scipy matrix (Simulation.jacobian)")
    system.AssembleLinearization(x)
    J = sp.csr_matrix(system.mat.CSR(), shape=(system.mat.height, system.mat.width))
    free = np.flatnonzero(np.array(list(space.FreeDofs()), dtype=bool))
    if scaled:
        norm = ResidualNorm(space, space.FreeDofs())
        norm.set_scales(J.diagonal())
        scale = np.ones(J.shape[0])
        for block, s in zip(norm.blocks, norm.scales):
            scale[block] = s ** -0.5
        J = sp.diags(scale) @ J @ sp.diags(scale)
    return J[free][:, free].tocsr()


def csr(matrix, copy=False):
    """An NGSolve sparse matrix (the rank's part of a ParallelMatrix) as a scipy CSR matrix: a
    view of NGSolve's arrays, valid while the NGSolve matrix lives (a form's matrix freed with
    its form leaves the view reading reused memory), or with ``copy`` a copy of them."""
    import scipy.sparse as sp
    matrix = parallel.local_matrix(matrix)
    return sp.csr_matrix(matrix.CSR(), shape=(matrix.height, matrix.width), copy=copy)


def _arrays(matrix):
    """(values, columns, row of each entry, height) of an NGSolve sparse matrix (the rank's part
    of a ParallelMatrix), numpy views of its CSR arrays but the rows."""
    matrix = parallel.local_matrix(matrix)
    values, columns, starts = (np.asarray(a) for a in matrix.CSR())
    rows = np.repeat(np.arange(matrix.height), np.diff(starts.astype(np.int64)))
    return values, columns, rows, matrix.height


def diagonal(matrix):
    """The diagonal of an NGSolve sparse matrix (numpy; the rank's part on a distributed mesh),
    read off its CSR arrays without SciPy (Newton's norms ask for it at the first iteration)."""
    values, columns, rows, height = _arrays(matrix)
    on = rows == columns
    out = np.zeros(height)
    out[rows[on]] = values[on]
    return out


class Absolute:
    """|A| of an NGSolve sparse matrix A (its entries' absolute values, explicit zeros kept) as a
    product ``Absolute(A) @ x``, row sums in the entries' order (as SciPy's CSR product adds
    them), without SciPy; the values are copied (``A`` may change after)."""

    def __init__(self, matrix):
        values, self.columns, self.rows, self.height = _arrays(matrix)
        self.values = np.abs(values)

    def __matmul__(self, x):
        return np.bincount(self.rows, weights=self.values * np.asarray(x)[self.columns], minlength=self.height)


def matching_positions(source, target, within=None):
    """Index arrays (s, t): entry s of ``source``'s values sits at entry t of ``target``'s,
    for the structural entries of ``source`` that ``target`` has; ``within``: a boolean array
    over the DOFs, only the entries of rows and columns within it (None: all). Only the rows
    within are read (the layer of Γ3: docs/measurements.md, section ngcontact/solve/linalg/matrices.py)."""
    rows = np.arange(source.height, dtype=np.int64) if within is None else np.flatnonzero(within)
    (si, sr, sc), (ti, tr, tc) = _entries(source, rows), _entries(target, rows)
    kept = np.ones(len(si), dtype=bool) if within is None else within[sc]
    s, t = sr * target.width + sc, tr * target.width + tc           # sorted: rows ascend, columns within rows
    where = np.clip(np.searchsorted(t, s), 0, max(len(t) - 1, 0))
    found = kept & (t[where] == s) if len(t) else np.zeros(len(s), dtype=bool)
    return si[found], ti[where[found]]


def _entries(matrix, rows):
    """(entry indices, their rows, their columns) of the CSR ``matrix`` in the sorted ``rows``."""
    _, cols, ptr = matrix.CSR()
    ptr = np.asarray(ptr, dtype=np.int64)
    starts, counts = ptr[rows], ptr[rows + 1] - ptr[rows]
    offsets = np.cumsum(counts) - counts
    index = np.repeat(starts - offsets, counts) + np.arange(counts.sum(), dtype=np.int64)
    return index, np.repeat(rows, counts), np.asarray(cols, dtype=np.int64)[index]
