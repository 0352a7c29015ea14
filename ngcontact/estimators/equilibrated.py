"""The error of a step by equilibrated stress and flux reconstructions (Prager–Synge).

A converged step of a ``Simulation`` gives u_h, φ_h with the step's stress and electric
displacement (``forms``; the step's elasticity C_c = F + c A, c the scheme's rate coefficient):

  σ_h = C_c ε(u_h) − c A ε(û) + Eᵀ∇φ_h,    D_h = E ε(u_h) − C ∇φ_h.

The exact solution (u, φ) of the same step (same t_n, c, û, β_n) satisfies −div σ = f0,
−div D = q0, the tractions and charges of Γ2, Γb, and the Γ3 laws. ``equilibration`` builds σ*
(rows in RT_p) and D* (RT_p) with div σ* = −Π_p f0, div D* = −Π_p q0, the data of Γ2 and Γb on
their normals, and on Γ3 (and every boundary with residual terms) the traction and charge flux
that represent the discrete solution's own Γ3 functional: t_h ∈ P1(Γ3)^d with
∫ t_h·ψ_a e_i = −R_Γ3(u_h, φ_h; ψ_a e_i) for every hat function ψ_a (``representative``; the
same for the charge flux of (2.7)). With the piezoelectric coupling written as in the step
(σ = … + Eᵀ∇φ, D = E ε − C∇φ) the cross terms cancel, and for e = (u − u_h, φ − φ_h)

  |||e|||² = (C_c ε(e_u), ε(e_u)) + (C ∇e_φ, ∇e_φ)
           = (σ* − σ_h, ε(e_u)) − (D* − D_h, ∇e_φ) + (skew σ*, ∇e_u)
             + ∫_Γ3 (t − t_h)·e_u − ∫_Γ3 (j − j_h) e_φ + (f0 − Π f0, e_u) − (q0 − Π q0, e_φ),

so that, with X = ‖C_c^{½} ε(e_u)‖ and Y = ‖C^{½} ∇e_φ‖ (|||e|||² = X² + Y²), Cauchy–Schwarz
gives |||e|||² ≤ (η_σ + C_K η_skew + η_osc,u) X + (η_D + η_osc,φ) Y + η_Γ3 |||e||| and

  |||e||| ≤ η = ((η_σ + C_K η_skew + η_osc,u)² + (η_D + η_osc,φ)²)^½ + η_Γ3,  with

* η_σ = ‖C_c^{−½}(sym σ* − σ_h)‖, η_D = ‖C^{−½}(D* − D_h)‖ (the energy of the reconstruction),
* η_skew = μ^{−½} ‖skew σ*‖, μ = min ε:C_c:ε / |ε|² over strain matrices (Frobenius norm;
  ``_skew_weight``), with ‖skew ∇e_u‖ ≤ C_K ‖ε(e_u)‖ on the whole body (Korn's inequality: the
  skew term is bounded globally, not element by element, where a rotation has no strain). σ* is
  equilibrated row by row in RT_p, each row the
  L²-nearest to ψ_a σ_h's row on every patch (``equilibration.Rows``: the rows, and D* as one more
  row, share one patch system), so it is not symmetric (with ``weak_symmetry``, symmetric in the
  least-squares sense of coupled local problems, and D* nearest in C⁻¹'s norm); C_K is
  taken as 1 (its value for a body clamped on its whole boundary),
* η_osc,u = (Σ_K η_osc,K²)^½, η_osc,K = (h_K/π) λ_min(C_c)^{−½} ‖f0 − Π_p f0‖_K, and η_osc,φ its
  electric twin (Poincaré on a convex element; the data that no flux of degree p can balance),
* η_Γ3 = (∫_Γ3 λ_h |u_hν − g|)^½ (the complementarity of the discrete contact pressure λ_h =
  −[P_h]_- and the gap: the Signorini part of ∫(t − t_h)·e_u, with the exact pressure replaced
  by λ_h); the glue and the compliant layer are monotone and only lower the error, the
  conduction's ψ(u_ν − g) cross term is of higher order and left out.

So η is an upper bound of the energy error when Korn's constant is 1 and the contact term is
exact; ``report`` gives every part.

Bodies of revolution (``model.axisymmetric``; norms weighted by w = 2π r, the whole body's).
With σ̃ = (σ_rr σ_rz; σ_zr σ_zz) and the meridian divergence, equilibrium reads
div(w σ̃_r) = 2π σ_θθ − w f_r, div(w σ̃_z) = −w f_z, div(w D) = −w q0. The rows τ = w σ̃ and
τ_D = w D are equilibrated in RT_p with the sources (w f_r − 2π σ_h,θθ, w f_z), w q0, the data
w t, w q (and the weighted Γ3 representative), the flux w σ_h; then σ̃* = τ/w, D* = τ_D/w and
the hoop stress σ*_θθ = div τ_r/(2π) + r f_r, which balances the r row exactly (it is Π_p σ_h,θθ).
The identity above holds with every integral weighted by w: η_σ, η_D, η_skew of σ̃*, σ*_θθ, D*;
the z row's and the charge's data oscillation g = w f_z − Π_p(w f_z) (g ⊥ 1 on K) by the
weighted Poincaré inequality (weight r, log-concave on a convex K: constant h_K/π),
η_osc,K = (h_K/π) λ_min^{−½} ‖g/w‖_K. At the axis τ need not vanish, so τ/w is not square
integrable on the elements with an edge on it: there the element quadrature (points off the
axis) gives a finite value that is not a proven bound; the bound is checked there numerically
(docs/adaptivity.md). Element indicators η_K² = η_σ,K² + η_D,K² + η_skew,K² +
(η_osc,u,K + η_osc,φ,K)² mark elements for refinement (``adapt``). Measured effectivities (η / the true error on
manufactured solutions): docs/adaptivity.md.
"""
from dataclasses import dataclass, field
import functools
import math

