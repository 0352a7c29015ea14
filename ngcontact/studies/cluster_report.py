"""The tables, charts and scaling model of ``python -m ngcontact cluster``, made from the runs
kept in a directory (``out/runs/*.json``, one per run, written by ``cluster``).

* ``runs.csv``: a row per run (``RUN_COLUMNS``), with ``force_diff``, the largest difference
  of its contact force from the serial run of the same size (per step and component,
  relative to the serial run's largest force; the serial run with the default solver of the
  first round where there is one), and ``force_diff_solver`` from the serial run with the same
  solver (where there is one: it separates the distribution from the solvers' tolerances);
* ``summary.csv`` and ``summary.md``: per size and configuration (``SUMMARY_COLUMNS``) the
  median time per step with its min–max, its ratio to the serial default's median on the
  same size, the largest rank's peak memory and its ratio to masterinverse's rank 0 on the
  same size and ranks, the largest force difference; then the model section;
* ``time_per_step.png``, ``memory_per_rank.png``: against the DOFs, per configuration, with
  the model's fits dashed;
* ``model.json``: ``cluster_model``'s fits per configuration and the prediction for 10⁷ DOFs.
"""
import json
import math
import os

import numpy as np
from matplotlib.figure import Figure

from . import cluster_model
from .cluster_case import SOLVERS
from .common import fmt, write_csv

RUN_COLUMNS = ("scene", "order", "level", "ndof", "ranks", "p", "solver", "solver_used", "round", "steps", "dt",
               "threads", "oversubscribed", "status", "build_s", "step_s", "first_step_s", "later_steps_s",
               "newton_mean", "krylov_per_newton", "factorizations_per_step", "peak_mib", "peak_mib_rank0",
               "peak_mib_computing", "force_max", "force_diff", "force_diff_solver")
"""Columns of runs.csv: ``ranks`` N (1: serial), ``p`` the computing ranks; times in s
(``step_s`` the mean over the run's steps, the first included; ``first_step_s`` the first,
with the solver's one-off setup; ``later_steps_s`` the mean of the others);
memory in MiB: ``peak_mib`` the largest rank's peak resident memory (ru_maxrss),
``peak_mib_rank0`` rank 0's, ``peak_mib_computing`` the largest computing rank's (serially
all three are the process's); ``force_max`` the largest contact force component (N, or N/m
in 2D); ``status`` ok, or failed with the worker's last line."""
SUMMARY_COLUMNS = ("scene", "order", "level", "ndof", "steps", "ranks", "p", "solver", "solver_used", "runs",
                   "failed", "oversubscribed", "step_s", "step_s_min", "step_s_max", "vs_serial", "later_steps_s",
                   "newton_mean", "krylov_per_newton", "factorizations_per_step", "peak_mib", "vs_masterinverse",
                   "peak_mib_rank0", "peak_mib_computing", "force_diff", "force_diff_solver", "build_s")
"""Columns of summary.csv: medians over the runs of a size and configuration (``step_s``,
with ``step_s_min``, ``step_s_max``), ``vs_serial`` its ratio to the serial default's median
on the same size, the peaks the largest over the runs, ``vs_masterinverse`` ``peak_mib`` over
masterinverse's ``peak_mib_rank0`` on the same size and ranks, the force differences the
largest."""
SHOWN = ("scene", "order", "level", "ndof", "ranks", "solver", "runs", "step_s", "vs_serial", "newton_mean",
         "krylov_per_newton", "peak_mib", "vs_masterinverse", "force_diff")
"""The summary's columns printed to stdout."""
_NUMBERS = ("ndof", "build_s", "step_s", "first_step_s", "later_steps_s", "newton_mean", "krylov_per_newton",
            "factorizations_per_step", "peak_mib", "peak_mib_rank0", "peak_mib_computing", "force_max", "force_diff",
            "force_diff_solver")


