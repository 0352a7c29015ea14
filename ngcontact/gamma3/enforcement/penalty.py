"""The penalty method for the contact law (2.8): a stiff normal compliance at the gap.

The Signorini part of (2.8) is replaced by σ̃_ν = −ε [u_ν − g]_+ with
ε = ``Contact.penalty`` × ``forms.boundary_stiffness`` (the scaling of Nitsche's γ, so the
penalty factor compares with γ0). Besides j_a the Γ3 part of the residual is
S = ∫_Γ3 ε [u_ν − g]_+ v_ν: no stress appears, so the method is simple and symmetric, but
inconsistent: the body penetrates by O(1/ε), and the Jacobian's condition number grows like ε.
"""
from dataclasses import dataclass

import ngsolve as ngs

from ngcontact.checks import number
from ngcontact.gamma3.contact_laws import positive_part
from ngcontact.model.forms import boundary_stiffness


@dataclass(frozen=True)
class Penalty:
    """The penalty method: ``Contact(method=Penalty(factor=1e3))``.

    factor : > 0; ε = factor p² (stiffness)/h, the scaling of Nitsche's γ (the factor compares
        with γ0). The body penetrates by O(1/ε).
    """
    factor: float = 1e3

    name = "penalty"
    """The shorthand ``Contact(method=...)`` takes."""
    condensable = True
    distributable = True
    takes_obstacle = True
    keeps_symmetry = True
    skew_symmetric = False

    def __post_init__(self):
        number("Penalty.factor", self.factor, 0, low_open=True)

    @classmethod
    def from_contact(cls, contact):
        """The method of ``Contact(method="penalty", penalty=...)`` (its default factor if not given)."""
        given = contact.given_parameters
        return cls(given["penalty"]) if "penalty" in given else cls()

    def contact_fields(self):
        """The fields of ``Contact`` that stand for this method's parameters."""
        return {"penalty": self.factor}

    def stiffness_factors(self):
        """{name: factor} of the Γ3 stiffnesses in multiples of ``forms.boundary_stiffness``."""
        return {"Contact.penalty": self.factor}

    def flags(self):
        return []

    def build(self, body, contact, side, *, gap, coefficients, normal):
        """The Γ3 expressions on ``body`` (``enforcement.Enforcement``)."""
        return PenaltyTerms(self, body, gap=gap, coefficients=coefficients, normal=normal)


class PenaltyTerms:
    """The Γ3 expressions of the penalty method (``enforcement.Enforcement``)."""

    newton_hook = None

    def __init__(self, method, body, *, gap, coefficients, normal):
        self.gap = gap
        self.n = normal
        self.epsilon = method.factor * boundary_stiffness(body, coefficients.rate)

    def signorini(self, u, phi, v, xi, traction):
        return self.multiplier(u, phi, traction) * (v * self.n)

    def contact_distance(self, u, phi, traction):
        """u_ν − g (m): >= 0 exactly where the penalty presses (conduction's argument)."""
        return u * self.n - self.gap

    def multiplier(self, u, phi, traction):
        """λ_h = ε [u_ν − g]_+, the penalty contact pressure (Pa)."""
        return self.epsilon * positive_part(u * self.n - self.gap)

    def active(self, u, phi, traction):
        """1 where the body reaches the foundation (u_ν >= g), else 0."""
        return ngs.IfPos(self.gap - u * self.n, 0, 1)
