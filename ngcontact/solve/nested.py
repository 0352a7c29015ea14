"""Nested iteration: a step solved on the coarser levels of nested meshes first, each level
started from the solution of the level below, carried up by an exact prolongation.

Semismooth Newton converges in one iteration from a start whose contact set is the
solution's, and needs about one iteration per point of Γ3 it has to release where the start
overestimates the set (``starts``). The solution of the level below has the contact zone to
within a facet of that level: the finest level then takes a few Newton iterations, far fewer
than from the warm start, and the coarsest level its own cold-start count on a fraction of the
DOFs (the Hertz half-disk: docs/speed.md). The same in order instead of mesh
(``Nested.first_order``, the start "p1"): a body of order p >= 2 solved with P1 on its own
mesh first, for meshes without a hierarchy.

The levels are those of the body's ``meshes.Hierarchy`` (``Body.hierarchy``; the geometries'
``refine=``): its kept coarse mesh refined 0, 1, ... times, curved as the finest. Each coarser level has the
``time.step.Step`` of the same scene (made by the simulation, with ``COARSE_OPTIONS``), stepped
to the same times.

The prolongation from level k to k + 1 is exact for the displacement as a polynomial on the
reference element: NGSolve's prolongation of H1 on a refined mesh carries only the vertex
values (a P2 function comes out as its P1 interpolant), and ``GridFunction.Set`` from the
coarse mesh misses the points of a refined curved boundary outside the coarse mesh (a P1
start that is no better than u = 0). So u goes H1 → L2 (``ConvertOperator``, exact: the same
polynomials) → refined L2 (NGSolve's L2 prolongation, exact on each child) → H1
(``ConvertOperator``, exact for the continuous result), as sparse matrices built once on a
replica of the coarse mesh refined as the body's (``Hierarchy.levels``, as ``multigrid``'s).
"""
import ngsolve as ngs

from ngcontact import parallel
from ngcontact.solve.newton import NewtonError

COARSE_OPTIONS = dict(keep_states=False, physical_checks=False, realcompile=False, solver={"ksp_type": "preonly"})
"""Options of the coarse levels' simulations: no copies of their states, no warnings (their
results are starts only), no compilation to machine code and a factorisation per iteration
(neither pays on a small system solved a few times)."""


def levels_below(body):
    """The number of coarser levels of ``body``'s mesh (its ``hierarchy``), or a ValueError naming
    ``guess`` if it has none."""
    levels = None if body.hierarchy is None else body.hierarchy.refinements
    if not levels:
        why = ("it keeps no coarse mesh" if levels is None else "it was not refined (refine=0)")
        raise ValueError(f"guess='nested' needs coarser levels of the mesh and {why}: build it with "
                         "ngcontact.meshes.nested_mesh(ngmesh, refine) with refine >= 1 (ngcontact.geometries "
                         "and scenes take refine=...), or give Body(hierarchy=...)")
    return levels


class Prolongation:
    """u from level k to level k + 1 of ``body``'s hierarchy (k = 0 the kept coarse mesh), exact
    for the displacement's polynomials on the reference element (module docstring), as sparse
    matrices; ``sizes[k]``: the DOFs of u on level k (numbered as a Body's V on that level)."""

    def __init__(self, body):
        parallel.serial_only(body.mesh, "guess='nested'", "NGSolve cannot refine a distributed mesh")
        hierarchy, order = body.hierarchy, body.order
        self.matrices, self.sizes = [], []
        H = L = to_l2 = None
        for replica in hierarchy.levels():
            if H is None:
                H, L = ngs.VectorH1(replica, order=order), ngs.VectorL2(replica, order=order)
            else:
                H.Update()
                L.Update()
                self.matrices.append((to_l2, L.Prolongation().CreateMatrix(replica.levels - 1),
                                      ngs.ConvertOperator(L, H)))
            to_l2 = ngs.ConvertOperator(H, L)
            self.sizes.append(H.ndof)
        hierarchy.check(replica, body.mesh, body.size, "guess='nested'")

    def __call__(self, k, values):
        """The DOF values (numpy) of u on level k prolonged to level k + 1 (numpy)."""
        to_l2, prolong, to_h1 = self.matrices[k]
        source = to_l2.CreateRowVector()
        source.FV().NumPy()[:] = values
        coarse_l2 = to_l2.CreateColVector()
        coarse_l2.data = to_l2 * source
        fine_l2 = prolong.CreateColVector()
        fine_l2.data = prolong * coarse_l2
        result = to_h1.CreateColVector()
        result.data = to_h1 * fine_l2
        return result.FV().NumPy().copy()


