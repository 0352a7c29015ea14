"""Nitsche's method for the contact law (2.8) on Γ3 (Chouly & Hild's θ-family).

With σ̃_ν = σ_ν + p(u_ν) − γ_ν β² R_ν(u_ν), Signorini u_ν ≤ g, σ̃_ν ≤ 0, σ̃_ν (u_ν − g) = 0
is, for any γ > 0,  σ̃_ν = [P]_-,  P = σ̃_ν − γ (u_ν − g),  [P]_- = min(P, 0).
Substituting this for the normal traction in the mechanical equation gives the Γ3 part
of the step residual, for test functions (v, ξ):

  ∫_Γ3 (p(u_ν) − γ_ν β² R_ν(u_ν)) v_ν − (θ/γ) ∫_Γ3 σ̃_ν σ_ν(v, ξ)
      + (1/γ) ∫_Γ3 [P]_- (θ σ_ν(v, ξ) − γ v_ν),

where σ_ν(v, ξ) is the variation of σ_ν: ν·(F ε(v) + A ε(v)/k + Eᵀ∇ξ)ν. The first term is
j_a of (2.28). It is consistent (the exact solution makes the last two cancel to −∫σ̃_ν v_ν),
and with p = 0, γ_ν = 0, A = 0 and E = 0 it is exactly Chouly & Hild's method. On the set
P ≤ 0 (P = 0 counts as contact, so a body starting exactly at the gap gets contact
stiffness at once) the constraint is active.
"""
import ngsolve as ngs
import numpy as np

from .forms import normal_stress, strain, stress


def stiffness(tensors, inv_dt):
    """The scale of σ_ν per unit strain, in Pa: λ_max(F + Eᵀ C⁻¹ E) + λ_max(A)/k.

    The open-circuit tensor F + Eᵀ C⁻¹ E bounds the coupled stiffness; A/k is the
    viscous stiffness of a backward Euler step."""
    T = tensors
    elastic = np.linalg.eigvalsh(T.F + T.E.T @ np.linalg.solve(T.C, T.E)).max()
    return elastic + inv_dt * (np.linalg.eigvalsh(T.A).max() if T.viscous else 0.0)


def nitsche_parameter(body, gamma0, inv_dt):
    """γ = γ0 p² (stiffness)/h, h = ``specialcf.mesh_size`` (the element height at a facet);
    the factor p² (p = order of u) follows the inverse inequality of degree-p polynomials."""
    return gamma0 * body.order ** 2 * stiffness(body.tensors, inv_dt) / ngs.specialcf.mesh_size


class NitscheContact:
    """Expressions of the Γ3 terms for a Body, its Contact data and the bonding field."""

    def __init__(self, body, contact, beta, inv_dt, gap):
        self.body, self.contact, self.beta, self.inv_dt, self.gap = body, contact, beta, inv_dt, gap
        self.n = ngs.specialcf.normal(body.dim)
        self.gamma = nitsche_parameter(body, contact.gamma0, inv_dt)

    def sigma_n(self, u, phi, u_old):
        """σ_ν of the step: ν·(F ε(u) + A ε(u − u_old)/k + Eᵀ∇φ)ν."""
        dim = self.body.dim
        rate = self.inv_dt * (strain(u, dim) - strain(u_old, dim)) if u_old is not None else \
            self.inv_dt * strain(u, dim)
        return normal_stress(stress(self.body.tensors, u, phi, dim, rate), self.n, dim)

    def surface_traction(self, u):
        """p(u_ν) − γ_ν β² R_ν(u_ν), the integrand of j_a (2.28)."""
        c, un = self.contact, u * self.n
        return c.p(un) - c.adhesion * self.beta ** 2 * c.R(un)

    def effective_stress(self, u, phi, u_old):
        """σ̃_ν = σ_ν + p(u_ν) − γ_ν β² R_ν(u_ν)."""
        return self.sigma_n(u, phi, u_old) + self.surface_traction(u)

    def P(self, u, phi, u_old):
        """P = σ̃_ν − γ (u_ν − g); [P]_- = min(P, 0) is the Nitsche contact stress."""
        return self.effective_stress(u, phi, u_old) - self.gamma * (u * self.n - self.gap)

    def residual(self, u, phi, v, xi, u_old):
        """The Γ3 integrand of the residual (to be integrated with ds(skeleton=True))."""
        theta, gamma = self.contact.theta, self.gamma
        traction = self.surface_traction(u)
        effective = self.sigma_n(u, phi, u_old) + traction
        P = effective - gamma * (u * self.n - self.gap)
        negative_part = ngs.IfPos(P, 0, P)
        terms = (traction - negative_part) * (v * self.n)
        if theta != 0:
            terms = terms + theta / gamma * (negative_part - effective) * self.sigma_n(v, xi, None)
        return terms

    def multiplier(self, u, phi, u_old):
        """λ_h = −[P]_-, the Nitsche contact pressure (>= 0), Pa."""
        P = self.P(u, phi, u_old)
        return -ngs.IfPos(P, 0, P)

    def active(self, u, phi, u_old):
        """1 where the contact is active (P <= 0), else 0."""
        return ngs.IfPos(self.P(u, phi, u_old), 0, 1)
