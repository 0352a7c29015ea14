"""The weak form of one backward Euler step: the paper's forms (2.26)-(2.31) in one place.

For u, v in V^h (displacements, zero on Γ1) and φ, ξ in W^h (potentials, prescribed on Γa)
(docs/model.md):

  a(u, v) = (A ε(u), ε(v))         viscosity                          (2.30)
  b(u, v) = (F ε(u), ε(v))         elasticity                         (2.30)
  c(φ, ξ) = (C ∇φ, ∇ξ)             permittivity                       (2.31)
  e(v, ξ) = (E ε(v), ∇ξ)           piezoelectric coupling             (2.30)-(2.31)
  f(v, ξ) = (f0, v) + (f2, v)_Γ2 + (q0, ξ) + (qb, ξ)_Γb               loads (2.26)-(2.27)
  j_a(β, u, v) = ∫_Γ3 (p(u_ν) − γ_ν β² R_ν(u_ν)) v_ν da            compliant layer, glue (2.28)
  j_e(u, φ, ξ) = ∫_Γ3 ψ(u_ν − g) φ_L(φ − φ_Γ) ξ da                 conductive foundation (2.29)

(j_a, j_e and the Signorini term live with Γ3: ``ngcontact.gamma3.integrands``).

Step n of the scheme (4.3)-(4.5) finds x = (u, φ) = (u_n, φ_n) such that for all (v, ξ)

  R(x; v, ξ) = a((u − u_{n−1})/dt, v) + b(u, v) + e(v, φ) + j_a(β_n, u, v) + S(x; v, ξ)
             + e(u, ξ) − c(φ, ξ) − j_e(u, φ, ξ) − f(v, ξ) = 0,

where, for nonlinear laws (``laws``, (2.16)-(2.17)), a and b read (A((u − u_{n−1})/dt), ε(v))
and (F(ε(u)), ε(v)) (``nonlinear_bulk``).

with the electric equation negated (its Jacobian is then symmetric quasi-definite) and S
the Signorini term of the enforcement method (``ngcontact.gamma3.enforcement``). ``StepSystem``
assembles R in the parts ``bulk`` (b + e + e − c), ``a``, ``f`` and the Γ3 part
(``gamma3.integrands.contact_terms``), each on the body's measures (``Kinematics.dx``, ``ds``).

Strains and stresses are Voigt vectors with engineering shear, so that σ : ε(v) is the dot
product of the Voigt vectors, in the representation of the tensors' kinematics
(``MaterialTensors.kinematics``: plane strain, 3D, a body of revolution).
"""
import ngsolve as ngs
import numpy as np

from ngcontact.model.loads import as_cf
from ngcontact.model import kinematics
from ngcontact.model.voigt import matrix_cf


def strain(u, T=None):
    """ε(u) as the Voigt vector the MaterialTensors ``T`` act on (``MaterialTensors.strain``:
    (ε11, ε22, 2ε12) in plane strain, six components in 3D, (ε_rr, ε_zz, 2ε_rz, ε_θθ) for a
    body of revolution); without ``T``, that of a plane or solid body of u's dimension."""
    if T is not None:
        return T.strain(u)
    return kinematics.of(u.dim).strain(u)


def stress(T, u, phi, strain_rate=None):
    """σ = A ε(u̇) + F ε(u) + Eᵀ ∇φ (2.3), Voigt vector, for the MaterialTensors T;
    ``strain_rate`` is ε(u̇) (Voigt), None for the elastic part only. Without piezoelectric
    coupling (E = 0) the term Eᵀ∇φ is left out of the expression (the Γ3 terms' Jacobian is
    then differentiated in u's components only)."""
    s = T.elastic_stress(strain(u, T))
    if T.E.any():
        s = s + matrix_cf(T.E).trans * ngs.grad(phi)
    if T.viscous and strain_rate is not None:
        s = s + T.viscous_stress(strain_rate)
    return s


def electric_displacement(T, u, phi):
    """D = E ε(u) − C ∇φ (2.4)."""
    return matrix_cf(T.E) * strain(u, T) - matrix_cf(T.C) * ngs.grad(phi)


