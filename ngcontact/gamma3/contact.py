"""The data of Γ3 (2.7)-(2.10) and of its enforcement method, with validation."""
import numbers
from dataclasses import dataclass

import ngsolve as ngs

from ngcontact.gamma3 import contact_laws as laws
from ngcontact.checks import number, parameters
from ngcontact.model.loads import as_cf
from ngcontact.gamma3 import enforcement
from ngcontact.gamma3.enforcement import CONTACT_FIELDS, METHODS, resolve
from ngcontact.gamma3 import obstacles


class _NotGiven:
    """The default of ``Contact.theta``, ``gamma0`` and ``penalty``: not given (a method that
    has the parameter takes its own default)."""
    __slots__ = ()

    def __repr__(self):
        return "NOT_GIVEN"

    def __reduce__(self):                # pickled and copied as the one object
        return "NOT_GIVEN"


NOT_GIVEN = _NotGiven()
"""A parameter of ``Contact`` left out: given explicitly it means the same."""

MEANING = {"theta": "θ, the variant of Nitsche's method (method='nitsche' or Nitsche(theta=...))",
           "gamma0": "γ0, the parameter of Nitsche's method (method='nitsche' or Nitsche(gamma0=...))",
           "penalty": "the factor of the penalty method (method='penalty' or Penalty(factor=...))"}
"""What each of ``CONTACT_FIELDS`` stands for, for the refusal of one a method ignores."""


