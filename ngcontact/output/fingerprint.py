"""The fingerprint of a simulation's scene: everything that defines its results, as a flat
JSON-serialisable dictionary, and the fields in which two fingerprints differ.

``results`` stores it in ``run.json`` and compares it when a run is resumed, so that a run is
never continued with another scene. Its fields (one key each, e.g. ``contact.gamma0``):

* ``mesh.*``: dimension, vertex and element counts, boundary names, curve order, and a hash
  of the vertex coordinates (to 1e-9 of the body's size) and of the vertex numbers and
  region indices of every element; ``space.ndof``;
* ``body.*``: the orders of u and φ, the boundary parts Γ1, Γa, Γ3 and the supports, and
  whether it is a body of revolution;
* ``material.*``: c, e, eps, eta and poling (the data as given, SI units), a law's name,
  sampled constants and tangent at 0;
* ``contact.*``: every field of ``Contact`` (``contact`` is None without a contact law; the
  method by its name, its parameters in ``theta``, ``gamma0``, ``penalty``, each the Contact's
  default where the method has none, ``UNUSED``) and ``contact.obstacle.*``, the obstacle's
  own data (its public attributes; the obstacle itself by its class's name, with its module
  for one of the user's); a method object of another class than the package's (``enforcement.METHODS``)
  adds ``contact.method.class`` (its module and qualified name) and
  ``contact.method.parameters.<name>`` for each of its parameters (its ``parameters()`` if it
  has one, else a dataclass's fields, else ``vars()`` without names starting with "_":
  values as plain JSON values, CoefficientFunctions sampled on Γ3, functions by their
  qualified name, other objects by their repr where their class defines one, else by their
  class name), so that two methods of the user's that differ in a parameter are two scenes;
* ``loads.*``: every entry of ``Loads``, keyed by its boundary;
* ``options.*``: the options of ``Simulation`` that change the results: Newton's rtol and
  maxit, the electric choice (``Simulation.electric``), the predictor, Newton's step limit and globalisation,
  static condensation, the linear solver as used (its name, ``inverse``: the factorisation,
  ``reuse_factorization``: kept as GMRES's preconditioner, ``iterative``: "multigrid", "gamg"
  or False, and ``petsc``: the options of ``Simulation(solver={...})`` that tune the solver it
  chose, only where there are any: ``solver_choice.describe``) and
  ``realcompile`` (True, False, or None: by the rule of ``machine_code``);
  ``scheme``: the time scheme's name (β's update of backward Euler is ``contact.beta_update``),
  and for a class of the user's (not in ``schemes.SCHEMES``) ``scheme.class``, its module and
  qualified name;
* ``run.*`` (``run_options``, added by ``results`` to the fingerprint it stores): the options
  of ``Simulation.run`` that change the results: dt, T, rtol and, with rtol, dt_min and
  event_dt as used (their defaults resolved), without it max_cutbacks and a guess for every
  step ("nested", "p1"). ``results`` compares them at ``run(..., out=DIR)``, the rest at
  ``resume(DIR)`` already.

Numbers are stored as numbers. Data that may depend on position and time
(CoefficientFunctions) are sampled on their region (Γ3 for the contact data, the boundary of
a load, the volume for f0 and q0) at ``SAMPLE_TIMES`` times spread over [0, T] set on the
simulation's time Parameter (restored afterwards): at ``SAMPLE_POINTS`` element centres spread
over the region and the mean over all its element centres (which a local change moves). A
law r ↦ CoefficientFunction (``Contact.compliance``, ``Contact.conductance``) is sampled at
the arguments ``LAW_ARGUMENTS`` × the body's size. A number and a sampled field are compared
by broadcasting, so ``gap=2e-5`` and ``gap=CF(2e-5)`` are the same scene.

On a distributed mesh the fingerprint is the same on every rank: the counts are global, the
mesh hash is the hash of the ranks' hashes of their parts in rank order, and the element
centres are taken in rank order (the mean over all of them summed over the ranks). The same
mesh on the same number of ranks is distributed alike, so it is the same fingerprint there;
on another number of ranks it is another (``results`` refuses that first, by the numbers).
"""
import dataclasses
import hashlib
import numbers

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.solve.linalg.solver_choice import describe
from ngcontact.gamma3.contact import NOT_GIVEN, Contact
from ngcontact.gamma3 import obstacles
from ngcontact.gamma3.enforcement import METHODS
from ngcontact.model.loads import Loads
from ngcontact.model.materials import Material
from ngcontact.time.schemes import SCHEMES

