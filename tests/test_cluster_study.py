"""``python -m ngcontact cluster`` (ngcontact/studies/cluster.py): each run launched as its own
process (python, or mpiexec -n N from the mpich wheel of the test extra), the tables, the
equality column, the memory columns, the scaling model and its fitting, the refusal under
mpiexec and bad options. Tiny sizes: the 2D reference plate P1 at levels 0 and 1."""
import csv
import importlib.util
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from ngcontact import cli
from ngcontact.studies import cluster, cluster_model, cluster_report


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.slow      # mpiexec runs of the study (CI's PETSc leg runs this module whole)
def test_the_command_compares_serial_and_distributed_runs(tmp_path, capsys):
    """``python -m ngcontact cluster``: the plate P1 at levels 0 and 1 (576 and 2 088 DOFs),
    serial and on ``mpiexec -n 2``, the default solver and masterinverse (skipped serially,
    with a note), 2 steps of 2^-8 s (contact at the second), not compiled (quicker): runs.csv has its columns and a row
    per run; the distributed runs' contact forces equal the serial run's to 1e-8 (the
    command's own column); every memory column is positive; masterinverse's ratio to its own
    rank 0 is 1; model.json has finite coefficients for each configuration; the charts and
    summary.md are written."""
    cli.main(["cluster", "--out", str(tmp_path), "--levels", "0", "1", "--ranks", "1", "2", "--steps", "2",
              "--solvers", "default", "masterinverse", "--realcompile", "no"])
    printed = capsys.readouterr()
    assert "skipped: masterinverse on 1 rank" in printed.out + printed.err
    runs = read(tmp_path / "runs.csv")
    assert list(runs[0]) == list(cluster_report.RUN_COLUMNS)
    assert len(runs) == 6 and {r["status"] for r in runs} == {"ok"}
    assert {(r["ranks"], r["p"]) for r in runs} == {("1", "1"), ("2", "1")}
    assert {r["ndof"] for r in runs} == {"576", "2088"}
    summary = read(tmp_path / "summary.csv")
    assert list(summary[0]) == list(cluster_report.SUMMARY_COLUMNS) and len(summary) == 6
    for row in summary:
        assert float(row["force_diff"]) <= 1e-8, row
        assert float(row["force_diff_solver"]) <= 1e-8 or row["solver"] == "masterinverse", row
        assert all(float(row[c]) > 0 for c in ("peak_mib", "peak_mib_rank0", "peak_mib_computing", "step_s"))
        assert float(row["newton_mean"]) >= 1
    for row in runs:
        assert float(row["force_max"]) > 1.0                       # in contact: the equality means something
    assert {float(r["vs_masterinverse"]) for r in summary if r["solver"] == "masterinverse"} == {1.0}
    assert {float(r["vs_serial"]) for r in summary if r["ranks"] == "1"} == {1.0}
    model = json.loads((tmp_path / "model.json").read_text())
    kinds = {(g["solver"], g["kind"]) for g in model["groups"]}
    assert kinds == {("default", "serial"), ("default", "mpiexec"), ("masterinverse", "mpiexec")}
    for group in model["groups"]:
        fits = [group["time"]["a"], group["time"]["alpha"], group["memory"]["m0"], group["memory"]["b"],
                group["memory"]["beta"]]
        assert all(math.isfinite(v) for v in fits), group
    assert model["predictions"] == []                              # no 3D block P1 runs: no extrapolation
    assert "## Scaling model" in (tmp_path / "summary.md").read_text()
    assert (tmp_path / "time_per_step.png").exists() and (tmp_path / "memory_per_rank.png").exists()
    assert len(list((tmp_path / "runs").glob("*.json"))) == 6


def test_a_failed_run_is_a_row(tmp_path, monkeypatch):
    """A worker that fails (here: a module that does not exist) is a row of runs.csv with its
    last line of output, counted in summary.csv's ``failed``; the study goes on and fits
    nothing to it."""
    monkeypatch.setattr(cluster, "WORKER", "ngcontact.no_such_worker")
    summary = cluster.run(tmp_path, levels=[0], ranks=[1], steps=1, realcompile=False, progress=False)
    (run,) = read(tmp_path / "runs.csv")
    assert run["status"].startswith("failed: exit status 1: ") and "no_such_worker" in run["status"]
    assert [(s["runs"], s["failed"]) for s in summary] == [(0, 1)]
    assert json.loads((tmp_path / "model.json").read_text())["groups"] == []
    assert "no_such_worker" in (tmp_path / "logs" / "plate_p1_l0_n1_default_tauto_r1.log").read_text()


