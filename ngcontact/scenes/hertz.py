"""Hertz contact on a curved Γ3: an elastic half-disk (2D, plane strain) or half-ball (3D)
pressed onto a rigid plane, with the closed forms it is checked against.

Body {|x − (0, R)| <= R, y <= R} (2D; in 3D the half-ball about (0, 0, R) with z <= R), its
lowest point on the plane y = 0 (z = 0), the curved side ("contact") on the plane obstacle
``obstacles.Plane`` (or, ``normal="body"``, the paper's form with the body's normal ν and the
gap taken along it). Isotropic, elastic, no piezoelectric coupling. Two controls:

* displacement: the flat top ("top") pushed down by d (a support with prescribed displacement,
  ``Loads.displacement``);
* force: a uniform traction of resultant F on the top, held there only tangentially (u_x = 0,
  and u_y = 0 in 3D): the vertical motion and the rotations about the top's points are held by
  the contact alone (``rigid.Floating``). ``informed_start`` is the peer's start: the body
  moved rigidly onto the plane by Hertz's approach for F.

Hertz, for the computed contact force F (per unit depth in 2D), E* = E/(1 − ν²):
  2D (cylinder on a plane): a = sqrt(4 F R/(π E*)), p(x) = p0 sqrt(1 − x²/a²), p0 = 2F/(π a);
  3D (sphere on a plane):   a = (3 F R/(4 E*))^(1/3), p(r) = p0 sqrt(1 − r²/a²), p0 = 3F/(2π a²).
They hold for a/R small (the half-disk is not a half-plane; how closely they are met:
docs/curved_contact.md).
"""
import math

import ngsolve as ngs
import numpy as np
from netgen.meshing import MeshingParameters
from netgen.occ import Box, Circle, OCCGeometry, Pnt, Rectangle, Sphere, X, Y, Z

import ngcontact as ngc
from ngcontact import parallel
from ngcontact.meshes import check_meshed, nested_mesh
from ngcontact.obstacles import Plane
from ngcontact.solve.starts import Approach

E, NU, R = 1.0, 0.3, 1.0
E_STAR = E / (1 - NU ** 2)


def material():
    """Isotropic elastic material E = 1 Pa, ν = 0.3 (the peer's), no coupling."""
    return ngc.Material.isotropic(E, NU, permittivity=1.0, name="hertz")