SAMPLE_TIMES = 5
"""Times in [0, T] at which data that may depend on time are sampled."""
SAMPLE_POINTS = 16
"""Element centres of a region at which data are sampled (and the mean over all of them)."""
LAW_ARGUMENTS = (-1e-2, -1e-4, -1e-6, -1e-8, 0.0, 1e-8, 1e-6, 1e-4, 1e-2)
"""Arguments r (× the body's size, m) at which a law r ↦ CoefficientFunction is sampled."""
RTOL = 1e-9
"""Numbers that agree to this relative tolerance (of the field's largest value) are the same."""

_CENTRES = {et: ngs.IntegrationRule(et, 0) for et in
            (ngs.SEGM, ngs.TRIG, ngs.QUAD, ngs.TET, ngs.HEX, ngs.PRISM, ngs.PYRAMID)}


def fingerprint(body, loads, contact, ndof, options, at, T):
    """The fingerprint of the scene of ``body``, ``loads`` and ``contact`` (see the module) on a
    space of ``ndof`` DOFs (over all ranks), solved with ``options`` (the ``options.*`` and
    ``scheme`` fields, ``options``), with the data sampled at ``SAMPLE_TIMES`` times in [0, T]
    (T in s, the final time of the run) inside ``at(t)`` (``StepCoefficients.at``)."""
    mesh = body.mesh
    sample = _Sampler(at, mesh, np.linspace(0.0, float(T), SAMPLE_TIMES))
    found = {"sample times": sample.times.tolist(), **_mesh(mesh, body.size), "space.ndof": ndof,
             "body.order": body.order, "body.order_phi": body.order_phi}
    found.update({f"body.{part}": list(names) for part, names in body.boundaries.items()})
    found["body.supports"] = [repr(s) for s in body.supports]
    if body.axisymmetric:                          # (only then: runs of other bodies keep their keys)
        found["body.axisymmetric"] = True
    found.update({f"material.{f.name}": _plain(getattr(body.material, f.name))
                  for f in dataclasses.fields(Material) if f.name != "name"})
    for key, law in (("elasticity_law", body.tensors.F_law), ("viscosity_law", body.tensors.A_law)):
        if law is not None:      # its name (a built-in's parameters) and its sampled constants and tangent
            found[f"material.{key}"] = [law.name, law.lipschitz, law.monotonicity, law.linear.tolist()]
    found.update(_contact(contact, body, sample))
    for f in dataclasses.fields(Loads):
        value = getattr(loads, f.name)
        if isinstance(value, dict):
            found.update({f"loads.{f.name}[{key!r}]": sample(v, mesh.Boundaries(key)) for key, v in value.items()})
        else:
            found[f"loads.{f.name}"] = sample(value, ngs.VOL)
    found.update(options)
    return found


def options(newton, scheme, electric, condense, machine_code_rule):
    """The ``options.*`` and ``scheme`` fields of a simulation solved by ``newton`` with the time
    scheme ``scheme``: Newton's rtol, maxit, step limit, globalisation and linear solver as used
    (``solver_choice.describe``), ``electric`` and ``condense`` (as used), and ``realcompile``
    (None where ``machine_code_rule`` decides, else whether the Γ3 integrand is compiled);
    ``scheme.class`` for a scheme of the user's."""
    return {"options.rtol": newton.rtol, "options.maxit": newton.maxit, "options.electric": bool(electric),
            "options.predictor": bool(scheme.predictor), "options.limit_steps": newton.step_length is not None,
            "options.globalise": newton.line_search is not None, "options.condense": bool(condense),
            "options.switch_loop": newton.switch_loop is not None,
            "options.solver": newton.solver_name, **describe(newton.solver),
            "options.realcompile": None if machine_code_rule else bool(scheme.system.machine_code),
            "scheme": scheme.name, **({} if type(scheme) in SCHEMES.values() else {"scheme.class": _class(scheme)})}


