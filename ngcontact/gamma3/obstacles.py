"""Rigid obstacles: the foundation given as a geometry (``Contact(obstacle=...)``).

An obstacle gives, at each point x of Γ3 (reference configuration), the gap g(x) (m, the
distance to the obstacle, >= 0 where the body is clear of it) and the obstacle normal n_o(x),
a unit vector pointing from the body into the obstacle (on a flat Γ3 lying on a plane
obstacle n_o = ν, the body's outward normal). Then the normal displacement is u_n = u·n_o,
the normal stress σ_n = n_o·σν, and Signorini u_n ≤ g, the compliant layer p(u_n), the glue
γ_ν β² R_ν(u_n) and the conduction law ψ(u_n − g) act along n_o (docs/model.md, with ν
replaced by n_o). The paper's form, the body's ν with a given gap, is what a flat Γ3 on a
plane reduces to; on a curved Γ3 at P1, ν jumps at every vertex and its Nitsche multiplier
oscillates inside each facet, while n_o is smooth (docs/curved_contact.md).

Points, centres and distances may be CoefficientFunctions of the time Parameter (an
indenter driven into the body: g < 0 ahead of it is then the prescribed approach). At t = 0
the obstacle must not intersect the body beyond a tolerance, and n_o must be a unit field
pointing into the obstacle where the body is closest to it (``Simulation`` checks both,
``check_normal``). ``Plane`` and ``SignedDistance`` take the direction as ``outward``, the
normal pointing out of the obstacle towards the body (n_o = −outward); errors name it as
the user passed it.

An obstacle of the user's is any object that follows ``Obstacle`` (its ``fields(dim)``):
``Contact()`` checks it (``check``: a TypeError naming ``Contact.obstacle`` and what it lacks),
and what ``fields`` returns is checked where the simulation first calls it (``obstacle_fields``).
"""
import inspect
import warnings
from typing import Protocol

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.checks import number, uses_only
from ngcontact.model.loads import as_cf
from ngcontact.moved import REMOVED_IN

NEAR = 0.05
"""``check_normal`` looks at the points of Γ3 whose gap is within this fraction of the
body's size of the smallest gap."""


class Obstacle(Protocol):
    """What ``Contact(obstacle=...)`` and the contact side read of a rigid obstacle (an instance, not its class).

    Its public attributes (``vars()`` without the names that start with "_") are its data: the
    run's fingerprint samples them on Γ3 (so that a run is never resumed with another obstacle),
    and the CoefficientFunctions among them (or in tuples and lists of them) may depend on no
    ngsolve.Parameter but the simulation's time.
    """

    def fields(self, dim):
        """(g, n_o) in ``dim`` D (2 or 3) at the points of Γ3 in the reference configuration: the
        gap g (m; a scalar CoefficientFunction or number, >= 0 where the body is clear of the
        obstacle, the distance to it) and the obstacle normal n_o (a unit vector of ``dim``
        components, CoefficientFunction or tuple, pointing from the body into the obstacle).
        Both may depend on the simulation's time Parameter (a moving obstacle) and on position.
        Called once when the simulation is built; a ValueError for a ``dim`` it cannot serve."""


def check(obstacle):
    """Raise a TypeError naming ``Contact.obstacle`` and the object's class if ``obstacle`` is a
    class, or lacks ``fields`` callable as ``fields(dim)`` (the protocol ``Obstacle``)."""
    kind = _class(obstacle)
    protocol = "(the protocol ngcontact.obstacles.Obstacle: fields(dim) returning the gap and the obstacle normal)"
    if isinstance(obstacle, type):
        raise TypeError(f"Contact.obstacle must be an obstacle object, got the class {obstacle.__qualname__}: give an "
                        f"instance, e.g. {obstacle.__qualname__}(...) {protocol}")
    fields = getattr(obstacle, "fields", None)
    if fields is None:
        raise TypeError(f"Contact.obstacle must be an ngcontact.obstacles Plane, Cylinder, Sphere or SignedDistance, "
                        f"or an object of the user's with fields(dim); got {obstacle!r:.80} ({kind}), which lacks "
                        f"fields {protocol}")
    if not callable(fields):
        raise TypeError(f"Contact.obstacle: the obstacle {kind} has fields = {fields!r:.60}: not callable {protocol}")
    try:
        inspect.signature(fields).bind(2)
    except TypeError as err:
        raise TypeError(f"Contact.obstacle: the obstacle {kind} has fields{inspect.signature(fields)}, which cannot "
                        f"be called as fields(dim): {err} {protocol}") from None
    except ValueError:                          # no signature to read (a builtin): it is called as it is
        pass


