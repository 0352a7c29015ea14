"""The penalty method for the contact law (2.8): a stiff normal compliance at the gap.

The Signorini part of (2.8) is replaced by σ̃_ν = −ε [u_ν − g]_+, ε = penalty p² (stiffness)/h
(the scaling of Nitsche's γ, so ``Contact.penalty`` compares with ``gamma0``). The Γ3 part of
the residual is ∫_Γ3 (p(u_ν) − γ_ν β² R_ν(u_ν) + ε [u_ν − g]_+) v_ν: no stress appears, so
the method is simple and symmetric, but inconsistent: the body penetrates by O(1/ε), and
the Jacobian's condition number grows like ε.
"""
import ngsolve as ngs

from .contact_laws import positive_part
from .nitsche import NitscheContact, nitsche_parameter


class PenaltyContact(NitscheContact):
    """Expressions of the Γ3 terms with the penalty method (same interface as Nitsche's)."""

    def __init__(self, body, contact, beta, inv_dt, gap):
        super().__init__(body, contact, beta, inv_dt, gap)
        self.epsilon = nitsche_parameter(body, contact.penalty, inv_dt)

    def multiplier(self, u, phi, u_old):
        """λ_h = ε [u_ν − g]_+, the penalty contact pressure (Pa)."""
        return self.epsilon * positive_part(u * self.n - self.gap)

    def active(self, u, phi, u_old):
        """1 where the body penetrates (u_ν >= g), else 0."""
        return ngs.IfPos(self.gap - u * self.n, 0, 1)

    def residual(self, u, phi, v, xi, u_old):
        return (self.surface_traction(u) + self.multiplier(u, phi, u_old)) * (v * self.n)
