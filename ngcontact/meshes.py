"""Nested meshes: a Netgen mesh refined uniformly, with its coarse mesh kept (a ``Hierarchy``);
and adapted meshes: a copy refined where marked (``refined``, for ``adapt``).

The ground floor of everything that needs the levels below a mesh: the geometries and the
scenes make their meshes here, the multigrid preconditioner (``multigrid``) and nested
iteration (``nested``) rebuild the levels from the hierarchy a Body holds (``Body.hierarchy``).
``mesh.Refine()`` bisects every element (h halves); the coarse mesh is a copy of the Netgen mesh
before the first refinement. NGSolve 6.2.2608 cannot refine a distributed mesh: a mesh
distributed over MPI ranks has no hierarchy.
"""
import math
import numbers
import pickle
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from netgen.meshing import Mesh as NetgenMesh

from ngcontact import checks

COARSE = "ngcontact_hierarchy"
"""The attribute by which ``nested_mesh`` hands its ``Hierarchy`` to the Body of the mesh it makes."""
MAX_MESHED_VERTICES = 5e4
"""The most vertices a scene's mesh maker (``scenes.hertz.mesh``, ``scenes.indenter.mesh``) asks
Netgen to make at once (estimated, ``check_meshed``): a finer mesh comes from ``refine=``
(``nested_mesh``), since meshing under local size restrictions costs more than refining
(docs/measurements.md)."""


def check_meshed(what, name, h, fine, dim, refine=0, finer="refine=..., which halves h each time"):
    """Refuse, before meshing, a mesh size ``h`` (m; the parameter ``name``) that would have Netgen
    make more than ``MAX_MESHED_VERTICES`` vertices over the region of measure ``fine`` (m² in 2D,
    m³ in 3D) meshed at h (``checks.VERTICES_PER_CELL``), naming its smallest allowed value; and
    the mesh refined ``refine`` times that does not fit in memory (``checks.fits_in_memory``);
    ``finer`` says how to make a finer mesh."""
    log = math.log(checks.VERTICES_PER_CELL[dim] * fine) - dim * math.log(h)
    vertices = math.exp(min(log, 690.0))
    if vertices > MAX_MESHED_VERTICES:
        smallest = (checks.VERTICES_PER_CELL[dim] * fine / MAX_MESHED_VERTICES) ** (1 / dim)
        step = 10.0 ** (math.floor(math.log10(smallest)) - 2)              # 3 digits, rounded up
        raise ValueError(f"{what}: {name} = {h:g} m would have Netgen make about {vertices:.2g} vertices (at most "
                         f"{MAX_MESHED_VERTICES:g}); {name} must be >= {math.ceil(smallest / step) * step:.3g} m "
                         f"(a finer mesh: {finer})")
    checks.fits_in_memory(f"{what}: {name} = {h:g} m, refine = {refine} (u and φ at P1)",
                          checks.estimated_ndof(vertices, dim, refine))


@dataclass(frozen=True, eq=False)
class Hierarchy:
    """Nested meshes: the ``coarse`` Netgen mesh (a copy, kept) refined uniformly ``refinements``
    times (h halves each time) makes a mesh of ``vertices`` vertices, its finest level."""

    coarse: object
    refinements: int
    vertices: int

    def __post_init__(self):
        if not isinstance(self.coarse, NetgenMesh):
            raise TypeError(f"Hierarchy: coarse must be a Netgen mesh (netgen.meshing.Mesh, e.g. ngsolve_mesh.ngmesh "
                            f"before it is refined; nested_mesh keeps one), got {type(self.coarse).__name__}")
        object.__setattr__(self, "refinements", checks.integer("Hierarchy: refinements", self.refinements, 0,
                                                               checks.MAX_REFINE))
        object.__setattr__(self, "vertices", checks.integer("Hierarchy: vertices", self.vertices, 1))
        points = len(self.coarse.Points())
        if self.refinements and self.vertices <= points or self.vertices < points:
            raise ValueError(f"Hierarchy: {self.vertices} vertices of the finest level, but the coarse mesh has "
                             f"{points}, refined {self.refinements} times (each refinement adds vertices)")

    def check_finest(self, mesh, size):
        """A ValueError naming ``hierarchy`` unless ``mesh`` (of diagonal ``size``, m) is the finest
        level: its dimension, boundary names and vertices (``check``) those of the coarse mesh
        refined ``refinements`` times."""
        if self.coarse.dim != mesh.dim:
            raise ValueError(f"hierarchy: its coarse mesh is {self.coarse.dim}D, the mesh {mesh.dim}D")
        names, theirs = set(self.coarse.GetRegionNames(codim=1)), set(mesh.GetBoundaries())
        if names != theirs:
            raise ValueError(f"hierarchy: its coarse mesh has the boundaries {sorted(names)}, the mesh "
                             f"{sorted(theirs)} (the levels of nested meshes share their boundaries)")
        if self.vertices != mesh.nv:
            raise ValueError(f"hierarchy must be an ngcontact.meshes.Hierarchy whose finest level is the mesh "
                             f"({mesh.nv} vertices), got {self.vertices} vertices")
        self.check(self.level(self.refinements), mesh, size, "hierarchy")

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
                             f"{self.refinements} times: the mesh was changed after nested_mesh(), or the "
                             "hierarchy is another mesh's")


