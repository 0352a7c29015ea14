"""The protocol of a time scheme, as ``Simulation(scheme=...)`` takes it besides a name of
``SCHEMES``: a class that follows ``TimeScheme``, built by the simulation with its step system.

A scheme is handed in as its class, not an instance: it is made from the simulation's parts
(the step coefficients, the step system, Newton, the state), which exist only once the
simulation builds them, and again for each coarser level of nested iteration. The class is
checked member by member before any work (``check``: a TypeError naming ``scheme``, the class
and the members it lacks or whose signature does not take what the simulation passes), the
instance's data once it is built (``check_built``).

The rest of the package reads a scheme through these members only: ``time.step.Step`` (``start``
through ``Simulation``, ``advance``, ``checkpoint``/``restore``, ``t``, ``last_order``,
``coefficients``, ``system``, ``newton``, ``state``), ``time.stepping`` (``estimates_error``,
``estimate``, ``restart``, ``control``), ``arguments.controlled`` (``estimates_error``),
``output.results`` and ``Simulation.resume`` (``name``, ``save``/``load``) and
``output.fingerprint`` (``name``, ``predictor``, ``system``).
"""
import inspect
from abc import abstractmethod
from typing import Protocol

CONSTRUCTOR = "(coefficients, system, newton, state, beta=None, predictor=False, normal=None)"
"""How the simulation builds a scheme, in words (all seven passed by position)."""


class TimeScheme(Protocol):
    """A time scheme of the step system R(x) = K_el x + c K_A (x − x̂) − f(t_n) + R_Γ3(x)
    (``coefficients``): it writes t_n, c and û, and owns what changes from step to step.

    Built as ``Scheme(coefficients, system, newton, state, beta, predictor, normal)``: the
    ``StepCoefficients`` it alone writes (t_n in s, c in 1/s, û in m), the ``StepSystem``,
    Newton on it for ``state``, the GridFunction of (u, φ) it changes in place, the bonding
    field β (``adhesion.BondingField``, None without contact) it updates, whether Newton starts
    from an extrapolation (``predictor``), and the contact normal of Γ3 (the body's ν or an
    obstacle's n_o; None without contact) along which u_ν is taken.

    Every member below is needed; a class that subclasses ``TimeScheme`` takes the defaults of
    ``estimates_error``, ``estimate``, ``last_order``, ``restart`` and ``control`` (a scheme
    without an error estimate whose every step is a one-step formula).
    """

    name: str
    """Its name, in each StepRecord, the fingerprint and a streamed run's run.json (a resume into
    a scheme of another name is refused); not the name of another class of ``SCHEMES``."""
    t: float
    """The time of the last step, s (0 after ``start``)."""
    coefficients: object
    """The ``StepCoefficients`` it was built with."""
    system: object
    """The ``StepSystem`` it was built with."""
    newton: object
    """Newton it was built with."""
    state: object
    """The GridFunction of (u, φ) it was built with."""
    predictor: bool
    """Whether Newton starts from an extrapolation of the last states (the fingerprint records it)."""

    estimates_error: bool = False
    """Whether ``advance`` leaves a local error estimate in ``estimate``: ``run(rtol=...)`` chooses
    steps by it, and refuses a scheme without one."""
    estimate: dict | None = None
    """After a step, its relative local error per field ({"u": ..., "phi": ..., "beta": ...},
    each dimensionless), or None where there is none yet; read where ``estimates_error``."""
    last_order: int = 1
    """The order of the formula of the last step (each StepRecord's ``order``)."""

    @abstractmethod
    def start(self) -> None:
        """Step 0 at t = 0: set t_0 = 0, c and û = u0 in ``coefficients`` (the terms of the
        potential φ0 with u held at u0) and call ``system.begin_step(state)``."""

    @abstractmethod
    def advance(self, dt, *, step=None, timer=None, start=None, target=None):
        """One step of nominal length dt (s; its rate coefficient comes from dt) from the current
        state to ``target`` (s; None: t + dt): set t_n, c and û, call ``system.begin_step(state)``,
        then ``start(u, t_{n−1}, t_n)`` if given (Newton's start), and return
        ``newton.solve(step=step, time=t_n, timer=timer)``'s NewtonResult. Not transactional:
        the caller puts a failed step back with ``restore``."""

    @abstractmethod
    def checkpoint(self):
        """A copy of everything ``advance`` changes (t, the state, β, its own memory)."""

    @abstractmethod
    def restore(self, saved) -> None:
        """Put back what ``checkpoint`` returned, bitwise, and t_n with it (``coefficients.set``)."""

    @abstractmethod
    def save(self) -> dict:
        """The checkpoint as named numpy arrays (a step archive's restart state)."""

    @abstractmethod
    def load(self, arrays) -> None:
        """Put back the arrays of ``save`` (a resume from disk), bitwise."""

    def restart(self) -> None:
        """Forget the earlier states: the next step uses none of them (after an event, a kink in
        time that a multistep formula would straddle)."""

    def control(self, rtol) -> None:
        """An error-controlled run with the relative tolerance ``rtol`` begins: make its own inner
        tolerances at least as tight (BDF2: its passes of β)."""


