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
import numbers
from dataclasses import dataclass

import ngsolve as ngs

from ngcontact.checks import number
from ngcontact.model.forms import boundary_stiffness, step_normal_stress, step_normal_stress_variation

ACCURATE_FROM = {1: 3.0, 0: 0.1, -1: 3.0}
"""γ0 from which each variant θ has an accurate contact force on the reference plate
(fitted to measurements on the reference plate, docs/stability.md, section 1, and
docs/measurements.md, section ngcontact/gamma3/enforcement/nitsche.py): below, θ = 1 and θ = 0
may converge to forces far off or fail (their coercivity needs γ0 above a trace-inequality
constant), θ = −1 is stable but imposes contact only weakly, the more so the smaller γ0."""


@dataclass(frozen=True)
class Nitsche:
    """Nitsche's method (Chouly & Hild's θ-family): ``Contact(method=Nitsche(theta=1, gamma0=10))``.

    theta : 1 (symmetric), 0 (incomplete) or -1 (skew-symmetric).
    gamma0 : γ0 > 0; γ = γ0 p² (stiffness)/h (``forms.boundary_stiffness``). The variants
        give an accurate contact force from γ0 = ``ACCURATE_FROM[theta]`` on.
    """
    theta: int = 1
    gamma0: float = 10.0

    name = "nitsche"
    """The shorthand ``Contact(method=...)`` takes."""
    condensable = True
    distributable = True
    takes_obstacle = True

    def __post_init__(self):
        if isinstance(self.theta, bool) or not isinstance(self.theta, numbers.Real):
            raise TypeError(f"Nitsche.theta must be 1, 0 or -1, got {self.theta!r} ({type(self.theta).__name__})")
        if self.theta not in (1, 0, -1):
            raise ValueError(f"Nitsche.theta must be 1, 0 or -1, got {self.theta!r}")
        number("Nitsche.gamma0", self.gamma0, 0, low_open=True)

    @classmethod
    def from_contact(cls, contact):
        """The method of ``Contact(method="nitsche", theta=..., gamma0=...)`` (its defaults for
        those not given)."""
        return cls(**{k: v for k, v in contact.given_parameters.items() if k in ("theta", "gamma0")})

    def contact_fields(self):
        """The fields of ``Contact`` that stand for this method's parameters."""
        return {"theta": self.theta, "gamma0": self.gamma0}

    @property
    def keeps_symmetry(self):
        """θ = 1 is the symmetric variant (with linear tensors: ``solver_choice``)."""
        return self.theta == 1

    @property
    def skew_symmetric(self):
        """θ = −1: the skew part of the Jacobian lives on Γ3."""
        return self.theta == -1

    def stiffness_factors(self):
        """{name: factor} of the Γ3 stiffnesses in multiples of ``forms.boundary_stiffness``."""
        return {"Contact.gamma0": self.gamma0}

    def flags(self):
        """Messages on a γ0 below ``ACCURATE_FROM`` of its θ (results that may be wrong)."""
        bound = ACCURATE_FROM[self.theta]
        if self.gamma0 >= bound:
            return []
        why = ("skew-symmetric Nitsche is stable for every γ0 but imposes contact only weakly" if self.theta == -1
               else f"Nitsche with θ = {self.theta} is not coercive for small γ0: it may converge to a wrong "
                    "contact force")
        return [f"Contact.gamma0 = {self.gamma0:g} is below {bound:g}, where θ = {self.theta} gave the contact "
                f"force within 1 % (docs/stability.md): {why}; use γ0 >= {bound:g}"]

    def build(self, body, contact, side, *, gap, coefficients, normal):
        """The Γ3 expressions on ``body`` (``enforcement.Enforcement``)."""
        return NitscheTerms(self, body, gap=gap, coefficients=coefficients, normal=normal)


class NitscheTerms:
    """The Γ3 expressions of Nitsche's method (``enforcement.Enforcement``)."""

    newton_hook = None

    def __init__(self, method, body, *, gap, coefficients, normal):
        self.tensors, self.theta, self.gap = body.tensors, method.theta, gap
        self.coefficients = coefficients                    # the time scheme's c and û
        self.n = normal
        self.gamma = method.gamma0 * boundary_stiffness(body, coefficients.rate)
        self._effective = {}                                # σ̃_ν and P by their arguments

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
