"""Time schemes: each poses its step through ``StepCoefficients`` (t_n, c, û) and owns what
changes from step to step (the state, β, the memory it needs), saving and restoring it bitwise.

A scheme is a class with

* ``name``: its name in ``SCHEMES`` (``Simulation(scheme=...)``, the run.json of a stream);
* ``__init__(coefficients, system, newton, state, beta=None, predictor=False, normal=None)``;
* ``start()``: the coefficients of step 0 (t = 0, u held at u0) and ``system.begin_step``;
* ``advance(dt, *, step, timer, start, target)``: one step of nominal length dt (its rate
  coefficient comes from dt) from the current state to ``target`` (default t + dt); returns
  Newton's result;
* ``t``: the time of the last step (s);
* ``checkpoint()`` / ``restore(saved)``: an in-memory copy of everything ``advance`` changes;
* ``save()`` / ``load(arrays)``: the same as named numpy arrays, for a restart from disk
  (``results``).

A new scheme is one new module here and one entry in ``SCHEMES``.
"""
from .backward_euler import BackwardEuler
from .bdf2 import BDF2
from .coefficients import StepCoefficients

SCHEMES = {BackwardEuler.name: BackwardEuler, BDF2.name: BDF2}
"""The time schemes by name: "backward_euler" (the default, the paper's scheme (4.3)–(4.5)) and
"bdf2" (variable-step BDF2, second order: ``bdf2``)."""

DEFAULT = BackwardEuler.name


def scheme_class(name):
    """The scheme called ``name``, or a ValueError naming ``scheme``, the value and the choices."""
    if not isinstance(name, str) or name not in SCHEMES:
        raise ValueError(f"scheme must be one of {', '.join(repr(s) for s in SCHEMES)}, got {name!r}")
    return SCHEMES[name]


__all__ = ["SCHEMES", "DEFAULT", "BackwardEuler", "BDF2", "StepCoefficients", "scheme_class"]
