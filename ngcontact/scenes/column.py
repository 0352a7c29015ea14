"""A square column of a soft piezoelectric polymer-like material on the foundation: clamped
and grounded on top, its bottom Γ3 glued to (or pressed onto) the foundation by a body force.

Used where the reference plate does not show a failure mode: complete debonding (the whole
of Γ3 pulled off at once) and the conductive foundation meeting a flat face.
"""
import ngsolve as ngs

import ngcontact as ngc
from ngcontact.geometries import plate

WIDTH, HEIGHT, MAXH = 0.02, 0.02, 0.005
"""Column width and height, mesh size, m."""
RELAXATION_TIME = 2e-3
"""Kelvin-Voigt relaxation time of the viscous variant, s."""


def material(viscous=True):
    """E = 1 GPa, ν = 0.3, e33 = 0.05, e31 = −0.02 C/m², ε = 10 ε0 (not a data-sheet
    material); ``viscous``: A = τ F with τ = RELAXATION_TIME."""
    m = ngc.Material.isotropic(1e9, 0.3, permittivity=10 * ngc.EPS0, e31=-0.02, e33=0.05,
                               name="soft piezo polymer")
    return m.with_viscosity(RELAXATION_TIME) if viscous else m


def body(viscous=True):
    """The column [0, WIDTH] × [0, HEIGHT]: Γ1 = Γa = top, Γ3 = bottom (P1)."""
    return ngc.Body(plate(WIDTH, HEIGHT, maxh=MAXH), material(viscous), clamped="top", grounded="top",
                    contact_side="bottom")


def simulation(body_force, contact, *, viscous=True, **options):
    """The column under the upward body force ``body_force(t)`` (N/m³; a function of the
    time Parameter returning a CoefficientFunction) with the Contact ``contact``;
    ``options`` go to Simulation."""
    t = ngs.Parameter(0.0)
    return ngc.Simulation(body(viscous), ngc.Loads(f0=(0, body_force(t))), contact=contact, time=t, **options)