def normal_stress(T, sigma, n, direction=None):
    """σ_ν = σν · ν from a Voigt stress vector of the tensors ``T``'s kinematics and the unit
    normal n; with ``direction`` (an obstacle normal n_o) the traction's component σν · n_o."""
    return (n if direction is None else direction) * T.kinematics.traction(sigma, n)


def step_normal_stress(T, u, phi, rate, anchor=None, direction=None):
    """σ_ν of a time step: ν·(F ε(u) + c A ε(u − û) + Eᵀ∇φ)ν (Pa), with the scheme's rate
    coefficient c = ``rate`` (1/s) and anchor û = ``anchor`` (``schemes.StepCoefficients``;
    backward Euler: 1/dt and u_{n−1}). ``anchor=None``: the variation σ_ν(v, ξ) in the test
    functions, c A ε(v) included. ``direction``: the traction's component along it (n_o)."""
    rate = rate * (strain(u, T) - strain(anchor, T)) if anchor is not None else rate * strain(u, T)
    return normal_stress(T, stress(T, u, phi, rate), ngs.specialcf.normal(u.dim), direction)


def step_normal_stress_variation(T, v, xi, rate, direction=None):
    """Nitsche's σ_ν(v, ξ) in the test functions: ν·(F ε(v) + c A ε(v) + Eᵀ∇ξ)ν with the
    linear tensors, with a law its tangent at ε = 0 (``MaterialTensors.tangent``). Any linear
    map of (v, ξ) keeps Nitsche's method consistent (the exact solution makes the terms it
    multiplies cancel); with a law, the Jacobian is then not symmetric even for θ = 1. (The
    law's tangent at the state, by ``CoefficientFunction.Diff``, was tried and dropped: its second
    derivative in the Γ3 Jacobian made every assembly far too slow, docs/measurements.md, section
    ngcontact/model/forms.py.)"""
    return step_normal_stress(T.tangent(), v, xi, rate, direction=direction)


def boundary_stiffness(body, rate):
    """p² (λ_max(F + Eᵀ C⁻¹ E) + c λ_max(A))/h: the stiffness of σ_ν per unit normal
    displacement at a facet of height h = ``specialcf.mesh_size`` (Pa/m = N/m³), p the order of
    u, c the scheme's rate coefficient ``rate`` (1/s; 1/dt for backward Euler). The scale an
    enforcement method's Γ3 stiffness is expressed in, public as
    ``ngcontact.methods.boundary_stiffness``: Nitsche's γ and the penalty's ε are multiples of
    it (``Contact.gamma0``, default 10; ``Contact.penalty``, default 1e3), and a method of the
    user's takes its own as a factor × ``boundary_stiffness(body, coefficients.rate)`` in its
    ``build`` (and names the factor in its ``stiffness_factors``). The factor p² follows the
    inverse inequality of degree-p polynomials; with laws it follows their stiffness scales
    through the run (``MaterialTensors.contact_stiffness``).

    body : the Body.  rate : c (1/s), a number, ngsolve.Parameter or CoefficientFunction.
    Returns a CoefficientFunction (N/m³) for the integrals on Γ3 (h is the facet's element's height).
    """
    return body.order ** 2 * body.tensors.contact_stiffness(rate) / ngs.specialcf.mesh_size


# ------------------------------------------------------------------------ the bulk forms on Ω

def a(T, u, v):
    """a(u, v) = (A ε(u), ε(v)): the Kelvin-Voigt viscosity (2.30), integrand on Ω (the
    linear tensor A: for a law, its tangent at 0)."""
    return ngs.InnerProduct(matrix_cf(T.A) * strain(u, T), strain(v, T))


def b(T, u, v):
    """b(u, v) = (F ε(u), ε(v)): elasticity (2.30), integrand on Ω (the linear tensor F: for a
    law, its tangent at 0)."""
    return ngs.InnerProduct(matrix_cf(T.F) * strain(u, T), strain(v, T))