def mesh(dim=2, h_contact=None, refine=0, curve=1, radius=None, axisymmetric=False, quarter=False):
    """The half-disk (half-ball) of radius ``radius`` (m, default R) with mesh size h_contact
    (m) near the contact point over |x| < 0.25 R (default 0.02 R in 2D, 0.04 R in 3D), coarser
    away, ``refine`` uniform refinements (``meshes.nested_mesh``: boundary points on the circle
    or sphere, the coarse mesh kept for multigrid and nested iteration) and ``mesh.Curve(curve)``.
    ``axisymmetric`` (dim 2): the half-ball's meridian section, the quarter-disk x = r >= 0,
    with its boundary "axis" on r = 0 (``Body(axisymmetric=True)``); default h_contact 0.02 R.
    ``quarter`` (dim 3): the quarter-ball x, y >= 0, its symmetry planes named "symx" (x = 0)
    and "symy" (y = 0). Refused before meshing: h_contact outside (0, radius], or so small that
    Netgen would make more than ``meshes.MAX_MESHED_VERTICES`` vertices (``meshes.check_meshed``).
    """
    dim = ngc.checks.choice("dim", dim, (2, 3))
    axisymmetric, quarter = ngc.checks.flag("axisymmetric", axisymmetric), ngc.checks.flag("quarter", quarter)
    curve = ngc.checks.order("curve", curve)
    size = R if radius is None else ngc.checks.number("radius", radius, 0, ngc.checks.MAX_LENGTH, low_open=True,
                                                     unit="m")
    h_contact = (0.02 if dim == 2 else 0.04) * size if h_contact is None else \
        ngc.checks.number("h_contact", h_contact, 0, size, low_open=True, unit="m (up to the radius)")
    if axisymmetric and dim != 2:
        raise ValueError(f"axisymmetric: the mesh is the 2D meridian section (dim=2), got dim={dim}")
    if quarter and dim != 3:
        raise ValueError(f"quarter: the quarter-ball is 3D (dim=3), got dim={dim}")
    # the region meshed at h_contact: |x| < R/4 (x >= 0 on the section and the quarter), R/20 deep
    # in 2D, R/10 in 3D (upper estimates of Netgen's meshes)
    band = (0.25 if axisymmetric else 0.5) * 0.05 if dim == 2 else math.pi / 16 * 0.1 / (4 if quarter else 1)
    check_meshed("hertz.mesh", "h_contact", h_contact, band * size ** dim, dim,
                 ngc.checks.integer("refine", refine, 0, ngc.checks.MAX_REFINE))
    if dim == 2:
        width, left = (size, 0) if axisymmetric else (2 * size, -size)
        shape = Circle(Pnt(0, size), size).Face() * Rectangle(width, size).Face().Move((left, 0, 0))
        shape.edges.Max(Y).name = "top"
        if axisymmetric:
            shape.edges.Min(X).name = "axis"
        for edge in shape.edges:
            if edge.name not in ("top", "axis"):
                edge.name = "contact"
    else:
        low = 0 if quarter else -size
        shape = Sphere(Pnt(0, 0, size), size) * Box(Pnt(low, low, 0), Pnt(size, size, size))
        shape.faces.Max(Z).name = "top"
        if quarter:
            shape.faces.Min(X).name, shape.faces.Min(Y).name = "symx", "symy"
        for face in shape.faces:
            if face.name not in ("top", "symx", "symy"):
                face.name = "contact"
    parameters = MeshingParameters(maxh=10 * h_contact if dim == 2 else 0.4 * size)
    # the size is restricted at points along the contact region at most h_contact (2 h_contact
    # in 3D) apart, so that a small h_contact holds over the whole region (Netgen's grading
    # would coarsen between points further apart); at least 26 across (14 on a half)
    half = axisymmetric or quarter
    count = max(14 if half else 26, math.ceil((0.25 if half else 0.5) * size / (h_contact * (dim - 1))) + 1)
    for x in np.linspace(0 if axisymmetric or quarter else -0.25 * size, 0.25 * size, count):
        if dim == 2:
            parameters.RestrictH(x, size - math.sqrt(size * size - x * x), 0, h_contact)
        else:
            for y in np.linspace(0 if quarter else -0.25 * size, 0.25 * size, count):
                if x * x + y * y <= (0.25 * size) ** 2:
                    parameters.RestrictH(x, y, size - math.sqrt(size * size - x * x - y * y), h_contact)
    m = nested_mesh(OCCGeometry(shape, dim=dim).GenerateMesh(mp=parameters), refine)
    if curve > 1:
        m.Curve(curve)
    return m


def simulation(order=1, h_contact=None, refine=0, dim=2, depth=None, normal="obstacle", gamma0=10.0,
               control="displacement", force=None, mesh=None, axisymmetric=False, quarter=False, **options):
    """The Hertz scene as a Simulation of one step t: 0 -> 1 (mesh size ``h_contact`` as in
    ``mesh``). ``control="displacement"``: the top moved down by ``depth`` (m, default 0.02 R
    in 2D, 0.01 R in 3D); ``control="force"``: a traction on the top of resultant ``force``
    (N/m in 2D, N in 3D; default 0.01 in 2D, the peer's, 0.003 in 3D), the top held
    tangentially only. ``normal``: "obstacle" (n_o of the plane) or "body" (the paper's form:
    ν and the gap y/(−ν_y) along it). ``mesh``: a mesh of the half-disk (half-ball) with its
    boundaries "top" and "contact" to use instead (an adapted one, ``ngcontact.adapt``), curved to
    ``order``. ``axisymmetric``: the half-ball as a body of revolution on its meridian section
    (dim 2, ``mesh(axisymmetric=True)``; the 3D defaults of depth and force, records in N and m²).
    ``quarter`` (dim 3): the quarter-ball with its symmetry planes held normally (records of a
    quarter: its force, area and charges are a quarter of the ball's)."""
    if control not in ("displacement", "force"):
        raise ValueError(f"control must be 'displacement' or 'force', got {control!r}")
    if control == "force" and depth is not None or control == "displacement" and force is not None:
        raise ValueError(f"control={control!r} takes {'force' if control == 'force' else 'depth'}, not "
                         f"{'depth' if control == 'force' else 'force'}")
    m = globals()["mesh"](dim, h_contact, refine, curve=order, axisymmetric=axisymmetric,
                          quarter=quarter) if mesh is None else mesh
    t = ngs.Parameter(0.0)
    solid = 3 if axisymmetric else dim                 # the body's true dimension
    symmetry = {"symx": "x", "symy": "y"} if quarter else {}
    if control == "displacement":
        depth = (0.02 if solid == 2 else 0.01) * R if depth is None else depth
        supports = {"top": "all", **symmetry}
        loads = ngc.Loads(displacement={"top": tuple([0.0] * (dim - 1) + [-depth * t])})
    else:
        force = (0.01 if solid == 2 else 0.003) if force is None else ngc.checks.number("force", force, low=0.0, low_open=True, unit=" N (N/m in 2D)")
        supports = {"top": "xy"[:dim - 1], **symmetry}
        weight = 2 * math.pi * ngs.x if axisymmetric else ngs.CF(1.0)
        area = parallel.sum(m, ngs.Integrate(weight * ngs.ds(m.Boundaries("top")), m))   # the resultant is F
        area *= 4 if quarter else 1                                  # (the ball's: a quarter on the quarter)
        loads = ngc.Loads(f2={"top": tuple([0.0] * (dim - 1) + [-force / area * t])})
    body = ngc.Body(m, material(), grounded="top", supports=supports, contact_side="contact", order=order,
                    axisymmetric=axisymmetric)
    up = tuple([0.0] * (dim - 1) + [1.0])
    if normal == "obstacle":
        contact = ngc.Contact(obstacle=Plane(tuple([0.0] * dim), up), gamma0=gamma0)
    elif normal == "body":
        n = ngs.specialcf.normal(dim)
        height = ngs.y if dim == 2 else ngs.z
        contact = ngc.Contact(gap=height / ngs.IfPos(-n[dim - 1], -n[dim - 1], 1.0), gamma0=gamma0)
    else:
        raise ValueError(f"normal must be 'obstacle' or 'body', got {normal!r}")
    return ngc.Simulation(body, loads, contact=contact, time=t, **options)


