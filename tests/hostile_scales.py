"""Hostile inputs of scales that make no sense (added to ``test_hostile``'s classes): a permittivity
below the vacuum's, a coupling that swamps the mechanics, θ outside Nitsche's method, a β0 that
depends on time, and a valid scene on which Newton cycles (the error names the laws that flip)."""
import ngsolve as ngs
import numpy as np

import ngcontact as ngc
from ngcontact.model.materials import EPS0, isotropic_stiffness, transversely_isotropic_piezo

CLASSES = ()


def register(h):
    def material(**data):
        return lambda ctx: repr(ngc.Material.isotropic(**{**dict(E=60e9, nu=0.3, permittivity=1e-8), **data}))

    for value in (1e-30, 1e-20, 1e-13, 0.99 * EPS0):
        h.nonsense(f"Material.isotropic(permittivity={value:g}, e33=10)", material(permittivity=value, e33=10.0),
                   "permittivity")
    h.nonsense("Material(eps with one direction below ε0)", lambda ctx: repr(ngc.Material(
        isotropic_stiffness(60e9, 0.3), np.zeros((3, 6)), np.diag([1e-8, 1e-8, 1e-12])), "permittivity|eps"))
    for e33, eps in ((1e4, 1e-11), (1e6, 1e-8), (1e9, 1e-8)):
        h.nonsense(f"Material.isotropic(e33={e33:g}, permittivity={eps:g})", material(e33=e33, permittivity=eps),
                   "coupling", "eps")
    h.nonsense("Material(e 1e6 C/m² on PZT-5A's c, eps)", lambda ctx: repr(ngc.Material(
        ngc.pzt5a().c, transversely_isotropic_piezo(-5e5, 1e6, 1e6), ngc.pzt5a().eps)), "coupling")
    for method in ("penalty", "active_set"):
        for theta in (0, -1):
            h.nonsense(f"Contact(method={method}, theta={theta})",
                       lambda ctx, m=method, th=theta: repr(ngc.Contact(method=m, theta=th)), "theta", method)
    h.nonsense("Contact(beta0=1 - t)", lambda ctx: repr(ngc.Contact(beta0=1 - ngs.Parameter(0.0))), "beta0")
    h.nonsense("Contact(beta0=1 - t) in the scene", lambda ctx: h.built(h.simulation(
        contact=ngc.Contact(**{**h.scene.CONTACT, "beta0": 1 - 2 * ngs.Parameter(0.0)}))),
                "beta0")

    def grounded_at_the_clamp(ctx):
        t = ngs.Parameter(0.0)
        sim = ngc.Simulation(h.body(grounded="left"), h.scene.loads(t), contact=h.scene.contact(), time=t)
        sim.step(0.00625)
        sim.step(0.00625)
        return h.measure(sim, h.applied(sim.t))
    h.case("held", "plate grounded at its clamped end", grounded_at_the_clamp,
           h.Correct(lambda v, references: h._balance(v)))
