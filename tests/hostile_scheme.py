"""Hostile inputs of the time schemes and the error-controlled steps (``test_hostile``'s classes
``scheme`` and ``rtol``): every case ends in a clear error naming the parameter before the work,
a NewtonError with its reason, a flagged result or a result checked against physics.

* ``scheme``: ``Simulation(scheme=...)`` with bad names and types, ``demo`` and its CLI with a
  bad scheme, a run resumed into another scheme, BDF2 with every contact method, θ and adhesion,
  tiny and huge time steps, step ratios beyond BDF2's zero-stability;
* ``rtol``: ``run(rtol=...)`` with NaN, inf, 0, negative, 10, 1e-300 and values of the wrong
  type, rtol below Newton's tolerance or with a scheme without an estimate, ``dt_min`` and
  ``event_dt`` without rtol, out of range and at their extremes, a resumed controlled run with
  another rtol, dt_min, event_dt, dt or T, one that continues bitwise, one already complete.

The cases run the coarse reference scene (maxh 0.01); the runs that take more than a few
seconds are ``slow``.
"""
import json
import os
import shutil

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
import ngcontact.demo
from ngcontact.scenes import reference as scene

CLASSES = ("scheme", "rtol")
H = None
"""The hostile suite's module (``register``): its scenes, outcomes and checks."""

DT, T = 0.05, 0.1            # the hostile suite's reference run: two steps to full pressure
CONTROLLED_T = 0.02          # a controlled run across first contact (t ≈ 0.008 s)


def register(h):
    """Add the cases of both classes to the hostile suite ``h`` (``tests/test_hostile.py``) and
    the fixtures they need (runs streamed and stopped part-way, in the suite's module)."""
    global H
    H = h
    _fixtures(h)
    _scheme_cases(h)
    _rtol_cases(h)


# ----------------------------------------------------------------------------- fixtures

def _fixtures(h):
    """Module fixtures of ``h`` (found there by pytest): ``bdf2_resume_base``, BDF2's nominal
    steps streamed to 0.15 s and stopped after step 2 (as ``resume_base``); ``rtol_resume_base``,
    BDF2's error-controlled steps streamed to ``CONTROLLED_T`` and stopped after step 3."""
    @pytest.fixture(scope="module")
    def bdf2_resume_base(tmp_path_factory):
        directory = tmp_path_factory.mktemp("hostile_bdf2") / "run"
        h.interrupted(scene.simulation(1, 0.01, scheme="bdf2"), directory)
        return str(directory)

    @pytest.fixture(scope="module")
    def rtol_resume_base(tmp_path_factory):
        directory = tmp_path_factory.mktemp("hostile_rtol") / "run"
        _controlled_until(scene.simulation(1, 0.01, scheme="bdf2"), directory, 3)
        return str(directory)

    h.bdf2_resume_base, h.rtol_resume_base = bdf2_resume_base, rtol_resume_base


class _Stop(Exception):
    pass


def _controlled_until(sim, directory, stop, **options):
    """``sim.run(DT, CONTROLLED_T, rtol=1e-3, out=directory)`` stopped after step ``stop``."""
    def halt(record):
        if record.step == stop:
            raise _Stop
    try:
        sim.run(DT, CONTROLLED_T, **{"rtol": 1e-3, **options}, out=directory, on_step=halt)
    except _Stop:
        pass


# ----------------------------------------------------------------------------- class: scheme

