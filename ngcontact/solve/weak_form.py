"""The weak form of one time step, term by term, on the body's measures (docs/model.md).

Step n of the scheme finds x = (u, φ) such that for all (v, ξ)

  R(x; v, ξ) = a(c (u − û), v) + b(u, v) + e(v, φ) + e(u, ξ) − c(φ, ξ)      on Ω   (2.30)-(2.31)
             + j_a(β_n, u, v) + S(x; v, ξ) − j_e(u, φ, ξ)                  on Γ3  (2.28)-(2.29)
             + the Nitsche terms of the weak normal supports
             − f(v, ξ) = 0                                                          (2.26)-(2.27)

with the time scheme's rate coefficient c and anchor û (``schemes.StepCoefficients``;
backward Euler: 1/dt and u_{n−1}, the paper's (4.3)-(4.5)), a and b replaced by
(A(c ε(u − û)), ε(v)) and (F(ε(u)), ε(v)) where laws give them (2.16)-(2.17). Each term is an
integral on the measures of the body's kinematics (``Kinematics.dx``, ``ds``: 2π r for a body of
revolution); its integrand is ``model.forms``' (Ω) or ``gamma3.integrands``' (Γ3). ``WeakForm``
builds them once and says what the Jacobian is: ``linear``, ``symmetric``, ``condensable``.
``StepSystem`` assembles it.
"""
from __future__ import annotations

from ngcontact.gamma3 import integrands
from ngcontact.gamma3.contact_side import element_boundary_layer
from ngcontact.model import forms
from ngcontact.model.supports import SLIP_GAMMA0, weak_regions