def test_the_fits_recover_known_exponents():
    """Synthetic data: t = 3 (n/p)^1.3 p^0.2 over three p and m = 250 + 0.01 x^1.1 are
    recovered to 1e-6; without the p term the fit is another; the leave-one-out errors of an
    exact model vanish; fit_group takes p^γ where it predicts the left-out points better, and
    leaves the oversubscribed runs out of the time fit."""
    n, p = np.array([1e3, 1e4, 1e5, 1e6] * 3), np.repeat([1, 2, 4], 4)
    t = 3.0 * (n / p) ** 1.3 * p ** 0.2
    fit = cluster_model.fit_time(n, p, t, with_p=True)
    assert fit["a"] == pytest.approx(3.0, rel=1e-6)
    assert abs(fit["alpha"] - 1.3) < 1e-6 and abs(fit["gamma"] - 0.2) < 1e-6
    assert abs(cluster_model.fit_time(n, p, t)["alpha"] - 1.3) > 1e-3
    x = np.geomspace(1e3, 1e6, 6)
    memory = cluster_model.fit_memory(x, 250 + 0.01 * x ** 1.1)
    assert memory["m0"] == pytest.approx(250, rel=1e-6) and memory["b"] == pytest.approx(0.01, rel=1e-6)
    assert abs(memory["beta"] - 1.1) < 1e-6
    m = 250 + 0.01 * x ** 1.1
    loo = cluster_model.leave_one_out(cluster_model.fit_memory, cluster_model.memory_at, (x,), m)
    assert np.abs(loo).max() < 1e-6
    points = [dict(n=a, p=b, step_s=c, peak_mib=250 + 0.01 * (a / b) ** 1.1, rank0_mib=300 + 1e-3 * a,
                   krylov_per_newton=20 * a ** 0.1, newton_mean=4.0) for a, b, c in zip(n, p, t)]
    group = cluster_model.fit_group(points)
    assert abs(group["time"]["gamma"] - 0.2) < 1e-6 and abs(group["kappa"] - 0.1) < 1e-9
    assert max(abs(e) for e in group["time"]["loo"] + group["memory"]["loo"]) < 1e-6
    # runs with more processes than cores (10x slower than the law): left out of the time fit
    crowded = [dict(pt, p=8, step_s=10 * 3.0 * (pt["n"] / 8) ** 1.3 * 8 ** 0.2, oversubscribed=True)
               for pt in points[:4]]
    group = cluster_model.fit_group(points + crowded)
    assert group["time_points"] == len(points) and abs(group["time"]["gamma"] - 0.2) < 1e-6
    unflagged = cluster_model.fit_group(points + [dict(pt, oversubscribed=False) for pt in crowded])
    assert unflagged["time_points"] == len(points) + 4 and abs(unflagged["time"]["gamma"] - 0.2) > 0.1


def test_the_prediction_finds_the_smallest_p_that_fits():
    """predict: the memory per rank at the smallest p that fits the limit is within it, at one
    rank fewer it is not; too few points for a fit give None, not an error; the Krylov growth
    n^κ scales the time where κ > 0 only."""
    x = np.array([1e3, 1e4, 1e5, 1e6])
    points = [dict(n=2 * v, p=2, step_s=1e-4 * v, peak_mib=200 + 0.01 * v ** 1.1, rank0_mib=300 + 1e-3 * v,
                   krylov_per_newton=0.0, newton_mean=4.0) for v in x]
    model = cluster_model.fit_group(points)
    pred = cluster_model.predict(model, n=1e7, ranks=(8, 64), limit=4096)
    p, at = pred["smallest_p"], lambda ranks: cluster_model.memory_at(model["memory"], 1e7 / ranks)
    assert at(p) <= 4096 < at(p - 1)
    assert [r["p"] for r in pred["rows"]] == [8, 64] and math.isnan(pred["rows"][0]["step_s_iterations"])
    assert cluster_model.fit_time([1e3], [1], [1.0]) is None and cluster_model.fit_memory([1e3, 1e3], [1, 2]) is None
    # Krylov iterations growing as n^0.2 scale the time by (p / 2)^0.2; a falling count is not extrapolated
    for sign in (1, -1):
        grown = cluster_model.predict(cluster_model.fit_group([dict(pt, krylov_per_newton=10 * pt["n"] ** (0.2 * sign))
                                                               for pt in points]), n=1e7, ranks=(8, 64))
        for r in grown["rows"]:
            assert (r["step_s_iterations"] == pytest.approx(r["step_s"] * (r["p"] / 2) ** 0.2, rel=1e-9) if sign > 0
                    else math.isnan(r["step_s_iterations"]))