def level_mesh(body, level):
    """The mesh of ``level`` (0: the kept coarse mesh) of ``body``'s hierarchy, curved as its mesh."""
    return body.hierarchy.level(level, body.mesh.GetCurveOrder())


def coarse_body(body, mesh, order=None):
    """A Body of ``body``'s material, boundary parts and supports on ``mesh``, at ``order``
    (default: the body's orders): a level of nested iteration."""
    names = {part: body.region_names(part) or None for part in ("clamped", "grounded", "contact_side")}
    supports = {s.key: "normal" if s.normal or s.sign != 1 else "".join("xyz"[a] for a in s.axes)
                for s in body.supports}
    orders = dict(order=body.order, order_phi=body.order_phi) if order is None else dict(order=order, order_phi=order)
    return type(body)(mesh, body.material, supports=supports or None, **orders, **names,
                      axisymmetric=body.axisymmetric)


class Nested:
    """A start from coarser ``levels`` (module docstring): kept for later steps (the coarse
    levels are stepped to the times of the steps they start). ``iterations``: the Newton
    iterations of each coarse level in the last start (coarsest first); ``fallback``: why the
    last start fell back to the warm start (a coarse level failed), or None.

    ``levels``: the ``time.step.Step`` of each level, coarsest first; ``prolongation(k,
    values)``: level k's u to level k + 1's, the last level's to the body's.
    ``on_coarser_meshes`` builds the start "nested", ``first_order`` the start "p1"."""

    def __init__(self, levels, prolongation):
        self.levels, self.prolongation = levels, prolongation
        self._saved = [None] * len(levels)
        self.iterations, self.fallback = [], None

    @classmethod
    def on_coarser_meshes(cls, body, coarse):
        """The start "nested" of ``body``: its coarser meshes (``levels_below``), each level the
        Step ``coarse(mesh, None)``."""
        count = levels_below(body)
        prolongation = Prolongation(body)
        return cls([coarse(level_mesh(body, k), None) for k in range(count)], prolongation)

    @classmethod
    def first_order(cls, body, coarse):
        """The start "p1": the step solved with P1 on the body's own mesh first, its u
        interpolated into the body's space (exact: P1 is in Pp). Any mesh, no hierarchy; against
        the warm start: docs/speed.md.
        A ValueError naming ``guess`` for a body of order 1. ``coarse(mesh, order)``: the level's Step."""
        if body.order < 2:
            raise ValueError(f"guess='p1' starts a body of order >= 2 from P1 on its mesh; the body has order "
                             f"{body.order} (guess='nested' starts from coarser meshes)")
        level = coarse(body.mesh, 1)
        into = ngs.GridFunction(body.V)

        def interpolate(k, values):
            level.u.vec.FV().NumPy()[:] = values
            into.Set(level.u)
            return into.vec.FV().NumPy().copy()

        return cls([level], interpolate)

    def __call__(self, starts, u, t, target):
        """The DOF values of u on the body's mesh at ``target`` (s), prolonged from the coarse
        levels stepped from t to ``target``; None if a coarse level's Newton fails
        (``fallback``)."""
        values, self.iterations, self.fallback = None, [], None
        for k, coarse in enumerate(self.levels):
            self._sync(k, coarse, t)
            self._saved[k] = (coarse.t, coarse.scheme.checkpoint(), len(coarse.history))
            guess = None if values is None else self.prolongation(k - 1, values)
            try:
                records = coarse.advance(target, guess=guess)
            except NewtonError as err:
                self.fallback = f"level {k} of {len(self.levels) + 1}: {err.reason}"
                return None
            self.iterations.append(sum(r.newton_iterations for r in records))
            values = coarse.u.vec.FV().NumPy()
        return self.prolongation(len(self.levels) - 1, values)

    def _sync(self, k, coarse, t):
        """Bring level k back to the time t where a failed step left it ahead."""
        saved = self._saved[k]
        if coarse.t > t * (1 + 1e-12) and saved is not None and saved[0] <= t * (1 + 1e-12):
            coarse.scheme.restore(saved[1])
            del coarse.history[saved[2]:]