def row(result):
    """The runs.csv row of a worker's result (the per-step forces and times kept under
    ``force`` and ``time`` for the comparison, not written)."""
    ranks = result["ranks"]
    base = dict(scene=result["scene"], order=result["order"], level=result["level"], ranks=ranks, p=max(ranks - 1, 1),
                solver=result["solver"], round=result.get("round", 1), steps=result["steps"], dt=result["dt"],
                oversubscribed=ranks > (os.cpu_count() or 1))
    if "failed" in result:
        return dict(base, **{name: math.nan for name in _NUMBERS}, solver_used="", threads=result.get("threads"),
                    status=f"failed: {result['failed']}", force=None, time=None)
    newton, peak, steps = np.array(result["newton"]), result["peak_mib"], result["step_s"]
    force = np.array(result["force"], float)
    return dict(base, ndof=result["ndof"], solver_used=result["solver_used"], threads=result["threads"], status="ok",
                build_s=result["build_s"], step_s=float(np.mean(steps)), first_step_s=steps[0],
                later_steps_s=float(np.mean(steps[1:])) if len(steps) > 1 else math.nan,
                newton_mean=float(newton.mean()), krylov_per_newton=sum(result["krylov"]) / max(int(newton.sum()), 1),
                factorizations_per_step=float(np.mean(result["factorizations"])), peak_mib=max(peak),
                peak_mib_rank0=peak[0], peak_mib_computing=max(peak[1:] or peak),
                force_max=float(np.abs(force).max(initial=0.0)), force_diff=math.nan, force_diff_solver=math.nan,
                force=force,
                time=np.array(result["time"]))


def _size(r):
    return r["scene"], r["order"], r["level"]


def _order(r):
    return _size(r) + (r["ranks"], list(SOLVERS).index(r["solver"]), r["round"])


def force_diffs(rows):
    """Set each ok row's ``force_diff`` against the serial run of its size and
    ``force_diff_solver`` against the serial run of its size and solver (nan where there is
    none, or the steps' times differ: cut-backs)."""
    ok = [r for r in rows if r["status"] == "ok"]
    for r in ok:
        serial = [s for s in ok if _size(s) == _size(r) and s["ranks"] == 1]
        same = [s for s in serial if s["solver"] == r["solver"]]
        for column, runs in (("force_diff", serial), ("force_diff_solver", same)):
            base = min(runs, key=lambda s: (s["solver"] != "default", s["round"]), default=None)
            if base is not None and base["time"].shape == r["time"].shape and np.allclose(base["time"], r["time"]):
                r[column] = float(np.abs(r["force"] - base["force"]).max() / max(base["force_max"], 1e-300))


def summarise(rows):
    """The summary rows (``SUMMARY_COLUMNS``) of the runs.csv rows."""
    groups = {}
    for r in rows:
        groups.setdefault(_size(r) + (r["ranks"], r["solver"]), []).append(r)
    summary = []
    for (scene, order, level, ranks, solver), runs in groups.items():
        ok = [r for r in runs if r["status"] == "ok"]
        values = {name: [r[name] for r in ok] for name in _NUMBERS}
        median = {name: float(np.median(v)) if v else math.nan for name, v in values.items()}
        largest = {name: float(np.max(v)) if v and not np.all(np.isnan(v)) else math.nan for name, v in values.items()}
        summary.append(dict(scene=scene, order=order, level=level, ndof=ok[0]["ndof"] if ok else math.nan,
                            steps=runs[0]["steps"],
                            ranks=ranks, p=runs[0]["p"], solver=solver, oversubscribed=runs[0]["oversubscribed"],
                            solver_used="; ".join(dict.fromkeys(r["solver_used"] for r in ok)), runs=len(ok),
                            failed=len(runs) - len(ok), step_s=median["step_s"],
                            step_s_min=min(values["step_s"], default=math.nan),
                            step_s_max=max(values["step_s"], default=math.nan),
                            **{name: median[name] for name in ("later_steps_s", "newton_mean", "krylov_per_newton",
                                                               "factorizations_per_step", "build_s")},
                            **{name: largest[name] for name in ("peak_mib", "peak_mib_rank0", "peak_mib_computing",
                                                                "force_diff", "force_diff_solver")}))
    for s in summary:
        serial = _find(summary, s, 1, "default")
        master = _find(summary, s, s["ranks"], "masterinverse")
        s["vs_serial"] = s["step_s"] / serial["step_s"] if serial else math.nan
        s["vs_masterinverse"] = s["peak_mib"] / master["peak_mib_rank0"] if master else math.nan
    return summary


def _find(summary, like, ranks, solver):
    found = [s for s in summary if _size(s) == _size(like) and (s["ranks"], s["solver"]) == (ranks, solver)
             and s["runs"]]
    return found[0] if found else None


