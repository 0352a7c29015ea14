"""The arguments of ``Simulation``, ``step``, ``advance`` and ``run``, checked before any work.

Each failure is a TypeError (a value of the wrong type: a string for a boolean, a Contact
where a Body is expected) or a ValueError (a value out of its range), naming the argument,
the value and what is allowed. The bounds: at most ``checks.MAX_STEPS`` nominal steps per run,
``MAX_CUTBACKS`` halvings of a step, and a step of at least ``MIN_DT`` and ``RESOLUTION`` of
the time it reaches.
"""
import math
import numbers
import os
import pathlib

import ngsolve as ngs
import numpy as np

from ngcontact import checks, parallel
from ngcontact.model.body import Body
from ngcontact.checks import MAX_STEPS, flag, integer, number, writable_directory
from ngcontact.gamma3.contact import Contact
from ngcontact.model.loads import Loads
from ngcontact.solve.linalg.solver_choice import ITERATIVE
from ngcontact.time.stepping import MIN_DT, RESOLUTION

MAX_CUTBACKS = 20
"""Halvings of a step (2^-20 ~ 1e-6 of it). The smallest step of a run is then
dt/2^20 >= T/(MAX_STEPS 2^20) ~ 9.5e-13 T, above ``RESOLUTION``."""
AUTOMATIC = ("condense", "realcompile", "iterative", "electric")
"""The options of Simulation that are True, False or None (automatic); the others are True
or False."""


def simulation(body, loads, contact, time, inverse, options):
    """The objects given to ``Simulation`` must be of their types (``body`` a Body; ``loads``,
    ``contact``, ``time``, ``inverse`` of theirs or None); returns ``options`` (a dict {name:
    value} of the boolean options) as booleans, or None for those of AUTOMATIC."""
    for name, value, kind, expected in (("body", body, Body, "an ngcontact.Body"),
                                        ("loads", loads, Loads, "an ngcontact.Loads or None"),
                                        ("contact", contact, Contact, "an ngcontact.Contact or None"),
                                        ("time", time, ngs.Parameter, "an ngsolve.Parameter or None"),
                                        ("inverse", inverse, str, "a solver's name (str) or None")):
        if not isinstance(value, kind) and (value is not None or name == "body"):
            raise TypeError(f"Simulation: {name} must be {expected}, got {type(value).__name__}")
    iterative = options.get("iterative")
    if isinstance(iterative, str):                  # or the name of an iterative solver
        if iterative not in ITERATIVE:
            raise ValueError(f"Simulation: iterative must be True, False, None or one of "
                             f"{', '.join(map(repr, ITERATIVE))}, got {iterative!r}")
        options = dict(options, iterative=None)
    checked = {name: flag(name, value, none=name in AUTOMATIC) for name, value in options.items()}
    if isinstance(iterative, str):
        checked["iterative"] = iterative
    return checked


def time_step(dt, t):
    """dt (s) as a float, for a step from time t (s): a finite number >= MIN_DT and >=
    RESOLUTION |t|."""
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real):
        raise TypeError(f"time step dt must be a number > 0 s, got {dt!r} ({type(dt).__name__})")
    smallest = max(MIN_DT, RESOLUTION * abs(t))
    if not (math.isfinite(dt) and dt >= smallest):
        raise ValueError(f"time step dt must be > 0 s, finite and at least {smallest:.3g} s ({MIN_DT:g} s, and "
                         f"{RESOLUTION:g} of the time t = {t:.6g} s), got {dt!r}")
    return float(dt)


