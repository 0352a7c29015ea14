"""A piezoelectric disk glued to a rigid plane and pulled off it by a stud: on its meridian
section (a body of revolution) or as the 3D quarter of it.

A PZT-5A disk (radius W = 5 mm, thickness H = 1 mm, poled along its axis) is glued on its bottom
(Γ3) to the plane z = 0 (γ_ν = 1e14 Pa/m, bond length L = 1 µm, β updated implicitly) and pulled
up by ``pull`` (m) over t ∈ [0, 1] by a stud of radius S = 1 mm on its top, which is grounded. The
debonding front runs out from under the stud. Section: x = r, y = z, boundaries "bottom", "rim",
"top", "stud", "axis"; quarter: "bottom", "rim", "top", "stud", "symx", "symy" (the stud's force
of the whole disk is 4 times the quarter's).
"""
import math

import ngsolve as ngs

import ngcontact as ngc
from ngcontact.checks import number
from ngcontact.obstacles import Plane

W, H, S = 5e-3, 1e-3, 1e-3
"""The disk's radius, its thickness and the stud's radius (m)."""
PULL = 4e-6
"""The stud's lift at t = 1 (m)."""
KINDS = ("section", "quarter")


def mesh(kind="section", maxh=1e-4):
    """The disk's meridian section (2D) or its 3D quarter, meshed at ``maxh`` (m)."""
    if kind not in KINDS:
        raise ValueError(f"glued_disk: kind must be one of {KINDS}, got {kind!r}")
    maxh = number("maxh", maxh, 0, H, low_open=True, unit="m (at most the disk's thickness)")
    if kind == "section":
        from netgen.geom2d import SplineGeometry
        geometry = SplineGeometry()
        points = [geometry.AppendPoint(*p) for p in ((0, 0), (W, 0), (W, H), (S, H), (0, H))]
        for (a, b), name in zip(((0, 1), (1, 2), (2, 3), (3, 4), (4, 0)), ("bottom", "rim", "top", "stud", "axis")):
            geometry.Append(["line", points[a], points[b]], bc=name)
        return ngs.Mesh(geometry.GenerateMesh(maxh=maxh))
    from netgen.occ import Box, Cylinder, Glue, OCCGeometry, Pnt, Z
    box = Box(Pnt(0, 0, 0), Pnt(W, W, H))
    inner = Cylinder(Pnt(0, 0, 0), Z, r=S, h=H) * box
    shape = Glue([inner, (Cylinder(Pnt(0, 0, 0), Z, r=W, h=H) - Cylinder(Pnt(0, 0, 0), Z, r=S, h=H)) * box])
    for face in shape.faces:
        c = face.center
        face.name = ("stud" if math.hypot(c.x, c.y) < S else "top") if abs(c.z - H) < 1e-9 else \
            "bottom" if abs(c.z) < 1e-9 else "symx" if abs(c.x) < 1e-9 else "symy" if abs(c.y) < 1e-9 else "rim"
    return ngs.Mesh(OCCGeometry(shape).GenerateMesh(maxh=maxh))


def simulation(kind="section", maxh=1e-4, pull=PULL, **options):
    """The pull-off as a Simulation on ``mesh(kind, maxh)``; ``options`` go to Simulation."""
    section = kind == "section"
    supports, up = ({"stud": "all"}, (0, 1)) if section else ({"stud": "all", "symx": "x", "symy": "y"}, (0, 0, 1))
    t = ngs.Parameter(0.0)
    body = ngc.Body(mesh(kind, maxh), ngc.pzt5a(), supports=supports, grounded="stud", contact_side="bottom",
                    axisymmetric=section)
    contact = ngc.Contact(obstacle=Plane((0,) * len(up), up), adhesion=1e14, bond_length=1e-6, beta_update="implicit")
    return ngc.Simulation(body, ngc.Loads(displacement={"stud": tuple(pull * t * c for c in up)}), contact=contact,
                          time=t, **options)
