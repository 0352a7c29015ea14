"""Hostile inputs (issue 22): every case ends in a clear error before the work, a NewtonError
with its reason, a flagged result or a result that passes a check against physics; none
ends silently or hangs.

Each case is one test id, ``<class>:<input>``, with the classes of issue 22: ``extreme``
(extreme and tiny numerical parameters, run on the reference scene), ``held`` (bodies held
only by the contact), ``sizes`` (sizes without bounds), ``types`` (options of the wrong type
or out of range), ``objects`` (wrong object types in the constructors' slots), ``nonsense``
(data that makes no sense), ``resume`` (resume into another scene, missing or corrupt
archives), ``output`` (unwritable output paths) and ``cli`` (every subcommand with bad
values). A case states the outcomes it accepts:

* ``Error(type, words)``: that exception (or a subclass) naming every word (regular
  expressions matched as whole words; the parameter's name), raised within
  ``BEFORE_WORK`` s of the call, so before any long work;
* ``NewtonFailure(words)``: ``ngcontact.NewtonError`` naming one of the words (any reason if
  none are given);
* ``Flagged(words)``: the run completes and a ``ngcontact.PhysicsWarning`` names the problem;
* ``Correct(check)``: the run completes and ``check`` passes: force balance against the
  applied load, the same contact force and deflection as a reference run with a normal value
  of the parameter, penetration below 0.1 of the gap;
* ``CliError(words)``: exit status 2, one line on stderr naming the option, no traceback.

``SOUND`` (any of the first four) is what the issue asks of extreme values: "either converge
to the right answer or fail with the reason". Anything else fails the case: another
exception, a result that fails its check unflagged, a crash or a hang.

Every case runs in a fresh process forked from a server that has imported ngcontact but never
meshed (forking after Netgen has meshed deadlocks in OpenCASCADE's thread pool), with a limit on
its CPU time and 4 GiB of address space, so that a hang or a runaway size fails its case only.
Every limit of the suite is on **CPU time** (the case's process and the processes it waited for),
not on the wall clock: a machine busy with other work (a second copy of the suite beside it)
stretches the wall clock several times but hardly the CPU time, so no outcome flips with load.
The wall clock only catches a process that waits for ever (``WALL`` times its CPU limit).
The CLI cases call ``ngcontact.cli.main`` there (as ``python -m ngcontact`` would, without
Python's start-up); a few run ``python -m ngcontact`` itself, the rest of those are ``slow``.
"""
import functools
import glob
import importlib
import math
import multiprocessing
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import traceback
import warnings
from dataclasses import dataclass
from multiprocessing import forkserver

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
import ngcontact.cli
import ngcontact.demo
import ngcontact.studies.bench
import ngcontact.studies.convergence
import ngcontact.studies.hertz
import ngcontact.studies.stability
from ngcontact import Simulation, adapt, obstacles  # noqa: F401 (loaded in the fork server, not by each case)
from ngcontact.output import results
from ngcontact.geometries import block, plate
from ngcontact.model.materials import isotropic_stiffness
from ngcontact.scenes import hertz
from ngcontact.scenes import reference as scene

pytestmark = pytest.mark.timeout(400)     # pytest-timeout: the outer guard; each case has its own limit

BEFORE_WORK = 5.0         # CPU s: an error on bad input comes before any long work (coarse meshes here)
CLI_LIMIT = 20.0          # CPU s: a CLI error, Python's start-up included
HANG = dict(default=30.0, extreme=120.0, held=120.0, resume=60.0, cli=40.0)   # CPU s until a case is a hang
WALL = 10.0               # a case's process that has not ended after WALL × its CPU limit waits for ever
MEMORY = 4 << 30          # bytes of address space of a case's process
TE, VE = "TypeError", "ValueError"
CHOICE = "TypeError|ValueError"   # a value of the wrong type for an option with a few allowed values
NAN, INF = math.nan, math.inf
H3 = 0.005                # m, the facets of Γ3 of the coarse reference plate (maxh 0.01, halved on Γ3)


# ----------------------------------------------------------------------------- outcomes

@dataclass(frozen=True)
class Outcome:
    """What a case's call did: ``kind`` "returned", "raised", "died" or "hang"; the exception's
    type names (its MRO) and message; the value returned; the CPU seconds it took (its own and
    its child processes'); the warnings issued (category name, message)."""
    kind: str
    types: tuple = ()
    message: str = ""
    value: object = None
    elapsed: float = 0.0
    warnings: tuple = ()
    detail: str = ""

    def describe(self):
        if self.kind == "raised":
            return f"{self.types[0]}: {_line(self.message)}"
        if self.kind == "returned":
            return f"completed silently ({_short(self.value)})"
        return f"{self.kind}: {self.detail}"


def _line(text, limit=200):
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit] + " ..."


def _short(value):
    if isinstance(value, dict):
        return ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {_line(v, 80)}"
                         for k, v in value.items() if k not in ("stderr",))
    return _line(repr(value), 120)


def _named(message, words):
    """The words (regular expressions) that ``message`` does not contain as whole words (an
    option's leading "--" is not part of its name)."""
    message = message.replace("--", " ")
    return [w for w in words if not re.search(rf"(?<![\w-])(?:{w})(?![\w-])", message)]


@dataclass(frozen=True)
class Error:
    """The call raises ``kind`` (or a subclass; "TypeError|ValueError" for either) within
    BEFORE_WORK s, naming all ``words``."""
    kind: str
    words: tuple

    def __init__(self, kind, *words):
        object.__setattr__(self, "kind", kind)
        object.__setattr__(self, "words", words)

    def problem(self, outcome, references):
        if outcome.kind != "raised":
            return f"expected {self.kind} naming {'/'.join(self.words)}; {outcome.describe()}"
        if not set(self.kind.split("|")) & set(outcome.types):
            return f"expected {self.kind}; got {outcome.describe()}"
        missing = _named(outcome.message, self.words)
        if missing:
            return f"{self.kind} does not name {'/'.join(missing)}: {_line(outcome.message)}"
        if outcome.elapsed > BEFORE_WORK:
            return f"{self.kind} after {outcome.elapsed:.1f} s, not before the work: {_line(outcome.message)}"
        return None


@dataclass(frozen=True)
class NewtonFailure:
    """``ngcontact.NewtonError`` whose message names one of ``words`` (any reason if empty)."""
    words: tuple = ()

    def __init__(self, *words):
        object.__setattr__(self, "words", words)

    def problem(self, outcome, references):
        if outcome.kind != "raised" or "NewtonError" not in outcome.types:
            return f"expected a NewtonError ({'|'.join(self.words) or 'with its reason'}); {outcome.describe()}"
        if self.words and len(_named(outcome.message, self.words)) == len(self.words):
            return f"the NewtonError gives no reason ({'|'.join(self.words)}): {_line(outcome.message)}"
        return None


@dataclass(frozen=True)
class Flagged:
    """The run completes and a PhysicsWarning names one of ``words`` (anything if empty)."""
    words: tuple = ()

    def __init__(self, *words):
        object.__setattr__(self, "words", words)

    def problem(self, outcome, references):
        if outcome.kind != "returned":
            return f"expected a flagged result; {outcome.describe()}"
        flags = [m for category, m in outcome.warnings if category == "PhysicsWarning"]
        if not any(not self.words or len(_named(m, self.words)) < len(self.words) for m in flags):
            return f"not flagged ({'|'.join(self.words) or 'PhysicsWarning'}): {outcome.describe()}"
        return None


@dataclass(frozen=True)
class Correct:
    """The run completes and ``check(value, references)`` returns None (else what is wrong)."""
    check: object

    def problem(self, outcome, references):
        if outcome.kind != "returned":
            return f"expected a correct result; {outcome.describe()}"
        wrong = self.check(outcome.value, references)
        return None if wrong is None else f"silently wrong: {wrong}"


@dataclass(frozen=True)
class CliError:
    """Exit status ``code`` (2: refused; 1: the command ran but missed its target) within CLI_LIMIT
    s (``within`` s for an error that comes after the work, a run that fails by name), one line on
    stderr naming the ``words``, no traceback (besides one-line warnings, "ngcontact: warning:
    ...", printed before it)."""
    words: tuple
    within: float = CLI_LIMIT
    code: int = 2

    def __init__(self, *words, within=CLI_LIMIT, code=2):
        object.__setattr__(self, "words", words)
        object.__setattr__(self, "within", within)
        object.__setattr__(self, "code", code)

    def problem(self, outcome, references):
        if outcome.kind != "returned":
            return outcome.describe()
        code, stderr = outcome.value["code"], outcome.value["stderr"]
        lines = [line for line in stderr.splitlines() if line.strip() and not line.startswith("ngcontact: warning:")]
        if "Traceback" in stderr:
            return f"exit {code} with a traceback: {_line(lines[-1] if lines else '')}"
        if code != self.code:
            return f"exit status {code}, not {self.code} ({_line(lines[-1]) if lines else 'nothing on stderr'})"
        if len(lines) != 1:
            return f"{len(lines)} lines on stderr, not one: {_line(' / '.join(lines))}"
        missing = _named(lines[0], self.words)
        if missing:
            return f"the line does not name {'/'.join(missing)}: {_line(lines[0])}"
        if outcome.elapsed > self.within:
            return f"exit {code} after {outcome.elapsed:.1f} s: {_line(lines[0])}"
        return None


def SOUND(parameter, check):
    """What the issue asks of an extreme value: refused before the work, a NewtonError, a
    flagged result, or a correct one."""
    return (Correct(check), NewtonFailure(), Flagged(), Error(VE, parameter))


# ----------------------------------------------------------------------------- the cases

@dataclass(frozen=True)
class Case:
    id: str
    group: str
    call: object              # call(ctx) -> a small picklable value; runs in the case's process
    expect: tuple             # accepted outcomes
    needs: tuple = ()         # module fixtures whose values (paths) go into ctx
    slow: bool = False        # True: a slow case (-m slow); "long": CI's leg of long tests (-m long)


CASES = []


def case(group, label, call, *expect, needs=(), slow=False):
    CASES.append(Case(f"{group}:{label}", group, call, expect, needs, slow))


# ----------------------------------------------------------------------------- scenes (built in the case's process)

PARTS = dict(clamped="left", grounded="top", contact_side="bottom")


@functools.cache
def plate_mesh(maxh=0.01):
    """The reference plate 0.1 m × 0.02 m, halved along Γ3 (as ``scenes.reference``)."""
    return plate(maxh=maxh, maxh_contact=maxh / 2)


def body(mesh=None, material=None, **changes):
    return ngc.Body(plate_mesh() if mesh is None else mesh, material or ngc.pzt5a(relaxation_time=2e-3),
                    **{**PARTS, **changes})