def obstacle_fields(obstacle, dim, time):
    """(g, n_o) of ``obstacle.fields(dim)`` as CoefficientFunctions, checked: a pair, g scalar and
    n_o of ``dim`` components, real, on no Parameter but ``time`` (the simulation's); else a
    TypeError or ValueError naming ``Contact.obstacle`` and the object's class."""
    kind = _class(obstacle)
    returned = obstacle.fields(dim)
    if not isinstance(returned, tuple) or len(returned) != 2:
        what = f"a {type(returned).__name__}" + (f" of {len(returned)}" if isinstance(returned, (tuple, list)) else "")
        raise TypeError(f"Contact.obstacle: {kind}.fields({dim}) returned {what}: it must return the pair (gap, "
                        "obstacle normal) (the protocol ngcontact.obstacles.Obstacle)")
    gap_name, normal_name = (f"Contact.obstacle: the {what} of {kind}.fields({dim})" for what in ("gap", "normal"))
    gap, normal = as_cf(returned[0], 1, gap_name), as_cf(returned[1], dim, normal_name)
    uses_only(time, [(gap_name, gap), (normal_name, normal)])
    return gap, normal


def data(obstacle):
    """{name: value} of the obstacle's public attributes (its data: ``Obstacle``); {} for an
    object without a ``__dict__``."""
    return {k: v for k, v in getattr(obstacle, "__dict__", {}).items() if not k.startswith("_")}


def named_direction(obstacle):
    """(the argument the user gave a built-in obstacle's direction as, s = ±1 with n_o = s × it)
    for the messages of ``check_normal``; None where the obstacle computes n_o itself (a ball, or
    one of the user's)."""
    return obstacle._given if isinstance(obstacle, (Plane, SignedDistance)) else None


def _class(value):
    return f"{type(value).__module__}.{type(value).__qualname__}"


def _position(dim):
    return ngs.CF((ngs.x, ngs.y, ngs.z)[:dim])


def _vector(value, dim, name):
    cf = as_cf(value, None, name)
    if cf.dim != dim:
        raise ValueError(f"{name} must have {dim} components in {dim}D, got {cf.dim}")
    return cf


def _which(owner, outward, normal, advice):
    """(value, name) of the direction given to ``owner`` as ``outward`` or as the deprecated
    ``normal`` (with ``advice``, what to pass instead); a TypeError if both or none."""
    if (outward is None) == (normal is None):
        raise TypeError(f"{owner}: give outward, the normal pointing out of the obstacle towards the body "
                        f"(got {'both outward and normal' if outward is not None else 'neither'})")
    if normal is None:
        return outward, "outward"
    warnings.warn(f"{owner}: normal is deprecated and will be removed in ngcontact {REMOVED_IN}: "
                  f"{advice}", DeprecationWarning, stacklevel=3)
    return normal, "normal"


class Plane:
    """The half-space obstacle {(x − point)·outward <= 0}.

    point : a point of the plane (m), a tuple or a CoefficientFunction (may move in time).
    outward : the plane's normal pointing out of the obstacle towards the body (any length,
        constant, normalised here), as for ``SignedDistance``; ``normal=`` is its deprecated
        name (the same direction).
    Gap g = (x − point)·outward/|outward|, obstacle normal n_o = −outward/|outward|.
    """

    def __init__(self, point, outward=None, *, normal=None):
        value, self._name = _which("Plane", outward, normal, "pass outward= (the same direction: out of the "
                                  "obstacle towards the body)")
        label = f"Plane: {self._name} (the normal pointing out of the obstacle towards the body)"
        as_cf(point, None, "Plane: point")
        self.point = point
        if not isinstance(value, (tuple, list, np.ndarray)):
            raise TypeError(f"{label} must be a vector of numbers, got {value!r}")
        try:
            value = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"{label} must be a vector of numbers, got {value!r}") from None
        if value.ndim != 1 or not np.all(np.isfinite(value)) or not np.linalg.norm(value) > 0:
            raise ValueError(f"{label} must be a nonzero finite vector, got {value.tolist()}")
        self.unit = value / np.linalg.norm(value)
        self._given = (f"Plane's {self._name}", -1)

    def fields(self, dim):
        """(gap g, obstacle normal n_o) as CoefficientFunctions in ``dim`` D."""
        if len(self.unit) != dim:
            raise ValueError(f"Plane: {self._name} (the normal pointing out of the obstacle) must have {dim} "
                             f"components in {dim}D, got {len(self.unit)}")
        m = ngs.CF(tuple(self.unit))
        return (_position(dim) - _vector(self.point, dim, "Plane: point")) * m, -m

    def __repr__(self):
        return f"Plane(point={self.point}, outward={self.unit.tolist()})"


class Ball:
    """A rigid disk (2D, a cylinder seen end-on) or ball (3D) of ``radius`` (m) about ``center``
    (m, tuple or CoefficientFunction, may move in time); the body lies outside it.
    Gap g = |x − c| − R, obstacle normal n_o = (c − x)/|x − c|."""

    def __init__(self, center, radius):
        as_cf(center, None, f"{type(self).__name__}: center")
        self.center = center
        self.radius = number(f"{type(self).__name__}: radius", radius, 0, low_open=True, unit="m")

    def fields(self, dim):
        d = _position(dim) - _vector(self.center, dim, f"{type(self).__name__}: center")
        distance = ngs.sqrt(d * d)
        return distance - self.radius, -d / distance

    def __repr__(self):
        return f"{type(self).__name__}(center={self.center}, radius={self.radius})"


