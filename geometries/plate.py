"""Rectangular meshes with named boundaries: the plate (2D) and the block (3D) of the reference scene.

Boundary names (use them for the parts of (2.5)-(2.6)):

* 2D plate 0 ≤ x ≤ L1, 0 ≤ y ≤ L2: "left" (x = 0, Γ1 clamped), "right" and "top" (Γ2,
  tractions), "bottom" (y = 0, the contact side Γ3); electrically "top" is the grounded
  electrode Γa and the rest is Γb.
* 3D block 0 ≤ x ≤ L1, 0 ≤ y ≤ L2, 0 ≤ z ≤ L3: "left", "right", "front" (y = 0), "back",
  "bottom" (z = 0, the contact side Γ3) and "top" (z = L3).

Lengths in metres. ``refine`` applies ``mesh.Refine()`` that many times (nested meshes,
h halves each time): far cheaper than generating a fine mesh; the coarse mesh is kept for
the multigrid solver (``ngcontact.meshes.nested_mesh``).

Before meshing, the lengths must be in (0, 1000] m and the mesh sizes at most the longest
side, both at least ``NETGEN_RESOLUTION`` of it, ``refine`` in [0, ``checks.MAX_REFINE``],
and the mesh must fit in the machine's memory with u and φ at P1 (``checks.estimated_ndof``,
``checks.fits_in_memory``): a ValueError or TypeError naming the parameter otherwise.

Under ``mpiexec -n N`` (N >= 2) the mesh is generated and refined on rank 0 and distributed
over the ranks (``ngcontact.parallel.distributed_mesh``; no coarse mesh is kept: NGSolve
6.2.2608 cannot refine a distributed mesh); ``comm=False`` keeps it serial.
"""
from netgen.occ import Box, OCCGeometry, Pnt, Rectangle, X, Y, Z

from ngcontact import checks, parallel
from ngcontact.meshes import nested_mesh


NETGEN_RESOLUTION = 2e-4
"""The shortest segment Netgen divides an edge into, relative to the geometry's longest side
(checked: 2e-4 meshed, 1e-4 gave "Could not divide Edge" and faces left unmeshed): the
shortest side and the mesh sizes must be at least this fraction of the longest side."""


def _lengths(**lengths):
    """The lengths, each in (0, ``checks.MAX_LENGTH``] m, as a dict of floats."""
    return {name: checks.number(name, value, 0, checks.MAX_LENGTH, low_open=True, unit="m")
            for name, value in lengths.items()}


def _check(what, lengths, sizes, refine, graded=0.0):
    """The lengths (``_lengths``; the shortest at least ``NETGEN_RESOLUTION`` of the longest),
    the mesh sizes (in [``NETGEN_RESOLUTION`` × longest,
    longest]) and ``refine`` checked, and the estimated mesh against the memory (``graded``:
    the length of a side meshed at the last of ``sizes``, counted as an extra band of
    vertices). Returns refine as an int."""
    longest = max(lengths.values())
    described = ", ".join(f"{name} = {value:g} m" for name, value in lengths.items())
    if min(lengths.values()) < NETGEN_RESOLUTION * longest:
        raise ValueError(f"{what}: the sides {described} differ by more than {1 / NETGEN_RESOLUTION:g} times "
                         "(Netgen cannot divide the long edges finely enough for the short ones)")
    side = max(lengths, key=lengths.get)
    for name, value in sizes.items():
        checks.number(name, value, NETGEN_RESOLUTION * longest, longest, unit=f"m ({NETGEN_RESOLUTION:g} of the "
                      f"longest side, {side} = {longest:g} m, to the longest side: Netgen's resolution)")
    refine = checks.integer("refine", refine, 0, checks.MAX_REFINE)
    maxh, fine = list(sizes.values())[0], list(sizes.values())[-1]
    vertices = checks.estimated_vertices(list(lengths.values()), maxh) + \
        (checks.estimated_vertices([graded, fine], fine) if graded else 0.0)
    settings = ", ".join([described] + [f"{name.split(' (')[0]} = {value:g} m" for name, value in sizes.items()])
    checks.fits_in_memory(f"{what}: {settings}, refine = {refine} (u and φ at P1)",
                          checks.estimated_ndof(vertices, len(lengths), refine))
    return refine


def _mesh(geometry, dim, maxh, refine, comm=None):
    """The mesh, refined ``refine`` times; ``comm``: an mpi4py communicator to distribute it
    over, None for COMM_WORLD under mpiexec (else serial), False for serial."""
    if not (comm is None or comm is False or hasattr(comm, "Get_size")):
        raise TypeError(f"comm must be None, False or an mpi4py communicator, got {comm!r}")
    comm = parallel.world() if comm is None else comm
    if comm:
        return parallel.distributed_mesh(lambda: OCCGeometry(geometry, dim=dim).GenerateMesh(maxh=maxh),
                                         int(refine), comm)
    return nested_mesh(OCCGeometry(geometry, dim=dim).GenerateMesh(maxh=maxh), refine)


def plate(L1=0.1, L2=0.02, maxh=None, refine=0, maxh_contact=None, comm=None):
    """Mesh of the plate [0, L1] × [0, L2] (plane strain); maxh defaults to L2/2,
    ``maxh_contact`` grades the mesh towards the contact side "bottom"; ``comm`` as in
    the module's note (distributed under mpiexec)."""
    lengths = _lengths(L1=L1, L2=L2)
    name, maxh = ("maxh (by default L2/2)", L2 / 2) if maxh is None else ("maxh", maxh)
    sizes = {name: maxh} if maxh_contact is None else {name: maxh, "maxh_contact": maxh_contact}
    refine = _check("plate", lengths, sizes, refine, graded=0.0 if maxh_contact is None else L1)
    face = Rectangle(L1, L2).Face()
    face.edges.Min(X).name = "left"
    face.edges.Max(X).name = "right"
    face.edges.Min(Y).name = "bottom"
    face.edges.Max(Y).name = "top"
    if maxh_contact is not None:
        face.edges.Min(Y).maxh = maxh_contact
    return _mesh(face, 2, maxh, refine, comm)


def block(L1=0.1, L2=0.04, L3=0.02, maxh=None, refine=0, comm=None):
    """Mesh of the block [0, L1] × [0, L2] × [0, L3]; maxh defaults to L3/2; ``comm`` as in
    the module's note (distributed under mpiexec)."""
    lengths = _lengths(L1=L1, L2=L2, L3=L3)
    name, maxh = ("maxh (by default L3/2)", L3 / 2) if maxh is None else ("maxh", maxh)
    refine = _check("block", lengths, {name: maxh}, refine)
    box = Box(Pnt(0, 0, 0), Pnt(L1, L2, L3))
    for axis, low, high in ((X, "left", "right"), (Y, "front", "back"), (Z, "bottom", "top")):
        box.faces.Min(axis).name = low
        box.faces.Max(axis).name = high
    return _mesh(box, 3, maxh, refine, comm)