DEFAULT = object()


def simulation(*, loads=None, contact=DEFAULT, body_changes=None, material=None, **options):
    """The coarse reference scene (``scenes.reference`` at maxh 0.01) with ``loads(t)`` (a
    function of the time Parameter) and ``contact`` in place of its own."""
    t = ngs.Parameter(0.0)
    return ngc.Simulation(body(material=material, **(body_changes or {})),
                          scene.loads(t) if loads is None else loads(t),
                          contact=scene.contact() if contact is DEFAULT else contact, time=t, **options)


def applied(T):
    """The load on top of the reference plate at time T, N/m (downward, so the contact force
    and the reaction balance it upward)."""
    return scene.PRESSURE * float(np.interp(T, *zip(*scene.LOAD_HISTORY))) * scene.L1


def measure(sim, load, tip=True, allowed=None):
    """The last step of ``sim`` as numbers: the vertical contact force and held reaction
    (N/m), the load they must balance, the tip deflection (m), penetration and gap (m), the
    penetration ``allowed`` (m; default 0.1 of the gap + 1e-4 of a facet of Γ3), the largest
    |u| (m), the body's size (m) and the time reached (s)."""
    record, d = sim.history[-1], sim.body.dim - 1
    values = sim.u.vec.FV().NumPy()
    held = sum((np.asarray(v, dtype=float) for v in record.boundary_reaction.values()), np.zeros(sim.body.dim))
    contact = record.contact
    finite = bool(np.all(np.isfinite(values)))
    gap = float(np.min(sim.side.sample(sim.gap))) if contact is not None else INF
    point = (scene.L1, 0.0) if sim.body.dim == 2 else (scene.L1, 0.02, 0.0)
    return dict(force=float(contact.force[d]) if contact is not None else 0.0, reaction=float(held[d]),
                applied=float(load), tip=float(sim.u(sim.body.mesh(*point))[d]) if finite and tip else NAN,
                penetration=float(contact.max_penetration) if contact is not None else -INF,
                gap=gap, allowed=0.1 * gap + 1e-4 * H3 if allowed is None else allowed,
                umax=float(np.abs(values).max()) if finite else INF, size=float(sim.body.size), finite=finite,
                steps=len(sim.history) - 1, time=float(sim.t))


def reference_run(contact=None, *, dt=0.05, T=0.1, max_cutbacks=0, **options):
    """The coarse reference scene pushed to full pressure (t = 0.1 s) in two steps."""
    sim = scene.simulation(1, 0.01, contact=contact, **options)
    sim.run(dt, T, max_cutbacks=max_cutbacks)
    return dict(measure(sim, applied(sim.t)), target=T)


def free_run():
    """The reference plate without contact (the gap never closes)."""
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(body(), scene.loads(t), time=t)
    sim.run(0.05, 0.1, max_cutbacks=0)
    return measure(sim, applied(sim.t))


def step_once(sim, dt=0.05):
    sim.step(dt)
    return dict(t=sim.t)


def built(sim):
    return dict(model=sim.model, t=sim.t)


# ----------------------------------------------------------------------------- checks against physics

def _balance(v):
    gap = abs(v["force"] + v["reaction"] - v["applied"])
    if gap > 1e-6 * abs(v["applied"]) + 1e-9:
        return (f"force balance off by {gap:.3g} N/m of {v['applied']:.4g} (contact {v['force']:.4g}, "
                f"reaction {v['reaction']:.4g})")
    return None


def _reached(v):
    if "target" in v and not math.isclose(v["time"], v["target"], rel_tol=1e-9):
        return f"the run ended at t = {v['time']:.6g} s, not at T = {v['target']:.6g} s"
    return None


def _penetration(v):
    if v["penetration"] > v["allowed"]:
        return f"penetration {v['penetration']:.3g} m > {v['allowed']:.3g} m (gap {v['gap']:.3g} m)"
    return None


def matches(name, force=0.02, tip=0.01):
    """In equilibrium, penetration below 0.1 of the gap, and the contact force and tip
    deflection of the reference run ``name`` to ``force`` and ``tip`` (relative; the tip
    also to 1e-8 m, 3e-5 of the free plate's deflection), at the final time asked for."""
    def check(v, references):
        r = references[name]
        if not v["finite"]:
            return "the state has NaN or inf entries"
        wrong = [_reached(v), _balance(v), _penetration(v)]
        if abs(v["force"] - r["force"]) > force * max(abs(r["force"]), 1e-6 * abs(r["applied"])):
            wrong.append(f"contact force {v['force']:.5g} N/m, reference ({name}) {r['force']:.5g}")
        if abs(v["tip"] - r["tip"]) > tip * abs(r["tip"]) + 1e-8:
            wrong.append(f"tip deflection {v['tip']:.5g} m, reference ({name}) {r['tip']:.5g}")
        return "; ".join(w for w in wrong if w) or None
    return check


def balanced(v, references):
    """In equilibrium with the load alone (no held reaction needed), penetration below 0.1 of
    the gap, displacements below 0.05 of the body's size."""
    if not v["finite"]:
        return "the state has NaN or inf entries"
    wrong = [_reached(v), _balance(v), _penetration(v)]
    if v["umax"] > 0.05 * v["size"]:
        wrong.append(f"|u| = {v['umax']:.3g} m on a body of {v['size']:.3g} m")
    return "; ".join(w for w in wrong if w) or None


def at_rest(v, references):
    """Nothing moves (no load yet), at the final time asked for."""
    if not v["finite"] or v["umax"] > 1e-12:
        return f"|u| = {v['umax']:.3g} m under no load"
    return _reached(v)


# ----------------------------------------------------------------------------- class: extreme and tiny parameters

def extreme(label, changes, *expect, run=None, **options):
    """A reference run with the Contact changed by ``changes`` (or the Simulation by ``options``)."""
    run = run or {}
    case("extreme", label, lambda ctx: reference_run(scene.contact(**changes), **run, **options), *expect)


for g in (1e30, 1e15, 1e300, 5e-324, 1e-6):
    extreme(f"gamma0={g:g}", dict(gamma0=g), *SOUND("gamma0", matches("default")))
for th in (0, -1):
    extreme(f"theta={th},gamma0=1e-6", dict(theta=th, gamma0=1e-6), *SOUND("gamma0", matches("default")))
    extreme(f"theta={th}", dict(theta=th), Correct(matches("default")))
extreme("method=active_set", dict(method="active_set"), Correct(matches("default")))
extreme("method=penalty", dict(method="penalty"), Correct(matches("default")))
extreme("penalty=1e-9", dict(method="penalty", penalty=1e-9), Flagged("penetration"), Error(VE, "penalty"))
for p in (1e30, 1e300, 1e-300):
    extreme(f"penalty={p:g}", dict(method="penalty", penalty=p), *SOUND("penalty", matches("default")))
for name, values in dict(adhesion=(1e30, 1e300), eps_a=(1e30, 1e300), compliance=(1e30, 1e300),
                         conductance=(1e30, 1e300), bond_length=(1e-300, 5e-324, 1e300),
                         ramp_width=(1e-300, 5e-324, 1e300), potential_truncation=(1e-300, 1e300)).items():
    for value in values:
        extreme(f"{name}={value:g}", {name: value}, *SOUND(name, matches("default")))
for value in (1e30, -1e30, 1e300):      # φ_L(φ − φ_Γ) saturates at ∓L_φ: as a foundation at ±1 MV
    extreme(f"foundation_potential={value:g}", dict(foundation_potential=value),
            *SOUND("foundation_potential", matches("default" if value > 0 else "phi_low")))
for name in ("adhesion", "compliance", "conductance"):
    extreme(f"{name}=1e-300", {name: 1e-300}, Correct(matches("default")))
extreme("compliance=law 1e30[r]+", dict(compliance=lambda r: 1e30 * ngs.IfPos(r, r, 0.0)),
        *SOUND("compliance", matches("default")))
extreme("beta0=0", dict(beta0=0.0), Correct(matches("default")))
extreme("beta0=1e-300", dict(beta0=1e-300), Correct(matches("default")))
extreme("gap=1e-12", dict(gap=1e-12), Correct(matches("gap0")))
for g in (1e-300, 5e-324):
    extreme(f"gap={g:g}", dict(gap=g), *SOUND("gap", matches("gap0")))
extreme("gap=1", dict(gap=1.0), Correct(matches("free")))
extreme("gap=1e300", dict(gap=1e300), *SOUND("gap", matches("free")))
for r in (1e-300, 5e-324, 1e-17):
    extreme(f"rtol={r:g}", {}, *SOUND("rtol", matches("default")), rtol=r)
extreme("maxit=1", {}, NewtonFailure(), Error(VE, "maxit"), maxit=1)
extreme("maxit=1e12", {}, Correct(matches("default")), maxit=10 ** 12)
extreme("dt=1e300", {}, Correct(matches("default")), run=dict(dt=1e300, max_cutbacks=6))
extreme("T=1e-300", {}, *SOUND("T", at_rest), run=dict(T=1e-300))
extreme("T=5e-324", {}, Error(VE, "T|dt"), run=dict(T=5e-324))
extreme("max_cutbacks=20", {}, Correct(matches("default")), run=dict(max_cutbacks=20))


# ----------------------------------------------------------------------------- class: bodies held only by the contact

def floating(load, supports=None, u0=None, method="nitsche", dim=2):
    """The plate (or the block) held in x only, pressed onto (or pulled off) the foundation by
    ``load`` Pa on top (ramped to t = 0.1 s): vertically only the contact holds it."""
    t = ngs.Parameter(0.0)
    mesh = plate_mesh() if dim == 2 else block(maxh=0.02)
    held = ngc.Body(mesh, ngc.pzt5a(relaxation_time=2e-3), supports=supports or {"left": "x"}, grounded="top",
                    contact_side="bottom")
    f2 = (0.0,) * (dim - 1) + (load * t / 0.1,)
    sim = ngc.Simulation(held, ngc.Loads(f2={"top": f2}), contact=ngc.Contact(gap=2e-5, method=method), time=t, u0=u0)
    sim.run(0.05, 0.1, max_cutbacks=0)
    return dict(measure(sim, -load * (scene.L1 if dim == 2 else 0.1 * 0.04)), target=0.1)


def half_disk(load):
    """The Hertz half-disk held in x only on its flat top, ``load`` Pa on top (penetration
    allowed: 0.01 of the facets at the contact point, 0.05 m)."""
    t = ngs.Parameter(0.0)
    held = ngc.Body(hertz.mesh(2, 0.05), hertz.material(), supports={"top": "x"}, contact_side="contact")
    sim = ngc.Simulation(held, ngc.Loads(f2={"top": (0.0, load * t)}),
                         contact=ngc.Contact(obstacle=obstacles.Plane((0.0, 0.0), (0.0, 1.0))), time=t)
    sim.run(1.0, 1.0, max_cutbacks=0)
    return dict(measure(sim, -load * 2 * hertz.R, tip=False, allowed=0.01 * 0.05), target=1.0)