def _scheme_cases(h):
    VE, CHOICE = h.VE, h.CHOICE

    def case(label, call, *expect, **kwargs):
        h.case("scheme", label, call, *expect, **kwargs)

    # bad names and types: refused by name before any mesh is used
    for label, value in [("'bogus'", "bogus"), ("'BDF2'", "BDF2"), ("'backward euler'", "backward euler"),
                         ("''", ""), ("'bdf2 '", "bdf2 "), ("None", None), ("2", 2), ("True", True),
                         ("['bdf2']", ["bdf2"]), ("1.5", 1.5), ("the protocol itself", ngc.schemes.TimeScheme),
                         ("a class without the protocol", type("NoScheme", (), {}))]:
        case(f"Simulation(scheme={label})", lambda ctx, v=value: h.built(h.simulation(scheme=v)),
             h.Error(CHOICE, "scheme"))
    case("demo.run(scheme='bogus')", h.demo(scheme="bogus"), h.Error(VE, "scheme"))
    case("demo.run(scheme=None)", h.demo(scheme=None), h.Error(CHOICE, "scheme"))
    for arguments in ("--scheme bogus", "--scheme BDF2", "--scheme", "--scheme bdf2 --scheme euler"):
        argv = ["demo", *h.CHEAP["demo"], *arguments.split()]
        case(f"demo {arguments}", lambda ctx, a=argv: h.command_line(a, ctx), h.CliError("scheme"))

    # a run resumed into another scheme: refused naming both schemes
    case("resume backward Euler into bdf2", h.resume_into(lambda: scene.simulation(1, 0.01, scheme="bdf2")),
         h.Error(VE, "scheme", "backward_euler", "bdf2"), needs=("resume_base",))
    case("resume bdf2 into backward Euler", h.resume_into(lambda: scene.simulation(1, 0.01), "bdf2_resume_base"),
         h.Error(VE, "scheme", "backward_euler", "bdf2"), needs=("bdf2_resume_base",))
    case("stream backward Euler into a bdf2 run", lambda ctx: _stream_into(ctx, "bdf2_resume_base", "backward_euler"),
         h.Error(VE, "scheme"), needs=("bdf2_resume_base",))
    case("demo --resume of a backward Euler demo with bdf2", _demo_resumed_bdf2, h.Error(VE, "scheme"))
    case("resume bdf2 into bdf2 continues bitwise", _bdf2_resumed_bitwise, h.Correct(_same),
         needs=("bdf2_resume_base",), slow=True)

    # BDF2 with every contact method, θ and adhesion: the reference run's force and deflection
    default = h.matches("default")
    for label, contact in [("nitsche", {}), ("penalty", dict(method="penalty")),
                           ("active_set", dict(method="active_set")), ("theta=0", dict(theta=0)),
                           ("theta=-1", dict(theta=-1)), ("no glue, insulating", dict(bare=True)),
                           ("beta_update=implicit", dict(beta_update="implicit")),
                           ("adhesion=1e30", dict(adhesion=1e30))]:
        expect = (h.Correct(default),) if label != "adhesion=1e30" else h.SOUND("adhesion", default)
        case(f"bdf2 {label}", lambda ctx, c=contact: h.reference_run(scene.contact(**c), scheme="bdf2"), *expect)
    case("bdf2 without contact", lambda ctx: _free_bdf2(), h.Correct(h.matches("free")))
    case("bdf2 predictor=True", lambda ctx: h.reference_run(scheme="bdf2", predictor=True), h.Correct(default))
    # P2: another contact force than the P1 reference's (7 %), so checked against physics alone
    case("bdf2 order 2", lambda ctx: _bdf2_order2(), h.Correct(h.balanced), slow=True)

    # tiny and huge steps, step ratios
    case("bdf2 dt=1e300", lambda ctx: h.reference_run(scheme="bdf2", dt=1e300, max_cutbacks=6), h.Correct(default),
         slow=True)
    for label, dt in [("1e-300", 1e-300), ("5e-324", 5e-324), ("1e-9", 1e-9)]:
        case(f"bdf2 run(dt={label})", lambda ctx, d=dt: h.reference_run(scheme="bdf2", dt=d), h.Error(VE, "dt"))
    case("bdf2 step(dt=5e-324)", lambda ctx: h.step_once(scene.simulation(1, 0.01, scheme="bdf2"), 5e-324),
         h.Error(VE, "dt"))
    case("bdf2 step ratio 1e5 (beyond zero-stability)", lambda ctx: _steps(5e-7, 0.05 - 5e-7, 0.05),
         h.Correct(default))
    case("bdf2 step ratio 1e-5", lambda ctx: _steps(0.05, 5e-7, 0.05 - 5e-7), h.Correct(default))
    case("bdf2 step ratio 2.4 (at zero-stability)", lambda ctx: _steps(0.1 / 3.4, 0.1 - 0.1 / 3.4),
         h.Correct(default))