import ngsolve as ngs
import numpy as np

from ngcontact.gamma3 import integrands
from ngcontact.model import forms, kinematics
from ngcontact.model.kinematics import mesh_ds
from ngcontact import checks, meshes, parallel
from ngcontact.model.loads import as_cf
from ngcontact.model.voigt import matrix_cf
from ngcontact.solve.linalg.linear_solver import reproducible
from ngcontact.time.step import Step
from .equilibration import BONUS, TIMERS, Equilibration, Patches, Rows, all_cores

TIMERS.update({name: ngs.Timer(f"ngcontact estimate: {name}") for name in ("Γ3 data", "indicator integrals")})


RAISE = 0
"""σ* and D* are sought in RT_{p+RAISE}. One order more (RT_{p+1}) made the data oscillation of
one order higher and the estimate sharper, but its local problems are twice as large
and far costlier to factorise (docs/measurements.md, section ngcontact/estimators/equilibrated.py).
Scenes without a body force have no oscillation at all."""
SKEW_WEIGHT = 10.0
"""With ``weak_symmetry``: the weight of σ*'s skew part in its local problems, in units of
λ_min(C_c)^{−1}. Fitted to measurements on a manufactured elastic square
(docs/measurements.md, section ngcontact/estimators/equilibrated.py): a smaller weight leaves a
larger skew part and a looser estimate, a larger one the same skew part and a larger symmetric one."""
AXIS_FLOOR = 1e-12
"""On a body of revolution, 1/r is evaluated with r at least this times the body's size (padded
quadrature points of weight 0 may sit on the axis)."""
SECTION_BONUS = 2
"""Extra quadrature order of the element integrals on a body of revolution (integrands in 1/r)."""


@dataclass
class Estimate:
    """An error estimate of one step in the energy norm |||·||| (J^½ in 3D and on a body of
    revolution, (J/m)^½ in 2D).

    total : η, the bound (module docstring).
    parts : {"stress": η_σ, "flux": η_D, "skew": η_skew, "oscillation": (Σ_K (η_osc,u,K + η_osc,φ,K)²)^½,
             "contact": η_Γ3}.
    indicators : η_K per volume element (numpy), for marking.
    """
    total: float
    parts: dict
    indicators: np.ndarray
    fields: dict = field(default_factory=dict, repr=False)


def _matrix(M):
    return matrix_cf(np.asarray(M, dtype=float))


def check(sim):
    """The ``time.step.Step`` of ``sim`` (an ngcontact.Simulation's ``steps``, or a Step) after
    refusing what the estimator cannot estimate (``adapt`` asks before each level's solve):
    anything else (TypeError), a distributed mesh, a nonlinear law, weak 'normal' supports."""
    steps = getattr(sim, "steps", sim)
    if not isinstance(steps, Step):
        raise TypeError(f"the equilibrated estimator estimates an ngcontact.Simulation (sim) or its steps, got "
                        f"{type(sim).__name__}")
    body = steps.body
    parallel.serial_only(body.mesh, "the equilibrated error estimator", "its vertex patches cross the ranks' "
                         "parts and are solved as one scipy system of one process")
    if not body.tensors.linear:
        raise ValueError("the equilibrated estimator needs linear tensors: with a nonlinear law "
                         f"({(body.tensors.F_law or body.tensors.A_law).name}) its energy norm is not defined")
    for support in body.supports:
        if support.normal:
            raise ValueError(f"the equilibrated estimator does not take weak 'normal' supports yet "
                             f"(support {support.key!r}: its normal is not an axis)")
    return steps