def approach(force, dim=2):
    """The rigid approach (m) of the informed start for the contact force ``force``: Hertz's
    a²/R in 3D; in 2D, where the approach of a cylinder is not finite, the peer's a²/(2R)."""
    a, _ = closed_form(force, dim)
    return a * a / (2 * R if dim == 2 else R)


def informed_start(force, dim=2):
    """``Simulation.step(dt, guess=...)`` for a force-controlled Hertz step to ``force``: the
    body moved rigidly onto the plane by ``approach(force)``."""
    return Approach(approach(force, dim))


def closed_form(force, dim=2):
    """(a, p0) of Hertz for the contact force ``force`` (N/m in 2D, N in 3D; > 0) and ``dim`` 2 or 3."""
    dim = ngc.checks.choice("dim", dim, (2, 3))
    force = ngc.checks.number("force", force, 0, low_open=True, unit="N (N/m in 2D)")
    if dim == 2:
        a = math.sqrt(4 * force * R / (math.pi * E_STAR))
        return a, 2 * force / (math.pi * a)
    a = (3 * force * R / (4 * E_STAR)) ** (1 / 3)
    return a, 3 * force / (2 * math.pi * a * a)


def errors(sim):
    """Accuracy of a solved Hertz simulation (the half-disk, the half-ball, its quarter or its
    meridian section) against the closed form for its own force (the whole ball's):
    dict(force, a, a_h, p0, p0_h, pressure_L2) with a_h the half-width (radius) of the
    contact zone {λ_h > 0} (from its measure), p0_h the largest facet average of λ_h and
    pressure_L2 = ‖λ_h − p‖/‖p‖ on Γ3 (λ_h the enforcement's multiplier at the residual's
    points, integrated with 2p + 2 extra orders per facet)."""
    dim = 3 if sim.body.axisymmetric else sim.body.dim      # a body of revolution: the 3D closed form
    record = sim.history[-1].contact
    share = 4 if "symx" in sim.body.mesh.GetBoundaries() else 1        # a quarter-ball records a quarter
    force = share * float(record.force[-1])
    if not force > 0:
        raise ValueError(f"errors: the contact force of the simulation's last step is {force:g} (N, N/m in 2D): the "
                         "body does not press on the plane; Hertz's closed form needs a force > 0")
    a, p0 = closed_form(force, dim)
    u, phi = sim.u, sim.phi
    traction = ngs.CF(0.0)
    lam = sim.enforcement.multiplier(u, phi, traction)
    r2 = ngs.x * ngs.x if sim.body.dim == 2 else ngs.x * ngs.x + ngs.y * ngs.y     # (r = x on a meridian section)
    exact = p0 * ngs.sqrt(ngs.IfPos(1 - r2 / (a * a), 1 - r2 / (a * a), 0.0))
    difference = sim.side.integrate((lam - exact) ** 2)
    norm = sim.side.integrate(exact ** 2)
    area = share * record.contact_area
    a_h = area / 2 if dim == 2 else math.sqrt(area / math.pi)
    return dict(force=force, a=a, a_h=a_h, p0=p0, p0_h=float(record.multiplier.max()),
                pressure_L2=math.sqrt(difference / norm))
