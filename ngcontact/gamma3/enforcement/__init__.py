"""How the Signorini condition of (2.8) is enforced on Γ3: the methods and their protocols.

A method is an object a user hands to ``Contact(method=...)`` (``Method``): ``Nitsche(theta,
gamma0)``, ``Penalty(factor)``, ``NodalConstraint()``; the names in ``METHODS`` are shorthands
for them with the parameters read from ``Contact``'s fields (``resolve``). A method answers what
the rest of the package asks of it (symmetry, condensation, distribution, its stiffness, its
warnings) and ``build``s its Γ3 expressions (``Enforcement``) for a body. To add a method: one
module in this package with such a class (or an object of the user's), and, for a shorthand,
one line in ``METHODS``. No other module compares a method's name.

A method object of the user's is checked member by member at ``Contact()`` (``check``: a
TypeError naming the members it lacks and its class), and what its ``build`` returns where the
simulation first calls it (``built``). ``ngcontact.methods`` is this package: the protocols, the
methods, and ``boundary_stiffness``, the stiffness scale a method's Γ3 terms are expressed in.
"""
import inspect
import numbers

import numpy as np
from typing import Protocol

from ngcontact.model.forms import boundary_stiffness
from .active_set import NodalConstraint
from .nitsche import Nitsche
from .penalty import Penalty

CONTACT_FIELDS = ("theta", "gamma0", "penalty")
"""The fields of ``Contact`` that may stand for a method's parameters (``Method.contact_fields``)."""


class Method(Protocol):
    """The protocol of an enforcement method as ``Contact(method=...)`` takes it (an instance,
    not its class): every member below but the optional ``parameters``, and ``serial_only``
    where ``distributable`` is False, ``check_obstacle`` where ``takes_obstacle`` is False
    (``check`` tests them at ``Contact()``)."""

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

    # Where ``distributable`` is False: ``serial_only``, (what it is, why it runs on one rank
    # only), two str. Where ``takes_obstacle`` is False: ``check_obstacle()``, raising a
    # ValueError that says why it takes no obstacle.

    def contact_fields(self) -> dict:
        """{field of ``Contact``: value} that stand for its parameters, keys among
        ``CONTACT_FIELDS`` (θ, γ0, penalty); {} if none do."""

    def stiffness_factors(self) -> dict:
        """{name (str): factor (real number)} of its Γ3 stiffnesses in multiples of
        ``boundary_stiffness`` (Nitsche's γ0, the penalty's factor): a failed step names those
        above ``admissible.STIFF_CONTACT``."""

    def flags(self) -> list:
        """Messages (str) on parameters with which its results may be wrong."""

    def parameters(self) -> dict:
        """Optional: {name: plain value (number, str, bool, None, or lists of them)} of its
        parameters for the run's fingerprint. Without it the fingerprint takes a dataclass's
        fields, else ``vars(method)`` without the names that start with "_"."""

    def build(self, body, contact, side, *, gap, coefficients, normal) -> "Enforcement":
        """Its Γ3 expressions: the Body, the Contact data, the ContactSide Γ3, the gap g
        (CoefficientFunction, m), the time scheme's ``schemes.StepCoefficients`` (the rate
        coefficient c, 1/s, and the anchor û of the viscous stress c A ε(u − û); backward
        Euler: 1/dt and u_{n−1}) and the contact normal (the body's ν, or an obstacle's n_o):
        u_ν = u·normal, σ_ν = σν·normal. A stiffness of its own (a penalty, Nitsche's γ) is a
        factor times ``boundary_stiffness(body, coefficients.rate)``."""


class Enforcement(Protocol):
    """The protocol of a method's Γ3 expressions (``Method.build``).

    ``traction`` below is p(u_ν) − γ_ν β² R_ν(u_ν) (Pa), the integrand of j_a (2.28), so that
    σ̃_ν = σ_ν + traction; j_a itself is in ``integrands.contact_terms``.
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

    ``forces``: its contribution to the residual (an ngsolve vector); ``solver``: the name of
    the linear solver it uses (str)."""

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

    def save(self):
        """Its unknowns, for a step that may be redone (``restore``)."""

    def restore(self, saved):
        """Its unknowns as ``save`` returned them (the step is redone)."""


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


FLAGS = ("keeps_symmetry", "skew_symmetric", "condensable", "distributable", "takes_obstacle")
"""The members of ``Method`` that are booleans."""
CALLS = ("contact_fields", "stiffness_factors", "flags", "build")
"""The methods of ``Method`` every method object has."""
EXPRESSIONS = ("signorini", "multiplier", "active", "contact_distance")
"""The methods of ``Enforcement``."""
HOOK = ("start", "residual", "correct", "finish", "save", "restore", "forces", "solver")
"""The members of ``NewtonHook``."""


def _class(value):
    return f"{type(value).__module__}.{type(value).__qualname__}"


def _missing(value, names):
    return [n for n in names if not hasattr(value, n)]