class WeakForm:
    """R(x; v, ξ) of a step for a Body under Loads, with the time scheme's ``coefficients``
    (t_n, c, û); its Γ3 part comes with ``attach_gamma3`` (``gamma3.build``), without one Γ3 is
    traction-free and charge-free.

    Parameters
    ----------
    body, loads : Body and Loads.
    coefficients : ``schemes.StepCoefficients`` (read here, written by the scheme only).
    contact : the Contact of Γ3 or None (what the Jacobian's symmetry depends on).
    """

    def __init__(self, body, loads, coefficients, contact=None):
        self.body, self.loads, self.coefficients, self.contact = body, loads, coefficients, contact
        self.kinematics, self.tensors = body.kinematics, body.tensors
        self._gamma3 = None

    # ------------------------------------------------------------------ what the Jacobian is
    @property
    def linear(self):
        """R is affine in x: constant tensors and no Γ3 terms."""
        return self.tensors.linear and self.contact is None

    @property
    def symmetric(self):
        """The Jacobian is symmetric: constant tensors (a law's Nitsche term is not) and a Γ3
        method that keeps it so (``Contact.symmetric``), or no Γ3."""
        return self.tensors.linear and (self.contact is None or self.contact.symmetric)

    @property
    def condensable(self):
        """Interior DOFs may be condensed statically: constant tensors (a law makes the
        interiors nonlinear) and a Γ3 method without unknowns of its own."""
        return self.tensors.linear and (self.contact is None or self.contact.enforcement_method.condensable)

    # ------------------------------------------------------------------ the terms on Ω
    def a(self, u, v):
        """a(u, v) = (A ε(u), ε(v)), the viscosity (2.30) (A linear: a law's tangent at 0)."""
        return self.kinematics.dx(forms.a(self.tensors, u, v))

    def bulk(self, trial, test):
        """b(u, v) + e(v, φ) + e(u, ξ) − c(φ, ξ): the elastic and electric part with constant
        coefficients (with laws: b only where F is linear, ``forms.linear_bulk``)."""
        T = self.tensors
        return self.kinematics.dx(forms.bulk(T, trial, test) if T.linear else forms.linear_bulk(T, trial, test))

    def stepped_bulk(self, trial, test):
        """b + e + e − c + c a: the bulk of the step's Jacobian with linear tensors (static
        condensation assembles it whole)."""
        T = self.tensors
        bulk = forms.bulk(T, trial, test)
        if T.viscous:
            bulk = bulk + self.coefficients.rate * forms.a(T, trial[0], test[0])
        return self.kinematics.dx(bulk)

    def f(self, test):
        """f(v, ξ) (2.26)-(2.27): the loads, a list of integrals."""
        return forms.f(self.body, self.loads, test)

    def laws(self, u, v, bonus_intorder):
        """N(x; v): the terms the laws give (2.16)-(2.17), on Ω and on the weak supports,
        nonlinear in u, with ``bonus_intorder`` more quadrature orders (``law_terms``): a list of
        integrals; None without laws."""
        T, kin, coefficients = self.tensors, self.kinematics, self.coefficients
        if T.linear:
            return None
        integrals = [kin.dx(forms.nonlinear_bulk(T, u, v, coefficients.rate, coefficients.anchor).Compile(),
                            bonus_intorder=bonus_intorder)]
        for region in weak_regions(self.body.mesh, self.body.supports):
            integral, indicator = element_boundary_layer(kin, self.body.mesh, region, bonus_intorder)
            term = forms.weak_normal_support_laws(T, self.body.order, u, v, coefficients.rate, coefficients.anchor,
                                                  SLIP_GAMMA0)
            integrals.append(integral((indicator * term).Compile()))
        return integrals

    def laws_tangent(self, u, v):
        """The laws' tangents at 0 (b where F is a law, c a where A is one): Newton's scales."""
        T = self.tensors
        tangent = 0
        if T.F_law is not None:
            tangent = tangent + forms.b(T, u, v)
        if T.A_law is not None:
            tangent = tangent + self.coefficients.rate * forms.a(T, u, v)
        return self.kinematics.dx(tangent)

    def supports(self, trial, test):
        """The Nitsche terms of the weak normal supports (``forms.weak_normal_support``; with
        laws their linear part, the rest in ``laws``) as (elastic, viscous per unit c, integral):
        the integrands on the element boundaries at each support and the function that
        integrates them there (``integral(elastic)``); viscous None for an elastic body."""
        terms = []
        for region in weak_regions(self.body.mesh, self.body.supports):
            integral, indicator = element_boundary_layer(self.kinematics, self.body.mesh, region)
            elastic, viscous = forms.weak_normal_support(self.tensors, self.body.order, trial, test, SLIP_GAMMA0)
            terms.append((indicator * elastic, None if viscous is None else indicator * viscous, integral))
        return terms

    def preconditioner(self, u, v, phi, xi, rate):
        """The SPD forms block preconditioners approximate (``forms.preconditioner_forms``), as
        integrands to put on ``Kinematics.dx``."""
        return forms.preconditioner_forms(self.body, u, v, phi, xi, rate)

    # ------------------------------------------------------------------ the terms on Γ3
    def attach_gamma3(self, enforcement, beta, gap, foundation_potential, normal):
        """The Γ3 part j_a + S − j_e with the enforcement method, the bonding field's
        GridFunction ``beta``, the gap, φ_Γ and the contact normal (``gamma3.build``)."""
        self._gamma3 = (enforcement, beta, gap, foundation_potential, normal)

    def gamma3(self, state, test):
        """The integrand of j_a(β, u, v) + S(x; v, ξ) − j_e(u, φ, ξ) on Γ3 for the state (trial
        functions or GridFunctions) and the test functions (``gamma3.integrands.contact_terms``)."""
        if self._gamma3 is None:
            raise RuntimeError("the weak form has no Γ3 part (gamma3.build attaches it)")
        enforcement, beta, gap, foundation_potential, normal = self._gamma3
        return integrands.contact_terms(self.contact, enforcement, beta, gap, foundation_potential, state, test,
                                        normal)

    def __repr__(self):
        kinds = [k for k in ("linear", "symmetric", "condensable") if getattr(self, k)]
        return f"WeakForm({self.kinematics.name}, {', '.join(kinds) or 'nonlinear, non-symmetric'})"

