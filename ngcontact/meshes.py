"""Nested meshes: a Netgen mesh refined uniformly, with its coarse mesh kept.

The ground floor of everything that needs the levels below a mesh: the geometries and the
scenes make their meshes here, the multigrid preconditioner (``multigrid``) and nested
iteration (``nested``) rebuild the levels from the kept coarse mesh. ``mesh.Refine()``
bisects every element (h halves); the coarse mesh is a copy of the Netgen mesh before the
first refinement, stored on the ``ngsolve.Mesh`` with the number of refinements. NGSolve
6.2.2608 cannot refine a distributed mesh: a mesh distributed over MPI ranks keeps none.
"""
import ngsolve as ngs

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
