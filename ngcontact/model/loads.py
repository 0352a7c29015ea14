"""Data of (2.1)-(2.6): body force f0, tractions f2 on Γ2, charge density q0, surface
charge qb on Γb, the potential of the electrodes Γa, and the displacements of the supports.

Every entry is a number, a tuple of numbers, or an ngsolve CoefficientFunction that may
depend on the time ``Parameter`` handed to the simulation. Units: f0 in N/m³, f2 in Pa,
q0 in C/m³, qb in C/m², potentials in V, displacements in m.
"""
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ngcontact.model import axisymmetric
from ngcontact.model.body import split_names
from ngcontact.checks import number


def as_cf(value, dim=None, name="value"):
    """A number / tuple / CoefficientFunction as a CoefficientFunction of ``dim`` components."""
    if not isinstance(value, ngs.CoefficientFunction):
        items = value if isinstance(value, (tuple, list)) else (value,)
        if not items:
            raise TypeError(f"{name} must be a number, a tuple of numbers or a CoefficientFunction, got {value!r}")
        for item in items:
            if not isinstance(item, ngs.CoefficientFunction):
                number(name, item)
    cf = value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(
        tuple(value) if isinstance(value, (tuple, list)) else value)
    if cf.is_complex:
        raise TypeError(f"{name} must be real, got a complex CoefficientFunction")
    if dim is not None and cf.dim != dim:
        raise ValueError(f"{name} must have {dim} components, got {cf.dim}")
    return cf


@dataclass
class Loads:
    """Loads of the body; dictionaries are keyed by boundary name (or "a|b"). Each value is
    checked when the Loads are made (a number, tuple of numbers or CoefficientFunction;
    finite), its boundaries and components when a Simulation takes them (``check``)."""
    f0: object = None
    f2: dict = field(default_factory=dict)
    q0: object = None
    qb: dict = field(default_factory=dict)
    potential: dict = field(default_factory=dict)
    displacement: dict = field(default_factory=dict)

    def __post_init__(self):
        for entry in ("f0", "q0"):
            if getattr(self, entry) is not None:
                as_cf(getattr(self, entry), None, f"Loads.{entry}")
        for entry in ("f2", "qb", "potential", "displacement"):
            value = getattr(self, entry)
            if not isinstance(value, dict) or not all(isinstance(key, str) for key in value):
                raise TypeError(f"Loads.{entry} must be a dict {{boundary names (str): value}}, got {value!r}")
            for key, item in value.items():
                as_cf(item, None, f"Loads.{entry}[{key!r}]")

    def coefficients(self):
        """(name, value) of every entry, for the checks of ``Simulation``."""
        named = [("Loads.f0", self.f0), ("Loads.q0", self.q0)]
        for entry in ("f2", "qb", "potential", "displacement"):
            named += [(f"Loads.{entry}[{key!r}]", value) for key, value in getattr(self, entry).items()]
        out = []
        for name, value in named:
            values = value if isinstance(value, (tuple, list)) else [value]
            out += [(name, v) for v in values if isinstance(v, ngs.CoefficientFunction)]
        return out

    def nonfinite(self, body):
        """The name of the first entry that is not finite on its region at the current value of
        the time Parameter, or None."""
        mesh, kin = body.mesh, body.kinematics
        entries = [("f0", self.f0, kin.dx, ()), ("q0", self.q0, kin.dx, ())]
        for entry in ("f2", "qb", "potential", "displacement"):
            entries += [(f"{entry}[{key!r}]", value, kin.ds, (mesh.Boundaries(key),))
                        for key, value in getattr(self, entry).items()]
        for name, value, integral, region in entries:
            if value is not None:
                cf = as_cf(value, None, f"Loads.{name}")
                if not np.isfinite(ngs.Integrate(integral(ngs.InnerProduct(cf, cf), *region, weighted=False), mesh)):
                    return f"Loads.{name}"
        return None

    def check(self, body):
        """Each boundary key must lie on its part of ∂Ω: f2 on Γ2 (and the supports that leave
        components free), qb on Γb \\ Γ3, potential on Γa; each displacement key within one
        support of ``body.supports`` (its value: one number per fixed component). On a body of
        revolution no f2 or qb on its axis, and u_r = 0 there (``axisymmetric.check_loads``)."""
        held = [n for s in body.supports if len(s.axes) == body.dim for n in s.names]
        allowed = {"f2": [n for n in body.free_names(("clamped", "contact_side")) if n not in held],
                   "qb": body.free_names(("grounded", "contact_side")),
                   "potential": body.boundaries["grounded"]}
        for entry, names in allowed.items():
            for key in getattr(self, entry):
                wrong = [n for n in split_names(key) if n not in names]
                if wrong:
                    raise ValueError(f"Loads.{entry}: boundary {wrong} is not allowed; allowed "
                                     f"names are {names}")
        for key, value in self.displacement.items():
            support = body.support_of(key)
            if support.normal and not (isinstance(value, (int, float)) and value == 0):
                raise ValueError(f"Loads.displacement[{key!r}]: the normal support {support.key!r} is not "
                                 "along an axis, where only u·ν = 0 is offered (weak, Nitsche); got "
                                 f"{value!r}")
            as_cf(value, support.size, f"Loads.displacement[{key!r}] (support {support.key!r}: "
                                       f"{support.size} fixed component(s))")
        if body.axisymmetric:
            axisymmetric.check_loads(body, self)
