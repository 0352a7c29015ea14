"""A block-diagonal sparse system: the patch problems of an equilibration, all at once.

The unknowns are numbered block by block (``block``: the block of every unknown, non-decreasing)
and the entries come as COO positions, fixed, with values that change (``fill``). Small blocks
(at most ``DENSE`` unknowns: the 2D patches) are gathered into dense arrays,
one per block size, and solved by LAPACK in a batch (``numpy.linalg.solve``, the right-hand
sides of a call at once; from the second call on with the kept inverses); larger ones (the 3D
patches, sparse inside) by SuperLU, which uses their sparsity. The blocks are independent, so
the matrix is factorised in ``CHUNKS`` parts of whole blocks, each its own SuperLU factorisation.
The parts are queued to a background thread as soon as the values are set, so that they are
factorised while the caller prepares the right-hand sides (SuperLU, NGSolve's assembly and
NumPy release the GIL); the caller factorises those the thread has not started when it needs
the solution. A part's factorisation depends on its entries alone, so neither the result nor
which thread made it depends on the timing of the other.
"""
import threading
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

DENSE = 120
"""The largest block solved dense (unknowns)."""
CHUNKS = 16
"""The parts of a sparse system factorised one by one (whole blocks, about equal in Σ block size²)."""
_background = []                                   # the one worker thread of the estimators


def in_background(call):
    """A future of ``call()`` made by the one worker thread of the estimators (tasks run one
    after the other, in the order given). ``call`` works with NumPy and SciPy; of NGSolve it may
    only read sizes (no assembly, no Set: the caller's thread may be assembling). It may queue
    further tasks but not wait for them (they run after it)."""
    if not _background:
        _background.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="ngcontact-estimate"))
    return _background[0].submit(call)


class _Part:
    """One part of a sparse block-diagonal system (unknowns ``first`` to ``last`` − 1, whole
    blocks; ``entries``: the positions of its COO entries): its SuperLU factorisation, made once
    by whichever thread claims it first."""

    def __init__(self, first, last, entries):
        self.first, self.last, self.entries = first, last, entries
        self._claimed, self._lock, self.lu = False, threading.Lock(), Future()

    def factorise(self, values, rows, cols):
        """Factorise the part from the system's COO entries (their values ``values[k]``, or
        ``values[0][values[1][k]]`` for a pair), unless another thread has claimed it."""
        with self._lock:
            if self._claimed:
                return
            self._claimed = True
        try:
            import scipy.sparse as sp                 # (SciPy loads when a large block is first solved)
            import scipy.sparse.linalg as sla_sparse
            n, at = self.last - self.first, self.entries
            r, c = rows[at] - self.first, cols[at] - self.first
            if len(c) and (c.min() < 0 or c.max() >= n):
                raise ValueError("BlockDiagonal: an entry couples two blocks")
            entries = values[at] if isinstance(values, np.ndarray) else values[0][values[1][at]]
            self.lu.set_result(sla_sparse.splu(sp.csc_matrix((entries, (r, c)), shape=(n, n))))
        except BaseException as error:
            self.lu.set_exception(error)


def _parts(starts, sizes, size, rows):
    """(first, last, entries) of the parts of a system with blocks starting at ``starts`` (sizes
    ``sizes``) and entries in ``rows``: at most ``CHUNKS``, cut at block starts so that each holds
    about as many of Σ size² as the others; ``entries`` the positions of each part's entries."""
    work = np.cumsum(sizes.astype(float) ** 2)
    targets = work[-1] * np.arange(1, CHUNKS) / CHUNKS
    cuts = np.unique(starts[np.minimum(np.searchsorted(work, targets, side="right") + 1, len(starts) - 1)])
    bounds = np.unique(np.r_[0, cuts[cuts > 0], size])
    part = np.repeat(np.arange(len(bounds) - 1, dtype=np.uint8), np.diff(bounds))[rows]     # of every entry
    order = np.argsort(part, kind="stable")                  # (a radix sort of small integers)
    if len(order) < 2 ** 31:
        order = order.astype(np.int32)
    ends = np.searchsorted(part[order], np.arange(1, len(bounds), dtype=np.uint8))
    return [(int(a), int(b), order[e - k:e]) for a, b, e, k in
            zip(bounds[:-1], bounds[1:], ends, np.diff(np.r_[0, ends]))]


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
            self._layout, self._parts = _parts(starts, sizes, self.size, rows) if self.size else [], []
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

    def fill(self, values, gather=None):
        """Set the entries' values (duplicates add up): ``values``, or with ``gather``
        ``values[gather]`` (the sparse parts then gather their own entries)."""
        self._inverses, self._solves = None, 0
        if self.dense:
            entries = values if gather is None else values[gather]
            self._data = np.bincount(self.flat, weights=entries, minlength=self.total)
            return
        values = values if gather is None else (values, gather)
        self._values = values
        self._parts = [_Part(*layout) for layout in self._layout]
        for part in self._parts:
            in_background(lambda part=part: part.factorise(values, self.rows, self.cols))

    def solve(self, rhs):
        """The solution for the right-hand side ``rhs`` (a vector, or a matrix of them as columns)."""
        self._solves += 1
        if not self.dense:
            for part in reversed(self._parts):         # (those the background thread has not started)
                part.factorise(self._values, self.rows, self.cols)
            out = np.empty(rhs.shape)
            for part in self._parts:
                out[part.first:part.last] = part.lu.result().solve(rhs[part.first:part.last])
            return out
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
