"""A conducting spherical tip indenting a piezoelectric film, as a body of revolution: the
scene of piezoresponse and nano-indentation measurements (tutorials/10_axisymmetric_indenter).

A PZT-5A film of thickness H and radius W (m), poled along the tip's axis and bonded to a
grounded substrate, solved on its meridian section [0, W] × [0, H] (``Body(axisymmetric=True)``:
x = r, y = z; boundaries "axis", "right", "bottom", "top"), its top Γ3. A rigid sphere of radius
R, grounded and conducting (``Contact(conductance=k)``, φ_Γ = 0), touches the top at r = 0 at
t = 0 and goes down ``depth`` over t ∈ [0, 1]. Records in whole-body units: the tip's force
(N, ``record.contact.force[1]``), the contact radius (m, from ``contact_area`` in m²) and the
charge it draws (C, −``record.contact.charge_flux``).
"""
import ngsolve as ngs
import numpy as np
from netgen.meshing import MeshingParameters
from netgen.occ import OCCGeometry, Rectangle, X, Y

import ngcontact as ngc
from ngcontact.checks import number
from ngcontact.meshes import MAX_MESHED_VERTICES, check_meshed
from ngcontact.obstacles import Sphere

R, DEPTH = 100e-6, 0.5e-6
"""The tip's radius and its final indentation (m)."""
H, W = 20e-6, 100e-6
"""The film's thickness and radius (m)."""
MAX_ASPECT = 2000.0
"""The largest ratio of the film's radius to its thickness (or the inverse): the section is meshed
at a quarter of the shorter side, about ``VERTICES_PER_CELL`` · 16 · 2000 = 3.7e4 vertices at this
ratio, within ``meshes.MAX_MESHED_VERTICES``."""
CONDUCTANCE = 1.0
"""The tip's contact conductance (F/m²): large against ε33/a ≈ 1e-3 F/m², so that the contact
zone is held at the tip's potential (a larger one hardly changes the charge: docs/measurements.md,
section ngcontact/scenes/indenter.py)."""


def mesh(thickness=H, width=W, h_contact=0.25e-6, fine=12e-6):
    """The meridian section [0, width] × [0, thickness] (m), of mesh size ``h_contact`` (m) in the
    square of side ``fine`` under the tip (Netgen's grading 0.1 away from it: the default 0.3
    stiffens the film in force, docs/measurements.md, section ngcontact/scenes/indenter.py).
    Refused before meshing: an h_contact so small that
    Netgen would make more than ``meshes.MAX_MESHED_VERTICES`` vertices (``meshes.check_meshed``),
    or sides more than ``MAX_ASPECT`` apart."""
    thickness, width = number("thickness", thickness, 0, low_open=True, unit=" m"), \
        number("width", width, 0, low_open=True, unit=" m")
    h_contact = number("h_contact", h_contact, 0, min(thickness, width), low_open=True, unit=" m")
    fine = min(number("fine", fine, 0, low_open=True, unit=" m"), thickness, width)
    check_meshed("indenter.mesh", "h_contact", h_contact, fine * fine, 2, finer="mesh.Refine(), which halves h")
    longest = MAX_ASPECT * min(width, thickness)
    if max(width, thickness) > longest:
        raise ValueError(f"indenter.mesh: width = {width:g} m and thickness = {thickness:g} m: the longer must be "
                         f"at most {MAX_ASPECT:g} times the shorter ({longest:g} m; the section is meshed at a quarter "
                         f"of the shorter: at most {MAX_MESHED_VERTICES:g} vertices)")
    face = Rectangle(width, thickness).Face()
    face.edges.Min(X).name, face.edges.Max(X).name = "axis", "right"
    face.edges.Min(Y).name, face.edges.Max(Y).name = "bottom", "top"
    parameters = MeshingParameters(maxh=min(width, thickness) / 4, grading=0.1)
    for y in thickness - np.arange(0, fine, h_contact):
        parameters.RestrictHLine((0, y, 0), (fine, y, 0), h_contact)
    return ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(mp=parameters))


def simulation(thickness=H, width=W, radius=R, depth=DEPTH, h_contact=0.25e-6, conductance=CONDUCTANCE,
               material=None, order=1, **options):
    """The indentation as a Simulation over t ∈ [0, 1] (``sim.run(dt, 1.0)``): the film of
    ``mesh``, PZT-5A by default, the tip of ``radius`` (m) driven ``depth`` (m) down."""
    radius = number("radius", radius, 0, low_open=True, unit=" m")
    depth = number("depth", depth, 0, radius, low_open=True, unit=" m")
    body = ngc.Body(mesh(thickness, width, h_contact), material or ngc.pzt5a(), supports={"bottom": "all"},
                    grounded="bottom", contact_side="top", order=order, axisymmetric=True)
    t = ngs.Parameter(0.0)
    tip = Sphere(center=(0.0, thickness + radius - depth * t), radius=radius)
    contact = ngc.Contact(obstacle=tip, gamma0=10.0, conductance=conductance, foundation_potential=0.0)
    return ngc.Simulation(body, ngc.Loads(), contact=contact, time=t, **options)