def _refuse(method, what):
    raise TypeError(f"Contact.method: the method object {_class(method)} {what} (the protocol "
                    "ngcontact.gamma3.enforcement.Method)")


def check(method):
    """Raise a TypeError if ``method`` lacks a member of ``Method`` or has one of the wrong type,
    naming the members and the object's class: its data, its methods (``build`` callable with
    the arguments the simulation gives), and what ``contact_fields``, ``stiffness_factors``
    and ``flags`` return (called here: they are cheap and have no effect)."""
    if isinstance(method, type):
        raise TypeError(f"Contact.method must be a method object, got the class {method.__qualname__}: "
                        f"give an instance, e.g. {method.__qualname__}()")
    missing = _missing(method, ("name",) + FLAGS + CALLS)
    if missing:
        _refuse(method, f"lacks {', '.join(missing)}")
    if not isinstance(method.name, str) or not method.name:
        _refuse(method, f"has name = {method.name!r}: it must be a nonempty str")
    wrong = [f"{n} = {getattr(method, n)!r}" for n in FLAGS if not isinstance(getattr(method, n), (bool, np.bool_))]
    if wrong:
        _refuse(method, f"has {', '.join(wrong)}: each must be True or False")
    missing = [f"{n} (needed as its {flag} is False)" for n, flag in (("serial_only", "distributable"),
                                                                      ("check_obstacle", "takes_obstacle"))
               if not getattr(method, flag) and not hasattr(method, n)]
    if missing:
        _refuse(method, f"lacks {' and '.join(missing)}")
    if not method.distributable and not (isinstance(method.serial_only, tuple) and len(method.serial_only) == 2
                                         and all(isinstance(w, str) for w in method.serial_only)):
        _refuse(method, f"has serial_only = {method.serial_only!r}: it must be (what it is, why it runs on one "
                        "rank only), two str")
    calls = CALLS + (() if method.takes_obstacle else ("check_obstacle",))
    wrong = [n for n in calls if not callable(getattr(method, n))]
    if wrong:
        _refuse(method, f"has {', '.join(f'{n} = {getattr(method, n)!r}' for n in wrong)}: not callable")
    try:
        inspect.signature(method.build).bind(None, None, None, gap=None, coefficients=None, normal=None)
    except TypeError as err:
        _refuse(method, f"has a build that does not take (body, contact, side, *, gap, coefficients, normal): {err}")
    except ValueError:                          # no signature to read (a builtin): it is called as it is
        pass
    fields = method.contact_fields()
    if not isinstance(fields, dict) or not set(fields) <= set(CONTACT_FIELDS):
        _refuse(method, f"returned {fields!r} from contact_fields(): it must be a dict with keys among "
                        f"{', '.join(CONTACT_FIELDS)} (the fields of Contact that stand for its parameters)")
    factors = method.stiffness_factors()
    if not isinstance(factors, dict) or not all(isinstance(k, str) and isinstance(v, numbers.Real)
                                                and not isinstance(v, bool) for k, v in factors.items()):
        _refuse(method, f"returned {factors!r} from stiffness_factors(): it must be a dict of str: real number")
    flags = method.flags()
    if not isinstance(flags, (list, tuple)) or not all(isinstance(m, str) for m in flags):
        _refuse(method, f"returned {flags!r} from flags(): it must be a list of str (messages)")


def built(method, body, contact, side, *, gap, coefficients, normal):
    """``method.build(...)``, checked: a TypeError naming the method's class and what it returned
    if that lacks a member of ``Enforcement`` (or its ``newton_hook`` one of ``NewtonHook``)."""
    terms = method.build(body, contact, side, gap=gap, coefficients=coefficients, normal=normal)
    shown = repr(terms)
    shown = shown if len(shown) <= 80 else shown[:80] + " ..."
    missing = [n for n in EXPRESSIONS if not callable(getattr(terms, n, None))] + _missing(terms, ("newton_hook",))
    if terms is None or missing:
        raise TypeError(f"Contact.method: {_class(method)}.build returned {shown}"
                        + ("" if terms is None else f" ({type(terms).__qualname__}), which lacks {', '.join(missing)}")
                        + ": it must return the Γ3 expressions (the protocol ngcontact.gamma3.enforcement."
                          f"Enforcement: {', '.join(EXPRESSIONS)} and newton_hook)")
    hook = terms.newton_hook
    if hook is not None and _missing(hook, HOOK):
        raise TypeError(f"Contact.method: the newton_hook of what {_class(method)}.build returned "
                        f"({type(hook).__qualname__}) lacks {', '.join(_missing(hook, HOOK))} (the protocol "
                        "ngcontact.gamma3.enforcement.NewtonHook)")
    return terms


__all__ = ["Method", "Enforcement", "NewtonHook", "METHODS", "CONTACT_FIELDS", "resolve", "check", "built",
           "boundary_stiffness", "Nitsche", "Penalty", "NodalConstraint"]
