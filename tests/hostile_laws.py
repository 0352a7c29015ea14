"""Hostile nonlinear laws (the class "laws" of ``test_hostile``): laws of the wrong type or shape,
non-finite, not monotone or not Lipschitz within the sampled strains (refused before the work),
beyond them (the run's strains: a ``NewtonError`` naming the law), laws that read a global
variable or a Parameter changed after their check, and ``ProjectionLaw`` at extreme parameters
(refused, a NewtonError naming the law, or the right result)."""
import math

import ngsolve as ngs

import ngcontact as ngc
from ngcontact import laws

CLASSES = ("laws",)
NAN, INF = math.nan, math.inf


def register(h):
    TE, VE = h.TE, h.VE

    def material():
        return ngc.pzt5a(relaxation_time=h.scene.RELAXATION_TIME)

    def bound(make, dim=2, viscosity=False):
        """The law checked for PZT-5A (``Material.tensors``): refused or not, before any mesh."""
        def call(ctx):
            m = material()
            m = m.with_viscosity(make()) if viscosity else m.with_elasticity(make())
            tensors = m.tensors(dim)
            return repr((tensors.F_law or tensors.A_law).lipschitz)
        return call

    def refused(label, make, kind, *words, **options):
        h.case("laws", label, bound(make, **options), h.Error(kind, *words))

    def ran(make, dt=0.05, T=0.1, max_cutbacks=0, changed=None, **options):
        """The coarse reference scene to T with the law ``make()`` in F (``changed(sim)`` called
        between building the Simulation and the run; ``options`` for the Simulation)."""
        def call(ctx):
            sim = h.scene.simulation(1, 0.01, material=material().with_elasticity(make()), **options)
            if changed is not None:
                changed(sim)
            sim.run(dt, T, max_cutbacks=max_cutbacks)
            return dict(h.measure(sim, h.applied(sim.t)), target=T)
        return call

    def stiffened(v, references):
        """In equilibrium, penetration below 0.1 of the gap, the contact force 10-40 % below the
        linear plate's (the law stiffens the plate; measured 20 %)."""
        wrong = [h._reached(v), h._balance(v), h._penetration(v)]
        if not 0.6 < v["force"] / references["default"]["force"] < 0.9:
            wrong.append(f"contact force {v['force']:.5g} N/m, linear {references['default']['force']:.5g}")
        return "; ".join(w for w in wrong if w) or None

    def law(function, name=None, **options):
        return lambda: laws.StrainLaw(function, name, **options)

    # ------------------------------------------------------------------ wrong types and shapes
    refused("with_elasticity('2*eps')", lambda: "2*eps", TE, "law")
    refused("with_elasticity(5)", lambda: 5, TE, "law")
    refused("StrainLaw(CF)", lambda: laws.StrainLaw(ngs.CF(1e11)), TE, "law")
    h.case("laws", "with_viscosity('fast')", lambda ctx: repr(material().with_viscosity("fast")),
           h.Error(TE, "relaxation_time"))
    refused("law returning 1.0", lambda: lambda eps: 1.0, TE, "CoefficientFunction")
    refused("law returning None", lambda: lambda eps: None, TE, "CoefficientFunction")
    refused("law returning a complex stress", lambda: lambda eps: 1j * 1e11 * eps, TE, "real", "complex")
    refused("law returning a 3-vector", lambda: lambda eps: ngs.CF((eps[0, 0], eps[1, 1], eps[0, 1])), VE, "2x2")
    refused("law returning 3x3 in 2D", lambda: lambda eps: 1e11 * ngs.Trace(eps) * ngs.Id(3), VE, "2x2")
    refused("law returning 2x2 in 3D", lambda: lambda eps: 1e11 * eps[:2, :2], VE, "3x3|failed", dim=3)
    refused("law of no argument", lambda: lambda: 1.0, VE, "failed")
    refused("law of three arguments", lambda: lambda eps, linear, x: eps, VE, "failed")
    refused("law that raises", lambda: lambda eps: eps.no_such_attribute, VE, "failed")
    refused("Slab(2) in 2D", lambda: laws.ProjectionLaw(1e9, laws.Slab(2, -1e-3, 1e-3)), VE, "component")
    # ------------------------------------------------------------------ refused at the sampled strains
    refused("law non-symmetric", lambda: lambda eps: 1e11 * eps + 1e9 * ngs.CF(
        (eps[0, 0], eps[0, 1], 0, eps[1, 1]), dims=(2, 2)), VE, "non-symmetric")
    refused("law NaN", lambda: lambda eps: 1e11 * eps + NAN * eps, VE, "non-finite")
    refused("law inf", lambda: lambda eps: 1e11 * eps * ngs.CF(INF), VE, "non-finite")
    refused("law -1e11 eps", lambda: lambda eps: -1e11 * eps, VE, "monotone")
    refused("law 0 eps", lambda: lambda eps: 0 * eps, VE, "monotone")
    refused("law given a Lipschitz constant too small", law(lambda eps, linear: linear(eps), lipschitz=1e9),
            VE, "Lipschitz")
    refused("law given a monotonicity too large", law(lambda eps, linear: linear(eps), monotonicity=1e13),
            VE, "monotonicity")
    refused("law reversing within the samples", law(
        lambda eps, linear: linear(eps) - 2e11 * laws.Slab(1, lower=-1e-4).excess(eps, 2)), VE, "monotone")
    h.case("laws", "StrainLaw(strain_scale=0)", lambda ctx: repr(laws.StrainLaw(lambda e: e, strain_scale=0.0)),
           h.Error(VE, "strain_scale"))
    h.case("laws", "StrainLaw(strain_scale='1e-3')",
           lambda ctx: repr(laws.StrainLaw(lambda e: e, strain_scale="1e-3")), h.Error(TE, "strain_scale"))
    # ------------------------------------------------------------------ the built-in laws' parameters
    for label, value, kind in (("inf", INF, VE), ("nan", NAN, VE), ("-1", -1.0, VE), ("'1e9'", "1e9", TE)):
        refused(f"ProjectionLaw(zeta={label})", lambda v=value: laws.ProjectionLaw(v, laws.VonMisesBall(1e-5)),
                kind, "zeta")
    refused("ProjectionLaw(onto='ball')", lambda: laws.ProjectionLaw(1e9, "ball"), TE, "onto")
    refused("VonMisesBall(0)", lambda: laws.ProjectionLaw(1e9, laws.VonMisesBall(0.0)), VE, "radius")
    refused("PowerViscosity(exponent=3)", lambda: laws.PowerViscosity(1e5, 3.0), VE, "exponent", viscosity=True)
    refused("PowerViscosity(delta=0)", lambda: laws.PowerViscosity(1e5, 1.5, 0.0), VE, "delta", viscosity=True)

    # ------------------------------------------------------------------ a law changed after its check
    def global_changed_before_simulation(ctx):
        factor = [1.0]
        material_ = material().with_elasticity(laws.StrainLaw(lambda eps, linear: factor[0] * linear(eps), "scaled"))
        body = h.body(material=material_)
        factor[0] = -1.0
        t = ngs.Parameter(0.0)
        return h.built(ngc.Simulation(body, h.scene.loads(t), contact=h.scene.contact(), time=t))
    h.case("laws", "global read by the law changed before the Simulation", global_changed_before_simulation,
           h.Error(VE, "scaled", "changed"))

    def parameter_changed_before_simulation(ctx):
        factor = ngs.Parameter(1.0)
        material_ = material().with_elasticity(laws.StrainLaw(lambda eps, linear: factor * linear(eps), "scaled"))
        body = h.body(material=material_)
        factor.Set(-1.0)
        t = ngs.Parameter(0.0)
        return h.built(ngc.Simulation(body, h.scene.loads(t), contact=h.scene.contact(), time=t))
    h.case("laws", "Parameter read by the law changed before the Simulation", parameter_changed_before_simulation,
           h.Error(VE, "scaled", "changed"))

    def stateful(ctx):
        calls = [0]

        def alternating(eps, linear):
            calls[0] += 1
            return (1.0 if calls[0] < 3 else 0.5) * linear(eps)
        return h.built(h.simulation(material=material().with_elasticity(laws.StrainLaw(alternating))))
    h.case("laws", "law that changes from call to call", stateful, h.Error(VE, "alternating", "changed"))

    factor = [1.0]
    h.case("laws", "global read by the law changed after the Simulation (no effect)",
           ran(lambda: laws.StrainLaw(lambda eps, linear: factor[0] * linear(eps), "scaled"),
               changed=lambda sim: factor.__setitem__(0, -1.0)),
           h.Correct(h.matches("default", force=1e-9, tip=1e-9)))
    parameter = ngs.Parameter(1.0)
    h.case("laws", "Parameter read by the law changed after the Simulation",
           ran(lambda: laws.StrainLaw(lambda eps, linear: parameter * linear(eps), "scaled"),
               changed=lambda sim: parameter.Set(0.25)),
           h.NewtonFailure("changed"))

    def time_dependent(ctx):
        t = ngs.Parameter(0.0)
        material_ = material().with_elasticity(laws.StrainLaw(lambda eps, linear: (1 + 10 * t) * linear(eps), "aging"))
        sim = ngc.Simulation(h.body(material=material_), h.scene.loads(t), contact=h.scene.contact(), time=t)
        sim.run(0.05, 0.1, max_cutbacks=0)
        return h.measure(sim, h.applied(sim.t))
    h.case("laws", "law reading the time Parameter", time_dependent, h.NewtonFailure("changed"))

    # ------------------------------------------------------------------ beyond the sampled strains
    # strain_scale 1e-5: the check samples up to 1e-4; the coarse plate reaches |ε| ≈ 3e-4
    h.case("laws", "law reversing beyond the samples (kink)", ran(law(
        lambda eps, linear: linear(eps) - 1.5e11 * laws.Slab(1, -1e-4, 1e-4).excess(eps, 2), "reversing",
        strain_scale=1e-5)), h.NewtonFailure("monotone"))
    h.case("laws", "law reversing beyond the samples (smooth)", ran(law(
        lambda eps, linear: linear(eps) * (1 - ngs.InnerProduct(eps, eps) / 2e-4 ** 2), "softening",
        strain_scale=1e-5), maxit=15), h.NewtonFailure("monotone"))
    h.case("laws", "law stiffening beyond the samples", ran(lambda: laws.ProjectionLaw(     # allowed: any L
        1e13, laws.VonMisesBall(1e-4), strain_scale=1e-5)), h.Correct(stiffened))
    h.case("laws", "law cubic (not Lipschitz)", ran(law(
        lambda eps, linear: linear(eps) * (1 + ngs.InnerProduct(eps, eps) / 2e-5 ** 2), "cubic",
        strain_scale=1e-6)), h.NewtonFailure("Lipschitz"))
    h.case("laws", "law given a Lipschitz constant the run exceeds", ran(lambda: laws.ProjectionLaw(
        2e11, laws.VonMisesBall(1e-4), strain_scale=1e-5, lipschitz=2.5e11)), h.NewtonFailure("Lipschitz"))
    h.case("laws", "law NaN beyond the samples", ran(law(
        lambda eps, linear: linear(eps) * (1 + 1e-20 * ngs.sqrt(1e-8 - ngs.InnerProduct(eps, eps))), "nan beyond",
        strain_scale=1e-5)), h.NewtonFailure("non-finite"))
    # ------------------------------------------------------------------ ProjectionLaw extremes
    h.case("laws", "ProjectionLaw(1e30, VonMisesBall(1e-5))", ran(lambda: laws.ProjectionLaw(
        1e30, laws.VonMisesBall(1e-5)), maxit=15), h.NewtonFailure("projection law"), h.Correct(h.balanced))
    h.case("laws", "ProjectionLaw(1e-30, VonMisesBall(1e-5))", ran(lambda: laws.ProjectionLaw(
        1e-30, laws.VonMisesBall(1e-5))), h.Correct(h.matches("default", force=1e-9, tip=1e-9)))
    h.case("laws", "ProjectionLaw(5e10, VonMisesBall(1e30))", ran(lambda: laws.ProjectionLaw(
        5e10, laws.VonMisesBall(1e30))), h.Correct(h.matches("default", force=1e-9, tip=1e-9)))
    h.case("laws", "ProjectionLaw(5e10, VonMisesBall(1e-30))", ran(lambda: laws.ProjectionLaw(
        5e10, laws.VonMisesBall(1e-30))), h.Correct(h.balanced))
    h.case("laws", "ProjectionLaw with condense=True", lambda ctx: h.built(ngc.Simulation(
        h.body(material=material().with_elasticity(laws.ProjectionLaw(1e10, laws.VonMisesBall(1e-4))), order=3),
        condense=True)), h.Error(VE, "condense"))
