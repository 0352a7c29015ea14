"""Γ3 of a simulation, built from its Contact data: the side, the gap and contact normal, the
bonding field β, the enforcement method, and the Γ3 terms of the step residual.

``build`` checks the data of Γ3 at t = 0 (finite, a gap >= 0, an obstacle normal pointing
into the obstacle) and adds the terms j_a + S − j_e of ``forms.contact_terms`` to the
``StepSystem``; it returns the ``observables.Gamma3`` the rest of the simulation reads and
the ``admissible.GapCheck`` that checks a time-dependent gap at every step.
"""
import ngsolve as ngs

from . import arguments, forms
from .adhesion import BondingField
from .admissible import GapCheck
from .contact_side import ContactSide
from .loads import as_cf
from .observables import Gamma3
from .obstacles import check_normal


def build(body, contact, system, realcompile=False):
    """(Gamma3, GapCheck) of ``contact`` on ``body``, its terms added to ``system`` (with the
    time scheme's coefficients ``system.coefficients``: the data are checked at t = 0);
    ``realcompile``: compile the Γ3 Jacobian's integrand to machine code now
    (``StepSystem.use_machine_code``)."""
    side = ContactSide(body)
    if contact.obstacle is not None:
        gap, normal = contact.obstacle.fields(body.dim)
        sampled_normal = normal
    else:
        gap, normal, sampled_normal = as_cf(contact.gap, 1, "Contact.gap"), ngs.specialcf.normal(body.dim), None
    foundation_potential = as_cf(contact.foundation_potential, 1, "Contact.foundation_potential")
    data = Gamma3(side, contact, None, None, gap, foundation_potential, normal, sampled_normal)
    coefficients = system.coefficients
    arguments.gamma3_data(contact, data, body.mesh, coefficients.at, 0.0)
    gap_check = GapCheck(body, data)
    with coefficients.at(0.0):
        gap_check(0.0)
        if sampled_normal is not None:
            check_normal(side, gap, normal, body.size)
    beta = BondingField(side, contact)
    enforcement = contact.enforcement_method.build(body, contact, side, gap=gap, coefficients=coefficients,
                                          normal=normal)

    def terms(state, test):
        return forms.contact_terms(contact, enforcement, beta.gf, gap, foundation_potential, state, test, normal)
    system.add_boundary_terms(terms, side, realcompile=realcompile)
    return Gamma3(side, contact, enforcement, beta, gap, foundation_potential, normal, sampled_normal), gap_check
