"""Errors a user can read, and the compiler found where NGSolve installed it.

``Simulation.state`` names n and the range of steps; the command line turns a missing module
into one line; the studies' time windows and orders are checked before any work
(``studies.common``); ``machine_code.find_compiler`` puts NGSolve's ``ngscxx`` on PATH when
Python was started from a venv that was not activated. The command line's refusals themselves
are cases of ``tests/hostile_trust.py`` (class ``cli`` of ``tests/test_hostile.py``).
"""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from support import small_hertz
from ngcontact import cli
from ngcontact.model import machine_code
from ngcontact.scenes import reference
from ngcontact.studies import common


@pytest.fixture(scope="module")
def stepped():
    """The coarse reference plate after one step (records 0 and 1, states kept)."""
    sim = reference.simulation(1, 0.02)
    sim.step(0.01)
    return sim


@pytest.mark.parametrize("n", [1.5, "1", None, True, [1], slice(0, 1)])
def test_state_of_a_step_that_is_not_an_integer_names_n_and_the_range(stepped, n):
    with pytest.raises(TypeError, match=r"state: the step n must be an integer in \[0, 1\] \(or \[-2, -1\] from the "
                                        r"end\), got "):
        stepped.state(n)


@pytest.mark.parametrize("n", [2, -3, 10 ** 9, np.int64(7)])
def test_state_of_a_step_not_in_the_history_names_n_and_the_range(stepped, n):
    with pytest.raises(IndexError, match=rf"state: step n = {n} is not in the history: n must be in \[0, 1\] \(or "
                                         r"\[-2, -1\] from the end; 2 records"):
        stepped.state(n)


def test_state_of_a_step_in_the_history(stepped):
    last = stepped.u.vec.FV().NumPy()
    for n in (1, -1, np.int64(1)):
        u = stepped.state(n).components[0].vec.FV().NumPy()
        assert np.array_equal(u, last)
    assert not np.any(stepped.state(0).components[0].vec.FV().NumPy())


def test_a_missing_module_is_one_line(monkeypatch, capsys):
    """An optional module missing where a command needs it: one line, exit status 2."""
    def missing(args):
        raise ModuleNotFoundError("No module named 'tqdm'", name="tqdm")
    monkeypatch.setattr(cli, "_dispatch", missing)
    with pytest.raises(SystemExit) as stop:
        cli.main(["timeorder", "--out", "unused"])
    assert stop.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"ngcontact timeorder: error: this command needs the Python module 'tqdm', which is not "
                     f"installed here ({sys.executable})"]


def test_time_window_inside_the_load_history():
    common.time_window(200, 2.5e-3, 0.5)                          # the demo's steps: to the end exactly
    common.time_window(1, 1e-20, 0.5)
    with pytest.raises(ValueError, match=r"dt = 1e\+300 s: 1 step of it ends at t = 1e\+300 s, past the end of the "
                                         r"reference scene's load history at 0.5 s; with steps = 1, dt must be in "
                                         r"\[1e-20, 0.5\] s"):
        common.time_window(1, 1e300, 0.5)
    with pytest.raises(ValueError, match=r"dt = 0.005 s: 101 steps of it end at t = 0.505 s.*\[1e-20, 0.0049505\] s"):
        common.time_window(101, 5e-3, 0.5)
    with pytest.raises(ValueError, match=r"dt = 1e-300 s: 4 steps of it is below the smallest time step, 1e-20 s"):
        common.time_window(4, 1e-300, 0.5)


def test_orders_are_each_run_once():
    assert common.orders("--orders", [2, 1, 2, 1]) == [2, 1]


# ----------------------------------------------------------------------------- adapt --tol, axisymmetric, pull-off

class Stop(Exception):
    """Raised by a stand-in for the work, to see what it was given without doing it."""


