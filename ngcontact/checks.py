"""Checks of user input: numbers in their range, booleans, sizes against the machine's
memory, writable directories, and the time Parameter a scene's data use.

Each failure names the parameter, the value and the allowed range, before any work starts:
a TypeError for a value of the wrong type (a string, None or a boolean for a number, a
number for a boolean), a ValueError for one of the right type out of its range.
"""
import inspect
import math
import numbers
import os
import pathlib

import ngsolve as ngs
import numpy as np

from ngcontact import parallel

MAX_ORDER = 10
"""The highest polynomial order offered (H1 elements of order p have p^dim DOFs per vertex
and field: order 10 on a coarse mesh is already a large problem)."""
MAX_REFINE = 10
"""The most uniform refinements of a mesh (each multiplies its elements by 2^dim)."""
MAX_STEPS = 1_000_000
"""Nominal time steps of one run: more is a mistyped dt, not a plan."""
MEMORY_PER_DOF = 2048
"""Bytes per DOF a simulation needs at least: half the smallest peak memory per DOF of the
reference scenes (fitted to measurements on the reference scenes, docs/measurements.md, section
ngcontact/checks.py; docs/scale.md)."""
VERTICES_PER_CELL = {2: 1.15, 3: 0.8}
"""Vertices of a Netgen mesh per maxh^dim of the domain's area (volume), on fine meshes of
the plate and the block (coarse meshes have more, from their boundary)."""
MAX_LENGTH = 1e3
"""The longest side of a geometry, m (a body of a kilometre is not a piezoelectric device)."""


def number(name, value, low=-math.inf, high=math.inf, *, low_open=False, high_open=False, unit=""):
    """``value`` as a float, checked: a real number (TypeError otherwise: strings, None,
    booleans), finite, in [low, high] (or open at either end). Returns it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number{_range(low, high, low_open, high_open, unit)}, got {value!r} "
                        f"({type(value).__name__})")
    value = float(value)
    below = value <= low if low_open else value < low
    above = value >= high if high_open else value > high
    if not math.isfinite(value) or below or above:
        raise ValueError(f"{name} must be a finite number{_range(low, high, low_open, high_open, unit)}, "
                         f"got {value!r}")
    return value


def integer(name, value, low=1, high=None):
    """``value`` as an int >= low (<= high): TypeError for what is not an integer (strings,
    None, booleans, 2.5, NaN, inf; a float with an integer value is accepted), ValueError for
    an integer out of range."""
    limit = f">= {low}" + (f" and <= {high}" if high is not None else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) \
            or int(value) != value:
        raise TypeError(f"{name} must be an integer {limit}, got {value!r} ({type(value).__name__})")
    if value < low or (high is not None and value > high):
        raise ValueError(f"{name} must be an integer {limit}, got {value!r}")
    return int(value)


def order(name, value):
    """A polynomial order: an integer in [1, MAX_ORDER]."""
    return integer(name, value, 1, MAX_ORDER)


def choice(name, value, allowed):
    """``value`` if it is one of ``allowed`` (of the same type: True is not 1, 2.0 not 2),
    else a ValueError listing them."""
    if isinstance(value, (bool, np.bool_)) or not any(isinstance(value, type(a)) and value == a for a in allowed):
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
    return value


def flag(name, value, none=False):
    """``value`` if it is a boolean (numpy's too), or None where ``none`` (None meaning
    "automatic"); a TypeError naming the option otherwise (``"no"`` or 2 is not a boolean)."""
    if isinstance(value, (bool, np.bool_)) or (none and value is None):
        return None if value is None else bool(value)
    allowed = "True, False or None (automatic)" if none else "True or False"
    raise TypeError(f"{name} must be {allowed}, got {value!r} ({type(value).__name__})")


def callback(name, function, what):
    """``function``: None or a function of one argument (``what``, e.g. "the StepRecord"); a
    TypeError naming ``name`` otherwise."""
    if function is None:
        return None
    if not callable(function):
        raise TypeError(f"{name} must be a function of {what} or None, got {type(function).__name__}")
    try:
        inspect.signature(function).bind(None)
    except TypeError:
        raise TypeError(f"{name} must take one argument ({what}); {function!r} cannot") from None
    except ValueError:                                   # a builtin without a signature: not checked
        pass
    return function


def writable_directory(out, name="output directory"):
    """``out`` as a created, writable directory (a Path), checked before a run starts; the
    error names ``name``."""
    if not isinstance(out, (str, os.PathLike)) or not str(out):
        raise TypeError(f"{name} must be a path (str or pathlib.Path), got {out!r} ({type(out).__name__})")
    out = pathlib.Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".ngcontact-write-test-{os.getpid()}"      # one per process (mpiexec)
        probe.write_text("")
        probe.unlink()
    except OSError as err:
        raise ValueError(f"{name} {str(out)!r} cannot be written: {err.strerror}") from None
    return out


def node_memory():
    """The physical memory of this machine (node) in bytes (``os.sysconf``, else MemTotal of
    /proc/meminfo): fixed, unlike the memory free at the moment."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        with open("/proc/meminfo") as info:
            return next(int(line.split()[1]) * 1024 for line in info if line.startswith("MemTotal:"))


