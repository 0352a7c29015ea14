"""What every study shares: rows written as CSV and printed as tables, failed runs classified,
the one progress convention (``ngcontact.output.progress.bar``) and the one way a run's time is
told.

A study's result is a list of rows, flat dicts with the same keys; a failed Newton solve is
kept as a row too, with ``failure_kind`` of its residual history.

Times: a chart plots a run's solve time, its time steps as their records give it
(``solve_seconds``), and a table gives apart what the run paid once (``setup_s``: the mesh,
the simulation's forms and compiled integrands, step 0); where a case is repeated, the least
time over the repeats (``fastest``). A ``--quick`` run says that its numbers are indicative
(``QUICK``).
"""
import csv
import json
import math
import pathlib
import re

import numpy as np

import ngcontact as ngc
from ngcontact import checks


def orders(name, values):
    """A study's polynomial orders: a nonempty list of integers in [1, ``checks.MAX_ORDER``],
    each once in the order given (a TypeError or ValueError naming ``name`` otherwise)."""
    if isinstance(values, (str, bytes)) or not isinstance(values, (list, tuple, range)):
        raise TypeError(f"{name} must be a list of polynomial orders, got {values!r}")
    if not values:
        raise ValueError(f"{name} must name at least one polynomial order, got {list(values)}")
    return list(dict.fromkeys(checks.order(name, p) for p in values))      # each order once


def petsc_missing():
    """The modules of the PETSc engine (``ngcontact.petsc_solver``) that are not installed,
    found without importing them (importing PETSc sets thread variables for MUMPS)."""
    import importlib.util
    return [name for name in ("petsc4py", "ngsPETSc") if importlib.util.find_spec(name) is None]


def time_window(steps, dt, end, history="the reference scene's load history"):
    """Refuse ``steps`` time steps of ``dt`` s from t = 0 that run past ``end`` s, where the
    scene's ``history`` ends (beyond it the load is held: nothing the study measures), or
    steps below ``ngcontact.MIN_DT``: a ValueError naming dt, its value and the allowed range."""
    MIN_DT = ngc.MIN_DT
    if not MIN_DT <= dt <= end / steps * (1 + 1e-12):
        raise ValueError(f"dt = {dt:g} s: {steps} step{'s' if steps > 1 else ''} of it "
                         + (f"end{'' if steps > 1 else 's'} at t = {steps * dt:g} s, past the end of {history} at "
                            f"{end:g} s"
                            if dt > end / steps else f"is below the smallest time step, {MIN_DT:g} s")
                         + f"; with steps = {steps}, dt must be in [{MIN_DT:g}, {end / steps:g}] s")


def fmt(value):
    """A value for a table: yes/no, nan, 4 significant digits, or str."""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def write_csv(rows, path, columns=None):
    """The rows as a CSV file, one column per key of the first row (or ``columns``); floats
    with 12 significant digits."""
    columns = list(columns or rows[0])
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.12g}" if isinstance(v, (float, np.floating)) else v) for k, v in row.items()})


def table(rows, columns):
    """A plain-text table of the given columns of the rows."""
    cells = [[fmt(row[c]) for c in columns] for row in rows]
    widths = [max([len(c)] + [len(line[i]) for line in cells]) for i, c in enumerate(columns)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(columns, widths))]
    lines += ["  ".join(v.rjust(w) for v, w in zip(line, widths)) for line in cells]
    return "\n".join(lines)


def line(row, columns):
    """One row as ``key value`` pairs, for the progress output."""
    return "  ".join(f"{k} {fmt(row[k])}" for k in columns)


def add_row(rows, row, shown, columns):
    """Append a run's row to ``rows``, print its ``columns`` above the progress bar ``shown``
    and advance the bar."""
    rows.append(row)
    shown.write(line(row, columns))
    shown.update()