def _class(value):
    """The module and qualified name of ``value``'s class."""
    return f"{type(value).__module__}.{type(value).__qualname__}"


RUN_OPTIONS = ("dt", "T", "rtol", "dt_min", "event_dt", "max_cutbacks", "guess")
"""The options of ``Simulation.run`` in the fingerprint of a run (``run_options``)."""


def run_options(dt, T, rtol=None, dt_min=None, event_dt=None, max_cutbacks=None, guess=None):
    """The ``run.*`` fields of a run ``Simulation.run(dt, T, ...)`` (dt, T, dt_min and event_dt
    in s, dt_min and event_dt as used, defaults resolved): with ``rtol`` its dt_min and
    event_dt, without it max_cutbacks and a guess for every step ("nested" or "p1"; a guess
    for the first step alone is not kept), the options each kind of run uses."""
    controlled = rtol is not None
    return {"run.dt": _plain(dt), "run.T": _plain(T), "run.rtol": _plain(rtol),
            "run.dt_min": _plain(dt_min) if controlled else None,
            "run.event_dt": _plain(event_dt) if controlled else None,
            "run.max_cutbacks": None if controlled else _plain(max_cutbacks),
            "run.guess": guess if isinstance(guess, str) and not controlled else None}


def differences(stored, current):
    """The fields in which two fingerprints differ, as [(field, stored value, current value)]
    (None where a field is absent); a field ``a.b`` is left out when ``a`` differs already
    (the obstacle's data when the obstacles are of different kinds, say), and on two meshes
    the data sampled at the element centres of each are not compared (they are at other points)."""
    keys = list(dict.fromkeys([*stored, *current]))
    same_mesh = stored.get("mesh.hash") == current.get("mesh.hash")
    differing = [k for k in keys if k not in stored or k not in current or (
        not _same(stored[k], current[k]) and (same_mesh or np.ndim(stored[k]) < 3 or np.ndim(current[k]) < 3))]
    return [(k, stored.get(k), current.get(k)) for k in differing
            if not any(k.startswith(parent + ".") for parent in differing)]


def mismatch(stored, current):
    """The differing fields of two fingerprints in words, "<fields as stored>; this simulation
    has <fields as now>", or None if there are none. Arrays are shown by size and range, with
    how far they differ."""
    found = differences(stored, current)
    if not found:
        return None
    there = ", ".join(f"{key} = {_show(a) if key in stored else NOT_RECORDED}" for key, a, b in found)
    here = ", ".join(f"{key} = {_show(b)}{_by(a, b)}" for key, a, b in found)
    return f"{there}; this simulation has {here}"


NOT_RECORDED = "not recorded (a run of an earlier ngcontact)"
"""A field that a fingerprint lacks, in a message."""


def _show(value):
    """A value for a message: numbers as they are, arrays by size and range."""
    if _numeric(value) and isinstance(value, list):
        a = np.asarray(value, dtype=float)
        if a.size <= 6:
            return repr(a.ravel().tolist())
        return f"({a.size} values in [{a.min():.6g}, {a.max():.6g}])"
    return "none" if value is None else repr(value)


def _by(a, b):
    """" (differing by up to d)" for two arrays of the same shape shown by their range, else ""."""
    if not (_numeric(a) and _numeric(b) and isinstance(a, list) and np.shape(a) == np.shape(b)) or np.size(a) <= 6:
        return ""
    return f" (differing by up to {np.abs(np.subtract(a, b, dtype=float)).max():.3g})"


UNUSED = {"theta": 1, "gamma0": 10.0, "penalty": 1e3}
"""The values ``contact.theta``, ``contact.gamma0`` and ``contact.penalty`` take where the
method has no such parameter (``Contact``'s defaults, so that earlier runs keep their fingerprint)."""


