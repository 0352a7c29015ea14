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
        print("MACHINE", sim.system.boundary.machine_code)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env={**os.environ, "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-2000:]
    assert "realcompile failed" not in done.stderr and "FAILED []" in done.stdout, done.stdout + done.stderr
    assert "MACHINE True" in done.stdout
    assert f"PATH {os.path.dirname(sys.executable)}:/usr/bin:/bin" in done.stdout