class EquilibratedEstimator:
    """The estimator of the module docstring for the simulations on one mesh (its patch
    problems are set up once, ``__call__`` estimates the current step of a simulation).

    Parameters
    ----------
    sim : a Simulation (2D, 3D or a body of revolution, any order), or its ``steps``
        (``time.step.Step``): its body, loads, contact and state are read.
    weak_symmetry : False (default): the stress rows are equilibrated one by one, each the
        L²-nearest to ψ_a σ_h's row, and share one patch system (``equilibration.Rows``).
        D* is the L²-nearest too, one more row of the same system when φ has u's order.
        True: one local problem for all rows, weighted by the compliance with a penalty
        (``SKEW_WEIGHT``) on the skew part, and D* weighted by the inverse permittivity: a
        sharper bound from patch systems dim times as large (effectivities and cost of both:
        docs/adaptivity.md, docs/speed.md).
    """

    def __init__(self, sim, weak_symmetry=False):
        steps = check(sim)
        self.weak_symmetry = checks.flag("weak_symmetry", weak_symmetry)
        body = steps.body
        self.steps, self.body, self.dim = steps, body, body.dim
        T, dim = body.tensors, body.dim
        with TIMERS["element data"]:
            self.patches = Patches(body.mesh)
        held = {i: set(body.boundaries["clamped"]) for i in range(dim)}
        for support in body.supports:
            for axis in support.axes:
                held[axis] |= set(support.names)
        grounded = set(body.boundaries["grounded"])
        stress_neumann = lambda name, i: name not in held[i]     # noqa: E731
        self._stress_neumann, self._rate = stress_neumann, None
        self._stress = self._flux = self._fluxes = self._flux_alone = None
        if self.weak_symmetry:                  # the coupled stress problem is set up at the first call
            self._flux = Equilibration(body.mesh, 1, body.order_phi + RAISE, self._electric_weight(T),
                                       lambda name, i: name not in grounded, self.patches) if steps.electric else None
        else:                                   # every row in one patch system (D as the last row)
            shared = bool(steps.electric) and body.order_phi == body.order
            self._fluxes = Rows(body.mesh, dim + shared, body.order + RAISE,
                                lambda name, i: stress_neumann(name, i) if i < dim else name not in grounded,
                                self.patches)
            if steps.electric and not shared:
                self._flux_alone = Rows(body.mesh, 1, body.order_phi + RAISE, lambda name, i: name not in grounded,
                                        self.patches)
        self._diameters, self._gamma3 = None, None
        self._projections = {}                     # the fluxes' element-wise projections (``_piecewise``)

    def _equilibrated(self, sigma, f, t, D, q, j):
        """σ* (dim row GridFunctions of RT_p) and D* (a GridFunction; None for D None) for the
        stress σ_h (dim × dim CF) with its source f (dim components, None for none) and Neumann
        data t, and the displacement D_h (1 × dim CF) with q and j."""
        dim = self.dim
        constants = self._constants("stress")
        if self.weak_symmetry:
            rows = self._stress.gridfunctions(self._stress(sigma, f, t))
            return rows, None if D is None else self._flux.gridfunctions(self._flux(D, q, j))[0]
        fluxes, sources, tractions = [sigma[i, :] for i in range(dim)], [None if f is None else f[i] for i in
                                                                         range(dim)], [t[i] for i in range(dim)]
        if D is not None and self._flux_alone is None:
            fluxes, sources, tractions = fluxes + [D[0, :]], sources + [q], tractions + [j]
            flux = self._constants("flux")
            constants = None if constants is None or flux is None else constants + flux
        rows = self._fluxes.gridfunctions(self._fluxes(fluxes, sources, tractions, constants))
        if D is None:
            return rows, None
        if self._flux_alone is None:
            return rows[:dim], rows[dim]
        return rows, self._flux_alone.gridfunctions(self._flux_alone([D[0, :]], [q], [j]))[0]

    # ------------------------------------------------------------------ weights of the local problems
    def _compliance(self, rate):
        T = self.body.tensors
        C = T.F + (rate * T.A if T.viscous else 0.0)
        S = np.linalg.inv(C)
        return C, S, float(np.linalg.eigvalsh(S).max())

    def _skew_weight(self, S):
        """1/μ, μ = min ε:C_c:ε / |ε|² over strain matrices (Frobenius norm): the weight of
        ‖skew σ*‖² in η_skew. In the engineering Voigt vector |ε|² = Σ m_k ε_k², m_k = 1 on the
        diagonal entries and ½ on the shears, so 1/μ = λ_max(M^½ S M^½) ≤ λ_max(S)."""
        r = np.sqrt([1.0 if i == j else 0.5 for i, j in self.body.kinematics.pairs])
        return float(np.linalg.eigvalsh(r[:, None] * S * r[None, :]).max())

    def _stress_weight(self, S, skew):
        """The weight of the coupled stress problems (``weak_symmetry``) as a matrix on row-major
        dim × dim matrices (``Equilibration``):
        Voigt(τ)ᵀ S Voigt(σ) + skew Σ_{i<j} ½ (σ_ij − σ_ji)(τ_ij − τ_ji)."""
        dim = self.dim
        voigt = np.zeros((len(S), dim * dim))
        pairs = kinematics.of(dim).pairs[dim:]                     # the shear entries of the Voigt order
        for a in range(dim):
            voigt[a, a * dim + a] = 1.0
        for a, (i, j) in enumerate(pairs):
            voigt[dim + a, i * dim + j] = voigt[dim + a, j * dim + i] = 0.5
        weight = voigt.T @ S @ voigt
        for i, j in pairs:
            e = np.zeros(dim * dim)
            e[i * dim + j], e[j * dim + i] = 1.0, -1.0
            weight += 0.5 * skew * np.outer(e, e)
        return weight

    @staticmethod
    def _electric_weight(T):
        return np.linalg.inv(T.C)

    # ------------------------------------------------------------------ one step
    def __call__(self):
        """The ``Estimate`` of the simulation's current step."""
        steps, body, dim = self.steps, self.body, self.dim
        T = body.tensors
        coefficients = steps.system.coefficients
        rate = coefficients.rate.Get() if T.viscous else 0.0
        C, S, s_max = self._compliance(rate)
        if self.weak_symmetry:                  # the weight follows the rate c of the step
            weight = self._stress_weight(S, SKEW_WEIGHT * s_max)
            if self._stress is None:
                self._stress = Equilibration(body.mesh, dim, body.order + RAISE, weight, self._stress_neumann,
                                             self.patches)
            elif rate != self._rate:
                self._stress.set_weight(weight)
            self._rate = rate
        if body.axisymmetric:
            return self._section(T, rate, S, s_max)
        u, phi = steps.u, steps.phi
        strain_rate = rate * (forms.strain(u, T) - forms.strain(coefficients.anchor, T)) if T.viscous else None
        sigma_h = body.kinematics.plane_stress_matrix(forms.stress(T, u, phi, strain_rate))
        loads, n = steps.loads, ngs.specialcf.normal(dim)
        f0 = as_cf(loads.f0, dim) if loads.f0 is not None else ngs.CF((0.0,) * dim)
        t_mech, t_elec = self._boundary_data()
        q0 = as_cf(loads.q0, 1) if loads.q0 is not None else ngs.CF(0.0)
        D_h = forms.electric_displacement(T, u, phi) if steps.electric else None
        rows, D_star = self._equilibrated(
            self._piecewise("stress", sigma_h), f0 if loads.f0 is not None else None, t_mech,
            None if D_h is None else self._piecewise("flux", ngs.CF(D_h, dims=(1, dim))),
            q0 if loads.q0 is not None else None, t_elec)
        sigma_star = ngs.CF(tuple(rows), dims=(dim, dim))
        mesh, order = body.mesh, 2 * (max(body.order, body.order_phi) + RAISE) + 2     # (exact on straight elements)
        kin = body.kinematics
        diff = kin.symmetric_vector(sigma_star) - kin.symmetric_vector(sigma_h)
        parts_K = {"stress": ngs.InnerProduct(_matrix(S) * diff, diff),
                   "skew": self._skew_weight(S) * kin.skew_square(sigma_star)}
        fields = dict(sigma_star=sigma_star, sigma_h=sigma_h, sigma_star_rows=rows)
        if D_h is not None:
            dD = D_star - D_h
            parts_K["flux"] = ngs.InnerProduct(_matrix(np.linalg.inv(T.C)) * dD, dD)
            fields.update(D_star=D_star, D_h=D_h)
        indicators = dict(zip(parts_K, _element_integrals(list(parts_K.values()), mesh, order)))
        oscillation = self._oscillation(f0 if loads.f0 is not None else None,
                                        q0 if loads.q0 is not None else None, s_max, T)
        return _estimate(indicators, oscillation, self._contact_term(), fields)

    def _section(self, T, rate, S, s_max):
        """The ``Estimate`` of a body of revolution (module docstring, section "Bodies of
        revolution"): the weighted fluxes τ = w σ̃ (rows) and w D, w = 2π r, equilibrated with
        the sources (w f_r − 2π σ_h,θθ, w f_z) and w q0 and the data w t, w q; σ̃* = τ/w, D* =
        τ_D/w, the hoop stress σ*_θθ = div τ_r/(2π) + r f_r; every norm weighted by w."""
        steps, body, mesh = self.steps, self.body, self.body.mesh
        coefficients, loads = steps.system.coefficients, steps.loads
        u, phi = steps.u, steps.phi
        kin = body.kinematics
        w = kin.weight
        inverse_w = 1.0 / (2 * np.pi * ngs.IfPos(ngs.x - AXIS_FLOOR * body.size, ngs.x, AXIS_FLOOR * body.size))
        strain_rate = rate * (forms.strain(u, T) - forms.strain(coefficients.anchor, T)) if T.viscous else None
        sigma_h = forms.stress(T, u, phi, strain_rate)                    # (rr, zz, rz, θθ)
        f0 = as_cf(loads.f0, 2) if loads.f0 is not None else ngs.CF((0.0, 0.0))
        t_mech, t_elec = self._boundary_data()
        source = ngs.CF((w * f0[0] - 2 * np.pi * sigma_h[3], w * f0[1]))
        q0 = as_cf(loads.q0, 1) if loads.q0 is not None else ngs.CF(0.0)
        D_h = forms.electric_displacement(T, u, phi) if steps.electric else None
        rows, tau_D = self._equilibrated(w * kin.plane_stress_matrix(sigma_h), source, w * t_mech,
                                         None if D_h is None else ngs.CF(w * D_h, dims=(1, 2)), w * q0, w * t_elec)
        tau = ngs.CF(tuple(rows), dims=(2, 2))
        hoop = ngs.div(rows[0]) / (2 * np.pi) + ngs.x * f0[0]           # the r row in balance exactly
        sigma_star = inverse_w * tau
        diff = ngs.CF((sigma_star[0, 0], sigma_star[1, 1], 0.5 * (sigma_star[0, 1] + sigma_star[1, 0]), hoop)) \
            - sigma_h
        parts_K = {"stress": w * ngs.InnerProduct(_matrix(S) * diff, diff),
                   "skew": w * self._skew_weight(S) * kinematics.of(2).skew_square(sigma_star)}
        fields = dict(sigma_star=ngs.CF((sigma_star[0, 0], sigma_star[0, 1], sigma_star[1, 0], sigma_star[1, 1]),
                                        dims=(2, 2)), sigma_h=kin.plane_stress_matrix(sigma_h), hoop_star=hoop,
                      hoop_h=sigma_h[3])
        if D_h is not None:
            dD = inverse_w * tau_D - D_h
            parts_K["flux"] = w * ngs.InnerProduct(_matrix(np.linalg.inv(T.C)) * dD, dD)
            fields.update(D_star=inverse_w * tau_D, D_h=D_h)
        order = 2 * (max(body.order, body.order_phi) + RAISE) + 2 + SECTION_BONUS
        indicators = dict(zip(parts_K, _element_integrals(list(parts_K.values()), mesh, order)))
        oscillation = self._oscillation(
            w * f0[1] if loads.f0 is not None else None, w * q0 if loads.q0 is not None else None,
            s_max, T, inverse_w)
        return _estimate(indicators, oscillation, self._contact_term(), fields)

    def _piecewise(self, key, flux):
        """The matrix CoefficientFunction ``flux`` (σ_h or D_h) projected element by element onto
        P_{p−1}, p the larger order of u and φ (an L2 GridFunction kept per ``key``, set anew at
        each call): the patch problems' data read it instead of evaluating the flux's tree at the
        quadrature points of each of their forms. On straight elements with constant tensors it is
        the flux itself, and the patch problems stay compatible with any element-wise projection
        (∇ψ_a is constant there), so σ* stays equilibrated; the bound measures σ* − σ_h with σ_h
        itself. On a curved mesh the flux is used as it is."""
        if self.body.mesh.GetCurveOrder() > 1:             # (curved elements: ∇ψ_a is not a polynomial)
            return flux
        if key not in self._projections:
            order = max(self.body.order, self.body.order_phi) - 1
            shape = flux.dims
            space = ngs.L2(self.body.mesh, order=order) ** (shape[0] * shape[1])
            self._projections[key] = (ngs.GridFunction(space), shape)
        gf, shape = self._projections[key]
        components = ngs.CF(tuple(flux[i, j] for i in range(shape[0]) for j in range(shape[1]))).Compile()
        centroids = self._centroids if gf.space.globalorder == 0 else None
        if centroids is not None:                         # constant on each simplex: its value at the centroid
            gf.vec.FV().NumPy()[:] = components(centroids).T.ravel()
        else:
            gf.Set(components)
        return ngs.CF(gf, dims=tuple(shape))

    @functools.cached_property
    def _centroids(self):
        """The centroid of every element as mapped points, on a mesh of simplices (one element
        type throughout: ``Patches``); else None."""
        mesh = self.body.mesh
        first = next(iter(mesh.Elements(ngs.VOL)), None)
        if first is None or first.type not in (ngs.ET.TRIG, ngs.ET.TET):
            return None
        corners = len(first.vertices)
        return mesh.MapToAllElements(ngs.IntegrationRule([(1.0 / corners,) * (corners - 1)], [1.0]), ngs.VOL)

    def _constants(self, key):
        """The rows of the flux ``_piecewise`` projected for ``key``, each as its value on every
        element (elements × dim), when the projection is onto constants (P1) on straight
        elements; else None."""
        if key not in self._projections or self._projections[key][0].space.globalorder != 0:
            return None
        gf, (rows, d) = self._projections[key]
        values = gf.vec.FV().NumPy().reshape(rows * d, -1)                # (components, elements)
        return [values[i * d:(i + 1) * d].T for i in range(rows)]

    def _boundary_data(self):
        """The Neumann data of σ* and D* on the boundary (CFs of dim and 1 components): the
        tractions f2 and charges qb where given (0 elsewhere on Γ2, Γb), and on Γ3 the
        representatives of the discrete Γ3 functional."""
        with TIMERS["Γ3 data"]:
            return self._boundary_cfs()

    def _boundary_cfs(self):
        steps, body, dim = self.steps, self.body, self.dim
        mesh = body.mesh
        loads = steps.loads
        t = {name: ngs.CF((0.0,) * dim) for name in mesh.GetBoundaries()}
        q = {name: ngs.CF(0.0) for name in mesh.GetBoundaries()}
        for key, value in loads.f2.items():
            for name in key.split("|"):
                t[name] = as_cf(value, dim)
        for key, value in loads.qb.items():
            for name in key.split("|"):
                q[name] = as_cf(value, 1)
        self._corrections = None
        if steps.contact is not None:
            if self._gamma3 is None:
                self._gamma3 = Representative(steps)
            t_rep, q_rep, self._corrections = self._gamma3()
            for name in body.boundaries["contact_side"]:
                t[name], q[name] = t_rep, q_rep
        return mesh.BoundaryCF(t, default=ngs.CF((0.0,) * dim)), mesh.BoundaryCF(q, default=ngs.CF(0.0))

    def _oscillation(self, f0, q0, s_max, T, inverse_w=None):
        """The mechanical and electric oscillation per element, (h_K/π) λ_min(C_c)^{−½}‖f0 − Π_p f0‖_K
        and (h_K/π) λ_min(C)^{−½}‖q0 − Π_p q0‖_K, h_K its diameter (Poincaré on a convex element);
        0 without a body force or charge density (None). For a body of revolution (``inverse_w`` = 1/w, w = 2π r) f0 and q0
        are the weighted sources g of the z row and of the charge, and the norms those of
        (g − Π_p g)/w weighted by w (the weighted Poincaré inequality, module docstring)."""
        body, mesh = self.body, self.body.mesh
        out = (np.zeros(mesh.ne), np.zeros(mesh.ne))
        if f0 is None and q0 is None:
            return out
        if self._diameters is None:
            self._diameters = element_diameters(mesh)
        h = self._diameters
        for k, (data, order, weight) in enumerate(((f0, body.order + RAISE, s_max), (q0, body.order_phi + RAISE,
                                                                float(np.linalg.eigvalsh(np.linalg.inv(T.C)).max())))):
            if data is None:
                continue
            space = ngs.L2(mesh, order=order) ** data.dim if data.dim > 1 else ngs.L2(mesh, order=order)
            projected = ngs.GridFunction(space)
            if inverse_w is None:
                projected.Set(data)
                rest = data - projected
                square = ngs.InnerProduct(rest, rest)
            else:
                projected.Set(data, bonus_intorder=BONUS)
                rest = data - projected
                square = (rest * rest * inverse_w).Compile()
            norm = np.sqrt(np.maximum(ngs.Integrate(square, mesh, ngs.VOL, order=2 * order + 6,
                                                    element_wise=True).NumPy(), 0.0))
            out[k][:] = h / np.pi * np.sqrt(weight) * norm
        return out

    def _contact_term(self):
        """η_Γ3 = (∫_Γ3 λ_h |u_hν − g|)^½ (J^½; (J/m)^½ in 2D)."""
        steps = self.steps
        if steps.contact is None:
            return 0.0
        g = steps.gamma3
        lam = g.enforcement.multiplier(steps.u, steps.phi, integrands.adhesion_traction(steps.contact, g.beta.gf, steps.u * g.normal))
        opening = steps.u * g.normal - g.gap
        value = g.side.integrate(lam * ngs.IfPos(opening, opening, -opening))
        return float(np.sqrt(max(value, 0.0)))


