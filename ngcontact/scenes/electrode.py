"""Electrode contact: a PZT-5A half-disk pressed onto a grounded conducting plane (2D, plane
strain), the piezoelectric Hertz problem.

The half-disk {|x − (0, R)| <= R, y <= R} of radius R = 1 cm, poled along y (the contact
normal), its flat top ("top") grounded and pushed down by ``depth`` (default 0.16 mm, contact
half-width a ≈ 0.1 R) in one step; the curved side ("contact") meets the plane y = 0, a
conducting foundation at 0 V with the conductance ψ of ``Contact`` (k_e = ``conductance``, ramp
``ramp_width``), or insulating (``conductance=0``). Elastic, no glue. Hertz's solution holds
with the effective modulus of the piezoelectric half-plane (``piezo_hertz``): larger for an
insulating contact than for an equipotential one (PZT-5A's ratios to the uncoupled modulus:
docs/measurements.md, section ngcontact/scenes/electrode.py).
"""
import ngsolve as ngs

import ngcontact as ngc
from ngcontact.obstacles import Plane
from ngcontact.scenes import hertz

RADIUS = 0.01
"""R (m)."""
DEPTH = 1.6e-4
"""The push of the top (m): a ≈ 0.1 R."""


def simulation(conductance=0.1, ramp_width=1e-7, *, order=2, h_contact=None, depth=DEPTH, coupled=True,
               mesh=None, gamma0=10.0, **options):
    """The scene as a Simulation of one step t: 0 -> 1 (``Simulation.step(1.0)``).

    conductance : k_e (F/m²) of the foundation; 0 for an insulating contact.
    ramp_width : δ (m) of ψ's ramp.
    order : polynomial order (the mesh is curved to it).
    h_contact : mesh size (m) over |x| < R/4 (default R/100).
    depth : the push of the top (m).
    coupled : False for PZT-5A's elasticity without its piezoelectric coupling.
    ``options`` go to ``ngc.Contact`` where they name one of its fields, else to ``Simulation``.
    """
    h_contact = RADIUS / 100 if h_contact is None else h_contact
    m = hertz.mesh(2, h_contact, curve=order, radius=RADIUS) if mesh is None else mesh
    material = ngc.pzt5a()
    if not coupled:
        material = ngc.Material(material.c, 0 * material.e, material.eps, name="PZT-5A uncoupled")
    t = ngs.Parameter(0.0)
    body = ngc.Body(m, material, grounded="top", supports={"top": "all"}, contact_side="contact", order=order)
    loads = ngc.Loads(displacement={"top": (0.0, -depth * t)})
    fields = set(ngc.Contact.__dataclass_fields__)
    contact = ngc.Contact(obstacle=Plane((0.0, 0.0), (0.0, 1.0)), conductance=conductance, ramp_width=ramp_width,
                          foundation_potential=0.0, gamma0=gamma0,
                          **{k: v for k, v in options.items() if k in fields})
    return ngc.Simulation(body, loads, contact=contact, time=t,
                          **{k: v for k, v in options.items() if k not in fields})