def history_index(n, count):
    """n, an index of a history of ``count`` records ([0, count − 1], or [−count, −1] from the
    end): a TypeError or IndexError naming n and that range otherwise."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"state: the step n must be an integer in [0, {count - 1}] (or [-{count}, -1] from the "
                        f"end), got {n!r}")
    if not -count <= n < count:
        raise IndexError(f"state: step n = {n} is not in the history: n must be in [0, {count - 1}] (or "
                         f"[-{count}, -1] from the end; {count} records, step 0 the initial state)")


def later(name, value, t):
    """A time (s) after the current time t: a finite number > t by at least the smallest step
    (``MIN_DT``, and ``RESOLUTION`` of t)."""
    value = number(name, value, unit="s")
    smallest = max(MIN_DT, RESOLUTION * abs(t))
    if not value - t >= smallest:
        raise ValueError(f"{name} must be > the current time {t} s by at least {smallest:.3g} s (the smallest "
                         f"time step), got {value}")
    return value


def cutbacks(max_cutbacks):
    """max_cutbacks as an int in [0, MAX_CUTBACKS]."""
    return integer("max_cutbacks", max_cutbacks, 0, MAX_CUTBACKS)


def callback(on_step):
    """on_step: a function of one argument (the StepRecord) or None."""
    return checks.callback("on_step", on_step, "the StepRecord")


def run(t, mesh, dt, T, max_cutbacks, progress, vtk, on_step, out):
    """The arguments of ``Simulation.run`` from the time t (s) on ``mesh``: (dt, T, max_cutbacks,
    progress) checked, the directories of ``vtk`` and ``out`` writable (``out`` on every rank of
    a distributed mesh), at most MAX_STEPS steps."""
    dt, T = number("time step dt", dt, 0, low_open=True, unit="s"), later("final time T", T, t)
    max_cutbacks, progress = cutbacks(max_cutbacks), flag("progress", progress)
    callback(on_step)
    if vtk is not None:
        if not isinstance(vtk, (str, os.PathLike)) or not str(vtk):
            raise TypeError(f"vtk must be a file name stem (str or pathlib.Path) or None, got {vtk!r}")
        if str(vtk).endswith(("/", os.sep)) or pathlib.Path(vtk).is_dir():
            stem = pathlib.Path(vtk) / "fields"
            raise ValueError(f"vtk: {str(vtk)!r} names a directory; vtk is a file name stem (vtk={str(stem)!r} "
                             f"writes {stem}.pvd and {stem}*.vtu, u and φ); to write u, φ and Γ3 into a "
                             f"directory pass out={str(vtk)!r} (docs/output.md)")
        writable_directory(pathlib.Path(vtk).parent, "vtk: the directory")
    if out is not None:
        parallel.together(mesh, writable_directory, out, "out: the directory")
    if (T - t) / dt > MAX_STEPS:
        raise ValueError(f"time step dt = {dt:g} s gives {(T - t) / dt:.3g} steps to T = {T:g} s; at "
                         f"most {MAX_STEPS:,} steps per run (a larger dt, or several runs)")
    return dt, T, max_cutbacks, progress


def controlled(newton_rtol, scheme, dt, rtol, dt_min, event_dt, T=0.0):
    """The error-controlled steps of ``run`` with Newton's tolerance ``newton_rtol`` and the time
    scheme ``scheme``: None without ``rtol`` (then ``dt_min`` and
    ``event_dt`` must be None too), else (dt_min, event_dt) in s, checked: rtol in (0, 0.1] and
    at least a hundredfold Newton's tolerance,
    a scheme with an error estimate, 0 < dt_min <= event_dt <= dt (defaults 1e-6 dt and
    1e-3 dt), dt_min at least the smallest step a run to T takes (``time_step``). A ValueError or TypeError naming the parameter otherwise. On a distributed mesh the
    steps are those of a serial run: the estimate and the events are over all ranks (``schemes.bdf2``,
    ``stepping``)."""
    if rtol is None:
        for name, value in (("dt_min", dt_min), ("event_dt", event_dt)):
            if value is not None:
                raise ValueError(f"run: {name} = {value!r} is for error-controlled steps: give rtol too")
        return None
    rtol = number("rtol", rtol, 0, 0.1, low_open=True)
    if rtol < 100 * newton_rtol:
        raise ValueError(f"run: rtol = {rtol:g} is below 100 × Newton's tolerance ({newton_rtol:g}): the error "
                         "estimate would measure Newton's inexactness; a larger rtol, or Simulation(rtol=...) smaller")
    if not scheme.estimates_error:
        raise ValueError(f"run(rtol={rtol:g}): the scheme {scheme.name!r} has no local error estimate to choose "
                         "steps by; use Simulation(scheme='bdf2'), or fixed steps (no rtol)")
    smallest = max(MIN_DT, RESOLUTION * abs(T))               # the smallest step ``step`` takes up to T
    dt_min = number("dt_min", max(1e-6 * dt, smallest) if dt_min is None else dt_min, smallest, dt, unit="s")
    event_dt = number("event_dt", 1e-3 * dt if event_dt is None else event_dt, dt_min, dt, unit="s")
    return dt_min, event_dt