@dataclass
class Contact:
    """Frictionless unilateral contact with a compliant layer, adhesion and a conductive
    foundation on Γ3. SI units; numbers or CoefficientFunctions where noted.

    Signorini (2.8) with gap, along the body's normal ν (the paper's form), or with an obstacle:
        gap : g >= 0 in m, number or CoefficientFunction on Γ3 (may use the time Parameter;
            checked on Γ3 at every step, with a tolerance of 1e-8 of the body's size).
        obstacle : a rigid obstacle (``ngcontact.obstacles``: Plane, Cylinder, Sphere,
            SignedDistance, or an object of the user's with the protocol ``obstacles.Obstacle``)
            giving the gap and the obstacle normal n_o, along which every law of Γ3 then acts;
            None (default): the paper's form with ``gap``.
        compliance : c_ν in Pa/m of p(r) = c_ν [r]_+, or a function r ↦ CF (any Lipschitz p
            >= 0 vanishing for r <= 0; sampled by ``contact_laws.checked``).
    Adhesion (2.8)-(2.9):
        adhesion : γ_ν >= 0 in Pa/m; the glue pulls back with γ_ν β² R_ν(u_ν).
        eps_a : ε_a >= 0, the healing threshold of (2.9) (1/s, with γ_ν R_ν² read as a rate).
        bond_length : L > 0 in m, the truncation of R_ν.
        beta0 : β0 in [0, 1], number or CoefficientFunction.
        beta_update : "explicit" (the paper's (4.5), stable while dt γ_ν L² <= 1) or
            "implicit" (β_n implicit in (2.9) with u_{n-1}: unconditionally stable, see
            ``adhesion``).
    Conductive foundation (2.7):
        conductance : k_e >= 0 of the default ψ (``contact_laws.conductance_ramp``), or a
            function r ↦ CF for ψ(r) >= 0, r = u_ν - g (e.g. ``conductance_literal(k_e, δ)``;
            sampled by ``contact_laws.checked``).
        ramp_width : δ > 0 in m of the default ψ.
        potential_truncation : L_φ > 0 in V.
        foundation_potential : φ_Γ in V, number or CoefficientFunction (may use the time
            Parameter).
        gating : what ψ reads: "gap" (the paper's ψ(u_ν − g), (2.7)) or "pressure" (ψ of the
            enforcement's contact state, Nitsche's −P_γ/γ: full conductance wherever the method
            presses, the same ψ(u_ν − g) where the body is free; docs/model.md).
    Enforcement of the Signorini condition (``ngcontact.gamma3.enforcement``):
        method : a method object, ``Nitsche(theta, gamma0)`` (Chouly-Hild θ-family),
            ``Penalty(factor)`` (a stiff normal compliance), ``NodalConstraint()`` (the paper's
            nodal constraint u_ν <= g at the nodes of Γ3, P1 only, with nodal multipliers) or
            one of the user's (``enforcement.Method``); or a shorthand of ``enforcement.METHODS``,
            "nitsche" (the default), "penalty" or "active_set", with the parameters below.
        theta : 1 (symmetric, the default), 0 (incomplete) or -1 (skew-symmetric); Nitsche only.
        gamma0 : γ0 > 0 (default 10); γ = γ0 p² (stiffness)/h, see ``forms.boundary_stiffness``;
            Nitsche only.
        penalty : > 0 (default 1e3), the penalty factor: ε = penalty p² (stiffness)/h; the
            penalty method only.
    Only what is given counts (``NOT_GIVEN``, the default, is not a value): one of theta, gamma0,
    penalty that the method does not take is refused (ValueError naming both), and with a
    method object they are read from it (given here as well, they must agree, else a
    ValueError naming both). Afterwards each holds the method's value, or ``NOT_GIVEN`` where
    the method has no such parameter. ``enforcement_method`` is the method object either way.
    """
    gap: object = 0.0
    obstacle: object = None
    compliance: object = 0.0
    adhesion: float = 0.0
    eps_a: float = 0.0
    bond_length: float = 1e-4
    beta0: object = 1.0
    beta_update: str = "explicit"
    conductance: object = 0.0
    ramp_width: float = 1e-7
    potential_truncation: float = 1e4
    foundation_potential: object = 0.0
    gating: str = "pressure"
    theta: int = NOT_GIVEN
    gamma0: float = NOT_GIVEN
    method: object = "nitsche"
    penalty: float = NOT_GIVEN

    def __post_init__(self):
        given = self.method
        if not isinstance(given, str):
            if not isinstance(given, type) and not any(hasattr(given, n) for n in ("build", "keeps_symmetry", "name")):
                raise TypeError(f"Contact.method must be one of {', '.join(map(repr, METHODS))} or a method object "
                                "(ngcontact.Nitsche, Penalty, NodalConstraint, or one with the protocol of "
                                f"ngcontact.gamma3.enforcement.Method), got {given!r}")
            enforcement.check(given)                   # every member of the protocol
        for name, allowed, words in (("method", tuple(METHODS), "one of " + ", ".join(map(repr, METHODS))),
                                     ("gating", ("gap", "pressure"), "'gap' or 'pressure'"),
                                     ("beta_update", ("explicit", "implicit"), "'explicit' or 'implicit'")):
            value = getattr(self, name)
            if name == "method" and not isinstance(value, str):
                continue
            if not isinstance(value, str) or value not in allowed:
                raise (ValueError if isinstance(value, str) else TypeError)(
                    f"Contact.{name} must be {words}, got {value!r}")
        if self.penalty is not NOT_GIVEN:
            number("Contact.penalty", self.penalty, 0, low_open=True)
        if self.theta is not NOT_GIVEN:
            if isinstance(self.theta, bool) or not isinstance(self.theta, numbers.Real):
                raise TypeError(f"Contact.theta must be 1, 0 or -1, got {self.theta!r} ({type(self.theta).__name__})")
            if self.theta not in (1, 0, -1):
                raise ValueError(f"Contact.theta must be 1, 0 or -1, got {self.theta!r}")
        if self.gamma0 is not NOT_GIVEN:
            number("Contact.gamma0 (Nitsche parameter)", self.gamma0, 0, low_open=True)
        # theta, gamma0 and penalty as given: ``from_contact`` of a shorthand reads them
        self.given_parameters = {n: getattr(self, n) for n in CONTACT_FIELDS if getattr(self, n) is not NOT_GIVEN}
        self.enforcement_method = resolve(self)
        fields = self.enforcement_method.contact_fields()
        for name, value in self.given_parameters.items():
            if name not in fields:
                raise ValueError(f"Contact.{name} = {value!r} means nothing with method {given!r}: {name} is "
                                 f"{MEANING[name]}; leave {name} out")
            if not isinstance(given, str) and value != fields[name]:
                raise ValueError(f"Contact.{name} = {value!r} contradicts method={given!r} (its {name} is "
                                 f"{fields[name]!r}): give {name} in one place")
        for name in CONTACT_FIELDS:                     # the method's values, as it uses them
            setattr(self, name, fields.get(name, NOT_GIVEN))
        number("Contact.bond_length", self.bond_length, 0, low_open=True, unit="m")
        number("Contact.ramp_width", self.ramp_width, 0, low_open=True, unit="m")
        number("Contact.potential_truncation", self.potential_truncation, 0, low_open=True, unit="V")
        for name in ("compliance", "conductance"):
            if not callable(getattr(self, name)) and not isinstance(getattr(self, name), ngs.CoefficientFunction):
                number(f"Contact.{name}", getattr(self, name), 0)
        if not isinstance(self.foundation_potential, ngs.CoefficientFunction):
            number("Contact.foundation_potential", self.foundation_potential, unit="V")
        for name in ("adhesion", "eps_a"):
            number(f"Contact.{name}", getattr(self, name), 0)
        if not isinstance(self.gap, ngs.CoefficientFunction):
            number("Contact.gap", self.gap, 0, unit="m")
        if not isinstance(self.beta0, ngs.CoefficientFunction):
            number("Contact.beta0", self.beta0, 0, 1)
        else:
            as_cf(self.beta0, 1, "Contact.beta0")                # real, one component
            if parameters(self.beta0):
                raise ValueError("Contact.beta0 depends on an ngsolve.Parameter (the time?): β0 is the bonding "
                                 "at the start, read once at t = 0, and β then follows (2.9); give β0 without "
                                 "a Parameter")
        if self.obstacle is not None:
            obstacles.check(self.obstacle)             # the protocol obstacles.Obstacle
            if isinstance(self.gap, ngs.CoefficientFunction) or self.gap != 0:
                raise ValueError("Contact: give either gap (the paper's form, along the body's normal) or "
                                 "obstacle (the gap comes from it), not both")
            if not self.enforcement_method.takes_obstacle:
                self.enforcement_method.check_obstacle()
                raise ValueError(f"Contact: the method {given!r} takes no obstacle (its takes_obstacle is False), "
                                 "but its check_obstacle() did not refuse one; give gap, or a method that takes "
                                 "an obstacle")
        for name in ("compliance", "conductance"):
            if isinstance(getattr(self, name), ngs.CoefficientFunction):
                raise TypeError(f"Contact.{name} must be a number >= 0 or a function r ↦ "
                                "CoefficientFunction (the law itself), not a CoefficientFunction")
        self.p = laws.checked("Contact.compliance", self.compliance, "p", 0.0) \
            if callable(self.compliance) else laws.compliance_law(self.compliance)
        self.rest_side = ngs.Parameter(0.0)    # R_ν's slope at u_ν = 0: 0 glued, 1 pressed (``switch_loop``)
        self.R = laws.bond_truncation(self.bond_length, self.rest_side)
        self.truncation_widening = ngs.Parameter(1.0)    # of φ_L's level, for ``continuation``
        self.phi_L = laws.potential_truncation(self.potential_truncation, self.truncation_widening)
        self.widening = ngs.Parameter(1.0)      # of ψ's ramp, for ``continuation`` (1: as given)
        self.psi = laws.checked("Contact.conductance", self.conductance, "ψ", -1.0) if callable(self.conductance) else \
            laws.conductance_ramp(self.conductance, self.ramp_width, self.widening)

    def coefficients(self):
        """(name, CoefficientFunction) of its data, for the checks of ``Simulation``."""
        named = [("Contact.gap", self.gap), ("Contact.foundation_potential", self.foundation_potential),
                 ("Contact.beta0", self.beta0)]
        for attribute, value in (obstacles.data(self.obstacle) if self.obstacle is not None else {}).items():
            named += [(f"Contact.obstacle.{attribute}", v) for v in (value if isinstance(value, (tuple, list)) else [value])]
        return [(n, v) for n, v in named if isinstance(v, ngs.CoefficientFunction)]

    def regularised(self):
        """[(name, widening Parameter, unit, width)] of the laws ``continuation`` may widen where
        the foundation conducts: ψ's ramp δ (m; the default law) and φ_L's level L_φ (V)."""
        if not self.conducts:
            return []
        ramp = [] if callable(self.conductance) else [("the conduction ramp δ", self.widening, "m", self.ramp_width)]
        return ramp + [("the potential truncation L_φ", self.truncation_widening, "V", self.potential_truncation)]

    @property
    def conducts(self):
        """True if the foundation conducts (ψ is not identically 0)."""
        return callable(self.conductance) or self.conductance > 0

    @property
    def symmetric(self):
        """True if the Newton Jacobian is symmetric: a method whose Signorini term keeps it so
        (Nitsche with θ = 1, penalty, the nodal constraint), with no compliant layer, no
        adhesion and no conduction (those terms are not symmetrised)."""
        return (self.enforcement_method.keeps_symmetry and not callable(self.compliance)
                and self.compliance == 0 and self.adhesion == 0 and not self.conducts)