def nested_mesh(ngmesh, refine=0):
    """``ngsolve.Mesh(ngmesh)`` refined ``refine`` times by ``mesh.Refine()`` (h halves each
    time), with its ``Hierarchy`` (``hierarchy``: what a Body of it takes by default). ``refine``
    at most ``checks.MAX_REFINE``, and the refined mesh must fit in memory with u and φ at P1
    (estimated from the vertices, each refinement multiplying them by 2^dim): refused before
    refining otherwise."""
    if not isinstance(ngmesh, NetgenMesh):
        raise TypeError(f"nested_mesh takes a Netgen mesh (netgen.meshing.Mesh, e.g. geometry.GenerateMesh(...) or "
                        f"ngsolve_mesh.ngmesh), got {type(ngmesh).__name__}")
    if isinstance(refine, bool) or not isinstance(refine, numbers.Real):
        raise TypeError(f"refine must be an integer >= 0, got {refine!r} ({type(refine).__name__})")
    if not math.isfinite(refine) or int(refine) != refine or refine < 0:
        raise ValueError(f"refine must be an integer >= 0, got {refine}")
    if refine > checks.MAX_REFINE:
        raise ValueError(f"refine must be an integer >= 0 and <= {checks.MAX_REFINE} (each refinement multiplies the "
                         f"elements by 2^dim), got {refine}")
    points = len(ngmesh.Points())
    checks.fits_in_memory(f"nested_mesh: refine = {int(refine)} of a mesh of {points} vertices (u and φ at P1)",
                          checks.estimated_ndof(points, ngmesh.dim, int(refine)))
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


def vertex_points(mesh):
    """The coordinates of every vertex of ``mesh`` (vertices × dim, m)."""
    return np.array([v.point for v in mesh.vertices]).reshape(mesh.nv, mesh.dim)


# ---------------------------------------------------------------------- facets: edges in 2D, faces in 3D

def facets(mesh):
    """The facets of ``mesh``: its edges in 2D, its faces in 3D."""
    return mesh.edges if mesh.dim == 2 else mesh.faces


def facets_of(mesh, element):
    """The facets of a volume or boundary element of ``mesh`` (edges in 2D, faces in 3D)."""
    return element.edges if mesh.dim == 2 else element.faces


def facet_kind(mesh):
    """The NodeType of the facets of ``mesh``: ``ngs.EDGE`` in 2D, ``ngs.FACE`` in 3D."""
    return ngs.EDGE if mesh.dim == 2 else ngs.FACE


def facet_shape(mesh):
    """The ElementType of the facets of ``mesh``: a segment in 2D, a triangle in 3D."""
    return ngs.SEGM if mesh.dim == 2 else ngs.TRIG


def facet_sample_weights(mesh, order):
    """The barycentric weights of sample points on a facet: 2 ``order`` + 1 equidistant points
    on an edge in 2D; the vertices, the centroid and the edge midpoints of a triangle in 3D."""
    if mesh.dim == 2:
        s = np.linspace(0, 1, 2 * order + 1)
        return np.stack([1 - s, s], axis=1)
    return np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1 / 3] * 3, [.5, .5, 0], [0, .5, .5], [.5, 0, .5]])
