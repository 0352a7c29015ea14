"""Manufactured solutions of the strong form (2.1)-(2.11) (docs/model.md).

Given smooth u(x, t), φ(x, t) as sympy expressions in x, y (, z) and t, the data
f0 = −div σ, q0 = −div D, f2 = σν on Γ2 and qb = D·ν on Γb make them the exact solution,
with σ = A ε(u̇) + F ε(u) + Eᵀ∇φ and D = E ε(u) − C∇φ. ``ContactManufactured`` also
satisfies the contact, adhesion and conduction laws on Γ3 with a known contact set.
"""
import math

import ngsolve as ngs
import numpy as np
import sympy as sp

import ngcontact as ngc
from ngcontact.model.materials import VOIGT

x, y, z, t = sp.symbols("x y z t")


class Step(sp.Function):
    """The unit step; its derivative is taken as 0 (it only multiplies powers of Pos)."""

    def fdiff(self, argindex=1):
        return sp.S.Zero


class Pos(sp.Function):
    """The positive part [s]_+, with derivative Step(s)."""

    def fdiff(self, argindex=1):
        return Step(self.args[0])


def _voigt_strain(u, X, dim):
    """ε(u) in Voigt order with engineering shear (ε_ii, then ∂_j u_i + ∂_i u_j)."""
    pairs = [(i, j) for (i, j) in VOIGT if i < dim and j < dim]
    return sp.Matrix([sp.diff(u[i], X[i]) if i == j else sp.diff(u[i], X[j]) + sp.diff(u[j], X[i])
                      for (i, j) in pairs]), pairs


def fiber_excess(s, width, sqrt=sp.sqrt):
    """ψ(s) = s − w s / √(w² + s²): a smooth dead zone of width w (ψ(0) = ψ'(0) = 0,
    0 ≤ ψ' < 1), the smooth cousin of ``laws.Slab``'s ε − P_K ε; ``sqrt`` sympy's or ngsolve's."""
    return s - width * s / sqrt(width**2 + s**2)


def fiber_law(zeta, width, name):
    """The law ℰε + ζ ψ(ε_xx) e_x ⊗ e_x (2D; ℰ the material's linear tensor): fibres along x
    that stiffen by ζ outside |ε_xx| ≲ w. Strongly monotone (ψ nondecreasing), Lipschitz
    (L ≤ λ_max(ℰ) + ζ), smooth; it adds to σ_xx only, so the traction on Γ3 (normal y) is the
    linear one."""
    def fibers(eps, linear):
        return linear(eps) + zeta * ngs.CF((fiber_excess(eps[0, 0], width, ngs.sqrt), 0, 0, 0), dims=(2, 2))
    return ngc.laws.StrainLaw(fibers, name, strain_scale=width)