def test_refused_under_mpiexec(tmp_path):
    """Under mpiexec the command is refused on every rank before any work (it launches mpiexec
    itself): exit status 2, one line naming the command, nothing written."""
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    done = subprocess.run([cluster.mpiexec(), "-n", "2", sys.executable, "-m", "ngcontact", "cluster", "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 2
    assert "python -m ngcontact cluster runs serially only" in done.stderr and "without mpiexec" in done.stderr
    assert done.stderr.count("error") == 1 and not (tmp_path / "out").exists()


@pytest.mark.parametrize("options, message", [
    (dict(solvers=["fast"]), "solvers must be one of 'default', 'mumps', 'masterinverse', 'gamg', 'multigrid', "
                             "'umfpack', got 'fast'"),
    (dict(solvers="default"), "solvers must be a nonempty list"),
    (dict(ranks=[0]), "ranks must be an integer >= 1 and <= 1024, got 0"),
    (dict(scene="cube"), "scene must be one of 'plate', 'block', got 'cube'"),
    (dict(levels=[11]), "levels must be an integer >= 0 and <= 10, got 11"),
    (dict(orders=[0]), "orders must be an integer >= 1 and <= 10"),
    (dict(repeat=0), "repeat must be an integer >= 1"),
    (dict(steps=0), "steps must be an integer >= 1"),
    (dict(dt=-1.0), "dt must be a finite number > 0"),
    (dict(scene="block", levels=[9]), "about .* DOFs \\(estimated\\)"),
])
def test_bad_options_are_named(tmp_path, options, message):
    with pytest.raises(ValueError, match=message):
        cluster.run(tmp_path / "out", **options)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, named", [(["--solvers", "fast"], "--solvers"), (["--scene", "cube"], "--scene"),
                                         (["--threads", "2"], "--threads")])
def test_bad_command_line_options_are_named(capsys, argv, named):
    with pytest.raises(SystemExit) as stop:
        cli.main(["cluster", *argv])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert named in err and "invalid choice" in err and "choose from" in err


def test_runs_of_another_window_are_not_mixed(tmp_path):
    """A directory holding runs of other steps or dt is refused, naming both."""
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "plate_p1_l0_n1_default_tauto_r1.json").write_text(json.dumps(dict(steps=3, dt=0.01)))
    with pytest.raises(ValueError, match=r"holds runs of steps 3, dt 0.01, realcompile None .*"
                                         r"\(--steps, --dt, --realcompile\)"):
        cluster.run(tmp_path, steps=4, dt=5e-3)


@pytest.mark.slow      # mpiexec runs of the study (CI's PETSc leg runs this module whole)
def test_factorisations_compare_umfpack_and_mumps(tmp_path, capsys):
    """``--factorisations``: the 3D block P1 at level 0, 2 rounds: positive times, MUMPS's
    solutions equal UMFPACK's to 1e-10; a P2 case measured after it joins its tables; without
    PETSc the case is reported skipped."""
    rows = cluster.factorisations(tmp_path, scene="block", orders=[1], levels=[0], repeat=2, progress=False)
    if importlib.util.find_spec("petsc4py") is None:
        assert rows == [] and "skipped: P1 level 0" in capsys.readouterr().out
        return
    (row,) = rows
    assert row["ndof"] == 612 and row["rounds"] == 2 and 0 < row["free"] < row["ndof"]
    assert min(row["umfpack_s"], row["mumps_s"], row["update_s"]) > 0
    assert row["mumps_diff"] < 1e-10 and row["update_diff"] < 1e-10
    assert list(read(tmp_path / "factorisations.csv")[0]) == list(cluster.FACTORISATION_COLUMNS)
    # a second case measured into the same directory joins the tables (it overwrote them)
    rows = cluster.factorisations(tmp_path, scene="block", orders=[2], levels=[0], repeat=1, progress=False)
    assert [(row["order"], row["rounds"]) for row in rows] == [(1, 2), (2, 1)]
    assert [row["order"] for row in read(tmp_path / "factorisations.csv")] == ["1", "2"]
    assert (tmp_path / "factorisations.md").read_text().count("| block |") == 2
