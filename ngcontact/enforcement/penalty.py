"""The penalty method for the contact law (2.8): a stiff normal compliance at the gap.

The Signorini part of (2.8) is replaced by σ̃_ν = −ε [u_ν − g]_+ with
ε = ``Contact.penalty`` × ``forms.boundary_stiffness`` (the scaling of Nitsche's γ, so the
penalty factor compares with γ0). Besides j_a the Γ3 part of the residual is
S = ∫_Γ3 ε [u_ν − g]_+ v_ν: no stress appears, so the method is simple and symmetric, but
inconsistent: the body penetrates by O(1/ε), and the Jacobian's condition number grows like ε.
"""
import ngsolve as ngs

from ..contact_laws import positive_part
from ..forms import boundary_stiffness


class Penalty:
    """The Γ3 expressions of the penalty method (``enforcement.Enforcement``)."""

    newton_hook = None
    condensable = True

    def __init__(self, body, contact, side, *, gap, coefficients, normal):
        self.gap = gap
        self.n = normal
        self.epsilon = contact.penalty * boundary_stiffness(body, coefficients.rate)

    @classmethod
    def keeps_symmetry(cls, contact):
        return True

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
