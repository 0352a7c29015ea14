"""Hostile laws for the contact stiffness scale (the class "lawscale" of ``test_hostile``): laws
that meet (2.16)-(2.17) with constants their samples did not see (steeper beyond the samples,
in all or part of the body, in F with and without the electric coupling) run to the closed form
of a uniaxial column or to equilibrium, their stiffness scale raised; laws whose slope has no
bound, or exceeds the constant given, are refused by what was measured."""
import math

import ngsolve as ngs
import numpy as np

import ngcontact as ngc
from ngcontact import laws
from ngcontact.geometries import plate

CLASSES = ("lawscale",)
W, H = 0.01, 0.03                              # m: the column
C33, E33, EPS33 = 111e9, 15.8, 830 * ngc.EPS0


def clip_hardening(E, zeta, r, name="clip hardening", linear=False, **options):
    """E ε + ζ (ε − clip(ε, −r, r)) entrywise (Pa; with ``linear`` the material's ℰε for E ε):
    m = E, L = E + ζ."""
    def excess(eps):
        dim = eps.dims[0]
        return ngs.CF(tuple(ngs.IfPos(e - r, e - r, ngs.IfPos(-r - e, e + r, 0))
                            for e in (eps[i, j] for i in range(dim) for j in range(dim))), dims=(dim, dim))
    if linear:
        return laws.StrainLaw(lambda eps, hooke: hooke(eps) + zeta * excess(eps), name, **options)
    return laws.StrainLaw(lambda eps: E * eps + zeta * excess(eps), name, **options)


def uniaxial():
    """PZT-like with c12 = c13 = e31 = 0 (tests/conftest.py): a column along y stays uniaxial."""
    from ngcontact.model.materials import transversely_isotropic_piezo, transversely_isotropic_stiffness
    c = transversely_isotropic_stiffness(121e9, 0.0, 0.0, C33, 21.1e9, 22.6e9)
    return ngc.Material(c, transversely_isotropic_piezo(0.0, E33, 12.3), np.diag([916.0, 916.0, 830.0]) * ngc.EPS0,
                        name="uniaxial")


def register(h):
    def column(law, P, expected, material=None, grounded="bottom|top", potential=None):
        """The column clamped at its bottom, pulled by P (Pa) on top with the law in F: u_y/y at
        three points against ``expected`` (and φ on top against ``potential``)."""
        def call(ctx):
            m = (material or ngc.Material.isotropic(1.0, 0.0, 1e-8)).with_elasticity(law())
            body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), m, clamped="bottom", grounded=grounded)
            sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, P)}))
            sim.run(0.5, 1.0)
            points = [(W / 2, H), (0.2 * W, 0.7 * H), (0.8 * W, 0.2 * H)]
            strains = {f"strain{i}": float(sim.u(body.mesh(x, y))[1] / y) for i, (x, y) in enumerate(points)}
            return dict(strains, phi=float(sim.phi(body.mesh(W / 2, H))), rescaled=len(sim.rescaled_laws))
        return call

    def closed(expected, potential=None):
        def check(v, references):
            wrong = [f"u_y/y = {s:.10g}, closed form {expected:.10g}" for s in (v[f"strain{i}"] for i in range(3))
                     if not abs(s - expected) <= 1e-9 * abs(expected)]
            if potential is not None and not abs(v["phi"] - potential) <= 1e-9 * abs(potential):
                wrong.append(f"φ on top {v['phi']:.10g} V, closed form {potential:.10g} V")
            if not v["rescaled"]:
                wrong.append("the law's stiffness scale was not raised")
            return "; ".join(wrong) or None
        return check

    E, zeta, r = 1.0, 3.0, 0.01
    for target in (0.0125, -0.0125, 0.5):
        P = E * target + zeta * math.copysign(abs(target) - r, target)
        h.case("lawscale", f"clip hardening E=1 ζ=3 r=0.01, column to ε = {target:g}",
               column(lambda: clip_hardening(E, zeta, r), P, target), h.Correct(closed(target)))
    k = E33 ** 2 / EPS33                                  # open circuit: D_y = 0 stiffens by e33²/κ33
    target = 1.25e-4
    P = C33 * target + 3 * C33 * (target - 1e-4) + k * target
    h.case("lawscale", "clip hardening F of a piezoelectric column, open circuit",
           column(lambda: clip_hardening(C33, 3 * C33, 1e-4, strain_scale=1e-6), P, target, material=uniaxial(),
                  grounded="bottom"),
           h.Correct(closed(target, potential=E33 * target * H / EPS33)))

    def plate_run(law, T=0.1):
        def call(ctx):
            sim = h.scene.simulation(1, 0.01, material=ngc.pzt5a(relaxation_time=h.scene.RELAXATION_TIME)
                                     .with_elasticity(law()))
            sim.run(0.05, T, max_cutbacks=0)
            return dict(h.measure(sim, h.applied(sim.t)), target=T, rescaled=len(sim.rescaled_laws))
        return call

    def equilibrium(v, references):
        wrong = [h._reached(v), h._balance(v), h._penetration(v)]
        if not v["rescaled"]:
            wrong.append("the law's stiffness scale was not raised")
        return "; ".join(w for w in wrong if w) or None

    h.case("lawscale", "ℰε + 5e12 (ε − clip(ε, ±1e-4)) on the plate: steeper where |ε_ij| > 1e-4 only",
           plate_run(lambda: clip_hardening(0, 5e12, 1e-4, linear=True, strain_scale=1e-6)), h.Correct(equilibrium))
    # ------------------------------------------------------------------ refused: what was measured
    h.case("lawscale", "ℰε (1 + |ε|²/(2e-5)²): slope without bound", plate_run(lambda: laws.StrainLaw(
        lambda eps, hooke: hooke(eps) * (1 + ngs.InnerProduct(eps, eps) / 2e-5 ** 2), "cubic", strain_scale=1e-6)),
        h.NewtonFailure("cubic", "without bound", "per decade"))
    h.case("lawscale", "ℰε (1 + (|ε|² + s²)^½/s), s = 2e-5: slope growing linearly",
           plate_run(lambda: laws.StrainLaw(
               lambda eps, hooke: hooke(eps) * (1 + ngs.sqrt(ngs.InnerProduct(eps, eps) + 4e-10) / 2e-5), "growing",
               strain_scale=1e-6)),
           h.NewtonFailure("growing", "without bound"))
    h.case("lawscale", "clip hardening given lipschitz=2 (its slope 4 beyond the samples)",
           column(lambda: clip_hardening(E, zeta, r, lipschitz=2.0), 0.02, 0.0125),
           h.NewtonFailure("given Lipschitz"))
    h.case("lawscale", "ℰε − 1.5e11 (ε_yy − clip(ε_yy, ±1e-4)): reversing beyond the samples",
           plate_run(lambda: laws.StrainLaw(
               lambda eps, hooke: hooke(eps) - 1.5e11 * laws.Slab(1, -1e-4, 1e-4).excess(eps, 2), "reversing",
               strain_scale=1e-5)),
           h.NewtonFailure("reversing", "monotone"))
    # ------------------------------------------------------------------ a tangent NGSolve cannot evaluate
    h.case("lawscale", "ℰε (1 + |ε|/s) written with sqrt(ε:ε): a Jacobian of NaN at ε = 0",
           column(lambda: laws.StrainLaw(
               lambda eps, hooke: hooke(eps) * (1 + ngs.sqrt(ngs.InnerProduct(eps, eps)) / 0.01), "sqrt law"),
               0.01, 0.0),
           h.NewtonFailure("not finite"))