def memory():
    """The memory of the machine in bytes: its physical memory (``node_memory``), times the
    ranks under mpiexec (each may hold a node's)."""
    comm = parallel.world()
    return node_memory() * (1 if comm is None else comm.size)


def estimated_vertices(sides, maxh):
    """The vertices of a Netgen mesh of size ``maxh`` (m) of a box with ``sides`` (m; 2 or 3
    of them): ``VERTICES_PER_CELL`` · measure / h^dim with h = min(maxh, shortest side)
    (Netgen's elements are about as small as the box is thin), in logarithms: finite for any
    sides and maxh > 0."""
    h = min(maxh, *sides)
    log = math.log(VERTICES_PER_CELL[len(sides)]) + sum(math.log(side / h) for side in sides)
    return math.exp(min(log, 690.0))


def estimated_ndof(vertices, dim, refine=0, order=1):
    """The DOFs of u and φ (dim + 1 fields) of order ``order`` on a mesh of ``vertices``
    vertices refined ``refine`` times: 2^dim times the vertices per refinement, and about
    order^dim DOFs per vertex and field (the edge, face and cell DOFs of H1 of order p)."""
    return min(vertices * 2.0 ** (dim * refine) * order ** dim * (dim + 1), 1e300)


def fits_in_memory(what, ndof):
    """Refuse (a ValueError naming ``what`` and the estimate) a problem of ``ndof`` DOFs that
    needs more than the machine's ``memory()`` at ``MEMORY_PER_DOF`` bytes per DOF."""
    need, have = ndof * MEMORY_PER_DOF, memory()
    if need > have:
        raise ValueError(f"{what}: about {ndof:.2g} DOFs (estimated), needing at least "
                         f"{_bytes(need)} ({MEMORY_PER_DOF} bytes per DOF); this machine has {_bytes(have)}")
    return ndof


def _bytes(count):
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if count < 1024 or unit == "PiB":
            return f"{count:.3g} {unit}"
        count /= 1024


def _range(low, high, low_open, high_open, unit):
    unit = f" {unit}" if unit else ""
    if low == -math.inf and high == math.inf:
        return ""
    if high == math.inf:
        return f" {'>' if low_open else '>='} {low:g}{unit}"
    if low == -math.inf:
        return f" {'<' if high_open else '<='} {high:g}{unit}"
    return f" in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}{unit}"


def parameters(cf):
    """The ngsolve.Parameter objects in the expression tree of a CoefficientFunction."""
    found, stack = [], [cf]
    while stack:
        node = stack.pop()
        if isinstance(node, ngs.Parameter):
            found.append(node)
        elif not isinstance(node, ngs.GridFunction):     # a GridFunction holds no Parameter
            try:
                stack.extend(node.data["childs"])
            except Exception:                            # NGSolve raises a plain Exception for a
                continue                                 # node it cannot archive (no Parameter in it)
    return found


def uses_only(time, named_cfs):
    """Every Parameter in the named CoefficientFunctions must be ``time`` (the simulation's):
    a load on another Parameter would never move."""
    for name, cf in named_cfs:
        if isinstance(cf, ngs.CoefficientFunction) and any(p is not time for p in parameters(cf)):
            raise ValueError(f"{name} depends on an ngsolve.Parameter that is not the simulation's time: it "
                             "would never change; pass that Parameter as Simulation(time=...)")
