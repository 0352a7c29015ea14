"""Γ3 of a simulation, built from its Contact data: the side, the gap and contact normal, the
bonding field β, the enforcement method, and the Γ3 terms of the step residual.

``build`` checks the data of Γ3 at t = 0 (finite, a gap >= 0, an obstacle normal pointing
into the obstacle), attaches the enforcement method, β, the gap and the normal to the step's
weak form (its Γ3 part j_a + S − j_e, ``integrands.contact_terms``) and adds that part to the
``StepSystem``; it returns the ``Gamma3`` the rest of the simulation reads and
the ``admissible.GapCheck`` that checks a time-dependent gap at every step.
"""
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.gamma3.adhesion import BondingField
from ngcontact.model.admissible import GapCheck
from ngcontact.gamma3.contact_side import ContactSide
from ngcontact.model.loads import as_cf
from ngcontact.gamma3.obstacles import check_normal, named_direction, obstacle_fields
from ngcontact.gamma3.enforcement import built
from ngcontact.gamma3.integrands import adhesion_traction


@dataclass(frozen=True)
class Gamma3:
    """Γ3 of a simulation: the ContactSide ``side``, the Contact data ``contact``, its
    ``enforcement`` method, the BondingField ``beta``, the ``gap`` g (m) and
    ``foundation_potential`` φ_Γ (V) as CoefficientFunctions, and the contact ``normal``
    (the body's ν, or an obstacle's n_o) with ``sampled_normal``: the obstacle normal to
    sample at points, None for the facet normals."""
    side: object
    contact: object
    enforcement: object
    beta: object
    gap: object
    foundation_potential: object
    normal: object
    sampled_normal: object = None

    def multiplier(self, u, phi):
        """λ_h >= 0 (Pa), the rigid foundation's contact pressure of the state (u, φ) as the
        enforcement method defines it (Nitsche: −[P_γ]₋), a CoefficientFunction on Γ3; the
        body's normal stress is −σ_ν = λ_h + p(u_ν) − γ_ν β² R_ν(u_ν) (``contact_pressure``)."""
        return self.enforcement.multiplier(u, phi, self.traction(u))

    def traction(self, u):
        """p(u_ν) − γ_ν β² R_ν(u_ν) (Pa), the compliant layer's and the glue's normal traction
        of the displacement u (the integrand of j_a, (2.28))."""
        return adhesion_traction(self.contact, self.beta.gf, u * self.normal)

    def contact_pressure(self, u, phi):
        """−σ_ν = λ_h + p(u_ν) − γ_ν β² R_ν(u_ν) (Pa), the normal compressive stress on Γ3
        (positive where the body is pressed; the glue pulls it below zero)."""
        return self.multiplier(u, phi) + self.traction(u)


def gamma3_data(contact, gamma3, mesh, at, t):
    """The data of Γ3 written as CoefficientFunctions (gap, an obstacle's gap and normal, the
    foundation potential) must be finite on Γ3 at time t (s; evaluated inside ``at(t)``, the
    time scheme's ``StepCoefficients.at``): else a ValueError naming it, before Newton meets
    NaN."""
    named = [("Contact.foundation_potential", gamma3.foundation_potential)] \
        if isinstance(contact.foundation_potential, ngs.CoefficientFunction) else []
    if contact.obstacle is not None:
        named += [("Contact.obstacle: its gap (the distance to it)", gamma3.gap),
                  ("Contact.obstacle: its normal", gamma3.normal)]
    elif isinstance(contact.gap, ngs.CoefficientFunction):
        named.append(("Contact.gap", gamma3.gap))
    if not named:
        return
    with at(t):
        for name, cf in named:
            if parallel.any_rank(mesh, not np.all(np.isfinite(gamma3.side.sample(cf)))):
                raise ValueError(f"{name} is not finite (NaN or inf) on Γ3 at t = {t:.6g} s")


def build(body, contact, system, realcompile=False):
    """(Gamma3, GapCheck) of ``contact`` on ``body``, its terms added to ``system`` (with the
    time scheme's coefficients ``system.coefficients``: the data are checked at t = 0);
    ``realcompile``: compile the Γ3 Jacobian's integrand to machine code now
    (``StepSystem.use_machine_code``)."""
    side = ContactSide(body)
    coefficients = system.coefficients
    if contact.obstacle is not None:
        gap, normal = obstacle_fields(contact.obstacle, body.dim, coefficients.time)     # checked
        sampled_normal = normal
    else:
        gap, normal, sampled_normal = as_cf(contact.gap, 1, "Contact.gap"), ngs.specialcf.normal(body.dim), None
    foundation_potential = as_cf(contact.foundation_potential, 1, "Contact.foundation_potential")
    data = Gamma3(side, contact, None, None, gap, foundation_potential, normal, sampled_normal)
    gamma3_data(contact, data, body.mesh, coefficients.at, 0.0)
    gap_check = GapCheck(body, data)
    with coefficients.at(0.0):
        gap_check(0.0)
        if sampled_normal is not None:
            check_normal(side, gap, normal, body.size, named_direction(contact.obstacle))
    beta = BondingField(side, contact)
    enforcement = built(contact.enforcement_method, body, contact, side, gap=gap, coefficients=coefficients,
                        normal=normal)                    # checked: the Enforcement protocol

    system.weak_form.attach_gamma3(enforcement, beta.gf, gap, foundation_potential, normal)
    system.add_boundary_terms(side, realcompile=realcompile)
    return Gamma3(side, contact, enforcement, beta, gap, foundation_potential, normal, sampled_normal), gap_check