class Manufactured:
    """Exact (u, φ) and the loads that produce them, for the tensors of a Body; ``extra_stress``
    (optional): the nonlinear part of the stress, a sympy function of the Voigt strain and
    strain-rate vectors returning a Voigt stress vector (added to F ε + A ε̇ + Eᵀ∇φ)."""

    def __init__(self, tensors, u, phi, dim=2, extra_stress=None):
        X = (x, y, z)[:dim]
        self.dim, self.u, self.phi = dim, sp.Matrix(u), sp.sympify(phi)
        F, A, E, C = (sp.Matrix(np.asarray(m)) for m in (tensors.F, tensors.A, tensors.E, tensors.C))
        eps, pairs = _voigt_strain(self.u, X, dim)
        eps_dot = sp.diff(eps, t)
        grad_phi = sp.Matrix([sp.diff(self.phi, c) for c in X])
        s = F * eps + A * eps_dot + E.T * grad_phi
        if extra_stress is not None:
            s = s + extra_stress(eps, eps_dot)
        sigma = sp.zeros(dim, dim)
        for k, (i, j) in enumerate(pairs):
            sigma[i, j] = sigma[j, i] = s[k]
        self.sigma = sigma
        self.D = E * eps - C * grad_phi
        self.f0 = sp.Matrix([-sum(sp.diff(sigma[i, j], X[j]) for j in range(dim)) for i in range(dim)])
        self.q0 = -sum(sp.diff(self.D[i], X[i]) for i in range(dim))

    @staticmethod
    def cf(expr, time):
        """A sympy expression (or matrix) as an ngsolve CoefficientFunction at ``time``."""
        names = {"x": ngs.x, "y": ngs.y, "z": ngs.z, "t": time, "sin": ngs.sin, "cos": ngs.cos,
                 "exp": ngs.exp, "pi": math.pi, "sqrt": ngs.sqrt,
                 "Pos": lambda a: ngs.IfPos(a, a, 0), "Step": lambda a: ngs.IfPos(a, 1, 0)}
        if isinstance(expr, sp.MatrixBase):
            values = tuple(Manufactured.cf(e, time) for e in expr)
            return ngs.CF(values, dims=expr.shape) if expr.shape[1] > 1 else ngs.CF(values)
        return ngs.CF(eval(str(sp.sympify(expr)), names)) if expr.free_symbols else ngs.CF(float(expr))

    def loads(self, body, time):
        """Loads making (u, φ) exact: f0, q0, and σν / D·ν on Γ2 / Γb \\ Γ3."""
        n = ngs.specialcf.normal(self.dim)
        sigma, D = self.cf(self.sigma, time), self.cf(self.D, time)
        f2 = {name: sigma * n for name in body.free_names(("clamped", "contact_side"))}
        qb = {name: D * n for name in body.free_names(("grounded", "contact_side"))}
        return ngc.Loads(f0=self.cf(self.f0, time), q0=self.cf(self.q0, time), f2=f2, qb=qb)

    def errors(self, sim):
        """‖ε(u − u_h)‖ and ‖∇(φ − φ_h)‖ (L²(Ω)) at the simulation's current time."""
        mesh, dim = sim.body.mesh, self.dim
        grad_u = ngs.CF(tuple(self.cf(sp.diff(self.u[i], c), sim.time) for i in range(dim)
                              for c in (x, y, z)[:dim]), dims=(dim, dim))
        grad_phi = ngs.CF(tuple(self.cf(sp.diff(self.phi, c), sim.time) for c in (x, y, z)[:dim]))
        de = ngs.Sym(grad_u - ngs.Grad(sim.u))
        dp = grad_phi - ngs.grad(sim.phi)
        order = 2 * max(sim.body.order, sim.body.order_phi) + 4
        return (math.sqrt(ngs.Integrate(ngs.InnerProduct(de, de), mesh, order=order)),
                math.sqrt(ngs.Integrate(ngs.InnerProduct(dp, dp), mesh, order=order)))

    def energy_error(self, sim, rate=0.0):
        """|||e||| = ((C_c ε(e_u), ε(e_u)) + (C ∇e_φ, ∇e_φ))^½ at the simulation's current time,
        e = (u − u_h, φ − φ_h), C_c = F + ``rate`` A (the energy norm the estimators bound; 0 for
        a static step): J^½, (J/m)^½ in 2D."""
        mesh, dim, T = sim.body.mesh, self.dim, sim.body.tensors
        X = (x, y, z)[:dim]
        grad_u = ngs.CF(tuple(self.cf(sp.diff(self.u[i], c), sim.time) for i in range(dim) for c in X), dims=(dim, dim))
        grad_phi = ngs.CF(tuple(self.cf(sp.diff(self.phi, c), sim.time) for c in X))
        e = ngs.Grad(sim.u) - grad_u
        pairs = [(i, j) for (i, j) in VOIGT if i < dim and j < dim]
        strain = ngs.CF(tuple(e[i, j] if i == j else e[i, j] + e[j, i] for (i, j) in pairs))
        dp = ngs.grad(sim.phi) - grad_phi
        Cc = np.asarray(T.F) + rate * np.asarray(T.A)
        Cc, C = (ngs.CF(tuple(np.asarray(M, dtype=float).flat), dims=np.shape(M)) for M in (Cc, T.C))
        order = 2 * max(sim.body.order, sim.body.order_phi) + 6
        value = ngs.Integrate(ngs.InnerProduct(Cc * strain, strain) + ngs.InnerProduct(C * dp, dp), mesh, order=order)
        return math.sqrt(max(value, 0.0))


def smooth_block(material, order, level=0):
    """(sim, mms): the smooth (u, φ) = t (u_b, φ_b) on the block of ``geometries.block`` (sides
    1, 0.5, 0.5 m; clamped left, grounded bottom, the data of every other face given) in
    ``material``, solved by one step to t = 1 at order ``order`` on ``level`` refinements of
    its coarse mesh: the 3D case of the estimators' effectivity (docs/adaptivity.md)."""
    from ngcontact.geometries import block
    u = sp.Matrix([x * sp.sin(2 * y + z), x ** 2 * sp.cos(y - z), sp.sin(x) * (1 + y * z)]) / 100
    phi = z * sp.cos(x + y) / 10
    body = ngc.Body(block(1.0, 0.5, 0.5, maxh=0.25, refine=level), material, clamped="left", grounded="bottom",
                    order=order)
    mms = Manufactured(body.tensors, u * t, phi * t, dim=3)
    time = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, mms.loads(body, time), time=time, keep_states=False, physical_checks=False)
    sim.run(1.0, 1.0)
    return sim, mms