def _stream_into(ctx, base, scheme):
    directory = os.path.join(ctx["work"], "run")
    shutil.copytree(ctx[base], directory)
    sim = scene.simulation(1, 0.01, scheme=scheme)
    sim.run(DT, 0.15, out=directory)
    return dict(t=sim.t)


def _demo_files(ctx, settings, run):
    """The files a demo leaves when killed before its first step is on disk: demo.json with
    ``settings``, run.json with ``run``; returns the demo's output directory."""
    directory = os.path.join(ctx["work"], "demo")
    os.makedirs(os.path.join(directory, "run", "steps"))
    settings = {**dict(order=1, maxh=0.02, dim=2, refine=0, steps=2, theta=1, gamma0=10.0), **settings}
    for name, data in (("demo.json", settings), ("run.json", dict(dict(dt=0.25, T=0.5, start=0.0), **run))):
        with open(os.path.join(directory, "run", name), "w") as f:
            json.dump(data, f)
    return directory


def _demo_resumed_bdf2(ctx):
    """A backward Euler demo (its demo.json names no scheme: the default) resumed with --scheme
    bdf2: the demo's own check names it before meshing."""
    directory = _demo_files(ctx, {}, dict(scheme="backward_euler"))
    ngcontact.demo.run(out=directory, resume=True, steps=2, maxh=0.02, scheme="bdf2")
    return dict(done=True)


def _bdf2_resumed_bitwise(ctx):
    """The stopped BDF2 run resumed and run to 0.15 s, against a run never interrupted."""
    directory = os.path.join(ctx["work"], "run")
    shutil.copytree(ctx["bdf2_resume_base"], directory)
    resumed = scene.simulation(1, 0.01, scheme="bdf2").resume(directory)
    resumed.run(DT, 0.15, out=directory)
    whole = scene.simulation(1, 0.01, scheme="bdf2")
    whole.run(DT, 0.15)
    return _compared(resumed, whole)


def _compared(resumed, whole):
    """Whether two runs agree bitwise: times, states, β and contact forces of every step."""
    a, b = resumed.history, whole.history
    same = len(a) == len(b) and all(
        x.time == y.time and np.array_equal(x.state, y.state) and np.array_equal(x.contact.beta, y.contact.beta)
        and np.array_equal(x.contact.force, y.contact.force) for x, y in zip(a, b))
    return dict(same=same, steps=len(a) - 1, whole=len(b) - 1, t=resumed.t)


def _same(v, references):
    if not v["same"]:
        return f"the resumed run ({v['steps']} steps) differs from the one never interrupted ({v['whole']} steps)"
    return None


def _free_bdf2():
    """The reference plate without contact (the gap never closes), BDF2."""
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(H.body(), scene.loads(t), time=t, scheme="bdf2")
    sim.run(DT, T, max_cutbacks=0)
    return dict(_measure(sim), target=T)


def _bdf2_order2():
    sim = scene.simulation(2, 0.01, scheme="bdf2")
    sim.run(DT, T, max_cutbacks=0)
    return dict(_measure(sim), target=T)


def _steps(*steps):
    """The coarse reference scene with BDF2 stepped by hand through ``steps`` (s) to T."""
    sim = scene.simulation(1, 0.01, scheme="bdf2")
    for dt in steps:
        sim.step(dt)
    return dict(_measure(sim), target=T)


def _measure(sim):
    return H.measure(sim, H.applied(sim.t))


# ----------------------------------------------------------------------------- class: rtol