def nonlinear_bulk(T, u, v, rate, anchor):
    """(F(ε(u)), ε(v)) + (A(c ε(u − û)), ε(v)): the parts of R on Ω given by laws (2.16)-(2.17),
    integrand on Ω, nonlinear in u (the law's part only: F with a law ``T.F_law``, A with
    ``T.A_law``; c = ``rate``, û = ``anchor``, the time scheme's); None without laws."""
    terms = None
    if T.F_law is not None:
        terms = ngs.InnerProduct(T.elastic_stress(strain(u, T)), strain(v, T))
    if T.A_law is not None:
        viscous = ngs.InnerProduct(T.viscous_stress(rate * (strain(u, T) - strain(anchor, T))), strain(v, T))
        terms = viscous if terms is None else terms + viscous
    return terms


def linear_bulk(T, trial, test):
    """The part of ``bulk`` with constant coefficients when laws give F or A: e + e − c, and
    b where F is linear."""
    (u, phi), (v, xi) = trial, test
    terms = e(T, v, phi) + e(T, u, xi) - c(T, phi, xi)
    return terms if T.F_law is not None else terms + b(T, u, v)


def preconditioner_forms(body, u, v, phi, xi, rate):
    """The SPD forms that block preconditioners of the step Jacobian approximate (``multigrid``,
    ``petsc_iterative``), integrands on Ω: for u, (F̃ ε(u), ε(v)) + c (A ε(u), ε(v)) with the
    piezo-stiffened F̃ = F + Eᵀ C⁻¹ E (c = ``rate``, 1/s; the linear tensors, a law's tangent at
    0); for φ, (C ∇φ, ∇ξ). Returns (u integrand, φ integrand), to be integrated on the body's
    measure (``Kinematics.dx``)."""
    T = body.tensors
    stiffened = T.F + T.E.T @ np.linalg.solve(T.C, T.E) if body.coupled else T.F
    integrand = ngs.InnerProduct(matrix_cf(stiffened) * strain(u, T), strain(v, T))
    if T.viscous:
        integrand = integrand + rate * a(T, u, v)
    return integrand, c(T, phi, xi)


def c(T, phi, xi):
    """c(φ, ξ) = (C ∇φ, ∇ξ): permittivity (2.31), integrand on Ω."""
    return ngs.InnerProduct(matrix_cf(T.C) * ngs.grad(phi), ngs.grad(xi))


def e(T, v, xi):
    """e(v, ξ) = (E ε(v), ∇ξ): piezoelectric coupling (2.30)-(2.31), integrand on Ω."""
    return ngs.InnerProduct(matrix_cf(T.E) * strain(v, T), ngs.grad(xi))


def bulk(T, trial, test):
    """b(u, v) + e(v, φ) + e(u, ξ) − c(φ, ξ): the elastic and electric part of R on Ω, for
    trial = (u, φ) and test = (v, ξ) (σ(u, φ) : ε(v) + D(u, φ) · ∇ξ)."""
    (u, phi), (v, xi) = trial, test
    return b(T, u, v) + e(T, v, phi) + e(T, u, xi) - c(T, phi, xi)


def f(body, loads, test):
    """f(v, ξ) = (f0, v) + (f2, v)_Γ2 + (q0, ξ) + (qb, ξ)_Γb (2.26)-(2.27), as a list of
    integrals on the body's measures (``Kinematics.dx``, ``ds``) for a LinearForm."""
    (v, xi), mesh, dim, kin = test, body.mesh, body.dim, body.kinematics
    integrals = []
    if loads.f0 is not None:
        integrals.append(kin.dx(as_cf(loads.f0, dim, "f0") * v))
    if loads.q0 is not None:
        integrals.append(kin.dx(as_cf(loads.q0, 1, "q0") * xi))
    for names, f2 in loads.f2.items():
        integrals.append(kin.ds(as_cf(f2, dim, f"f2[{names!r}]") * v, mesh.Boundaries(names)))
    for names, qb in loads.qb.items():
        integrals.append(kin.ds(as_cf(qb, 1, f"qb[{names!r}]") * xi, mesh.Boundaries(names)))
    return integrals


# ------------------------------------------------------------------------ weak normal supports

