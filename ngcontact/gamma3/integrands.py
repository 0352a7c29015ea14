"""The Γ3 integrands of the step residual (docs/model.md), as CoefficientFunctions:

  j_a(β, u, v) = ∫_Γ3 (p(u_ν) − γ_ν β² R_ν(u_ν)) v_ν da      the layer and the glue (2.28)
  j_e(u, φ, ξ) = ∫_Γ3 ψ(u_ν − g) φ_L(φ − φ_Γ) ξ da          the conductive foundation (2.29)

and the whole Γ3 part j_a + S − j_e with the enforcement method's Signorini term S
(``contact_terms``), which ``build`` hands to the step system. u_ν = u·n with the contact
normal n: the body's ν, or an obstacle's n_o.
"""


def adhesion_traction(contact, beta, u_normal):
    """p(u_ν) − γ_ν β² R_ν(u_ν) (Pa): the compliant layer's push minus the glue's pull, the
    integrand of j_a (2.28) per unit v_ν."""
    return contact.p(u_normal) - contact.adhesion * beta ** 2 * contact.R(u_normal)


def conduction_distance(contact, enforcement, u, phi, gap, n, traction):
    """The argument r of ψ on Γ3 (m): u_ν − g, the paper's (2.7) (``Contact.gating = "gap"``),
    or, with ``gating = "pressure"``, the enforcement's own contact state
    (``contact_distance``: Nitsche's −P_γ/γ = (u_ν − g) − σ̃_ν/γ), which equals u_ν − g
    wherever the Signorini conditions hold and is >= 0 exactly where the method presses."""
    if contact.gating == "pressure" and enforcement is not None:
        return enforcement.contact_distance(u, phi, traction)
    return u * n - gap


def charge_flux_density(contact, u, phi, gap, foundation_potential, n, enforcement=None, traction=None):
    """ψ(r) φ_L(φ − φ_Γ) = D·ν on Γ3 (2.7), C/m²: the charge flux out of the body; r the
    ``conduction_distance`` (u_ν − g with u_ν = u·n, n the contact normal: ν, or an obstacle's
    n_o; with pressure gating the ``enforcement``'s contact state at the ``traction`` of j_a)."""
    r = conduction_distance(contact, enforcement, u, phi, gap, n, traction)
    return contact.psi(r) * contact.phi_L(phi - foundation_potential)


def j_e(contact, u, phi, xi, gap, foundation_potential, n, enforcement=None, traction=None):
    """j_e(u, φ, ξ) (2.29), integrand on Γ3."""
    return charge_flux_density(contact, u, phi, gap, foundation_potential, n, enforcement, traction) * xi


def contact_terms(contact, enforcement, beta, gap, foundation_potential, state, test, n):
    """The Γ3 part of R: j_a(β, u, v) + S(x; v, ξ) − j_e(u, φ, ξ), for the state
    x = (u, φ) (trial functions or GridFunctions) and test = (v, ξ); S is the
    ``enforcement`` method's Signorini term, which may use the traction of j_a. ``n`` is
    the contact normal: the body's ν (``specialcf.normal``) or an obstacle's n_o, so that
    u_ν = u·n and v_ν = v·n."""
    (u, phi), (v, xi) = state, test
    traction = adhesion_traction(contact, beta, u * n)
    terms = traction * (v * n) + enforcement.signorini(u, phi, v, xi, traction)     # j_a + S
    if contact.conducts:
        terms = terms - j_e(contact, u, phi, xi, gap, foundation_potential, n, enforcement, traction)
    return terms