def _estimate(indicators, oscillation, contact, fields):
    """The ``Estimate`` from the element parts (squares), the mechanical and electric
    oscillation per element and the Γ3 term (module docstring)."""
    mechanical, electric = oscillation
    indicators["oscillation"] = (mechanical + electric) ** 2
    total_sq = sum(indicators.values())
    parts = {name: float(np.sqrt(v.sum())) for name, v in indicators.items()}
    parts.setdefault("flux", 0.0)                        # no electric unknown
    parts["contact"] = contact
    total = math.hypot(parts["stress"] + parts["skew"] + np.linalg.norm(mechanical),
                       parts["flux"] + np.linalg.norm(electric)) + contact
    return Estimate(total=float(total), parts=parts, indicators=np.sqrt(total_sq), fields=fields)


def _element_integrals(cfs, mesh, order):
    """[∫_K cf for every volume element K] for each scalar CF of ``cfs`` by a quadrature of order
    ``order``, each clipped at 0 (they are squares).
    Every CF is compiled first: its tree (the compliance times the Voigt differences) evaluated
    uncompiled costs far more in 3D (docs/measurements.md, section ngcontact/estimators/equilibrated.py).
    They run on every core (``equilibration.all_cores``): nothing else runs then."""
    with TIMERS["indicator integrals"], all_cores():
        return [np.maximum(ngs.Integrate(cf.Compile(), mesh, ngs.VOL, order=order, element_wise=True).NumPy(), 0.0)
                for cf in cfs]