def weak_normal_support(T, order, trial, test, gamma0):
    """The symmetric Nitsche terms of u·ν = 0 on a support (``supports``), integrands on its
    ds in the trial (u, φ) and test (v, ξ) functions, as (elastic part, viscous part per
    1/dt) for K_el and K_A (the viscous part None for an elastic material):

      −σ_ν(u, φ) v_ν − σ_ν(v, ξ) u_ν + γ_s u_ν v_ν,   γ_s = gamma0 p² stiffness / h,

    σ_ν of the step (its A ε(u)/dt part in the viscous term), so that the traction of the
    support, −∫ σ_ν v_ν, is consistent and the whole stays symmetric. With laws (2.16)-(2.17)
    these are the terms without them (``weak_normal_support_laws`` gives the rest): the
    consistency term leaves out F(ε(u)) where F is a law, and the viscous part is None where A
    is one."""
    (u, phi), (v, xi) = trial, test
    n = ngs.specialcf.normal(u.dim)
    gamma_el, _ = _support_gammas(T, order, gamma0)
    tangent = T.tangent()
    own = stress(T, u, phi) if T.F_law is None else matrix_cf(T.E).trans * ngs.grad(phi)
    elastic = (-normal_stress(T, own, n) * (v * n) - normal_stress(T, stress(tangent, v, xi), n) * (u * n)
               + gamma_el * (u * n) * (v * n))
    if not T.viscous or T.A_law is not None:
        return elastic, None
    return elastic, -normal_stress(T, matrix_cf(T.A) * strain(u, T), n) * (v * n) + _viscous_support(T, order, gamma0, u, v)


def _viscous_support(T, order, gamma0, w, v):
    """−ν·(A ε(v))ν w_ν + γ_A w_ν v_ν: the symmetric and penalty terms of a weak normal support
    per unit rate coefficient, A the linear tensor (a law's tangent at 0)."""
    n = ngs.specialcf.normal(v.dim)
    _, gamma_A = _support_gammas(T, order, gamma0)
    return -normal_stress(T, matrix_cf(T.A) * strain(v, T), n) * (w * n) + gamma_A * (w * n) * (v * n)


def weak_normal_support_laws(T, order, u, v, rate, anchor, gamma0):
    """The weak normal support's terms that laws give (``weak_normal_support`` has the rest),
    integrand on the support, nonlinear in u: the consistency term −ν·F(ε(u))ν v_ν where F is
    a law; where A is one, −ν·A(c ε(u − û))ν v_ν and the symmetric and penalty terms
    c (−ν·(A'(0) ε(v))ν (u − û)_ν + γ_A (u − û)_ν v_ν) (c = ``rate``, û = ``anchor``, the time
    scheme's); None without laws."""
    n = ngs.specialcf.normal(u.dim)
    terms = None
    if T.F_law is not None:
        terms = -normal_stress(T, T.elastic_stress(strain(u, T)), n) * (v * n)
    if T.A_law is not None:
        viscous = -normal_stress(T, T.viscous_stress(rate * (strain(u, T) - strain(anchor, T))), n) * (v * n) \
            + rate * _viscous_support(T, order, gamma0, u - anchor, v)
        terms = viscous if terms is None else terms + viscous
    return terms


def _support_gammas(T, order, gamma0):
    """(γ_el, γ_A) of a weak normal support: γ_s = γ_el + γ_A/dt (Pa/m, Pa·s/m)."""
    scale = gamma0 * order ** 2 / ngs.specialcf.mesh_size
    return scale * T.stiffness(0.0), scale * (T.stiffness(1.0) - T.stiffness(0.0))


def support_multiplier(T, order, u, phi, anchor, rate, gamma0):
    """λ (Pa) of a weak normal support, read off its residual terms −∫ λ v_ν:
    λ = σ_ν − γ_el u_ν − γ_A c (u − û)_ν → σ_ν (c = ``rate``, û = ``anchor``, the time
    scheme's: ``step_normal_stress``); its traction is λ ν."""
    n = ngs.specialcf.normal(u.dim)
    gamma_el, gamma_A = _support_gammas(T, order, gamma0)
    lam = step_normal_stress(T, u, phi, rate, anchor) - gamma_el * (u * n)
    if T.viscous:
        lam = lam - gamma_A * rate * ((u - anchor) * n)
    return lam