def _contact(contact, body, sample):
    """The ``contact.*`` fields."""
    if contact is None:
        return {"contact": None}
    gamma3 = body.region("contact_side")
    found = {"contact": "Contact"}
    for f in dataclasses.fields(Contact):
        value = getattr(contact, f.name)
        if f.name in UNUSED and value is NOT_GIVEN:
            found[f"contact.{f.name}"] = UNUSED[f.name]
        elif f.name == "method":        # its name; the parameters of a built-in one are the fields θ, γ0, penalty
            method = contact.enforcement_method
            found["contact.method"] = method.name
            if type(method) not in METHODS.values():
                found["contact.method.class"] = _class(method)
                found.update({f"contact.method.parameters.{k}": v
                              for k, v in _method_parameters(method, lambda v: sample(v, gamma3)).items()})
        elif f.name == "obstacle":        # a built-in one by its class's name, one of the user's by its module's too
            found["contact.obstacle"] = None if value is None else \
                type(value).__name__ if isinstance(value, obstacles.OBSTACLES) else _class(value)
            if value is not None:
                found.update({f"contact.obstacle.{k}": sample(v, gamma3) for k, v in obstacles.data(value).items()})
        elif callable(value) and not isinstance(value, ngs.CoefficientFunction):
            found[f"contact.{f.name}"] = sample.law(value, gamma3, body.size)
        else:
            found[f"contact.{f.name}"] = sample(value, gamma3)
    return found


def _method_parameters(method, sampled):
    """{name: value} of a method object's parameters as JSON values (see the module)."""
    if callable(getattr(method, "parameters", None)):
        found = method.parameters()
        if not isinstance(found, dict):
            raise TypeError(f"Contact.method: {type(method).__qualname__}.parameters() returned {found!r}: it must "
                            "be a dict {name: value} of the method's parameters (for the run's fingerprint)")
    elif dataclasses.is_dataclass(method):
        found = {f.name: getattr(method, f.name) for f in dataclasses.fields(method)}
    else:
        found = {k: v for k, v in vars(method).items() if not str(k).startswith("_")} \
            if hasattr(method, "__dict__") else {}                  # (private attributes are no parameters)
    return {str(k): _parameter(v, sampled) for k, v in sorted(found.items(), key=lambda item: str(item[0]))}


def _parameter(value, sampled):
    """One parameter of a method as a JSON value: plain data as ``_plain``, CoefficientFunctions
    sampled, containers entry by entry, other objects by their repr if their class has one of
    its own (not an address), else by their class name."""
    if isinstance(value, ngs.CoefficientFunction):
        return sampled(value)
    if isinstance(value, dict):
        return {str(k): _parameter(v, sampled) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [_parameter(v, sampled) for v in value]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"class": type(value).__qualname__,
                **{f.name: _parameter(getattr(value, f.name), sampled) for f in dataclasses.fields(value)}}
    if isinstance(value, numbers.Complex) and not isinstance(value, numbers.Real):
        return [_plain(value.real), _plain(value.imag)]
    if value is None or isinstance(value, (bool, str, numbers.Number, np.ndarray, np.generic)):
        return _plain(value)
    if callable(value):
        return f"{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', type(value).__qualname__)}"
    return repr(value) if type(value).__repr__ is not object.__repr__ else type(value).__qualname__


def _mesh(mesh, size):
    """The ``mesh.*`` fields. On a distributed mesh: the global counts, and the hash of the
    ranks' hashes of their parts in rank order (the same mesh on the same number of ranks is
    distributed alike)."""
    ngmesh = mesh.ngmesh
    digest = hashlib.sha256(np.round(ngmesh.Coordinates() / size, 9) + 0.0)      # + 0.0: no -0.0
    for elements in (ngmesh.Elements1D(), ngmesh.Elements2D(), ngmesh.Elements3D()):
        table = elements.NumPy()
        digest.update(np.ascontiguousarray(table["nodes"]))
        digest.update(np.ascontiguousarray(table["index"]))
    vertices, elements = mesh.nv, mesh.ne
    if parallel.is_distributed(mesh):
        digest = hashlib.sha256("".join(parallel.every(mesh, digest.hexdigest())).encode())
        vertices, elements = ngs.H1(mesh, order=1).ndofglobal, parallel.sum(mesh, mesh.ne)
    return {"mesh.dim": mesh.dim, "mesh.vertices": vertices, "mesh.elements": elements,
            "mesh.boundaries": list(mesh.GetBoundaries()), "mesh.curve order": mesh.GetCurveOrder(),
            "mesh.hash": digest.hexdigest()[:32]}