def _cli(argv, capsys):
    """(exit status, the lines on stderr but one-line warnings, stdout) of ``python -m ngcontact
    ARGV`` in this process."""
    with pytest.raises(SystemExit) as stop:
        cli.main(argv)
    out = capsys.readouterr()
    lines = [line for line in out.err.splitlines() if line.strip() and not line.startswith("ngcontact: warning:")]
    return stop.value.code, lines, out.out


@pytest.mark.parametrize("arguments, words", [
    ("--tol 1e-300", "--tol must be a finite number in [1e-06, 1), got 1e-300"),
    ("--tol 0", "--tol must be a finite number in [1e-06, 1), got 0.0"),
    ("--tol 1", "--tol must be a finite number in [1e-06, 1), got 1.0"),
    ("--tol nan", "--tol must be a finite number in [1e-06, 1), got nan"),
    ("--tol 0.1 --stop-newton 5", "--stop-newton must be a finite number in (0, 1], got 5.0"),
    ("--tol 0.1 --fraction 0", "--fraction must be a finite number in (0, 1], got 0.0"),
    ("--tol 0.1 --scene hertz3d --orders 2", "--scene hertz3d with --orders 2: nothing to solve to --tol (hertz3d "
                                             "runs P1 only); add --orders 1 or another --scene"),
    ("--tol 0.1 --scene reference", "--tol solves one step to a tolerance; the reference plate is a load history: "
                                    "run it without --tol"),
])
def test_adapt_to_a_tolerance_refuses_before_any_work(arguments, words, capsys, monkeypatch, tmp_path):
    """Each option of ``adapt --tol`` is checked (the --tol floor, adaptive stopping, the
    fraction, scenes and orders that leave nothing to solve) before any scene is built."""
    from ngcontact.studies import adaptivity
    monkeypatch.chdir(tmp_path)                 # the default --out is ./adapt
    monkeypatch.setattr(adaptivity.adapt, "solve", lambda *a, **k: pytest.fail("solved"))
    code, lines, _ = _cli(["adapt", *arguments.split()], capsys)
    assert code == 2 and lines == [f"ngcontact adapt: error: {words}"]


@pytest.mark.parametrize("arguments, given", [
    ("", dict(goal="energy")),                                         # adapt.solve's own defaults
    ("--marking equilibrated --stop-newton 0.5 --fraction 0.7", dict(marking="equilibrated", stop_newton=0.5,
                                                                     fraction=0.7, goal="energy")),
    ("--marking averaging", dict(marking="averaging", goal="energy")),
    ("--goal pressure", dict(goal="pressure")),
])
def test_adapt_to_a_tolerance_honours_marking_and_adaptive_stopping(arguments, given, capsys, monkeypatch, tmp_path):
    from ngcontact.studies import adaptivity
    monkeypatch.chdir(tmp_path)                 # the default --out is ./adapt
    calls = []

    def solve(scene, mesh, tol, **options):
        calls.append((tol, options))
        raise Stop
    monkeypatch.setattr(adaptivity.adapt, "solve", solve)
    with pytest.raises(Stop):
        cli.main(["adapt", "--tol", "0.01", "--scene", "hertz", "--orders", "1", *arguments.split()])
    ((tol, options),) = calls
    assert tol == 0.01 and {k: v for k, v in options.items() if k not in ("dt", "max_ndof")} == given


def test_adapt_to_a_tolerance_not_reached_exits_1_saying_so(capsys, monkeypatch, tmp_path):
    """The Hertz disk (P1, coarse) with a DOF limit of 400: the levels stop at the limit with a
    relative estimate above the tol; the certificate line says NOT reached and ">", the one
    line on stderr names the scene and the reason, exit status 1."""
    from ngcontact.studies import adaptivity
    monkeypatch.setitem(adaptivity.SCENES, "hertz", small_hertz)
    code, lines, out = _cli(["adapt", "--tol", "1e-3", "--scene", "hertz", "--orders", "1", "--out", str(tmp_path)],
                            capsys)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith("ngcontact adapt: --tol 0.001 NOT reached for hertz P1 (DOF limit: relative estimate ")
    (certificate,) = [line for line in out.splitlines() if "reached" in line or "certified" in line]
    relative = float(certificate.split("relative estimate ")[1].split()[0])
    assert certificate.startswith("NOT reached (DOF limit 400): ") and f"{relative:.3g} > 0.001 at " in certificate
    assert relative > 1e-3