METHODS = {"start": ((), {}), "advance": ((1.0,), dict(step=None, timer=None, start=None, target=None)),
           "checkpoint": ((), {}), "restore": ((None,), {}), "save": ((), {}), "load": ((None,), {}),
           "restart": ((), {}), "control": ((1e-3,), {})}
"""The methods of ``TimeScheme`` and the arguments the package calls them with."""
CLASS_DATA = ("name", "estimates_error")
"""The data of ``TimeScheme`` its class holds."""
INSTANCE_DATA = ("t", "coefficients", "system", "newton", "state", "predictor", "estimate", "last_order")
"""The data of ``TimeScheme`` a built scheme holds (its constructor sets them, or its class)."""


def _refuse(scheme, what):
    raise TypeError(f"scheme: the time scheme class {scheme.__module__}.{scheme.__qualname__} {what} (the "
                    "protocol ngcontact.schemes.TimeScheme)")


def _signature_problem(scheme, name, args, kwargs):
    """Why the method ``name`` of the class ``scheme`` cannot be called with ``args`` and
    ``kwargs`` (after the instance), or None (also where it has no signature to read)."""
    member = getattr(scheme, name)
    try:
        signature = inspect.signature(member)
    except (TypeError, ValueError):
        return None
    static = isinstance(inspect.getattr_static(scheme, name), (staticmethod, classmethod))
    try:
        signature.bind(*(() if static else (None,)), *args, **kwargs)
    except TypeError as err:
        return f"{name}{signature}: {err}"
    return None


def check(scheme, built_in=()):
    """Raise a TypeError naming ``scheme`` (a class) and its members that are missing, abstract
    or of the wrong kind: ``name`` a nonempty str (not the name of another class of
    ``built_in``, {name: class}), ``estimates_error`` True or False, the methods callable with the
    arguments the package gives them, the constructor with ``CONSTRUCTOR``."""
    missing = [n for n in CLASS_DATA + tuple(METHODS) if not hasattr(scheme, n)]
    missing += sorted(set(getattr(scheme, "__abstractmethods__", ())) - set(missing))
    if missing:
        _refuse(scheme, f"lacks {', '.join(missing)}")
    if not isinstance(scheme.name, str) or not scheme.name:
        _refuse(scheme, f"has name = {scheme.name!r}: it must be a nonempty str")
    if scheme.name in built_in and built_in[scheme.name] is not scheme:
        _refuse(scheme, f"has name = {scheme.name!r}, the name of the built-in {built_in[scheme.name].__qualname__}: "
                        "a scheme of its own needs a name of its own (run.json records it, a resume compares it)")
    if not isinstance(scheme.estimates_error, bool):
        _refuse(scheme, f"has estimates_error = {scheme.estimates_error!r}: it must be True or False")
    wrong = [n for n in METHODS if not callable(getattr(scheme, n))]
    if wrong:
        _refuse(scheme, f"has {', '.join(f'{n} = {getattr(scheme, n)!r}' for n in wrong)}: not callable")
    try:
        inspect.signature(scheme).bind(*[None] * 7)
    except TypeError as err:
        _refuse(scheme, f"cannot be built as Scheme{CONSTRUCTOR}: {err}")
    except ValueError:                          # no signature to read: built as it is
        pass
    problems = [p for p in (_signature_problem(scheme, n, *a) for n, a in METHODS.items()) if p]
    if problems:
        _refuse(scheme, f"has methods that cannot take the package's arguments: {'; '.join(problems)}")


def check_built(scheme):
    """Raise a TypeError naming ``scheme``'s class if the built scheme lacks data of
    ``INSTANCE_DATA`` (its constructor sets them, or its class)."""
    missing = [n for n in INSTANCE_DATA if not hasattr(scheme, n)]
    if missing:
        _refuse(type(scheme), f"built as Scheme{CONSTRUCTOR} lacks {', '.join(missing)}")
