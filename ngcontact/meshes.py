"""Nested meshes: a Netgen mesh refined uniformly, with its coarse mesh kept (a ``Hierarchy``);
and adapted meshes: a copy refined where marked (``refined``, for ``adapt``).

The ground floor of everything that needs the levels below a mesh: the geometries and the
scenes make their meshes here, the multigrid preconditioner (``multigrid``) and nested
iteration (``nested``) rebuild the levels from the hierarchy a Body holds (``Body.hierarchy``).
``mesh.Refine()`` bisects every element (h halves); the coarse mesh is a copy of the Netgen mesh
before the first refinement. NGSolve 6.2.2608 cannot refine a distributed mesh: a mesh
distributed over MPI ranks has no hierarchy.
"""
import pickle
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

COARSE = "ngcontact_hierarchy"
"""The attribute by which ``nested_mesh`` hands its ``Hierarchy`` to the Body of the mesh it makes."""


@dataclass(frozen=True, eq=False)
class Hierarchy:
    """Nested meshes: the ``coarse`` Netgen mesh (a copy, kept) refined uniformly ``refinements``
    times (h halves each time) makes a mesh of ``vertices`` vertices, its finest level."""

    coarse: object
    refinements: int
    vertices: int

    def levels(self, curve_order=1):
        """The levels 0 (a copy of the coarse mesh), 1, ..., ``refinements`` as one ngsolve.Mesh
        refined in place: yields it at each level (curved to ``curve_order`` where > 1)."""
        mesh = ngs.Mesh(self.coarse.Copy())
        for level in range(self.refinements + 1):
            if level:
                mesh.Refine()
            if curve_order > 1:
                mesh.Curve(curve_order)
            yield mesh

    def level(self, k, curve_order=1):
        """Level k (0: the coarse mesh) as a new ngsolve.Mesh, curved to ``curve_order``."""
        mesh = nested_mesh(self.coarse.Copy(), k)
        if curve_order > 1:
            mesh.Curve(curve_order)
        return mesh

    def check(self, replica, mesh, size, what):
        """A ValueError naming ``what`` if ``replica`` (the finest level rebuilt) and ``mesh`` differ
        in their vertices (to 1e-12 of ``size``, m): ``mesh`` was changed after it was made."""
        mine, theirs = np.asarray(replica.ngmesh.Coordinates()), np.asarray(mesh.ngmesh.Coordinates())
        if mine.shape != theirs.shape or not np.allclose(mine, theirs, rtol=0, atol=1e-12 * size):
            raise ValueError(f"{what}: the mesh's vertices differ from its kept coarse mesh refined "
                             f"{self.refinements} times: the mesh was changed after nested_mesh()")


def nested_mesh(ngmesh, refine=0):
    """``ngsolve.Mesh(ngmesh)`` refined ``refine`` times by ``mesh.Refine()`` (h halves each
    time), with its ``Hierarchy`` (``hierarchy``: what a Body of it takes by default)."""
    if int(refine) != refine or refine < 0:
        raise ValueError(f"refine must be an integer >= 0, got {refine}")
    coarse = ngmesh.Copy()
    mesh = ngs.Mesh(ngmesh)
    for _ in range(int(refine)):
        mesh.Refine()
    setattr(mesh, COARSE, Hierarchy(coarse, int(refine), mesh.nv))
    return mesh


def hierarchy(mesh):
    """The ``Hierarchy`` of a mesh made by ``nested_mesh``, or None: for another mesh, or one
    refined or changed in its vertex count since (its levels would not be the mesh's)."""
    kept = getattr(mesh, COARSE, None)
    return kept if kept is not None and kept.vertices == mesh.nv else None


def refinements(mesh):
    """How many times ``mesh`` was refined from its kept coarse mesh (None without a
    ``hierarchy``)."""
    kept = hierarchy(mesh)
    return None if kept is None else kept.refinements


def coarse(mesh):
    """(a copy of the kept coarse Netgen mesh, refinements) of ``mesh``, or None without a
    ``hierarchy``."""
    kept = hierarchy(mesh)
    return None if kept is None else (kept.coarse.Copy(), kept.refinements)


def refined(mesh, marked, polygonal=False):
    """A new mesh: a copy of ``mesh`` with the volume elements where ``marked`` (a boolean
    array, one entry per element) is True bisected, and their neighbours as far as a conforming
    mesh needs (Netgen's refinement; new boundary points on the geometry), curved again to the
    order of ``mesh``. ``mesh`` itself is left as it was. A mesh without a geometry (made point
    by point, or read from another mesher) would put its new boundary points on its straight
    facets: refused (a ValueError) unless ``polygonal`` says its boundary is polygonal. Serial
    meshes only (NGSolve cannot refine a distributed mesh)."""
    marked = np.asarray(marked)
    if marked.dtype != bool or marked.shape != (mesh.ne,):
        raise ValueError(f"marked must be a boolean array with one entry per volume element ({mesh.ne}), got "
                         f"{marked.dtype} of shape {marked.shape}")
    if mesh.comm.size > 1:
        raise ValueError("refined: a distributed mesh cannot be refined (NGSolve refines serial meshes only)")
    curve = mesh.GetCurveOrder()
    bare = type(mesh.ngmesh.GetGeometry()).__name__ == "NetgenGeometry"
    if bare and not polygonal:
        raise ValueError("refined: the mesh has no geometry to place new boundary points on (made point by point or "
                         "read from another mesher): they would lie on its straight facets; mesh a geometry "
                         "(netgen.occ, geom2d, csg), or pass polygonal=True if the boundary is polygonal")
    # Netgen's Copy of a mesh without a geometry crashes in Refine (6.2.2608): a pickled copy does not
    copy = ngs.Mesh(pickle.loads(pickle.dumps(mesh.ngmesh)) if bare else mesh.ngmesh.Copy())
    for element in copy.Elements(ngs.VOL):
        copy.SetRefinementFlag(element, bool(marked[element.nr]))
    copy.Refine()
    if curve > 1:
        copy.Curve(curve)
    return copy
