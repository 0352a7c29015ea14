"""NGSolve sparse matrices seen from numpy and scipy: CSR copies, where one pattern's entries
sit in another's, and the step Jacobian on the free DOFs (``Simulation.jacobian``)."""
import numpy as np
import scipy.sparse as sp

from . import parallel
from .newton import ResidualNorm


def free_jacobian(system, x, space, scaled=True):
    """R'(x) of ``system`` (full Jacobian protocol) on the free DOFs of ``space`` as a scipy
    CSR matrix; ``scaled``: S J S with S = diag(s_u^-½, s_φ^-½), s_b the mean of |diagonal|
    over block b (the scaling of Newton's norms). Serial meshes only."""
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


def csr(matrix):
    """An NGSolve sparse matrix (the rank's part of a ParallelMatrix) as a scipy CSR matrix."""
    matrix = parallel.local_matrix(matrix)
    return sp.csr_matrix(matrix.CSR(), shape=(matrix.height, matrix.width))


def matching_positions(source, target, within=None):
    """Index arrays (s, t): entry s of ``source``'s values sits at entry t of ``target``'s,
    for the structural entries of ``source`` that ``target`` has; ``within``: a boolean array
    over the DOFs, only the entries of rows and columns within it (None: all)."""
    def keys(matrix):
        _, cols, ptr = matrix.CSR()
        rows = np.repeat(np.arange(matrix.height, dtype=np.int64), np.diff(np.asarray(ptr, dtype=np.int64)))
        return rows, np.asarray(cols, dtype=np.int64)
    (rs, cs), (rt, ct) = keys(source), keys(target)
    s, t = rs * source.width + cs, rt * target.width + ct
    kept = np.ones(len(s), dtype=bool) if within is None else within[rs] & within[cs]
    where = np.clip(np.searchsorted(t, s), 0, len(t) - 1)
    found = kept & (t[where] == s)
    return np.flatnonzero(found), where[found]
