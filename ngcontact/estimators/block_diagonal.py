"""A block-diagonal sparse system: the patch problems of an equilibration, all at once.

The unknowns are numbered block by block (``block``: the block of every unknown, non-decreasing)
and the entries come as COO positions, fixed, with values that change (``fill``). Small blocks
(at most ``DENSE`` unknowns: the 2D patches) are gathered into dense arrays,
one per block size, and solved by LAPACK in a batch (``numpy.linalg.solve``, the right-hand
sides of a call at once; from the second call on with the kept inverses); larger ones (the 3D
patches, sparse inside) by one SuperLU factorisation of the whole matrix, which uses their
sparsity. That factorisation starts in a background thread as soon as the values are set, so
that it runs while the caller prepares the right-hand sides (SuperLU, NGSolve's assembly and
NumPy release the GIL); it depends on the matrix alone, so the result does not depend on the
timing.
"""
from concurrent.futures import ThreadPoolExecutor

import numpy as np

DENSE = 120
"""The largest block solved dense (unknowns)."""
_background = []                                   # the one worker thread of the estimators


def in_background(call):
    """A future of ``call()`` made by the one worker thread of the estimators (tasks run one
    after the other, in the order given). ``call`` works with NumPy and SciPy; of NGSolve it may
    only read sizes (no assembly, no Set: the caller's thread may be assembling). It may queue
    further tasks but not wait for them (they run after it)."""
    if not _background:
        _background.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="ngcontact-estimate"))
    return _background[0].submit(call)


def _factorise_in_background(values, rows, cols, size):
    """A future of SuperLU's factorisation of the (size × size) matrix of the COO entries
    (values, rows, cols), assembled and factorised by the worker thread."""
    import scipy.sparse as sp                     # (SciPy loads when a large block is first solved)
    import scipy.sparse.linalg as sla_sparse
    return in_background(lambda: sla_sparse.splu(sp.csc_matrix((values, (rows, cols)), shape=(size, size))))


class BlockDiagonal:
    """The block-diagonal matrix of size len(block) with entries at (rows, cols)."""

    def __init__(self, block, rows, cols):
        block = np.asarray(block)
        self.size = len(block)
        self.rows, self.cols = rows, cols
        starts = np.flatnonzero(np.r_[True, np.diff(block) != 0]) if self.size else np.zeros(0, dtype=np.int64)
        sizes = np.diff(np.r_[starts, self.size])
        self.dense = self.size > 0 and sizes.max() <= DENSE
        if not self.dense:
            return
        number = np.zeros(self.size, dtype=np.int64)                # the block of every unknown, 0, 1, ...
        number[starts[1:]] = 1
        number = np.cumsum(number)
        of_entry = number[rows]
        if np.any(number[cols] != of_entry):
            raise ValueError("BlockDiagonal: an entry couples two blocks")
        # blocks grouped by their size: group g holds count_g blocks of n_g unknowns, stored as
        # one (count_g, n_g, n_g) array at offset_g of the flat data
        self.groups = []
        rank, offset_of = np.zeros(len(starts), dtype=np.int64), np.zeros(len(starts), dtype=np.int64)
        offset = 0
        for n in np.unique(sizes):
            ids = np.flatnonzero(sizes == n)
            rank[ids] = np.arange(len(ids))
            offset_of[ids] = offset
            self.groups.append((int(n), offset, starts[ids][:, None] + np.arange(n)[None, :]))
            offset += len(ids) * int(n) ** 2
        self.total = offset
        n_of = sizes[of_entry]
        first = starts[of_entry]
        self.flat = offset_of[of_entry] + rank[of_entry] * n_of * n_of + (rows - first) * n_of + (cols - first)

    def fill(self, values):
        """Set the entries' values (duplicates add up)."""
        self._inverses, self._solves = None, 0
        if self.dense:
            self._data = np.bincount(self.flat, weights=values, minlength=self.total)
            return
        self._lu = _factorise_in_background(values, self.rows, self.cols, self.size)

    def solve(self, rhs):
        """The solution for the right-hand side ``rhs`` (a vector, or a matrix of them as columns)."""
        self._solves += 1
        if not self.dense:
            return self._lu.result().solve(rhs)
        if self._inverses is None and self._solves > 1:           # a second call: keep inverses
            self._inverses = [np.linalg.inv(self._blocks(g)) for g in range(len(self.groups))]
        columns = rhs.reshape(self.size, -1)
        out = np.empty(columns.shape)
        for g, (n, offset, unknowns) in enumerate(self.groups):
            b = columns[unknowns]                                  # (blocks, n, columns)
            out[unknowns] = np.linalg.solve(self._blocks(g), b) if self._inverses is None else \
                np.einsum("bij,bjk->bik", self._inverses[g], b)
        return out.reshape(rhs.shape)

    def _blocks(self, g):
        n, offset, unknowns = self.groups[g]
        return self._data[offset:offset + len(unknowns) * n * n].reshape(len(unknowns), n, n)