def element_diameters(mesh):
    """The diameter of every volume element (its longest edge; m)."""
    points = meshes.vertex_points(mesh)[[[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)]]
    edges = points[:, :, None, :] - points[:, None, :, :]                   # (elements, vertices, vertices, dim)
    return np.sqrt((edges ** 2).sum(axis=3)).max(axis=(1, 2))


def pointwise_data(steps):
    """(T_h, j_h): the traction on the body and the charge flux out of it that the Γ3 terms of
    the step residual give at each point of Γ3 at the current state — the coefficients of v and
    ξ in the integrand of R_Γ3 (``integrands.contact_terms``) with ∇v = ∇ξ = 0: −λ_h ν and the
    glue's and the layer's pull and push, and the conduction flux ψ φ_L (CFs of dim and 1
    components). Nitsche's θ-term tests ∇v and is not among them."""
    body, dim = steps.body, steps.body.dim
    g = steps.gamma3
    V1 = ngs.VectorH1(body.mesh, order=1)
    W1 = ngs.H1(body.mesh, order=1)
    zero_v, zero_s = ngs.GridFunction(V1), ngs.GridFunction(W1)
    state = (steps.u, steps.phi)
    traction = []
    for i in range(dim):                   # (P1 holds constants in its vertex values: no Set's projection)
        e_i = ngs.GridFunction(V1)
        e_i.components[i].vec[:] = 1.0
        traction.append(-integrands.contact_terms(steps.contact, g.enforcement, g.beta.gf, g.gap, g.foundation_potential,
                                             state, (e_i, zero_s), g.normal))
    one = ngs.GridFunction(W1)
    one.vec[:] = 1.0
    flux = -integrands.contact_terms(steps.contact, g.enforcement, g.beta.gf, g.gap, g.foundation_potential, state,
                                (zero_v, one), g.normal)
    return ngs.CF(tuple(traction)), flux