@pytest.mark.parametrize("out, words", [
    ("/proc/ngcontact-cannot-write", "out (the output directory) '/proc/ngcontact-cannot-write' cannot be written"),
    ("FILE", "cannot be written: File exists"),
])
def test_axisymmetric_refuses_an_output_it_cannot_write_before_any_run(out, words, tmp_path, capsys, monkeypatch):
    from ngcontact.studies import axisymmetric
    monkeypatch.setattr(axisymmetric, "study", lambda *a, **k: pytest.fail("ran"))
    (tmp_path / "file").write_text("")
    out = str(tmp_path / "file") if out == "FILE" else out
    code, lines, _ = _cli(["axisymmetric", "--quick", "--out", out], capsys)
    assert code == 2 and len(lines) == 1 and words in lines[0], lines


@pytest.mark.parametrize("argv, words", [
    (["--adaptive", "--quick"], "--adaptive runs each adaptation once to --tol: --quick is the uniform study's"),
    (["--adaptive", "--rounds", "2"], "--rounds is the uniform study's"),
    (["--tol", "0.1"], "--tol is the target of --adaptive"),
    (["--adaptive", "--tol", "1"], "--tol must be a finite number in (0, 1), got 1.0"),
    (["--adaptive", "--out", "/proc/ngcontact-cannot-write"], "'/proc/ngcontact-cannot-write' cannot be written"),
])
def test_axisymmetric_adaptive_refuses_what_it_cannot_do_before_any_run(argv, words, capsys, monkeypatch):
    from ngcontact.studies import axisymmetric
    monkeypatch.setattr(axisymmetric, "adaptive", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(axisymmetric, "study", lambda *a, **k: pytest.fail("ran"))
    code, lines, _ = _cli(["axisymmetric", *argv], capsys)
    assert code == 2 and len(lines) == 1 and words in lines[0], lines


@pytest.mark.parametrize("command", ["axisymmetric", "adapt", "timesteps", "timeorder", "demo", "bench"])
def test_an_empty_out_is_refused_by_name(command, capsys, monkeypatch):
    """``--out ''`` would write into the working directory: refused, naming --out."""
    monkeypatch.setattr(cli, "_dispatch", lambda args: pytest.fail("dispatched"))
    code, lines, _ = _cli([command, "--out", ""], capsys)
    assert code == 2 and len(lines) == 1
    assert lines[0].startswith(f"ngcontact {command}: error: argument --out: an empty path ('') names no directory")


@pytest.mark.parametrize("cases, error, words", [
    ([(0.5, 0.005)], ValueError, r"cases: dt = 0.5 s must be in \[2e-07, 0.1\] s: the history runs to T_END = 0.2 s "
                                 r"in at least two steps"),
    ([(0.15, 0.005)], ValueError, r"cases: dt = 0.15 s must be in \[2e-07, 0.1\] s"),         # one step
    ([(0.0, 0.005)], ValueError, r"cases: dt = 0 s must be in \[2e-07, 0.1\] s"),
    ([(float("nan"), 0.005)], ValueError, r"cases: dt = nan s must be in"),
    ([(1e-9, 0.005)], ValueError, r"cases: dt = 1e-09 s .*at most 1000000 steps"),
    ([(0.01, 0.005), (0.01, 0.0)], ValueError, r"cases: maxh must be a finite number in \(0, 0.02\] m"),
    ([(0.01, 1e-7)], ValueError, r"cases: maxh = 1e-07 m, order = 2: about .* DOFs \(estimated\)"),
    ([], ValueError, "cases must hold at least one"),
    ("x", TypeError, "cases must be a list of"),
    ([0.01], TypeError, "each of cases must be a"),
    ([("a", 0.005)], TypeError, "cases: dt must be a number"),
])
def test_the_pull_off_cases_are_refused_before_any_run(cases, error, words, monkeypatch):
    from ngcontact.studies.stability import pull_off
    monkeypatch.setattr(pull_off, "_case", lambda *a: pytest.fail("ran"))
    with pytest.raises(error, match=words):
        pull_off.run(cases=cases, progress=False)


def test_the_pull_off_in_two_steps_runs():
    """The fewest steps allowed (dt = T_END / 2): the rows (plain corrections and the inner loop)
    are measured, their force balance holds."""
    from ngcontact.studies.stability import pull_off
    rows = pull_off.run(cases=[(0.1, 0.01)], order=1, progress=False)
    assert [row["switch_loop"] for row in rows] == [False, True]
    for row in rows:
        assert row["failure"] == "" and row["steps"] == 2 and row["balance"] < 1e-8


# ----------------------------------------------------------------------------- the compiler

def _wrapper(directory):
    path = directory / "ngscxx"
    path.write_text("#!/bin/sh\nexit 1\n")
    path.chmod(0o755)
    return path


def test_find_compiler_prepends_the_directory_beside_python(tmp_path, monkeypatch):
    _wrapper(tmp_path)
    monkeypatch.setattr(sys, "executable", str(tmp_path / "python"))
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    assert machine_code.find_compiler() == str(tmp_path)
    assert os.environ["PATH"] == f"{tmp_path}:/usr/bin:/bin"
    assert machine_code.find_compiler() == str(tmp_path)            # found first now: PATH unchanged
    assert os.environ["PATH"] == f"{tmp_path}:/usr/bin:/bin"


def test_find_compiler_prefers_this_pythons_wrapper_to_another_on_path(tmp_path, monkeypatch):
    mine, other = tmp_path / "venv", tmp_path / "other"
    mine.mkdir(), other.mkdir()
    _wrapper(mine), _wrapper(other)
    monkeypatch.setattr(sys, "executable", str(mine / "python"))
    monkeypatch.setenv("PATH", f"{other}:/usr/bin")
    machine_code.find_compiler()
    assert os.environ["PATH"] == f"{mine}:{other}:/usr/bin"


def test_find_compiler_without_a_wrapper_beside_python_leaves_path(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "executable", str(tmp_path / "python"))
    monkeypatch.setattr(machine_code.sysconfig, "get_path", lambda name: str(tmp_path))
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    assert machine_code.find_compiler() is None and os.environ["PATH"] == "/usr/bin:/bin"


@pytest.mark.long
@pytest.mark.skipif(not os.path.exists(os.path.join(os.path.dirname(sys.executable), "ngscxx")),
                    reason="no ngscxx beside this Python")
def test_a_python_started_without_its_bin_on_path_compiles(tmp_path):
    """``<venv>/bin/python`` with PATH=/usr/bin:/bin (the venv not activated): a scene built with
    realcompile=True compiles its Γ3 integrand to machine code, with no fallback warning, by
    the ngscxx beside the interpreter."""
    script = textwrap.dedent("""
        import os, sys, warnings
        warnings.simplefilter("always")
        with warnings.catch_warnings(record=True) as caught:
            from ngcontact.scenes import reference
            sim = reference.simulation(1, 0.02, realcompile=True)
        failed = [str(w.message) for w in caught if "realcompile failed" in str(w.message)]
        print("PATH", os.environ["PATH"])
        print("FAILED", failed)
        print("MACHINE", sim.realcompile)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env={**os.environ, "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-2000:]
    assert "realcompile failed" not in done.stderr and "FAILED []" in done.stdout, done.stdout + done.stderr
    assert "MACHINE True" in done.stdout
    assert f"PATH {os.path.dirname(sys.executable)}:/usr/bin:/bin" in done.stdout
