"""Nitsche's method for the contact law (2.8) on Γ3 (Chouly & Hild's θ-family).

With σ̃_ν = σ_ν + p(u_ν) − γ_ν β² R_ν(u_ν), Signorini u_ν ≤ g, σ̃_ν ≤ 0, σ̃_ν (u_ν − g) = 0
is, for any γ > 0,  σ̃_ν = [P]_-,  P = σ̃_ν − γ (u_ν − g),  [P]_- = min(P, 0).
Substituting this for the normal traction in the mechanical equation gives, besides j_a,
the Signorini term of the step residual, for test functions (v, ξ):

  S = −(θ/γ) ∫_Γ3 σ̃_ν σ_ν(v, ξ) + (1/γ) ∫_Γ3 [P]_- (θ σ_ν(v, ξ) − γ v_ν),

where σ_ν(v, ξ) is the variation of σ_ν: ν·(F ε(v) + c A ε(v) + Eᵀ∇ξ)ν (c the time scheme's rate coefficient, 1/dt for backward Euler;
with nonlinear laws their tangents at 0, ``forms.step_normal_stress_variation``). It is consistent
(the exact solution makes the two terms −∫σ̃_ν v_ν), and with p = 0, γ_ν = 0, A = 0 and
E = 0 it is exactly Chouly & Hild's method. On the set P ≤ 0 (P = 0 counts as contact, so a
body starting exactly at the gap gets contact stiffness at once) the constraint is active.
γ = γ0 ``forms.boundary_stiffness`` (γ0 = ``Contact.gamma0``).
"""
import ngsolve as ngs

from ..forms import boundary_stiffness, step_normal_stress, step_normal_stress_variation


class Nitsche:
    """The Γ3 expressions of Nitsche's method (``enforcement.Enforcement``)."""

    newton_hook = None
    condensable = True

    def __init__(self, body, contact, side, *, gap, coefficients, normal):
        self.tensors, self.theta, self.gap = body.tensors, contact.theta, gap
        self.coefficients = coefficients                    # the time scheme's c and û
        self.n = normal
        self.gamma = contact.gamma0 * boundary_stiffness(body, coefficients.rate)
        self._effective = {}                                # σ̃_ν and P by their arguments

    @classmethod
    def keeps_symmetry(cls, contact):
        """θ = 1 is the symmetric variant (with linear tensors: ``solver_choice``)."""
        return contact.theta == 1

    def sigma_n(self, u, phi):
        """σ_ν of the step at (u, φ), Pa."""
        return step_normal_stress(self.tensors, u, phi, self.coefficients.rate, self.coefficients.anchor, self.n)

    def effective(self, u, phi, traction):
        """σ̃_ν = σ_ν + traction (Pa), one CoefficientFunction per (u, φ, traction), so that the
        Signorini term and ψ's argument share it (``Compile`` evaluates it once)."""
        key = (id(u), id(phi), id(traction))
        if key not in self._effective:                  # (the arguments kept: their ids stay theirs)
            self._effective[key] = (u, phi, traction, self.sigma_n(u, phi) + traction)
        return self._effective[key][-1]

    def P(self, u, phi, traction):
        """P = σ̃_ν − γ (u_ν − g); [P]_- = min(P, 0) is the Nitsche contact stress."""
        key = (id(u), id(phi), id(traction), "P")
        if key not in self._effective:
            self._effective[key] = (u, phi, traction, self.effective(u, phi, traction)
                                    - self.gamma * (u * self.n - self.gap))
        return self._effective[key][-1]

    def signorini(self, u, phi, v, xi, traction):
        theta, gamma = self.theta, self.gamma
        effective, P = self.effective(u, phi, traction), self.P(u, phi, traction)
        negative_part = ngs.IfPos(P, 0, P)
        terms = -negative_part * (v * self.n)
        if theta != 0:
            variation = step_normal_stress_variation(self.tensors, v, xi, self.coefficients.rate, self.n)
            terms = terms + theta / gamma * (negative_part - effective) * variation
        return terms

    def contact_distance(self, u, phi, traction):
        """−P/γ = (u_ν − g) − σ̃_ν/γ (m): >= 0 where the method presses ([P]_- < 0), u_ν − g
        where the body is free (σ̃_ν = 0); conduction's argument with pressure gating."""
        return -self.P(u, phi, traction) / self.gamma

    def multiplier(self, u, phi, traction):
        """λ_h = −[P]_-, the Nitsche contact pressure (>= 0), Pa."""
        P = self.P(u, phi, traction)
        return -ngs.IfPos(P, 0, P)

    def active(self, u, phi, traction):
        """1 where P <= 0, else 0."""
        return ngs.IfPos(self.P(u, phi, traction), 0, 1)