SINGULAR = ("singular", "held only by the contact")
REPORTED = (NewtonFailure(*SINGULAR), Error(VE, "|".join(SINGULAR)))
case("held", "plate supports x, pushed", lambda ctx: floating(-2e6), Correct(balanced), *REPORTED)
case("held", "plate supports x, pushed, penalty", lambda ctx: floating(-2e6, method="penalty"),
     Correct(balanced), *REPORTED)
case("held", "plate supports x, pushed, active_set", lambda ctx: floating(-2e6, method="active_set"),
     Correct(balanced), *REPORTED)
case("held", "plate supports x, pushed from touching", lambda ctx: floating(-2e6, u0=(0.0, -2e-5)),
     Correct(balanced), *REPORTED)
case("held", "plate supports x, no load", lambda ctx: floating(0.0), Correct(at_rest), *REPORTED)
case("held", "plate supports x, pulled off", lambda ctx: floating(2e6), *REPORTED)
case("held", "plate supports y (x free), pushed", lambda ctx: floating(-2e6, supports={"left": "y"}),
     Correct(balanced), *REPORTED)
case("held", "block supports x, pushed", lambda ctx: floating(-2e6, dim=3), Correct(balanced), *REPORTED)
case("held", "half-disk supports x, pushed", lambda ctx: half_disk(-0.01), Correct(balanced), *REPORTED)
case("held", "half-disk supports x, pulled off", lambda ctx: half_disk(0.01), *REPORTED)


# ----------------------------------------------------------------------------- class: sizes without bounds

def sized(label, call, *words):
    case("sizes", label, call, Error(VE, *words))


for h in (1e-6, 1e-300, INF, NAN, 0.0, -0.01):
    sized(f"plate(maxh={h:g})", lambda ctx, h=h: plate(maxh=h), "maxh")
for h in (1e-7, NAN, 0.0):
    sized(f"plate(maxh_contact={h:g})", lambda ctx, h=h: plate(maxh=0.01, maxh_contact=h), "maxh_contact")
for k in (12, 100, -1):
    sized(f"plate(refine={k})", lambda ctx, k=k: plate(maxh=0.01, refine=k), "refine")
sized("plate(L1=1e300)", lambda ctx: plate(L1=1e300), "L1|maxh")
sized("plate(L1=inf)", lambda ctx: plate(L1=INF), "L1")
sized("plate(L2=nan)", lambda ctx: plate(L2=NAN), "L2")
for h in (1e-5, NAN, INF):
    sized(f"block(maxh={h:g})", lambda ctx, h=h: block(maxh=h), "maxh")
sized("block(refine=8)", lambda ctx: block(maxh=0.02, refine=8), "refine")
sized("block(L3=-1)", lambda ctx: block(L3=-1.0), "L3")
for p in (30, 10 ** 6):
    sized(f"Body(order={p})", lambda ctx, p=p: body(order=p), "order")
sized("Body(order_phi=30)", lambda ctx: body(order_phi=30), "order_phi")
for k in (1000, 10 ** 6):
    sized(f"run(max_cutbacks={k})", lambda ctx, k=k: scene.simulation(1, 0.01).run(0.05, 0.1, max_cutbacks=k),
          "max_cutbacks")
sized("advance(max_cutbacks=1000)", lambda ctx: scene.simulation(1, 0.01).advance(0.05, max_cutbacks=1000),
      "max_cutbacks")
sized("run(T=1e300)", lambda ctx: scene.simulation(1, 0.01).run(0.05, 1e300), "T|dt")

DEMO = dict(steps=2, maxh=0.02)          # what a demo that is not refused costs little with


def demo(**changes):
    return lambda ctx: _demo(ctx, changes)


def _demo(ctx, changes):
    ngcontact.demo.run(**{"out": os.path.join(ctx["work"], "demo"), **DEMO, **changes})
    return dict(done=True)


for label, changes, words in [
        ("maxh=1e-6", dict(maxh=1e-6), "maxh"), ("maxh=inf", dict(maxh=INF), "maxh"),
        ("maxh=nan", dict(maxh=NAN), "maxh"), ("refine=12", dict(refine=12), "refine"),
        ("order=30", dict(order=30), "order"), ("steps=1e9", dict(steps=10 ** 9), "steps"),
        ("steps=0", dict(steps=0), "steps"), ("dim=3,maxh=1e-5", dict(dim=3, maxh=1e-5), "maxh")]:
    sized(f"demo.run({label})", demo(**changes), words)


def convergence(**changes):
    arguments = {**dict(orders=[1], levels=1, case="viscous", smoothness=4, dt_halvings=0), **changes}
    return lambda ctx: ngcontact.studies.convergence.command(out=os.path.join(ctx["work"], "conv"), **arguments)


for label, changes, words in [
        ("levels=100", dict(levels=100), "levels"), ("levels=0", dict(levels=0), "levels"),
        ("orders=[30]", dict(orders=[30]), "orders?"), ("orders=[0]", dict(orders=[0]), "orders?"),
        ("orders=[]", dict(orders=[]), "orders?"), ("dt_halvings=100", dict(dt_halvings=100), "dt[-_]halvings"),
        ("dt_halvings=-1", dict(dt_halvings=-1), "dt[-_]halvings"),
        ("smoothness=0", dict(smoothness=0), "smoothness"), ("smoothness=-1", dict(smoothness=-1), "smoothness"),
        ("case='bogus'", dict(case="bogus"), "case")]:
    sized(f"convergence.command({label})", convergence(**changes), *words.split(","))


def hertz_study(**changes):
    arguments = {**dict(orders=[1], levels=1, dim=2), **changes}
    return lambda ctx: ngcontact.studies.hertz.command(os.path.join(ctx["work"], "hertz"), **arguments)


for label, changes, words in [
        ("levels=50", dict(levels=50), "levels"), ("orders=[30]", dict(orders=[30]), "orders?"),
        ("orders=[0]", dict(orders=[0]), "orders?"), ("dim=4", dict(dim=4), "dim")]:
    sized(f"hertz.command({label})", hertz_study(**changes), words)


def bench(**changes):
    arguments = {**dict(orders=[1], max_ndof=1e3, steps=1, progress=False), **changes}
    return lambda ctx: ngcontact.studies.bench.run(os.path.join(ctx["work"], "bench"), **arguments)


for label, changes, words in [
        ("max_ndof=nan", dict(max_ndof=NAN), "max[-_]ndof"), ("max_ndof=inf", dict(max_ndof=INF), "max[-_]ndof"),
        ("max_ndof=0", dict(max_ndof=0), "max[-_]ndof"), ("max_ndof=-1", dict(max_ndof=-1), "max[-_]ndof"),
        ("max_ndof=1e15", dict(max_ndof=1e15), "max[-_]ndof"), ("steps=0", dict(steps=0), "steps"),
        ("steps=-1", dict(steps=-1), "steps"), ("dt=0", dict(dt=0.0), "dt"), ("dt=nan", dict(dt=NAN), "dt"),
        ("orders=[0]", dict(orders=[0]), "orders?"), ("orders=[30]", dict(orders=[30]), "orders?"),
        ("dim=4", dict(dim=4), "dim")]:
    sized(f"bench.run({label})", bench(**changes), words)


# ----------------------------------------------------------------------------- class: wrong types, out of range

NUMBER_BAD = [("'1'", "1", TE), ("None", None, TE), ("True", True, TE), ("nan", NAN, VE), ("inf", INF, VE),
              ("1j", 1j, TE), ("[1.0]", [1.0], TE)]
INTEGER_BAD = [("'2'", "2", TE), ("None", None, TE), ("True", True, TE), ("2.5", 2.5, TE), ("nan", NAN, TE),
               ("1j", 1j, TE)]
BOOL_BAD = [("'no'", "no", TE), ("2", 2, TE), ("None", None, TE), ("1.0", 1.0, TE), ("[True]", [True], TE)]
AUTO_BAD = [("'yes'", "yes", TE), ("2", 2, TE), ("1.0", 1.0, TE), ("'auto'", "auto", TE)]


def typed(label, call, kind, *words):
    case("types", label, call, Error(kind, *words))


# Simulation
for option in ("keep_states", "predictor", "limit_steps", "reuse_factorization", "physical_checks"):
    for label, value, kind in BOOL_BAD:
        typed(f"Simulation({option}={label})", lambda ctx, o=option, v=value: built(simulation(**{o: v})), kind,
              option)
for option in ("condense", "realcompile", "iterative", "electric"):
    for label, value, kind in AUTO_BAD:
        if option == "iterative" and isinstance(value, str):    # it also takes a solver's name
            kind = VE
        typed(f"Simulation({option}={label})", lambda ctx, o=option, v=value: built(simulation(**{o: v})), kind,
              option)
for label, value, kind in NUMBER_BAD + [("0", 0.0, VE), ("-1", -1.0, VE), ("1", 1.0, VE), ("2", 2.0, VE)]:
    typed(f"Simulation(rtol={label})", lambda ctx, v=value: built(simulation(rtol=v)), kind, "rtol")
for label, value, kind in INTEGER_BAD + [("0", 0, VE), ("-3", -3, VE), ("inf", INF, TE)]:
    typed(f"Simulation(maxit={label})", lambda ctx, v=value: built(simulation(maxit=v)), kind, "maxit")
for label, value, kind in [("'bogus'", "bogus", VE), ("5", 5, CHOICE), ("True", True, CHOICE),
                           ("['umfpack']", ["umfpack"], CHOICE)]:
    typed(f"Simulation(inverse={label})", lambda ctx, v=value: built(simulation(inverse=v)), kind, "inverse")
for label, value, kind in [("'bogus'", "bogus", VE), ("5", 5, TE), ("True", True, TE), ("['umfpack']", ["umfpack"], TE),
                           ("{'pc_type': 'jacobi'}", {"pc_type": "jacobi"}, VE)]:
    typed(f"Simulation(solver={label})", lambda ctx, v=value: built(simulation(solver=v)), kind, "solver")


# run, advance, step
def run_with(**arguments):
    """The coarse reference scene run with ``arguments`` over one step of 0.05 s."""
    arguments = {**dict(dt=0.05, T=0.05), **arguments}
    return lambda ctx: _run_with(arguments)


def _run_with(arguments):
    sim = scene.simulation(1, 0.01)
    dt, T = arguments.pop("dt"), arguments.pop("T")
    sim.run(dt, T, **arguments)
    return dict(t=sim.t, steps=len(sim.history) - 1)