def failure_kind(residuals):
    """Classify the residual history of a failed Newton solve.

    Returns "stagnation" if the residual fell below 1e-6 of the first one but not to the
    tolerance (it stalls at round-off level), "cycle p" if the last residuals repeat with
    period p <= 8 (the semismooth Newton iteration cycles between active sets; p = 1: it is
    stuck), "diverged" if a residual is not finite, "no convergence" otherwise.
    """
    r = np.asarray(residuals, dtype=float)
    if not np.all(np.isfinite(r)):
        return "diverged"
    if r.min() < 1e-6 * r[0]:
        return "stagnation"
    tail = r[len(r) // 2:]
    for p in range(1, 9):
        if len(tail) > 2 * p and np.allclose(tail[p:], tail[:-p], rtol=1e-6, atol=0):
            return f"cycle {p}"
    return "no convergence"


def failure(err):
    """A NewtonError as a dict: ``failure`` (``failure_kind``), ``failed_step``,
    ``failed_iterations``."""
    return dict(failure=failure_kind(err.residuals), failed_step=err.step, failed_iterations=err.iteration)


def run(sim, dt, T, max_cutbacks=0):
    """``sim.run`` without raising: None if it reached T, else ``failure`` of the error."""
    try:
        sim.run(dt=dt, T=T, max_cutbacks=max_cutbacks)
    except ngc.NewtonError as err:
        return failure(err)
    return None


def newton_total(sim, failed):
    """Newton iterations of a run: all computed steps, plus the failed attempt (``failed``
    from ``run``, or None)."""
    return int(sim.history.newton_iterations[1:].sum()) + (failed["failed_iterations"] if failed else 0)


def solve_seconds(history):
    """The solve time of a run (s): the wall time its time steps recorded (``StepRecord.wall_s``
    of steps 1 on: Newton, its factorisations, the records). Building the simulation and step 0
    are not in it, nor the failed tries of cut-backs (not recorded)."""
    return float(sum(record.wall_s for record in history[1:]))


def split_seconds(total_s, history, measured_s=0.0):
    """(setup_s, solve_s) of a run that took ``total_s`` s from its mesh to its last step,
    ``measured_s`` of them in the study's own error measurement: the solve time
    (``solve_seconds``) and the rest, what the run paid once (building, compiling, step 0)."""
    solve_s = solve_seconds(history)
    return max(total_s - solve_s - measured_s, 0.0), solve_s


def fastest(rows, key, times=("setup_s", "solve_s")):
    """One row per case (``key(row)``, in the order of first appearance): the first row of the
    case with each of ``times`` the least over its repeats and ``repeats`` their number. The
    least, not the median: other work on the machine only ever slows a run down."""
    cases = {}
    for row in rows:
        cases.setdefault(key(row), []).append(row)
    return [dict(runs[0], **{t: min(r[t] for r in runs) for t in times}, repeats=len(runs))
            for runs in cases.values()]


def timing_label(repeats):
    """How a chart's times were taken: the least of ``repeats`` rounds, or a single timing."""
    return "a single timing, one round" if repeats == 1 else f"the least of {repeats} rounds"


QUICK = "quick: indicative only"
"""The mark of a ``--quick`` run's charts and printed tables: few and small cases, one round."""


def fitted_slope(xs, ys):
    """Least-squares slope of log y against log x over the finite, positive pairs; nan with
    fewer than three (a slope from two points is not a fit)."""
    pts = [(x, y) for x, y in zip(xs, ys) if np.isfinite(x) and np.isfinite(y) and x > 0 and y > 0]
    if len(pts) < 3:
        return math.nan
    lx, ly = np.log(np.array(pts)).T
    return float(np.polyfit(lx, ly, 1)[0])


class CaseStore:
    """The finished cases of a study in ``out/cases/<key>.json``, each written as it ends, so
    that the study run again with ``resume`` skips them (``python -m ngcontact ... --resume``).
    ``None`` for ``out`` keeps nothing."""

    def __init__(self, out, resume=False):
        self.dir = None if out is None else pathlib.Path(out) / "cases"
        self.resume = bool(resume)
        if self.dir is not None:
            self.dir.mkdir(parents=True, exist_ok=True)

    def get(self, key, compute, encode=lambda result: result, decode=lambda data: data):
        """The result of ``compute()`` for ``key``, from disk when resuming and it is there."""
        path = None if self.dir is None else self.dir / (re.sub(r"[^A-Za-z0-9_.=-]+", "_", key) + ".json")
        if path is not None and self.resume and path.exists():
            return decode(json.loads(path.read_text()))
        result = compute()
        if path is not None:
            temporary = path.with_suffix(".tmp")
            temporary.write_text(json.dumps(encode(result)))
            temporary.replace(path)
        return result