class Representative:
    """The Neumann data of σ* and D* on Γ3 that make every patch problem compatible, whatever
    the enforcement method: t_h = T_h + c_h with T_h the pointwise traction (``pointwise_data``)
    and c_h ∈ P1(Γ3)^d such that ∫_Γ3 t_h·ψ_a e_i = −R_Γ3[ψ_a e_i] for the hat functions ψ_a of
    the vertices of Γ3, R_Γ3 the Γ3 part of the step residual at the current state
    (``StepSystem.boundary_residual``, with an enforcement method's own forces); the same for the
    charge flux. c_h is what of the discrete Γ3 functional no pointwise traction gives (Nitsche's
    θ-term, quadrature). The P1 space of Γ3, its mass matrix and the DOF maps are set up once."""

    def __init__(self, steps):
        body = steps.body
        mesh, dim = body.mesh, body.dim
        self.steps, self.dim = steps, dim
        self.region = body.region("contact_side")
        self.P1 = ngs.H1(mesh, order=1, definedon=self.region)
        self.w = self.P1.TestFunction()
        mass = ngs.BilinearForm(self.P1)
        mass += mesh_ds(self.P1.TrialFunction() * self.w, self.region)
        with reproducible():                      # (one thread: the same sums in every run)
            self.inverse = mass.Assemble().mat.Inverse(self.P1.FreeDofs(), inverse="sparsecholesky")
        X = steps.X
        V, W = X.components
        local, targets = [], [[] for _ in range(dim + 1)]
        on_gamma3 = {}                                   # the vertices of Γ3 and their P1 DOFs
        for el in self.P1.Elements(ngs.BND):
            for vertex, dof in zip(el.vertices, el.dofs):
                if dof >= 0:
                    on_gamma3[vertex.nr] = dof
        for v, dof in sorted(on_gamma3.items()):
            node = ngs.NodeId(ngs.VERTEX, v)
            local.append(dof)
            for i in range(dim):
                targets[i].append(X.Range(0).start + V.GetDofNrs(node)[i])
            targets[dim].append(X.Range(1).start + W.GetDofNrs(node)[0])
        self.local = np.array(local, dtype=np.int64)
        self.targets = [np.array(t, dtype=np.int64) for t in targets]
        self.quadrature = dict(definedon=self.region, bonus_intorder=2 * body.order + 2)
        # the pointwise data need the volume element's stress at Γ3 (on a plain ds NGSolve would
        # take the surface gradient): evaluated from the volume, then projected facet by facet
        # onto SurfaceL2 of order p, so that every later form reads them cheaply; the projection
        # keeps their moments against the hat functions, which is all the patch problems see
        T_h, j_h = pointwise_data(steps)
        if body.axisymmetric:                            # the data of the weighted fluxes w σ̃, w D
            T_h, j_h = body.weighted(T_h), body.weighted(j_h)
        surface = ngs.SurfaceL2(mesh, order=body.order, definedon=self.region)
        self._traction = ngs.GridFunction(surface ** dim if dim > 1 else surface)
        self._flux = ngs.GridFunction(surface)
        # (compiled inside: outside, BoundaryFromVolumeCF evaluates the tree node by node)
        self._pointwise_cf = (ngs.BoundaryFromVolumeCF(T_h.Compile()), ngs.BoundaryFromVolumeCF(j_h.Compile()))
        self._pointwise = (self._traction, self._flux)

    def __call__(self):
        """(t_h, j_h, (c_t, c_j)) at the simulation's current state."""
        steps, dim = self.steps, self.dim
        residual = steps.system.boundary_residual.FV().NumPy().copy()
        hook = steps.gamma3.enforcement.newton_hook
        if hook is not None:
            residual += hook.forces.FV().NumPy()
        T_cf, j_cf = self._pointwise_cf
        self._traction.Set(T_cf, ngs.BND, definedon=self.region)
        self._flux.Set(j_cf, ngs.BND, definedon=self.region)
        T_h, j_h = self._pointwise
        corrections = []
        for i in range(dim + 1):
            given = ngs.LinearForm(self.P1)
            given += mesh_ds((T_h[i] if i < dim else j_h) * self.w, **self.quadrature)
            given = given.Assemble().vec.FV().NumPy()
            rhs = ngs.GridFunction(self.P1)
            values = rhs.vec.FV().NumPy()
            values[self.local] = -residual[self.targets[i]] - given[self.local]
            gf = ngs.GridFunction(self.P1)
            with reproducible():
                gf.vec.data = self.inverse * rhs.vec
            corrections.append(gf)
        c_t, c_j = ngs.CF(tuple(corrections[:dim])), corrections[dim]
        return T_h + c_t, j_h + c_j, (c_t, c_j)


def _vector_dof(V, node, component):
    """The DOF of ``node`` in component ``component`` of a VectorH1 space."""
    dofs = V.GetDofNrs(node)
    return dofs[component]