for label, value, kind in NUMBER_BAD + [("-0.05", -0.05, VE), ("0", 0.0, VE), ("5e-324", 5e-324, VE),
                                        ("1e-300", 1e-300, VE)]:
    typed(f"run(dt={label})", run_with(dt=value), kind, "dt")
for label, value, kind in NUMBER_BAD + [("-1", -1.0, VE), ("0", 0.0, VE)]:
    typed(f"run(T={label})", run_with(T=value), kind, "T")
for label, value, kind in INTEGER_BAD + [("-1", -1, VE)]:
    typed(f"run(max_cutbacks={label})", run_with(max_cutbacks=value), kind, "max_cutbacks")
for label, value in [("'no'", "no"), ("2", 2), ("[True]", [True])]:
    typed(f"run(progress={label})", run_with(progress=value), TE, "progress")
for label, value in [("5", 5), ("True", True), ("['f']", ["f"]), ("1.5", 1.5)]:
    typed(f"run(vtk={label})", run_with(vtk=value), TE, "vtk")
for label, value in [("'print'", "print"), ("5", 5), ("lambda: None", lambda: None)]:
    typed(f"run(on_step={label})", run_with(on_step=value), TE, "on_step")
for label, value in [("5", 5), ("True", True), ("['d']", ["d"])]:
    typed(f"run(out={label})", run_with(out=value), TE, "out")


def advance_with(target=0.05, **arguments):
    def call(ctx):
        sim = scene.simulation(1, 0.01)
        sim.advance(target, **arguments)
        return dict(t=sim.t)
    return call


for label, value, kind in NUMBER_BAD + [("-1", -1.0, VE), ("0", 0.0, VE), ("5e-324", 5e-324, VE)]:
    typed(f"advance(target={label})", advance_with(value), kind, "target")
for label, value, kind in [("-1", -1, VE), ("2.5", 2.5, TE), ("'2'", "2", TE), ("None", None, TE)]:
    typed(f"advance(max_cutbacks={label})", advance_with(max_cutbacks=value), kind, "max_cutbacks")
for label, value in [("'x'", "x"), ("5", 5)]:
    typed(f"advance(on_step={label})", advance_with(on_step=value), TE, "on_step")
for label, value, kind in NUMBER_BAD + [("-1", -1.0, VE), ("0", 0.0, VE), ("5e-324", 5e-324, VE)]:
    typed(f"step(dt={label})", lambda ctx, v=value: step_once(scene.simulation(1, 0.01), v), kind, "dt")

# Contact
for name in ("adhesion", "eps_a", "bond_length", "ramp_width", "potential_truncation", "gamma0", "penalty",
             "compliance", "conductance", "gap", "beta0", "foundation_potential"):
    extra = [] if name == "foundation_potential" else [("-1", -1.0, VE)]
    if name in ("bond_length", "ramp_width", "potential_truncation", "gamma0", "penalty"):
        extra.append(("0", 0.0, VE))
    if name == "beta0":
        extra.append(("1.5", 1.5, VE))
    for label, value, kind in NUMBER_BAD + extra:
        typed(f"Contact({name}={label})", lambda ctx, n=name, v=value: repr(ngc.Contact(**{n: v})), kind, name)
for label, value, kind in [("2", 2, VE), ("0.5", 0.5, VE), ("-2", -2, VE), ("'1'", "1", CHOICE), ("None", None, CHOICE),
                           ("True", True, CHOICE), ("1j", 1j, CHOICE), ("nan", NAN, VE)]:
    typed(f"Contact(theta={label})", lambda ctx, v=value: repr(ngc.Contact(theta=v)), kind, "theta")
for label, value, kind in [("'bogus'", "bogus", VE), ("'NITSCHE'", "NITSCHE", VE), ("None", None, CHOICE),
                           ("1", 1, CHOICE),
                           ("['nitsche']", ["nitsche"], CHOICE)]:
    typed(f"Contact(method={label})", lambda ctx, v=value: repr(ngc.Contact(method=v)), kind, "method")
for label, value, kind in [("'bogus'", "bogus", VE), ("None", None, CHOICE), ("1", 1, CHOICE), ("True", True, CHOICE)]:
    typed(f"Contact(beta_update={label})", lambda ctx, v=value: repr(ngc.Contact(beta_update=v)), kind,
          "beta_update")

# Body
for label, value, kind in INTEGER_BAD + [("0", 0, VE), ("-1", -1, VE)]:
    typed(f"Body(order={label})", lambda ctx, v=value: repr(body(order=v)), kind, "order")
for label, value, kind in [c for c in INTEGER_BAD if c[1] is not None] + [("0", 0, VE)]:   # None: = order
    typed(f"Body(order_phi={label})", lambda ctx, v=value: repr(body(order_phi=v)), kind, "order_phi")
for part, values in dict(clamped=[("1", 1), ("['left']", ["left"]), ("True", True)],
                         grounded=[("1", 1), ("['top']", ["top"])],
                         contact_side=[("1", 1), ("['bottom']", ["bottom"]), ("('bottom',)", ("bottom",))]).items():
    for label, value in values:
        typed(f"Body({part}={label})", lambda ctx, p=part, v=value: repr(body(**{p: v})), TE, part)
for label, value, kind in [("'left'", "left", TE), ("['left']", ["left"], TE), ("{'left': 1}", {"left": 1}, TE),
                           ("{'left': None}", {"left": None}, TE), ("{5: 'x'}", {5: "x"}, TE),
                           ("{'left': 'w'}", {"left": "w"}, VE), ("{'left': 'xz'}", {"left": "xz"}, VE),
                           ("{'nowhere': 'x'}", {"nowhere": "x"}, VE)]:
    typed(f"Body(supports={label})", lambda ctx, v=value: repr(body(clamped=None, supports=v)), kind, "supports")

# Material and its presets
STIFF = isotropic_stiffness(60e9, 0.3)
GOOD = dict(c=STIFF, e=np.zeros((3, 6)), eps=1e-8 * np.eye(3))
for slot, values in dict(
        c=[("'x'", "x", TE), ("None", None, TE), ("complex", STIFF * (1 + 1e-3j), TE), ("nan", STIFF * NAN, VE),
           ("inf", np.full((6, 6), INF), VE), ("(5, 5)", np.eye(5), VE), ("{}", {}, TE)],
        e=[("'x'", "x", TE), ("complex", np.full((3, 6), 1j), TE), ("inf", np.full((3, 6), INF), VE),
           ("(6, 3)", np.zeros((6, 3)), VE)],
        eps=[("'x'", "x", TE), ("complex", 1e-8j * np.eye(3), TE), ("nan", np.full((3, 3), NAN), VE),
             ("zero", np.zeros((3, 3)), VE)],
        eta=[("'x'", "x", TE), ("complex", 1j * np.eye(6), TE), ("nan", np.full((6, 6), NAN), VE),
             ("negative", -np.eye(6), VE)],
        poling=[("'w'", "w", VE), ("1", 1, CHOICE), ("['x']", ["x"], CHOICE), ("True", True, CHOICE)],
        name=[("5", 5, TE), ("['a']", ["a"], TE)]).items():
    for label, value, kind in values:
        typed(f"Material({slot}={label})", lambda ctx, s=slot, v=value: repr(ngc.Material(**{**GOOD, s: v})), kind,
              slot)
ISOTROPIC = dict(E=60e9, nu=0.3, permittivity=1e-8)
for name in ("E", "nu", "permittivity", "e31", "e33", "e15", "viscosity", "bulk_viscosity"):
    for label, value, kind in NUMBER_BAD:
        typed(f"Material.isotropic({name}={label})",
              lambda ctx, n=name, v=value: repr(ngc.Material.isotropic(**{**ISOTROPIC, n: v})), kind, name)
for label, changes, word in [("E=0", dict(E=0.0), "E"), ("E=-1", dict(E=-1.0), "E"), ("nu=0.5", dict(nu=0.5), "nu"),
                             ("nu=-1", dict(nu=-1.0), "nu"), ("nu=0.7", dict(nu=0.7), "nu"),
                             ("permittivity=0", dict(permittivity=0.0), "permittivity"),
                             ("viscosity=-1", dict(viscosity=-1.0), "viscosity"),
                             ("bulk_viscosity=-1", dict(bulk_viscosity=-1.0), "bulk_viscosity"),
                             ("poling='q'", dict(poling="q"), "poling")]:
    typed(f"Material.isotropic({label})", lambda ctx, c=changes: repr(ngc.Material.isotropic(**{**ISOTROPIC, **c})),
          VE, word)
for label, changes, kind, word in [("poling=3", dict(poling=3), CHOICE, "poling"),
                                   ("name=5", dict(name=5), TE, "name")]:
    typed(f"Material.isotropic({label})", lambda ctx, c=changes: repr(ngc.Material.isotropic(**{**ISOTROPIC, **c})),
          kind, word)
for preset in ("pzt5a", "batio3", "academic"):
    for label, value, kind in NUMBER_BAD[:4] + [("-1", -1.0, VE)]:
        typed(f"{preset}(relaxation_time={label})",
              lambda ctx, p=preset, v=value: repr(getattr(ngc, p)(relaxation_time=v)), kind, "relaxation_time")
for label, value, kind in [("'x'", "x", TE), ("nan", NAN, VE), ("-1", -1.0, VE)]:
    typed(f"Material.with_viscosity({label})", lambda ctx, v=value: repr(ngc.pzt5a().with_viscosity(v)), kind,
          "relaxation_time")

# obstacles
for label, value, kind in NUMBER_BAD + [("0", 0.0, VE), ("-1", -1.0, VE)]:
    typed(f"Cylinder(radius={label})", lambda ctx, v=value: repr(obstacles.Cylinder((0.05, -1.0), v)), kind, "radius")
for label, value, kind in [("'x'", "x", TE), ("None", None, TE), ("(0, 0)", (0.0, 0.0), VE),
                           ("(nan, 1)", (NAN, 1.0), VE),
                           ("(1j, 1)", (1j, 1.0), TE)]:
    typed(f"Plane(normal={label})", lambda ctx, v=value: repr(obstacles.Plane((0.0, -2e-5), v)), kind, "normal")

# geometries
for label, value, kind in [("'0.01'", "0.01", TE), ("1j", 1j, TE), ("True", True, TE), ("[0.01]", [0.01], TE)]:
    typed(f"plate(maxh={label})", lambda ctx, v=value: plate(maxh=v).ne, kind, "maxh")
for label, value, kind in [("1.5", 1.5, TE), ("'2'", "2", TE), ("True", True, TE), ("nan", NAN, TE),
                           ("None", None, TE)]:
    typed(f"plate(refine={label})", lambda ctx, v=value: plate(maxh=0.01, refine=v).ne, kind, "refine")
