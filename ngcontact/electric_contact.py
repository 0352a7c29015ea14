"""The conductive foundation (2.7) on Γ3: D·ν = ψ(u_ν − g) φ_L(φ − φ_Γ).

In the (negated) electric equation of the step residual this contributes
−∫_Γ3 ψ(u_ν − g) φ_L(φ − φ_Γ) ξ da (j_e of (2.29), with the sign of model.md: current
leaves the body where its potential exceeds the foundation's).
"""
import ngsolve as ngs


def flux_density(contact, u, phi, gap, foundation_potential):
    """ψ(u_ν − g) φ_L(φ − φ_Γ): the normal flux D·ν through Γ3 (C/m²)."""
    n = ngs.specialcf.normal(u.dim)
    return contact.psi(u * n - gap) * contact.phi_L(phi - foundation_potential)


def residual(contact, u, phi, xi, gap, foundation_potential):
    """The Γ3 integrand of the electric part of the residual."""
    return -flux_density(contact, u, phi, gap, foundation_potential) * xi