class ContactManufactured(Manufactured):
    """An exact solution of the full problem on the plate [0, L1] × [0, L2] with Γ1 = left
    (clamped), Γa = top (grounded) and Γ3 = bottom, whose contact set on Γ3 is [0, x_c].

    Construction: u = s_u(t) Û, φ = s_φ(t) Φ̂ with s_φ = s_u + τ ṡ_u, so that for A = τ F
    the stress separates, σ = s_φ(t) σ̂ with σ̂ = F ε(Û) + Eᵀ∇Φ̂. On y = 0 the trace Û_y = T(x)
    is chosen, and the normal derivatives ∂_y Û are solved from σ̂_xy = 0 (frictionless) and
    σ̂_yy = ŝ(x), the wanted normal stress. Û = (x² T_x, T) + y N(x) + y² x W, Φ̂ vanishes on
    the top and has ∇Φ̂ = 0 at x = 0, so that u = 0 on Γ1. The data g, φ_Γ and β0 then make
    the laws hold (k = ``smoothness``, the exponent at the contact-set ends, x_c their place):

    * ``case="viscous"``: s_u = 1 + t (``time_profile="linear"``, backward Euler exact in
      time) or 1 + sin(2t)/2 (``"nonlinear"``); T = (x − x_c)_+^k: separation for x > x_c,
      g = 0, ŝ = −x²(x_c − x)_+^k (compression on the contact set, σ̃_ν = 0 off it).
    * ``case="adhesive"``: static (s_u = s_φ = 1); on [0, x_c] the body presses into the
      compliant layer, u_ν = g = η x²(x_c − x)_+^k with σ̃_ν = σ_ν + c_ν u_ν < 0; on (x_c, L1]
      it is separated and held by the glue, σ_ν = γ_ν β0² R_ν(u_ν); β0(x) = 0.6 + 0.3 sin(4·x)
      stays constant (ε_a > γ_ν β R_ν²).

    Conduction everywhere on Γ3 (ramp width δ larger than any separation, L_φ large):
    φ_Γ = φ − D·ν / ψ(u_ν − g).

    Nonlinear laws (``fibers=(ζ_F, ζ_A)``, ``fiber_width`` w): F(ε) = ℰε + ζ_F ψ(ε_xx) e_x ⊗ e_x
    and A(ε̇) = τℰε̇ + ζ_A ψ(ε̇_xx) e_x ⊗ e_x (``fiber_law``; ``with_laws(material)`` gives the
    material): they add to σ_xx only, so the construction on Γ3 holds unchanged and f0, f2
    carry the laws (each a smooth function of x). Backward Euler stays exact in time for the
    linear profile (ε̇ = ε̂ is constant).

    Regularity: N(x) contains T'(x), so u ∈ H^{k − 1/2 − ε}(Ω) and the energy error of order
    p converges as h^min(p, k − 3/2); k = 3 mimics the H^{5/2 − ε} of real contact solutions.
    """

    def __init__(self, tensors, case="viscous", time_profile="linear", L1=1.0, L2=0.5,
                 x_c=0.5, smoothness=4, tau=0.3, fibers=(0.0, 0.0), fiber_width=0.1):
        k = smoothness
        self.fibers = tuple(float(z) for z in fibers)
        self.fiber_width = float(fiber_width)
        if len(self.fibers) != 2 or min(self.fibers) < 0 or not self.fiber_width > 0:
            raise ValueError(f"fibers must be two numbers >= 0 (zeta_F, zeta_A) and fiber_width > 0, got "
                             f"{fibers!r}, {fiber_width!r}")
        if case not in ("viscous", "adhesive"):
            raise ValueError(f"case must be 'viscous' or 'adhesive', got {case!r}")
        if int(k) != k or k < 3:
            raise ValueError(f"smoothness must be an integer >= 3 (f0 needs the third derivative "
                             f"of (x - x_c)_+^k), got {k}")
        if time_profile not in ("linear", "nonlinear"):
            raise ValueError(f"time_profile must be 'linear' or 'nonlinear', got {time_profile!r}")
        if not np.allclose(tensors.A, tau * tensors.F):
            raise ValueError("ContactManufactured needs the viscosity A = tau F")
        self.case, self.L1, self.L2, self.x_c, self.smoothness = case, L1, L2, x_c, k
        self.conductance, self.ramp_width, self.gamma_nu, self.c_nu, eta = 1.0, 10.0, 2.0, 3.0, 0.5
        F, E = sp.Matrix(tensors.F), sp.Matrix(tensors.E)
        inside, outside = Pos(x_c - x) ** k, Pos(x - x_c) ** k
        if case == "viscous":
            s_u = 1 + t if time_profile == "linear" else 1 + sp.sin(2 * t) / 2
            trace_y, self.gap_expr = outside, sp.S.Zero
            s_hat = -x**2 * inside
            self.beta0_expr, self.eps_a = sp.S.One, 0.0
        else:
            s_u = sp.S.One
            trace_y = outside - eta * x**2 * inside
            self.gap_expr = eta * x**2 * inside
            self.beta0_expr = 0.6 + 0.3 * sp.sin(4 * x)
            s_hat = self.gamma_nu * self.beta0_expr**2 * outside - (self.c_nu * eta + 1) * x**2 * inside
            self.eps_a = 10.0
        s_phi = s_u + tau * sp.diff(s_u, t)
        Phi = x**2 * (L2 - y) * (1 + x * y) / 2
        trace_x = x**2 * sp.sin(x) / 4
        a, b = sp.symbols("a b")                     # ∂_y Û_x, ∂_y Û_y on y = 0
        eps0 = sp.Matrix([sp.diff(trace_x, x), b, a + sp.diff(trace_y, x)])
        grad0 = sp.Matrix([sp.diff(Phi, x), sp.diff(Phi, y)]).subs(y, 0)
        sig0 = F * eps0 + E.T * grad0
        sol = sp.solve([sig0[2], sig0[1] - s_hat], [a, b], dict=True)[0]
        W = sp.Matrix([sp.cos(y) / 5, sp.sin(x + y) / 10])
        U = sp.Matrix([trace_x, trace_y]) + y * sp.Matrix([sol[a], sol[b]]) + y**2 * x * W

        def extra_stress(eps, eps_dot):              # Voigt (xx, yy, xy): σ_xx only
            zeta_F, zeta_A = self.fibers
            w = self.fiber_width
            return sp.Matrix([zeta_F * fiber_excess(eps[0], w) + zeta_A * fiber_excess(eps_dot[0], w), 0, 0])
        super().__init__(tensors, s_u * U, s_phi * Phi, dim=2,
                         extra_stress=extra_stress if any(self.fibers) else None)
        self.u_normal_expr = -self.u[1].subs(y, 0)   # ν = (0, −1) on Γ3

    def with_laws(self, material):
        """``material`` with this solution's fibre laws (those with ζ > 0)."""
        zeta_F, zeta_A = self.fibers
        if zeta_F:
            material = material.with_elasticity(fiber_law(zeta_F, self.fiber_width, f"fibres ζ = {zeta_F:g}"))
        if zeta_A:
            material = material.with_viscosity(fiber_law(zeta_A, self.fiber_width, f"viscous fibres ζ = {zeta_A:g}"))
        return material

    def contact(self, time, theta=1, gamma0=10.0, beta_update="explicit"):
        """The Contact data (g, laws, φ_Γ, β0) that make this solution exact."""
        dn = (-self.D[1]).subs(y, 0)                                   # D·ν on Γ3
        r = self.u_normal_expr - self.gap_expr
        psi = self.conductance * (1 + r / self.ramp_width)
        phi_gamma = self.phi.subs(y, 0) - dn / psi
        return ngc.Contact(gap=self.cf(self.gap_expr, time),
                       compliance=self.c_nu if self.case == "adhesive" else 0.0,
                       adhesion=self.gamma_nu if self.case == "adhesive" else 0.0,
                       eps_a=self.eps_a, bond_length=10.0, beta0=self.cf(self.beta0_expr, time),
                       beta_update=beta_update, conductance=self.conductance,
                       ramp_width=self.ramp_width, potential_truncation=1e6,
                       foundation_potential=self.cf(phi_gamma, time), theta=theta, gamma0=gamma0)

    def beta_error(self, sim):
        """‖β − β_h‖_L²(Γ3): β = β0 (constant in time, ε_a large)."""
        beta = self.cf(self.beta0_expr, sim.time)
        return math.sqrt(sim.side.facet_integrals((beta - sim.beta.gf) ** 2)().sum())