for label, value, kind in [("'0.1'", "0.1", TE), ("-1", -1.0, VE), ("None", None, TE)]:
    typed(f"plate(L1={label})", lambda ctx, v=value: plate(L1=v, maxh=0.01).ne, kind, "L1")
typed("plate(L2=1j)", lambda ctx: plate(L2=1j).ne, TE, "L2")
typed("plate(maxh_contact='x')", lambda ctx: plate(maxh=0.01, maxh_contact="x").ne, TE, "maxh_contact")
typed("plate(comm='x')", lambda ctx: plate(maxh=0.01, comm="x").ne, TE, "comm")
typed("block(L3='1')", lambda ctx: block(L3="1").ne, TE, "L3")
typed("block(refine=1.5)", lambda ctx: block(maxh=0.02, refine=1.5).ne, TE, "refine")
typed("block(maxh='x')", lambda ctx: block(maxh="x").ne, TE, "maxh")


# ----------------------------------------------------------------------------- class: wrong object types in the slots

def wrong(label, call, *words):
    case("objects", label, call, Error(TE, *words))


OBJECTS = [("None", lambda: None), ("'x'", lambda: "x"), ("5", lambda: 5), ("Contact()", lambda: ngc.Contact()),
           ("Loads()", lambda: ngc.Loads())]
for label, make in OBJECTS + [("a netgen mesh", lambda: plate_mesh().ngmesh)]:
    wrong(f"Body(mesh={label})", lambda ctx, m=make: repr(ngc.Body(m(), ngc.pzt5a(), **PARTS)), "mesh")
for label, make in OBJECTS[:4] + [("{'E': 1e9}", lambda: {"E": 1e9}), ("pzt5a (uncalled)", lambda: ngc.pzt5a)]:
    wrong(f"Body(material={label})", lambda ctx, m=make: repr(ngc.Body(plate_mesh(), m(), **PARTS)), "material")
for label, make in OBJECTS + [("a Body's mesh", lambda: plate_mesh())]:
    wrong(f"Simulation(body={label})", lambda ctx, m=make: built(ngc.Simulation(m())), "body")
for label, make in [("'x'", lambda: "x"), ("5", lambda: 5), ("Contact()", lambda: ngc.Contact()), ("{}", lambda: {}),
                    ("[]", lambda: []), ("{'f2': {}}", lambda: {"f2": {}})]:
    wrong(f"Simulation(loads={label})", lambda ctx, m=make: built(ngc.Simulation(body(), m())), "loads")
for label, make in [("'nitsche'", lambda: "nitsche"), ("Loads()", lambda: ngc.Loads()),
                    ("{'gap': 0}", lambda: {"gap": 0}),
                    ("1.0", lambda: 1.0), ("True", lambda: True)]:
    wrong(f"Simulation(contact={label})", lambda ctx, m=make: built(ngc.Simulation(body(), contact=m())), "contact")
for label, make in [("0.0", lambda: 0.0), ("'t'", lambda: "t"), ("CF(0)", lambda: ngs.CF(0.0)), ("[0]", lambda: [0])]:
    wrong(f"Simulation(time={label})", lambda ctx, m=make: built(ngc.Simulation(body(), time=m())), "time")
for label, make in [("'x'", lambda: "x"), ("Contact()", lambda: ngc.Contact()), ("(1j, 0)", lambda: (1j, 0.0)),
                    ("CF(1j) pair", lambda: ngs.CF((1j, 0.0)))]:
    wrong(f"Simulation(u0={label})", lambda ctx, m=make: built(simulation(u0=m())), "u0")
for label, make in [("'plane'", lambda: "plane"), ("5", lambda: 5), ("(0, 0)", lambda: (0.0, 0.0)),
                    ("Loads()", lambda: ngc.Loads()), ("True", lambda: True)]:
    wrong(f"Contact(obstacle={label})", lambda ctx, m=make: repr(ngc.Contact(obstacle=m())), "obstacle")
for name in ("compliance", "conductance"):
    for label, law in [("'linear'", "linear"), ("law returning 'x'", lambda r: "x"),
                       ("law of no argument", lambda: 1.0),
                       ("law of two arguments", lambda r, s: r), ("law returning None", lambda r: None),
                       ("a CoefficientFunction", ngs.CF(1e9))]:
        wrong(f"Contact({name}={label})", lambda ctx, n=name, f=law: built(simulation(contact=ngc.Contact(**{n: f}))),
              name)
for label, make, words in [
        ("f2=[('top', (0, 1))]", lambda: ngc.Loads(f2=[("top", (0.0, 1.0))]), "f2"),
        ("f2='top'", lambda: ngc.Loads(f2="top"), "f2"),
        ("f2={'top': 'x'}", lambda: ngc.Loads(f2={"top": "x"}), "f2"),
        ("f2={'top': None}", lambda: ngc.Loads(f2={"top": None}), "f2"),
        ("f2={5: (0, 1)}", lambda: ngc.Loads(f2={5: (0.0, 1.0)}), "f2"),
        ("f2={'top': (1j, 0)}", lambda: ngc.Loads(f2={"top": (1j, 0.0)}), "f2"),
        ("f0='x'", lambda: ngc.Loads(f0="x"), "f0"),
        ("f0=(True, 0)", lambda: ngc.Loads(f0=(True, 0.0)), "f0"),
        ("f0=CF complex", lambda: ngc.Loads(f0=ngs.CF((1j, 0.0))), "f0"),
        ("q0='x'", lambda: ngc.Loads(q0="x"), "q0"),
        ("q0=1j", lambda: ngc.Loads(q0=1j), "q0"),
        ("qb=[('right', 1)]", lambda: ngc.Loads(qb=[("right", 1.0)]), "qb"),
        ("qb={'right': 'x'}", lambda: ngc.Loads(qb={"right": "x"}), "qb"),
        ("potential=10", lambda: ngc.Loads(potential=10.0), "potential"),
        ("potential={'top': '10'}", lambda: ngc.Loads(potential={"top": "10"}), "potential"),
        ("displacement=['right']", lambda: ngc.Loads(displacement=["right"]), "displacement")]:
    wrong(f"Loads({label})", lambda ctx, m=make: step_once(simulation(loads=lambda t, m=m: m())), words)
for label, call in [
        ("Plane(point='x')", lambda: obstacles.Plane("x", (0.0, 1.0))),
        ("Plane(point=None)", lambda: obstacles.Plane(None, (0.0, 1.0))),
        ("Cylinder(center='x')", lambda: obstacles.Cylinder("x", 1.0)),
        ("Cylinder(center=None)", lambda: obstacles.Cylinder(None, 1.0)),
        ("SignedDistance(distance='x')", lambda: obstacles.SignedDistance("x", (0.0, -1.0))),
        ("SignedDistance(distance=None)", lambda: obstacles.SignedDistance(None, (0.0, -1.0))),
        ("SignedDistance(normal='x')", lambda: obstacles.SignedDistance(ngs.y + 2e-5, "x"))]:
    word = re.search(r"\((\w+)=", label).group(1)
    wrong(label, lambda ctx, c=call: built(simulation(contact=ngc.Contact(obstacle=c()))), word)
wrong("resume(5)", lambda ctx: built(scene.simulation(1, 0.01).resume(5)), "directory")


# ----------------------------------------------------------------------------- class: data that makes no sense

def nonsense(label, call, *words):
    case("nonsense", label, call, Error(VE, *words))


def with_contact(**data):
    """The coarse reference scene with Contact(**data), one step of 0.05 s."""
    return lambda ctx: step_once(simulation(contact=ngc.Contact(**{**scene.CONTACT, **data})))


for name, laws in dict(
        compliance=[("-1e9 r", lambda r: -1e9 * r), ("1e9 everywhere", lambda r: 1e9 + 0 * r),
                    ("1e9 r (no positive part)", lambda r: 1e9 * r),
                    ("-1e9 [r]+", lambda r: ngs.IfPos(r, -1e9 * r, 0.0)),
                    ("NaN", lambda r: NAN + 0 * r), ("two components", lambda r: ngs.CF((r, r)))],
        conductance=[("-1e-4", lambda r: -1e-4 + 0 * r), ("-1e-4 at contact", lambda r: ngs.IfPos(r, -1e-4, 0.0)),
                     ("1e-4 at any distance", lambda r: 1e-4 + 0 * r), ("1e-4 r", lambda r: 1e-4 * r),
                     ("inf", lambda r: INF + 0 * r), ("two components", lambda r: ngs.CF((r, r)))]).items():
    for label, law in laws:
        nonsense(f"Contact({name}=law {label})", with_contact(**{name: law}), name)
for label, make in [("CF(nan)", lambda: ngs.CF(NAN)), ("CF(inf)", lambda: ngs.CF(INF)),
                    ("CF(-inf)", lambda: ngs.CF(-INF)),
                    ("nan on half of Γ3", lambda: ngs.IfPos(ngs.x - 0.05, NAN, 2e-5)),
                    ("CF(-1e-3)", lambda: ngs.CF(-1e-3)), ("two components", lambda: ngs.CF((2e-5, 2e-5)))]:
    nonsense(f"Contact(gap={label})", lambda ctx, m=make: step_once(simulation(contact=scene.contact(gap=m()))), "gap")
for label, make in [("CF(nan)", lambda: ngs.CF(NAN)), ("CF(inf)", lambda: ngs.CF(INF)),
                    ("two components", lambda: ngs.CF((1.0, 1.0)))]:
    nonsense(f"Contact(foundation_potential={label})",
             lambda ctx, m=make: step_once(simulation(contact=scene.contact(foundation_potential=m()))),
             "foundation_potential")
for label, make in [("CF(nan)", lambda: ngs.CF(NAN)), ("CF(inf)", lambda: ngs.CF(INF)), ("CF(2)", lambda: ngs.CF(2.0)),
                    ("CF(-0.5)", lambda: ngs.CF(-0.5)), ("two components", lambda: ngs.CF((1.0, 1.0)))]:
    nonsense(f"Contact(beta0={label})", lambda ctx, m=make: step_once(simulation(contact=scene.contact(beta0=m()))),
             "beta0")
for label, make in [("(nan, 0)", lambda: (NAN, 0.0)), ("(0, inf)", lambda: (0.0, INF)),
                    ("CF((nan, 0))", lambda: ngs.CF((NAN, 0.0))), ("CF((0, inf))", lambda: ngs.CF((0.0, INF))),
                    ("(1, 2, 3)", lambda: (1.0, 2.0, 3.0)), ("into the foundation", lambda: (0.0, -1e-3 * ngs.x))]:
    nonsense(f"Simulation(u0={label})", lambda ctx, m=make: built(simulation(u0=m())), "u0")