class Cylinder(Ball):
    """The 2D rigid cylinder (a disk in the plane of the plate), as ``Ball``."""


class Sphere(Ball):
    """The 3D rigid ball, as ``Ball``."""


class SignedDistance:
    """An obstacle given by the user: ``distance`` g(x) (m, a scalar CoefficientFunction of
    position and time, >= 0 outside the obstacle) and ``outward``, a unit vector field pointing
    out of the obstacle towards the body (∇g where g is a distance; the direction of
    ``Plane``'s), so n_o = −outward (checked on Γ3 by ``Simulation``, ``check_normal``).
    ``normal`` (also the second positional argument) is deprecated: n_o itself, pointing into
    the obstacle, the opposite of ``outward``."""

    def __init__(self, distance, normal=None, *, outward=None):
        value, name = _which("SignedDistance", outward, normal, "normal points into the obstacle, the opposite "
                             "of Plane's; pass outward=-normal (out of the obstacle towards the body, as Plane's)")
        as_cf(distance, 1, "SignedDistance: distance")
        as_cf(value, None, f"SignedDistance: {name}")
        if name == "outward":        # n_o = −outward, numbers kept as numbers (``fingerprint``)
            plain = isinstance(value, (tuple, list)) and not any(isinstance(v, ngs.CoefficientFunction) for v in value)
            value = tuple(-float(v) for v in value) if plain else -as_cf(value, None, "SignedDistance: outward")
        self.distance, self.normal = distance, value            # self.normal: n_o
        self._given = (f"SignedDistance's {name}", -1 if name == "outward" else 1)

    def fields(self, dim):
        """(gap g, obstacle normal n_o) as CoefficientFunctions in ``dim`` D."""
        return as_cf(self.distance, 1, "SignedDistance: distance"), _vector(
            self.normal, dim, f"SignedDistance: {self._given[0].split()[-1]}")

    def __repr__(self):
        return "SignedDistance(...)"


OBSTACLES = (Plane, Ball, SignedDistance)
"""The obstacles of the package (the fingerprint names them by their class's name alone)."""


def check_normal(side, gap, normal, size, given=None):
    """The obstacle normal n_o (a CoefficientFunction) sampled on Γ3 (``side``, a
    ContactSide) at the time Parameter's value, with the gap (both finite,
    ``build.gamma3_data``): n_o must be a unit vector, and it must point from the body
    into the obstacle where the body is closest to it: n_o·ν > 0 somewhere and n_o·ν >= 0
    everywhere among the points whose gap is within ``NEAR`` × ``size`` (m, the body's size)
    of the smallest gap (ν the body's outward normal; a reversed n_o lets the body pass
    through the obstacle). ``given``: (the argument the user passed, e.g. "SignedDistance's
    outward", and s = ±1 with n_o = s × it), or None (the obstacle computes n_o). A ValueError
    naming that argument otherwise."""
    mesh = side.mesh
    name, sign = given or ("its normal n_o", 1)
    symbol = name.split()[-1]
    g, n = side.sample(gap), side.sample(normal)
    length = np.linalg.norm(n, axis=-1)
    if parallel.maximum(mesh, np.abs(length - 1)) > 1e-8:
        raise ValueError(f"Contact.obstacle: {name} must be a unit vector field on Γ3; |{symbol}| ranges "
                         f"over [{parallel.minimum(mesh, length):.6g}, {parallel.maximum(mesh, length):.6g}]")
    along = sign * np.einsum("fsd,fd->fs", n, side.normals)
    near = g <= parallel.minimum(mesh, g) + NEAR * size
    low, high = parallel.minimum(mesh, along[near]), parallel.maximum(mesh, along[near])
    if sign > 0 and (low < -1e-8 or high <= 1e-8):
        raise ValueError(f"Contact.obstacle: {name} must point from the body into the obstacle ({symbol}·ν > 0 "
                         f"where the body is closest to it, ν the body's outward normal); where the gap is within "
                         f"{NEAR:g} of the body's size of its smallest value, {symbol}·ν ranges over [{low:.3g}, "
                         f"{high:.3g}] on Γ3: is {symbol} reversed?")
    if sign < 0 and (high > 1e-8 or low >= -1e-8):
        raise ValueError(f"Contact.obstacle: {name} must point out of the obstacle towards the body "
                         f"({symbol}·ν < 0 where the body is closest to it, ν the body's outward normal); where the "
                         f"gap is within {NEAR:g} of the body's size of its smallest value, {symbol}·ν ranges over "
                         f"[{low:.3g}, {high:.3g}] on Γ3: is {symbol} reversed?")