def model(summary):
    """(the fitted model per configuration (scene, order, solver, "serial" or "mpiexec"), the
    predictions of the distributed 3D block P1 configurations); ``cluster_model``."""
    points = {}
    for s in summary:
        if s["runs"] and np.isfinite(s["step_s"]):
            kind = "serial" if s["ranks"] == 1 else "mpiexec"
            points.setdefault((s["scene"], s["order"], s["solver"], kind), []).append(dict(
                n=s["ndof"], p=s["p"], ranks=s["ranks"], step_s=s["step_s"], peak_mib=s["peak_mib_computing"],
                rank0_mib=s["peak_mib_rank0"] if kind == "mpiexec" else None,
                krylov_per_newton=s["krylov_per_newton"], newton_mean=s["newton_mean"], solver_used=s["solver_used"],
                oversubscribed=s["oversubscribed"] in (True, "yes", "True")))
    groups = {key: cluster_model.fit_group(p) for key, p in points.items()}
    predictions = {key: cluster_model.predict(g) for key, g in groups.items()
                   if key[0] == "block" and key[1] == 1 and key[3] == "mpiexec"}
    return groups, predictions


def markdown_table(rows, columns):
    """A markdown table of the given columns of the rows (``common.fmt``)."""
    lines = ["| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    return "\n".join(lines + ["| " + " | ".join(fmt(r.get(c, "")) for c in columns) + " |" for r in rows])


def write(out):
    """Read every run in ``out/runs``; write runs.csv, summary.csv, summary.md, model.json and
    the charts; return the summary rows."""
    results = [json.loads(path.read_text()) for path in sorted((out / "runs").glob("*.json"))]
    rows = sorted((row(r) for r in results), key=_order)
    force_diffs(rows)
    write_csv(rows, out / "runs.csv", RUN_COLUMNS)
    summary = summarise(rows)
    write_csv(summary, out / "summary.csv", SUMMARY_COLUMNS)
    groups, predictions = model(summary)
    (out / "model.json").write_text(json.dumps(dict(
        groups=[dict(scene=k[0], order=k[1], solver=k[2], kind=k[3], **g) for k, g in groups.items()],
        predictions=[dict(scene=k[0], order=k[1], solver=k[2], kind=k[3], **p) for k, p in predictions.items()],
        target_ndof=cluster_model.TARGET_NDOF, memory_limit_mib=cluster_model.MEMORY_LIMIT_MIB,
        cores=os.cpu_count()), indent=1))
    (out / "summary.md").write_text(
        f"# python -m ngcontact cluster: {len(rows)} runs on a machine of {os.cpu_count()} cores\n\n"
        "Medians over the runs of each size and configuration; columns: `summary.csv` (ngcontact/studies/"
        "cluster_report.py).\n\n" + markdown_table(summary, SUMMARY_COLUMNS) + "\n\n"
        + cluster_model.markdown(groups, predictions))
    _plot(out, summary, groups)
    return summary


def _plot(out, summary, groups):
    """time_per_step.png and memory_per_rank.png: per configuration against the DOFs (colour:
    the solver, marker: the ranks), the model's fit dashed."""
    scenes = {(s["scene"], s["order"]) for s in summary}
    for name, column, fitted, at, label in (
            ("time_per_step.png", "step_s", "time", cluster_model.time_at, "median wall time per step [s]"),
            ("memory_per_rank.png", "peak_mib_computing", "memory",
             lambda f, n, p: cluster_model.memory_at(f, n / p), "largest computing rank's peak memory [MiB]")):
        fig = Figure(figsize=(8, 5), layout="constrained")
        ax = fig.subplots()
        configurations = dict.fromkeys((s["scene"], s["order"], s["ranks"], s["solver"]) for s in summary if s["runs"])
        for scene, order, ranks, solver in configurations:
            sel = sorted((s for s in summary if (s["scene"], s["order"], s["ranks"], s["solver"])
                          == (scene, order, ranks, solver) and s["runs"]), key=lambda s: s["ndof"])
            n = np.array([s["ndof"] for s in sel])
            where = f"{scene} P{order}, " if len(scenes) > 1 else ""
            color, marker = f"C{list(SOLVERS).index(solver)}", "osv^D"[min(ranks, 5) - 1]     # solver, ranks
            ax.loglog(n, [s[column] for s in sel], "-", marker=marker, color=color,
                      label=f"{where}{solver}, " + ("serial" if ranks == 1 else f"-n {ranks}"))
            fit = groups.get((scene, order, solver, "serial" if ranks == 1 else "mpiexec"), {}).get(fitted)
            if fit and len(n) > 1:
                grid = np.geomspace(n[0], n[-1], 20)
                ax.loglog(grid, at(fit, grid, sel[0]["p"]), "--", color=color, lw=0.8)
        ax.set(xlabel="DOFs", ylabel=label, title=f"{label.split(' [')[0]} (dashed: the model's fit)")
        ax.grid(True, which="both", alpha=0.3)
        if configurations:
            ax.legend(fontsize=7)
        fig.savefig(out / name, dpi=120)
