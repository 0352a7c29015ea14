"""How the Signorini condition of (2.8) is enforced on Γ3: the methods and their protocols.

A method is an object a user hands to ``Contact(method=...)`` (``Method``): ``Nitsche(theta,
gamma0)``, ``Penalty(factor)``, ``NodalConstraint()``; the names in ``METHODS`` are shorthands
for them with the parameters read from ``Contact``'s fields (``resolve``). A method answers what
the rest of the package asks of it (symmetry, condensation, distribution, its stiffness, its
warnings) and ``build``s its Γ3 expressions (``Enforcement``) for a body. To add a method: one
module in this package with such a class (or an object of the user's), and, for a shorthand,
one line in ``METHODS``. No other module compares a method's name.
"""
from typing import Protocol

from .active_set import NodalConstraint
from .nitsche import Nitsche
from .penalty import Penalty


class Method(Protocol):
    """The protocol of an enforcement method as ``Contact(method=...)`` takes it."""

    name: str
    """A short name for messages, records and the fingerprint (the shorthand, if it has one)."""
    keeps_symmetry: bool
    """Whether the method's Γ3 term keeps the step Jacobian symmetric."""
    skew_symmetric: bool
    """Whether the Jacobian's Γ3 part is skew (a kept factorisation of the symmetric part is not used)."""
    condensable: bool
    """Whether static condensation may eliminate element-interior DOFs."""
    distributable: bool
    """Whether it runs on a distributed mesh (else ``serial_only``: (what it is, why))."""
    takes_obstacle: bool
    """Whether it acts along an obstacle's normal (else ``check_obstacle()`` raises)."""

    def contact_fields(self) -> dict:
        """{field of ``Contact``: value} that stand for its parameters (θ, γ0, penalty)."""

    def stiffness_factors(self) -> dict:
        """{name: factor} of its Γ3 stiffnesses in multiples of ``forms.boundary_stiffness``."""

    def flags(self) -> list:
        """Messages on parameters with which its results may be wrong."""

    def build(self, body, contact, side, *, gap, coefficients, normal) -> "Enforcement":
        """Its Γ3 expressions: the Body, the Contact data, the ContactSide Γ3, the gap g
        (CoefficientFunction, m), the time scheme's ``schemes.StepCoefficients`` (the rate
        coefficient c, 1/s, and the anchor û of the viscous stress c A ε(u − û); backward
        Euler: 1/dt and u_{n−1}) and the contact normal (the body's ν, or an obstacle's n_o):
        u_ν = u·normal, σ_ν = σν·normal."""


class Enforcement(Protocol):
    """The protocol of a method's Γ3 expressions (``Method.build``).

    ``traction`` below is p(u_ν) − γ_ν β² R_ν(u_ν) (Pa), the integrand of j_a (2.28), so that
    σ̃_ν = σ_ν + traction; j_a itself is in ``forms.contact_terms``.
    """

    newton_hook: object
    """None, or an object that takes part in every Newton iteration (``NewtonHook``):
    extra unknowns such as the nodal multipliers of the active set method."""

    def signorini(self, u, phi, v, xi, traction):
        """S(x; v, ξ): the Γ3 integrand, linear in the test functions (v, ξ), that imposes
        u_ν <= g, σ̃_ν <= 0, σ̃_ν (u_ν − g) = 0 for the state x = (u, φ)."""

    def multiplier(self, u, phi, traction):
        """λ_h >= 0, the contact pressure of the rigid foundation (Pa), a CoefficientFunction."""

    def active(self, u, phi, traction):
        """1 where the constraint is active (u_ν reaches g), else 0."""

    def contact_distance(self, u, phi, traction):
        """The method's contact state as a distance (m): >= 0 where it presses, u_ν − g where the
        body is free; the argument of ψ with ``Contact(gating="pressure")``."""


class NewtonHook(Protocol):
    """Unknowns of an enforcement method solved inside Newton (e.g. nodal multipliers).

    ``forces``: its contribution to the residual (a vector); ``solver``: the name of the
    linear solver it uses."""

    def start(self):
        """A new solve begins."""

    def residual(self, x, r, norm) -> tuple:
        """Add ``forces`` to the residual r = R(x); return (the scaled norm of the whole
        residual, with the ``ResidualNorm`` norm, and whether its own unknowns have settled,
        so that the solve may stop)."""

    def correct(self, system, x, r, timer):
        """The Newton correction: update x (and its own unknowns) in place; the Jacobian
        R'(x) is assembled in ``system.mat``."""

    def finish(self):
        """The solve converged."""


METHODS = {
    "nitsche": Nitsche,
    "penalty": Penalty,
    "active_set": NodalConstraint,
}
"""The shorthands ``Contact(method=...)`` takes, and the method classes they stand for."""


def resolve(contact):
    """The ``Method`` of ``contact``: its ``method`` if an object, else the class of the
    shorthand built from the Contact's fields (``from_contact``). The Contact has checked
    the name."""
    method = contact.method
    return METHODS[method].from_contact(contact) if isinstance(method, str) else method


__all__ = ["Method", "Enforcement", "NewtonHook", "METHODS", "resolve", "Nitsche", "Penalty", "NodalConstraint"]
