"""Nested meshes: a Netgen mesh refined uniformly, with its coarse mesh kept; and adapted meshes:
a copy refined where marked (``refined``, for ``adapt``).

The ground floor of everything that needs the levels below a mesh: the geometries and the
scenes make their meshes here, the multigrid preconditioner (``multigrid``) and nested
iteration (``nested``) rebuild the levels from the kept coarse mesh. ``mesh.Refine()``
bisects every element (h halves); the coarse mesh is a copy of the Netgen mesh before the
first refinement, stored on the ``ngsolve.Mesh`` with the number of refinements. NGSolve
6.2.2608 cannot refine a distributed mesh: a mesh distributed over MPI ranks keeps none.
"""
import pickle

import ngsolve as ngs
import numpy as np

COARSE = "ngcontact_coarse"
"""The attribute of an ngsolve.Mesh that holds (coarse netgen mesh, refinements)."""


def nested_mesh(ngmesh, refine=0):
    """``ngsolve.Mesh(ngmesh)`` refined ``refine`` times by ``mesh.Refine()`` (h halves each
    time), keeping a copy of the coarse mesh (``coarse``)."""
    if int(refine) != refine or refine < 0:
        raise ValueError(f"refine must be an integer >= 0, got {refine}")
    coarse = ngmesh.Copy()
    mesh = ngs.Mesh(ngmesh)
    for _ in range(int(refine)):
        mesh.Refine()
    setattr(mesh, COARSE, (coarse, int(refine)))
    return mesh


def refinements(mesh):
    """How many times ``mesh`` was refined from its kept coarse mesh (None if it keeps none:
    not made by ``nested_mesh``)."""
    kept = getattr(mesh, COARSE, None)
    return None if kept is None else kept[1]


def coarse(mesh):
    """(a copy of the kept coarse Netgen mesh, refinements) of ``mesh``, or None if it keeps
    none."""
    kept = getattr(mesh, COARSE, None)
    return None if kept is None else (kept[0].Copy(), kept[1])


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