for label, make, word in [
        ("f2={'top': (0, nan)}", lambda t: ngc.Loads(f2={"top": (0.0, NAN)}), "f2"),
        ("f2={'top': CF((0, inf))}", lambda t: ngc.Loads(f2={"top": ngs.CF((0.0, INF))}), "f2"),
        ("f2={'top': (0,)}", lambda t: ngc.Loads(f2={"top": (0.0,)}), "f2"),
        ("f2 NaN from t = 0.05 s", lambda t: ngc.Loads(f2={"top": (0.0, ngs.IfPos(t - 0.01, NAN, 0.0))}), "f2"),
        ("f2 on another Parameter", lambda t: ngc.Loads(f2={"top": (0.0, -1e6 * ngs.Parameter(1.0))}), "f2"),
        ("f2={'nowhere': (0, 1)}", lambda t: ngc.Loads(f2={"nowhere": (0.0, 1.0)}), "f2"),
        ("f0=(nan, 0)", lambda t: ngc.Loads(f0=(NAN, 0.0)), "f0"),
        ("f0=(1, 2, 3)", lambda t: ngc.Loads(f0=(1.0, 2.0, 3.0)), "f0"),
        ("q0=nan", lambda t: ngc.Loads(q0=NAN), "q0"),
        ("q0=CF(inf)", lambda t: ngc.Loads(q0=ngs.CF(INF)), "q0"),
        ("q0=(1, 2)", lambda t: ngc.Loads(q0=(1.0, 2.0)), "q0"),
        ("qb={'right': nan}", lambda t: ngc.Loads(qb={"right": NAN}), "qb"),
        ("qb={'right': CF(inf)}", lambda t: ngc.Loads(qb={"right": ngs.CF(INF)}), "qb"),
        ("potential={'top': nan}", lambda t: ngc.Loads(potential={"top": NAN}), "potential"),
        ("potential={'top': CF(nan)}", lambda t: ngc.Loads(potential={"top": ngs.CF(NAN)}), "potential"),
        ("potential={'right': 1}", lambda t: ngc.Loads(potential={"right": 1.0}), "potential"),
        ("displacement={'left': (0, 0)} on a clamp", lambda t: ngc.Loads(displacement={"left": (0.0, 0.0)}),
         "displacements?")]:
    nonsense(f"Loads({label})", lambda ctx, m=make: step_once(simulation(loads=m)), word)


def supported(displacement):
    """A plate held on the right (support "all") with the prescribed ``displacement``."""
    def call(ctx):
        return step_once(simulation(loads=lambda t: ngc.Loads(displacement={"right": displacement}),
                                    body_changes=dict(supports={"right": "all"})))
    return call


for label, value in [("(nan, 0)", (NAN, 0.0)), ("(0,)", (0.0,)), ("CF((0, inf))", ngs.CF((0.0, INF))),
                     ("1e-3 at t = 0", (1e-3, 0.0))]:
    nonsense(f"Loads(displacement={{'right': {label}}})", supported(value), "displacements?")


def obstacle(make):
    return lambda ctx: step_once(simulation(contact=ngc.Contact(obstacle=make())))


for label, make, word in [
        ("SignedDistance reversed normal", lambda: obstacles.SignedDistance(ngs.y + 2e-5, (0.0, 1.0)), "normal"),
        ("SignedDistance normal of length 2", lambda: obstacles.SignedDistance(ngs.y + 2e-5, (0.0, -2.0)), "normal"),
        ("SignedDistance normal (nan, -1)", lambda: obstacles.SignedDistance(ngs.y + 2e-5, (NAN, -1.0)), "normal"),
        ("SignedDistance normal in 3D", lambda: obstacles.SignedDistance(ngs.y + 2e-5, (0.0, 0.0, -1.0)), "normal"),
        ("SignedDistance distance nan", lambda: obstacles.SignedDistance(ngs.CF(NAN), (0.0, -1.0)), "distance"),
        ("SignedDistance distance of two components",
         lambda: obstacles.SignedDistance(ngs.CF((ngs.y, ngs.y)), (0.0, -1.0)), "distance"),
        ("SignedDistance cutting into the body", lambda: obstacles.SignedDistance(ngs.y - 1e-3, (0.0, -1.0)),
         "obstacle|distance"),
        ("Plane point (nan, 0)", lambda: obstacles.Plane((NAN, 0.0), (0.0, 1.0)), "point"),
        ("Plane point in 3D", lambda: obstacles.Plane((0.0, 0.0, 0.0), (0.0, 1.0)), "point|normal"),
        ("Plane normal in 3D", lambda: obstacles.Plane((0.0, -2e-5), (0.0, 1.0, 0.0)), "normal"),
        ("Plane reversed (the body inside)", lambda: obstacles.Plane((0.0, -2e-5), (0.0, -1.0)), "obstacle|normal"),
        ("Plane on another Parameter", lambda: obstacles.Plane((0.0, -2e-5 * ngs.Parameter(1.0)), (0.0, 1.0)),
         "point|Parameter"),
        ("Cylinder center (nan, -1)", lambda: obstacles.Cylinder((NAN, -1.0), 1.0), "center"),
        ("Cylinder center in 3D", lambda: obstacles.Cylinder((0.05, -1.0, 0.0), 1.0), "center"),
        ("Cylinder around the body", lambda: obstacles.Cylinder((0.05, 0.01), 1.0), "obstacle")]:
    nonsense(label, obstacle(make), word)
nonsense("Contact(gap and obstacle)", lambda ctx: repr(ngc.Contact(gap=1e-5, obstacle=obstacles.Plane((0, 0), (0, 1)))),
         "gap|obstacle")
nonsense("Contact(active_set with obstacle)",
         lambda ctx: repr(ngc.Contact(method="active_set", obstacle=obstacles.Plane((0, 0), (0, 1)))), "active_set")
nonsense("Contact(active_set at order 2)",
         lambda ctx: built(simulation(contact=scene.contact(method="active_set"), body_changes=dict(order=2))),
         "active_set|order")
nonsense("Simulation(electric=False) with coupling", lambda ctx: built(simulation(electric=False)), "electric")
nonsense("Material(c not positive definite)", lambda ctx: repr(ngc.Material(**{**GOOD, "c": -STIFF})), "c")
nonsense("Material(c not symmetric)",
         lambda ctx: repr(ngc.Material(**{**GOOD, "c": STIFF + np.triu(np.ones((6, 6)), 1) * 1e9})), "c")
nonsense("Material(poling='z') in 2D",
         lambda ctx: repr(ngc.Body(plate_mesh(), ngc.Material(**GOOD, poling="z"), **PARTS)), "poling")
nonsense("Body(contact_side overlaps clamped)", lambda ctx: repr(body(contact_side="left")), "contact_side")
nonsense("Body(clamped nowhere)", lambda ctx: repr(body(clamped="nowhere")), "clamped")
nonsense("Body(nothing held)", lambda ctx: repr(body(clamped=None)), "clamped|supports")
nonsense("Body(grounded=None) with coupling", lambda ctx: repr(body(grounded=None)), "grounded")


# ----------------------------------------------------------------------------- class: resume into another scene

class _Stop(Exception):
    pass


def interrupted(sim, directory):
    """Stream ``sim.run(0.05, 0.15, out=directory)`` and stop it after step 2 (t = 0.1 s)."""
    def stop(record):
        if record.step == 2:
            raise _Stop
    try:
        sim.run(0.05, 0.15, out=directory, on_step=stop)
    except _Stop:
        pass


UNCOUPLED = dict(E=60e9, nu=0.3, permittivity=1e-8)      # no piezoelectric coupling: φ only by conduction


def copied(ctx, base):
    directory = os.path.join(ctx["work"], "run")
    shutil.copytree(ctx[base], directory)
    return directory


def resume_into(make, base="resume_base", then_run=False):
    """A copy of the interrupted run ``base`` resumed by the simulation ``make()``."""
    def call(ctx):
        directory = copied(ctx, base)
        sim = make()
        sim.resume(directory)
        if then_run:
            sim.run(0.05, 0.15, out=directory)
        return measure(sim, applied(sim.t))
    return call


def resumed(label, make, *words, base="resume_base"):
    case("resume", label, resume_into(make, base), Error(VE, *words), needs=(base,))


def scene_on(mesh, **parts):
    """The reference scene's data on another mesh or with other boundary parts."""
    t = ngs.Parameter(0.0)
    return ngc.Simulation(ngc.Body(mesh, ngc.pzt5a(2e-3), **{**PARTS, **parts}), scene.loads(t),
                          contact=scene.contact(), time=t)


def reference_with(**contact):
    return lambda: scene.simulation(1, 0.01, contact=scene.contact(**contact))


resumed("material batio3", lambda: scene.simulation(1, 0.01, material=ngc.batio3(2e-3)), "material")
resumed("material relaxation time", lambda: scene.simulation(1, 0.01, material=ngc.pzt5a(1e-3)), "material")
resumed("load history", lambda: scene.simulation(1, 0.01, load_history=((0.0, 0.0), (0.1, 0.5), (0.5, 0.5))),
        "loads?|f2")
resumed("gap", reference_with(gap=3e-5), "gap")
resumed("gamma0", reference_with(gamma0=100.0), "gamma0")
resumed("theta", reference_with(theta=0), "theta")
resumed("method", reference_with(method="penalty"), "method")
resumed("adhesion", reference_with(adhesion=0.0), "adhesion")
resumed("conductance", reference_with(conductance=2e-4), "conductance")
resumed("foundation_potential", reference_with(foundation_potential=0.0), "foundation_potential")
resumed("beta0", reference_with(beta0=0.5), "beta0")
resumed("beta_update", reference_with(beta_update="implicit"), "beta_update")
resumed("order", lambda: scene.simulation(2, 0.01), "order")
resumed("mesh", lambda: scene.simulation(1, 0.008), "mesh")
resumed("mesh of the same size, moved", lambda: scene_on(plate(L1=0.12, L2=0.024, maxh=0.012, maxh_contact=0.006)),
        "mesh")
resumed("supports for the clamp", lambda: scene_on(plate_mesh(), clamped=None, supports={"left": "all"}),
        "supports|clamped")
resumed("rtol", lambda: scene.simulation(1, 0.01, rtol=1e-6), "rtol")
resumed("predictor", lambda: scene.simulation(1, 0.01, predictor=True), "predictor")
resumed("electric part removed", lambda: scene.simulation(
    1, 0.01, material=ngc.Material.isotropic(**UNCOUPLED), contact=scene.contact(conductance=0.0)),
    "electric|model|conductance", base="uncoupled_base")


