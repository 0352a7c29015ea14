"""The scaled norms of Newton's residuals and states (J^½).

Forces (N) and charges (C) are not comparable, so a residual is taken as
‖r‖² = ‖r_u‖²/s_u + ‖r_φ‖²/s_φ and a state as ‖x‖² = s_u‖x_u‖² + s_φ‖x_φ‖², with s_u, s_φ the
mean diagonal entries of the two blocks of the bulk's Jacobian (N/m and C/V): each term is an
energy. ``newton`` and ``stopping`` measure with it.
"""
import numpy as np

from ngcontact import parallel


class ResidualNorm:
    """The scaled norms of residuals (dual) and states (primal) on the free DOFs of the u and
    φ blocks of ``space``; the scales s_u, s_φ are set once, from a Jacobian diagonal.
    On a distributed mesh the sums run over all ranks, each DOF counted once
    (``parallel.owned``), with the values of distributed vectors cumulated."""

    def __init__(self, space, freedofs):
        free = np.array(list(freedofs), dtype=bool)
        self.mesh = space.mesh
        self.distributed = parallel.is_distributed(space.mesh)
        if self.distributed:
            free &= parallel.owned(space)
        self.blocks = [np.flatnonzero(free[space.Range(i).start:space.Range(i).stop]) + space.Range(i).start
                       for i in range(2)]
        # every DOF (held ones too) of the blocks that have free DOFs: where forces act
        mine = parallel.owned(space) if self.distributed else np.ones(len(free), dtype=bool)
        self.whole_blocks = [np.flatnonzero(mine[space.Range(i).start:space.Range(i).stop]) + space.Range(i).start
                             if parallel.sum(self.mesh, len(block)) else np.zeros(0, dtype=int)
                             for i, block in enumerate(self.blocks)]
        self.scales = None

    def set_scales(self, diagonal):
        """s_b = mean |diagonal| over block b (1 for an empty or zero block); ``diagonal``
        cumulated on a distributed mesh."""
        diagonal = np.abs(diagonal)
        if self.distributed:
            totals = parallel.sum(self.mesh, np.array([[diagonal[b].sum(), len(b)] for b in self.blocks]))
            means = [total / count if count else 0.0 for total, count in totals]
        else:
            means = [diagonal[b].mean() if len(b) else 0.0 for b in self.blocks]
        self.scales = [float(mean) if mean > 0 else 1.0 for mean in means]
        self.weights, self._dual, self._everywhere = (np.zeros(len(diagonal)) for _ in range(3))
        for block, whole, scale in zip(self.blocks, self.whole_blocks, self.scales):
            self.weights[block], self._dual[block], self._everywhere[whole] = scale, 1 / scale, 1 / scale

    def restore_scales(self, scales, n):
        """The scales set to ``scales`` exactly (saved ones: ``set_scales`` takes a diagonal's
        means, which round), for vectors of length n."""
        self.set_scales(np.ones(n))
        self.scales = list(scales)
        for block, whole, scale in zip(self.blocks, self.whole_blocks, scales):
            self.weights[block], self._dual[block], self._everywhere[whole] = scale, 1 / scale, 1 / scale

    weights = None
    """s_b on the free DOFs of block b, 0 elsewhere (numpy): the primal norm is (Σ w x²)^½."""

    def _weighted(self, a, weights):
        """(Σ_i weights_i a_i²)^½, summed over the ranks: O(n), no copies."""
        return float(np.sqrt(parallel.sum(self.mesh, np.einsum("i,i,i", weights, a, a))))

    def _values(self, v):
        if isinstance(v, np.ndarray):          # numpy: cumulated values
            return v
        return parallel.cumulated(v) if self.distributed else v.FV().NumPy()

    def dual(self, r):
        """‖r‖ = (Σ_b ‖r_b‖²/s_b)^½ of a residual (vector or numpy array), J^½."""
        return self._weighted(self._values(r), self._dual)

    def dual_everywhere(self, r):
        """The dual norm of ``r`` over every DOF of the blocks that have free DOFs, the held ones
        included (where a force vector holds the reactions of the supports and the charges of
        the electrodes), J^½."""
        return self._weighted(self._values(r), self._everywhere)

    def block_duals(self, r, everywhere=False):
        """[‖r_u‖, ‖r_φ‖]: the dual norm of each block of ``r`` on its own (free DOFs, or every
        DOF with ``everywhere``), summed over the ranks, J^½."""
        a = self._values(r)
        blocks = self.whole_blocks if everywhere else self.blocks
        weights = self._everywhere if everywhere else self._dual
        squares = np.array([np.einsum("i,i,i", weights[b], a[b], a[b]) for b in blocks])
        return [float(v) for v in np.sqrt(parallel.sum(self.mesh, squares))]

    def primal(self, x):
        """‖x‖ = (Σ_b s_b ‖x_b‖²)^½ of a state vector, J^½."""
        return self._weighted(self._values(x), self.weights)