def _rtol_cases(h):
    VE, TE = h.VE, h.TE

    def case(label, call, *expect, **kwargs):
        h.case("rtol", label, call, *expect, **kwargs)

    def controlled(scheme="bdf2", simulation=None, **arguments):
        """The coarse reference scene run with error-controlled steps (``arguments`` of run)."""
        arguments = {**dict(dt=DT, T=T), **arguments}

        def call(ctx):
            sim = scene.simulation(1, 0.01, scheme=scheme, **(simulation or {}))
            dt, end = arguments.pop("dt"), arguments.pop("T")
            sim.run(dt, end, **arguments)
            return dict(_measure(sim), target=end)
        return call

    # rtol out of range or of the wrong type: refused by name before a step
    for label, value, kind in [("nan", h.NAN, VE), ("inf", h.INF, VE), ("-inf", -h.INF, VE), ("0", 0.0, VE),
                               ("-1e-3", -1e-3, VE), ("1e-300", 1e-300, VE), ("5e-324", 5e-324, VE),
                               ("10", 10.0, VE), ("0.5", 0.5, VE), ("'1e-3'", "1e-3", TE), ("True", True, TE),
                               ("1j", 1j, TE), ("[1e-3]", [1e-3], TE)]:
        case(f"run(rtol={label})", controlled(rtol=value), h.Error(kind, "rtol"))
    case("run(rtol=1e-5) with Simulation(rtol=1e-6)", controlled(simulation=dict(rtol=1e-6), rtol=1e-5),
         h.Error(VE, "rtol"))
    case("run(rtol=1e-3) with backward Euler", controlled(scheme="backward_euler", rtol=1e-3),
         h.Error(VE, "rtol", "scheme"))

    # dt_min and event_dt: without rtol, out of range, of the wrong type, at their extremes
    case("run(dt_min=1e-6) without rtol", controlled(dt_min=1e-6), h.Error(VE, "dt_min", "rtol"))
    case("run(event_dt=1e-6) without rtol", controlled(event_dt=1e-6), h.Error(VE, "event_dt", "rtol"))
    for name in ("dt_min", "event_dt"):
        for label, value, kind in [("0", 0.0, VE), ("-1", -1.0, VE), ("nan", h.NAN, VE), ("inf", h.INF, VE),
                                   ("0.06 > dt", 0.06, VE), ("'x'", "x", TE)]:
            case(f"run(rtol=1e-3, {name}={label})", controlled(rtol=1e-3, **{name: value}), h.Error(kind, name))
    case("run(rtol=1e-3, event_dt=5e-324)", controlled(rtol=1e-3, event_dt=5e-324), h.Error(VE, "event_dt"))
    case("run(rtol=1e-3, event_dt < dt_min)", controlled(rtol=1e-3, dt_min=1e-4, event_dt=1e-5),
         h.Error(VE, "event_dt"))
    case("run(rtol=1e-3, dt_min=dt)", controlled(rtol=1e-3, dt_min=DT), h.Error(VE, "dt_min|event_dt"))
    # event_dt = dt: an event is not located (the steps across it are accepted): two backward Euler steps
    case("run(rtol=1e-3, event_dt=dt)", controlled(rtol=1e-3, event_dt=DT), h.Correct(h.matches("default")))
    case("run(rtol=1e-3, dt_min=5e-324)", controlled(rtol=1e-3, dt_min=5e-324), h.Error(VE, "dt_min"))
    # located to below the resolution of the times (1e-13 t): refused by name, or located as far as it goes
    case("run(rtol=1e-3, dt_min=event_dt=1e-300)",
         controlled(rtol=1e-3, dt_min=1e-300, event_dt=1e-300, T=CONTROLLED_T), h.Error(VE, "dt_min|event_dt"),
         h.Correct(h.balanced))
    case("run(rtol=0.1)", controlled(rtol=0.1, T=CONTROLLED_T), h.Correct(h.balanced), slow=True)
    case("run(rtol=1e-3)", controlled(rtol=1e-3), h.Correct(h.matches("default")), slow=True)
    case("run(rtol=1e-3, T < dt)", controlled(rtol=1e-3, T=0.005), h.Correct(h.balanced))
    case("run(rtol=1e-3, dt=1e300)", controlled(rtol=1e-3, dt=1e300, T=0.005), h.Correct(h.balanced),
         h.Error(VE, "dt"))
    case("run(rtol=1e-3, dt=1e-300)", controlled(rtol=1e-3, dt=1e-300), h.Error(VE, "dt"))
    case("run(rtol=1e-3, T=nan)", controlled(rtol=1e-3, T=h.NAN), h.Error(VE, "T"))

    # a controlled run resumed with other options: refused naming the option and both values
    for label, changes, words in [("rtol", dict(rtol=1e-4), ("rtol", "0.001", "0.0001")),
                                  ("dt_min", dict(dt_min=1e-9), ("dt_min", "5e-08", "1e-09")),
                                  ("event_dt", dict(event_dt=5e-3 * DT), ("event_dt", "5e-05", "0.00025")),
                                  ("dt", dict(dt=DT / 2), ("dt", "0.05", "0.025")),
                                  ("T", dict(T=2 * CONTROLLED_T), ("T", "0.02", "0.04")),
                                  ("no rtol", dict(rtol=None), ("rtol", "0.001", "none"))]:
        case(f"resumed with another {label}", lambda ctx, c=changes: _resumed_controlled(ctx, **c),
             h.Error(VE, *words), needs=("rtol_resume_base",))
    case("resumed with the same options continues bitwise", _controlled_resumed_bitwise, h.Correct(_same),
         needs=("rtol_resume_base",), slow=True)
    case("resumed when already complete", _complete, h.Error(VE, "already", "complete", "extend"))
    case("demo --scheme bdf2 --rtol 1e-3 --resume of another rtol",
         lambda ctx: _demo_resumed_controlled(ctx), h.Error(VE, "rtol"))
    for arguments, words in [("--scheme bdf2 --rtol nan", "rtol"), ("--scheme bdf2 --rtol 0", "rtol"),
                             ("--scheme bdf2 --rtol -1", "rtol"), ("--scheme bdf2 --rtol abc", "rtol"),
                             ("--rtol 1e-3", "rtol")]:
        argv = ["demo", *h.CHEAP["demo"], *arguments.split()]
        case(f"demo {arguments}", lambda ctx, a=argv: h.command_line(a, ctx), h.CliError(words))