class _Sampler:
    """Values of a scene's data as plain JSON values: numbers as numbers, CoefficientFunctions
    sampled on a region at ``times`` on the simulation's time Parameter."""

    def __init__(self, at, mesh, times):
        self.at, self.mesh, self.times = at, mesh, times
        self._points = {}

    def __call__(self, value, region):
        if isinstance(value, ngs.CoefficientFunction) or (
                isinstance(value, (tuple, list)) and any(isinstance(v, ngs.CoefficientFunction) for v in value)):
            cf = value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(tuple(value))
            return self._sampled(lambda points: np.reshape(cf(points), (len(points), cf.dim)), region)
        return _plain(value)

    def law(self, law, region, size):
        """The law r ↦ CF at r = ``LAW_ARGUMENTS`` × size (m), at the region's first centre
        (distributed: of the first rank that holds part of the region)."""
        r = ngs.Parameter(0.0)
        points = self.points(region)
        first = parallel.offset(self.mesh, len(points))[0] == 0 and len(points) > 0
        cf, values = law(r), None
        if first:
            values = []
            for a in LAW_ARGUMENTS:
                r.Set(a * size)
                values.append(np.ravel(cf(points[:1]) if isinstance(cf, ngs.CoefficientFunction) else cf).tolist())
        return next(v for v in parallel.every(self.mesh, values) if v is not None)

    def points(self, region):
        """The element centres of ``region`` (a Region or ngsolve.VOL), located once."""
        key = "VOL" if region is ngs.VOL else (str(region.VB()), tuple(region.Mask()))
        if key not in self._points:
            self._points[key] = self.mesh.MapToAllElements(_CENTRES, region)
        return self._points[key]

    def _sampled(self, evaluate, region):
        """[time][point][component]: ``SAMPLE_POINTS`` centres spread over the region, then the
        mean over all its centres (distributed: spread over the centres of all ranks in rank
        order, gathered on every rank)."""
        points = self.points(region)
        before, count = parallel.offset(self.mesh, len(points))     # distributed: the centres in rank order
        kept = np.unique(np.linspace(0, count - 1, SAMPLE_POINTS).round().astype(int)) - before
        kept = kept[(kept >= 0) & (kept < len(points))]
        values = []
        for t in self.times:
            with self.at(t):
                v = evaluate(points)
            values.append(np.vstack([parallel.gather(self.mesh, v[kept]),
                                     parallel.sum(self.mesh, v.sum(axis=0)) / count]).tolist())
        return values


def _plain(value):
    """A number, string, None or array as a JSON value."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if value is None or isinstance(value, (bool, str, numbers.Number)):
        return value
    return type(value).__name__


def _numeric(value):
    """A number (not a bool) or a nonempty nested list of numbers."""
    if isinstance(value, bool):
        return False
    if isinstance(value, numbers.Number):
        return True
    return isinstance(value, list) and len(value) > 0 and all(_numeric(v) for v in value)


def _same(a, b):
    """Equal, numbers to ``RTOL`` of the larger field (a number against a sampled field by
    broadcasting)."""
    if not (_numeric(a) and _numeric(b)):
        return a == b
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    try:
        a, b = np.broadcast_arrays(a, b)
    except ValueError:
        return False
    scale = max(np.abs(a[np.isfinite(a)]).max(initial=0.0), np.abs(b[np.isfinite(b)]).max(initial=0.0))
    with np.errstate(invalid="ignore"):
        close = (np.abs(a - b) <= RTOL * scale) | (a == b) | (np.isnan(a) & np.isnan(b))
    return bool(close.all())
