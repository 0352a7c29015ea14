"""Rectangular meshes with named boundaries: the plate (2D) and the block (3D) of the reference scene.

Boundary names (use them for the parts of (2.5)-(2.6)):

* 2D plate 0 ≤ x ≤ L1, 0 ≤ y ≤ L2: "left" (x = 0, Γ1 clamped), "right" and "top" (Γ2,
  tractions), "bottom" (y = 0, the contact side Γ3); electrically "top" is the grounded
  electrode Γa and the rest is Γb.
* 3D block 0 ≤ x ≤ L1, 0 ≤ y ≤ L2, 0 ≤ z ≤ L3: "left", "right", "front" (y = 0), "back",
  "bottom" (z = 0, the contact side Γ3) and "top" (z = L3).

Lengths in metres. ``refine`` applies ``mesh.Refine()`` that many times (nested meshes,
h halves each time): far cheaper than generating a fine mesh; the coarse mesh is kept for
the multigrid solver (``ngcontact.multigrid.nested_mesh``).

Under ``mpiexec -n N`` (N >= 2) the mesh is generated and refined on rank 0 and distributed
over the ranks (``ngcontact.parallel.distributed_mesh``; no coarse mesh is kept: NGSolve
6.2.2608 cannot refine a distributed mesh); ``comm=False`` keeps it serial.
"""
from netgen.occ import Box, OCCGeometry, Pnt, Rectangle, X, Y, Z

from ngcontact import parallel
from ngcontact.multigrid import nested_mesh


def _check(**lengths):
    for name, value in lengths.items():
        if not value > 0:
            raise ValueError(f"{name} must be > 0 m, got {value}")


def _mesh(geometry, dim, maxh, refine, comm=None):
    """The mesh, refined ``refine`` times; ``comm``: an mpi4py communicator to distribute it
    over, None for COMM_WORLD under mpiexec (else serial), False for serial."""
    if int(refine) != refine or refine < 0:
        raise ValueError(f"refine must be an integer >= 0, got {refine}")
    comm = parallel.world() if comm is None else comm
    if comm:
        return parallel.distributed_mesh(lambda: OCCGeometry(geometry, dim=dim).GenerateMesh(maxh=maxh),
                                         int(refine), comm)
    return nested_mesh(OCCGeometry(geometry, dim=dim).GenerateMesh(maxh=maxh), refine)


def plate(L1=0.1, L2=0.02, maxh=None, refine=0, maxh_contact=None, comm=None):
    """Mesh of the plate [0, L1] × [0, L2] (plane strain); maxh defaults to L2/2,
    ``maxh_contact`` grades the mesh towards the contact side "bottom"; ``comm`` as in
    the module's note (distributed under mpiexec)."""
    maxh = L2 / 2 if maxh is None else maxh
    _check(L1=L1, L2=L2, maxh=maxh)
    face = Rectangle(L1, L2).Face()
    face.edges.Min(X).name = "left"
    face.edges.Max(X).name = "right"
    face.edges.Min(Y).name = "bottom"
    face.edges.Max(Y).name = "top"
    if maxh_contact is not None:
        _check(maxh_contact=maxh_contact)
        face.edges.Min(Y).maxh = maxh_contact
    return _mesh(face, 2, maxh, refine, comm)


def block(L1=0.1, L2=0.04, L3=0.02, maxh=None, refine=0, comm=None):
    """Mesh of the block [0, L1] × [0, L2] × [0, L3]; maxh defaults to L3/2; ``comm`` as in
    the module's note (distributed under mpiexec)."""
    maxh = L3 / 2 if maxh is None else maxh
    _check(L1=L1, L2=L2, L3=L3, maxh=maxh)
    box = Box(Pnt(0, 0, 0), Pnt(L1, L2, L3))
    for axis, low, high in ((X, "left", "right"), (Y, "front", "back"), (Z, "bottom", "top")):
        box.faces.Min(axis).name = low
        box.faces.Max(axis).name = high
    return _mesh(box, 3, maxh, refine, comm)