def damaged(label, damage, *words, call=None):
    """The interrupted run with ``damage(directory)`` done to it, then resumed (or ``call``)."""
    def run(ctx):
        directory = copied(ctx, "resume_base")
        damage(directory)
        if call is not None:
            return call(directory)
        sim = scene.simulation(1, 0.01)
        sim.resume(directory)
        sim.run(0.05, 0.15, out=directory)
        return measure(sim, applied(sim.t))
    case("resume", label, run, Error(VE, *words), needs=("resume_base",))


def _step(directory, n):
    return os.path.join(directory, "steps", f"{n:06d}.npz")


def _garbage(path):
    with open(path, "wb") as f:
        f.write(b"not a numpy archive" * 10)


def _truncate(path):
    size = os.path.getsize(path)
    with open(path, "r+b") as f:
        f.truncate(size // 2)


def _without_state(path):
    with np.load(path) as data:
        kept = {k: data[k] for k in data if k != "restart/state"}
    with open(path, "wb") as f:
        np.savez(f, **kept)


damaged("middle archive deleted", lambda d: os.remove(_step(d, 1)), "0+1(\\.npz)?")
damaged("last archive garbage", lambda d: _garbage(_step(d, 2)), "0+2\\.npz")
damaged("last archive truncated", lambda d: _truncate(_step(d, 2)), "0+2\\.npz")
damaged("last archive without its state", lambda d: _without_state(_step(d, 2)), "0+2\\.npz")
damaged("first archive garbage", lambda d: _garbage(_step(d, 0)), "0+0\\.npz")
damaged("run.json garbage", lambda d: _garbage(os.path.join(d, "run.json")), "run\\.json")
damaged("run.json deleted", lambda d: os.remove(os.path.join(d, "run.json")), "run\\.json")
damaged("steps deleted", lambda d: shutil.rmtree(os.path.join(d, "steps")), "steps?|archives?")
damaged("read() of a garbage archive", lambda d: _garbage(_step(d, 1)), "0+1\\.npz",
        call=lambda d: len(results.read(d)[1]))
case("resume", "a directory that does not exist",
     lambda ctx: built(scene.simulation(1, 0.01).resume(os.path.join(ctx["work"], "nowhere"))), Error(VE, "nowhere"))
case("resume", "a file, not a directory",
     lambda ctx: built(scene.simulation(1, 0.01).resume(__file__)), Error(VE, "test_hostile\\.py"))
case("resume", "another dt", lambda ctx: _resume_run(ctx, 0.025, 0.15), Error(VE, "dt"), needs=("resume_base",))
case("resume", "another T", lambda ctx: _resume_run(ctx, 0.05, 0.2), Error(VE, "T"), needs=("resume_base",))
case("resume", "another scene streamed into the directory",
     lambda ctx: _stream_into(ctx, reference_with(gamma0=100.0)), Error(VE, "gamma0"), needs=("resume_base",))
case("resume", "the same scene continues", resume_into(lambda: scene.simulation(1, 0.01), then_run=True),
     Correct(matches("t=0.15", force=1e-9, tip=1e-9)), needs=("resume_base",))


def _resume_run(ctx, dt, T):
    directory = copied(ctx, "resume_base")
    sim = scene.simulation(1, 0.01).resume(directory)
    sim.run(dt, T, out=directory)
    return measure(sim, applied(sim.t))


def _stream_into(ctx, make):
    directory = copied(ctx, "resume_base")
    sim = make()
    sim.run(0.05, 0.15, out=directory)
    return measure(sim, applied(sim.t))


# ----------------------------------------------------------------------------- class: unwritable output paths

def output(label, call, *words):
    case("output", label, call, Error(VE, *words))


output("run(vtk='/proc/hostile/fields')", run_with(vtk="/proc/hostile/fields"), "vtk")
output("run(vtk='/proc/self/fields')", run_with(vtk="/proc/self/fields"), "vtk")
output("run(out='/proc/hostile')", run_with(out="/proc/hostile"), "out")
output("run(out=a regular file)", lambda ctx: _run_with(dict(dt=0.05, T=0.05, out=__file__)), "out")
output("run(out='/proc/hostile', vtk='f')", run_with(out="/proc/hostile", vtk="f"), "out")
output("run(vtk=an existing directory)", run_with(vtk=os.path.dirname(__file__)), "vtk", "names a directory", "out=")
output("run(vtk='new/')", run_with(vtk="/proc/hostile/new/"), "vtk", "names a directory", "out=")
output("demo.run(out='/proc/hostile')", demo(out="/proc/hostile"), "/proc/hostile")
output("demo.run(out=a regular file)", demo(out=__file__), "out|test_hostile\\.py")
output("bench.run('/proc/hostile')",
       lambda ctx: ngcontact.studies.bench.run("/proc/hostile", orders=[1], max_ndof=1e3, steps=1, progress=False),
       "/proc/hostile")
output("convergence.command(out='/proc/hostile')",
       lambda ctx: ngcontact.studies.convergence.command([1], 1, "viscous", 4, 0, "/proc/hostile"), "/proc/hostile")
output("hertz.command('/proc/hostile')", lambda ctx: ngcontact.studies.hertz.command("/proc/hostile", [1], 1, 2),
       "/proc/hostile")
output("stability.command('/proc/hostile')", lambda ctx: ngcontact.studies.stability.command("/proc/hostile", True),
       "/proc/hostile")


# ----------------------------------------------------------------------------- class: the command line

CHEAP = {"demo": ["--steps", "2", "--maxh", "0.02"], "convergence": ["--orders", "1", "--levels", "1"],
         "hertz": ["--orders", "1", "--levels", "1"], "bench": ["--orders", "1", "--max-ndof", "1e3", "--steps", "1"],
         "stability": ["--quick"], "cluster": ["--levels", "0", "--ranks", "1", "--steps", "1"]}
"""Options added to a CLI case (before its own, which win) so that a case not refused costs little."""


def command_line(argv, ctx, base=None):
    """``python -m ngcontact ARGV`` in this process: exit status and stderr (a ``{out}`` in
    argv is a copy of the fixture ``base``)."""
    if base is not None:
        directory = os.path.join(ctx["work"], "base")
        shutil.copytree(ctx[base], directory)
        argv = [a.replace("{out}", directory) for a in argv]
    start = os.path.getsize(ctx["stderr"])
    try:
        ngcontact.cli.main(argv)
        code = 0
    except SystemExit as done:
        code = done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
        if isinstance(done.code, str):
            print(done.code, file=sys.stderr)
    except BaseException:            # what the interpreter prints for an uncaught exception
        traceback.print_exc()
        code = 1
    sys.stderr.flush()
    with open(ctx["stderr"]) as f:
        f.seek(start)
        return dict(code=code, stderr=f.read())


def cpu_limited(seconds):
    """A ``preexec_fn`` for a process that may use ``seconds`` of CPU time (then SIGXCPU ends it)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_CPU, (math.ceil(seconds), math.ceil(seconds) + 5))
    return limit


def python_m(argv, ctx):
    """``python -m ngcontact ARGV`` as its own process (Python's start-up included), with the
    CPU limit of a CLI case."""
    limit = HANG["cli"] - 5
    try:
        done = subprocess.run([sys.executable, "-m", "ngcontact", *argv], capture_output=True, text=True,
                              timeout=WALL * limit, cwd=ctx["work"], preexec_fn=cpu_limited(limit))
    except subprocess.TimeoutExpired:
        return dict(code=None, stderr=f"hang: still waiting after {WALL * limit:g} s")
    if done.returncode == -signal.SIGXCPU:
        return dict(code=None, stderr=f"hang: killed after {limit:g} s of CPU time")
    return dict(code=done.returncode, stderr=done.stderr)


def cli(arguments, words, base=None, process=False, slow=False, within=CLI_LIMIT):
    argv = arguments.split()
    command = argv[0] if argv else ""
    full = argv[:1] + (CHEAP.get(command, []) if base is None else []) + argv[1:]
    if process:
        call = lambda ctx, a=full: python_m(a, ctx)
        label = f"python -m ngcontact {arguments or '(no command)'}"
    else:
        call = lambda ctx, a=full, b=base: command_line(a, ctx, b)
        label = arguments or "(no command)"
    case("cli", label, call, CliError(*(words.split(",") if words else ()), within=within), needs=(base,) if base else (),
         slow=slow)


CLI_CASES = [
    ("", "command"), ("bogus", "bogus|command"), ("demo --bogus 1", "bogus"),
    ("demo --order 0", "order"), ("demo --order -1", "order"), ("demo --order 30", "order"),
    ("demo --order abc", "order"), ("demo --order 1.5", "order"),
    ("demo --maxh 0", "maxh"), ("demo --maxh -1", "maxh"), ("demo --maxh nan", "maxh"), ("demo --maxh inf", "maxh"),
    ("demo --maxh 1e-6", "maxh"), ("demo --maxh abc", "maxh"),
    ("demo --dim 4", "dim"), ("demo --dim x", "dim"), ("demo --dim 3 --maxh 1e-5", "maxh"),
    ("demo --refine -1", "refine"), ("demo --refine 12", "refine"), ("demo --refine x", "refine"),
    ("demo --steps 0", "steps"), ("demo --steps -1", "steps"), ("demo --steps x", "steps"),
    ("demo --steps 1000000000", "steps"),
    ("demo --theta 2", "theta"), ("demo --theta x", "theta"),
    ("demo --gamma0 0", "gamma0"), ("demo --gamma0 -1", "gamma0"), ("demo --gamma0 nan", "gamma0"),
    ("demo --gamma0 inf", "gamma0"), ("demo --gamma0 x", "gamma0"),
    ("demo --out /proc/hostile", "/proc/hostile"), ("demo --resume --out nowhere", "resume|nowhere"),
    ("convergence --orders 0", "orders?"), ("convergence --orders 30", "orders?"),
    ("convergence --orders x", "orders?"),
    ("convergence --orders", "orders?"),
    ("convergence --levels 0", "levels"), ("convergence --levels 100", "levels"), ("convergence --levels -1", "levels"),
    ("convergence --levels x", "levels"), ("convergence --case bogus", "case"),
    ("convergence --smoothness 0", "smoothness"), ("convergence --smoothness -1", "smoothness"),
    ("convergence --smoothness x", "smoothness"),
    ("convergence --dt-halvings -1", "dt[-_]halvings"), ("convergence --dt-halvings 100", "dt[-_]halvings"),
    ("convergence --dt-halvings x", "dt[-_]halvings"), ("convergence --out /proc/hostile", "/proc/hostile"),
    ("stability --out /proc/hostile", "/proc/hostile"), ("stability --quick=yes", "quick"),
    ("stability --bogus", "bogus"), ("stability --study nope", "studies|nope"),
    ("hertz --orders 0", "orders?"), ("hertz --orders 30", "orders?"), ("hertz --orders x", "orders?"),
    ("hertz --levels 0", "levels"), ("hertz --levels 50", "levels"), ("hertz --levels x", "levels"),
    ("hertz --dim 4", "dim"), ("hertz --out /proc/hostile", "/proc/hostile"),
    ("bench --dim 4", "dim"), ("bench --orders 0", "orders?"), ("bench --orders 30", "orders?"),
    ("bench --max-ndof nan", "max[-_]ndof"), ("bench --max-ndof inf", "max[-_]ndof"),
    ("bench --max-ndof 0", "max[-_]ndof"), ("bench --max-ndof -1", "max[-_]ndof"),
    ("bench --max-ndof 1e15", "max[-_]ndof"), ("bench --max-ndof x", "max[-_]ndof"),
    ("bench --steps 0", "steps"), ("bench --steps -1", "steps"), ("bench --steps x", "steps"),
    ("bench --dt 0", "dt"), ("bench --dt -1", "dt"), ("bench --dt nan", "dt"), ("bench --dt inf", "dt"),
    ("bench --dt x", "dt"), ("bench --inverse bogus", "inverse"), ("bench --realcompile maybe", "realcompile"),
    ("bench --threads bogus", "threads"), ("bench --path bogus", "path"), ("bench --solver bogus", "solver"),
    ("bench --merge /nonexistent-hostile", "merge|/nonexistent-hostile"),
    ("bench --out /proc/hostile", "/proc/hostile"),
    ("cluster --scene cube", "scene"), ("cluster --orders 0", "orders?"), ("cluster --levels 20", "levels"),
    ("cluster --levels -1", "levels"), ("cluster --ranks 0", "ranks"), ("cluster --ranks x", "ranks"),
    ("cluster --solvers bogus", "solvers"), ("cluster --steps 0", "steps"), ("cluster --dt nan", "dt"),
    ("cluster --dt -1", "dt"), ("cluster --repeat 0", "repeat"), ("cluster --threads 2", "threads"),
    ("cluster --realcompile maybe", "realcompile"), ("cluster --scene block --levels 9", "level|DOFs"),
    ("cluster --out /proc/hostile", "/proc/hostile"),
]
for arguments, words in CLI_CASES:
    cli(arguments, words)
for setting in ("--gamma0 100", "--theta 0", "--order 2", "--maxh 0.01", "--steps 3", "--refine 1"):
    cli(f"demo --resume --out {{out}} --steps 2 --maxh 0.02 {setting}", setting.split()[0][2:], base="demo_base")
PROCESS_CASES = ["demo --order abc", "demo --maxh 1e-6", "demo --refine 12", "demo --out /proc/hostile",
                 "convergence --levels 100", "hertz --levels 50", "bench --max-ndof nan", "bench --steps 0",
                 "stability --out /proc/hostile", ""]
for arguments, words in CLI_CASES:
    cli(arguments, words, process=True, slow=arguments not in PROCESS_CASES)
# fails by name (γ0 = 1e-6 converges since the Signorini switch's inner loop, with the warning on γ0 below 3)
cli("demo --steps 2 --maxh 0.02 --gamma0 1e-9", "step|gamma0", process=True, within=HANG["cli"],
    slow="long")


# ----------------------------------------------------------------------------- classes of the newer features

# Each newer feature has its class in a module of its own beside this one (``hostile_<class>.py``,
# found by name, with a ``register(h)`` that adds its cases through ``h.case`` and uses this module's scenes,
# outcomes and checks as ``h.<name>``); the fork server imports them with this module.
EXTENSIONS = tuple(sorted(os.path.basename(p)[:-3] for p in glob.glob(os.path.join(os.path.dirname(__file__),
                                                                                 "hostile_*.py"))))
for _name in EXTENSIONS:
    importlib.import_module(_name).register(sys.modules[__name__])


# ----------------------------------------------------------------------------- running a case in its own process

def cpu_seconds():
    """The CPU time of this process and of the child processes it waited for, s."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _child(connection, case_id, ctx, limit):
    """Run one case in this fresh process (at most ``limit`` s of CPU time) and send its Outcome."""
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))
    resource.setrlimit(resource.RLIMIT_CPU, (math.ceil(cpu_seconds() + limit), math.ceil(cpu_seconds() + limit) + 5))
    os.chdir(ctx["work"])
    for fd, name in ((1, "stdout"), (2, "stderr")):
        sys.stdout.flush(), sys.stderr.flush()
        target = os.open(ctx[name], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(target, fd)
        os.close(target)
    found = {c.id: c for c in CASES}[case_id]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        start = cpu_seconds()
        try:
            value = found.call(ctx)
            outcome = dict(kind="returned", value=_plain(value))
        except BaseException as err:        # the outcome to judge, whatever it is
            outcome = dict(kind="raised", types=tuple(c.__name__ for c in type(err).__mro__), message=str(err)[:4000],
                           detail=traceback.format_exc()[-2000:])
        outcome["elapsed"] = cpu_seconds() - start
    outcome["warnings"] = tuple((w.category.__name__, str(w.message)[:1000]) for w in caught)
    sys.stdout.flush(), sys.stderr.flush()
    connection.send(Outcome(**outcome))


def _plain(value):
    """``value`` with numpy scalars as Python numbers (picklable, small)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value if isinstance(value, (int, float, str, bool, type(None))) else repr(value)[:200]


_CONTEXT = multiprocessing.get_context("forkserver")


def _server():
    """The fork server, started with this module imported (its directory on PYTHONPATH for
    that start only: Python 3.11's fork server ignores the parent's sys.path)."""
    _CONTEXT.set_forkserver_preload([__name__])
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    try:
        forkserver.ensure_running()
    finally:
        if old is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = old


def outcome_of(found, ctx):
    """Run the case in a process forked from the server; its Outcome, or "hang" (its CPU limit
    used up, or no end after WALL times that) or "died"."""
    _server()
    limit = HANG.get(found.group, HANG["default"])
    receive, send = _CONTEXT.Pipe(duplex=False)
    process = _CONTEXT.Process(target=_child, args=(send, found.id, ctx, limit), daemon=True)
    process.start()
    send.close()
    try:
        if not receive.poll(WALL * limit):
            return Outcome("hang", detail=f"no outcome after {WALL * limit:g} s (waiting for ever?)")
        try:
            return receive.recv()
        except EOFError:
            process.join(5)
            if process.exitcode == -signal.SIGXCPU:
                return Outcome("hang", detail=f"no outcome in {limit:g} s of CPU time")
            return Outcome("died", detail=f"the process ended with status {process.exitcode} "
                                          f"({_tail(ctx['stderr'])})")
    finally:
        if process.is_alive():
            process.kill()
        process.join(5)


def _tail(path):
    try:
        with open(path, errors="replace") as f:
            lines = [line for line in f.read().splitlines() if line.strip()]
        return _line(lines[-1]) if lines else "nothing on stderr"
    except OSError:
        return "no stderr"


# ----------------------------------------------------------------------------- fixtures and the test

@pytest.fixture(scope="module")
def references():
    """The runs the extreme cases are compared with: the coarse reference scene with its own
    data (default), with gap 0 (gap0), without contact (free), to t = 0.15 s (t=0.15), and with the
    foundation at −1 MV (phi_low: the potential drop saturates the truncation L_φ)."""
    return {"default": reference_run(), "gap0": reference_run(scene.contact(gap=0.0)), "free": free_run(),
            "t=0.15": reference_run(T=0.15), "phi_low": reference_run(scene.contact(foundation_potential=-1e6))}


@pytest.fixture(scope="module")
def resume_base(tmp_path_factory):
    """The coarse reference scene streamed to 0.15 s in steps of 0.05 s, stopped after step 2."""
    directory = tmp_path_factory.mktemp("hostile_resume") / "run"
    interrupted(scene.simulation(1, 0.01), directory)
    return str(directory)


@pytest.fixture(scope="module")
def uncoupled_base(tmp_path_factory):
    """As ``resume_base`` with a material without coupling: the electric part is the conduction."""
    directory = tmp_path_factory.mktemp("hostile_uncoupled") / "run"
    interrupted(scene.simulation(1, 0.01, material=ngc.Material.isotropic(**UNCOUPLED)), directory)
    return str(directory)


@pytest.fixture(scope="module")
def demo_base(tmp_path_factory):
    """A demo of 2 steps at maxh 0.02 interrupted after step 1 (its last archive removed; the
    CLI's --resume cases resume a copy)."""
    directory = tmp_path_factory.mktemp("hostile_demo")
    ngcontact.demo.run(out=directory, **DEMO)
    os.remove(directory / "run" / "steps" / "000002.npz")
    return str(directory)


LONG = {"extreme:gamma0=1e+30", "extreme:gamma0=1e-06", "extreme:compliance=1e+30", "extreme:compliance=law 1e30[r]+",
        "extreme:foundation_potential=1e+30", "extreme:foundation_potential=1e+300", "scheme:bdf2 nitsche",
        "scheme:demo --scheme", "laws:law reversing beyond the samples (smooth)",
        "laws:ProjectionLaw(1e30, VonMisesBall(1e-5))", "cli:python -m ngcontact convergence --levels 100",
        "cli:python -m ngcontact demo --maxh 1e-6"}
"""Cases of 2.5 s or more whose class has cheaper cases of the same kind: CI's long leg runs them."""


def _params():
    marks = {False: [], True: [pytest.mark.slow], "long": [pytest.mark.long]}
    return [pytest.param(c, id=c.id, marks=marks["long" if c.id in LONG and not c.slow else c.slow]) for c in CASES]


@pytest.mark.parametrize("found", _params())
def test_hostile_input(found, request, tmp_path):
    ctx = dict(work=str(tmp_path), stdout=str(tmp_path / "stdout.txt"), stderr=str(tmp_path / "stderr.txt"),
               **{name: request.getfixturevalue(name) for name in found.needs})
    outcome = outcome_of(found, ctx)
    references = request.getfixturevalue("references") if any(isinstance(e, Correct) for e in found.expect) else {}
    problems = [e.problem(outcome, references) for e in found.expect]
    if None not in problems:
        pytest.fail(problems[0], pytrace=False)


def test_the_suite_has_400_default_cases_in_every_class():
    """The measure of issue 22: at least 400 hostile inputs, each class of the issue present."""
    default = [c for c in CASES if c.slow is False]
    groups = {c.group for c in default}
    assert len(default) >= 400 and len({c.id for c in CASES}) == len(CASES)
    assert {"extreme", "held", "sizes", "types", "objects", "nonsense", "resume", "output", "cli"} <= groups
    for name in EXTENSIONS:     # each extension module present brings its class(es)
        module = sys.modules.get(name)
        if module is not None:
            assert set(module.CLASSES) <= groups, name