def _resumed_controlled(ctx, **changes):
    directory = os.path.join(ctx["work"], "run")
    shutil.copytree(ctx["rtol_resume_base"], directory)
    sim = scene.simulation(1, 0.01, scheme="bdf2").resume(directory)
    arguments = {**dict(dt=DT, T=CONTROLLED_T, rtol=1e-3), **changes}
    sim.run(arguments.pop("dt"), arguments.pop("T"), out=directory, **arguments)
    return dict(t=sim.t)


def _controlled_resumed_bitwise(ctx):
    directory = os.path.join(ctx["work"], "run")
    shutil.copytree(ctx["rtol_resume_base"], directory)
    resumed = scene.simulation(1, 0.01, scheme="bdf2").resume(directory)
    resumed.run(DT, CONTROLLED_T, rtol=1e-3, out=directory)
    whole = scene.simulation(1, 0.01, scheme="bdf2")
    whole.run(DT, CONTROLLED_T, rtol=1e-3)
    return _compared(resumed, whole)


def _complete(ctx):
    """A controlled run of one step (T < dt) streamed to its end, resumed and run again."""
    directory = os.path.join(ctx["work"], "run")
    scene.simulation(1, 0.01, scheme="bdf2").run(DT, 0.005, rtol=1e-3, out=directory)
    sim = scene.simulation(1, 0.01, scheme="bdf2").resume(directory)
    sim.run(DT, 0.005, rtol=1e-3, out=directory)
    return dict(t=sim.t)


def _demo_resumed_controlled(ctx):
    """A BDF2 demo with rtol 0.1 resumed with --rtol 1e-3: the demo's own check names it before
    meshing."""
    directory = _demo_files(ctx, dict(scheme="bdf2", rtol=0.1), dict(scheme="bdf2", rtol=0.1))
    ngcontact.demo.run(out=directory, resume=True, steps=2, maxh=0.02, scheme="bdf2", rtol=1e-3)
    return dict(done=True)
