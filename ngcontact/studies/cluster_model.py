"""The scaling model of ``python -m ngcontact cluster``: how the time per step and the memory
per rank grow with the DOFs n and the computing ranks p (p = N − 1 under ``mpiexec -n N``,
1 serially), fitted to the runs made, checked against them, and extrapolated.

Per solver configuration (scene, order, solver name, serial or under mpiexec), over its
sizes and ranks (the medians of ``summary.csv``), by least squares in log space:

* time per step ≈ a·(n/p)^α, or a·(n/p)^α·p^γ where the data warrant it: at least four
  points over two or more p, and a smaller leave-one-out error than without γ; fitted to the
  runs with no more processes than cores only, where there are two sizes of them at least (an
  oversubscribed run's time measures the sharing of the cores: it makes γ > 0, a time per step
  growing with the ranks; docs/measurements.md, section cluster_model);
* memory per rank (the largest computing rank's peak) ≈ m₀ + b·(n/p)^β (m₀ = 0 with fewer
  than four points over three sizes); under mpiexec also rank 0's ≈ m₀ + b·n^β (rank 0 meshes
  the whole problem and holds it; "masterinverse" factorises there);
* the growth of the Krylov iterations per Newton iteration (∝ n^κ) and of the Newton
  iterations per step (∝ n^ν), ``common.fitted_slope`` (three sizes at least).

Each fit reports its relative residuals on the points it was fitted to and a leave-one-out
check (each point predicted by the fit to the others). ``predict`` extrapolates the
distributed fits of the 3D block at P1 to ``TARGET_NDOF``: time per step and memory per rank
for ``TARGET_RANKS`` and the smallest p whose memory per rank fits ``MEMORY_LIMIT_MIB``.
"""
import math

import numpy as np
from scipy.optimize import least_squares

from .common import fitted_slope, fmt

TARGET_NDOF = 1e7
"""The device size the prediction is for (3D, P1)."""
TARGET_RANKS = (8, 16, 32, 64)
"""The computing ranks of the prediction."""
MEMORY_LIMIT_MIB = 4096
"""The memory per rank of the prediction's question, MiB."""


def fit_time(n, p, t, with_p=False):
    """{"a", "alpha", "gamma"} of t ≈ a·(n/p)^α·p^γ by linear least squares in log space
    (``gamma`` None without ``with_p``); None where the points do not determine it (fewer
    distinct n/p than two, or n/p and p collinear)."""
    n, p, t = (np.asarray(v, float) for v in (n, p, t))
    columns = [np.ones_like(n), np.log(n / p)] + ([np.log(p)] if with_p else [])
    X = np.column_stack(columns)
    if len(np.unique(n / p)) < 2 or np.linalg.matrix_rank(X) < X.shape[1]:
        return None
    c = np.linalg.lstsq(X, np.log(t), rcond=None)[0]
    return dict(a=float(np.exp(c[0])), alpha=float(c[1]), gamma=float(c[2]) if with_p else None)


def time_at(fit, n, p):
    """The time per step of a ``fit_time`` fit at n DOFs on p ranks."""
    return fit["a"] * (n / p) ** fit["alpha"] * p ** (fit["gamma"] or 0.0)


def fit_memory(x, m):
    """{"m0", "b", "beta"} of m ≈ m₀ + b·x^β, minimising the squared differences of log m;
    m₀ = 0 (a power law, linear in log space) with fewer than four points or three distinct
    x; None with fewer than two distinct x."""
    x, m = np.asarray(x, float), np.asarray(m, float)
    if len(np.unique(x)) < 2:
        return None
    beta, log_b = np.polyfit(np.log(x), np.log(m), 1)
    power = dict(m0=0.0, b=float(np.exp(log_b)), beta=float(beta))
    if len(x) < 4 or len(np.unique(x)) < 3:
        return power
    scale = float(np.exp(np.log(x).mean()))             # conditioning: b·x^β = exp(c)·(x/scale)^β
    top = float(m.min()) * (1 - 1e-12)

    def residual(q):
        return np.log(q[0] + np.exp(q[1] + q[2] * np.log(x / scale))) - np.log(m)

    starts = []
    for share in (0.0, 0.25, 0.5, 0.75, 0.9, 0.99):     # a profile over m₀: the best linear fit of log(m − m₀)
        m0 = share * top
        slope, c = np.polyfit(np.log(x / scale), np.log(m - m0), 1)
        starts.append((float(np.sum(residual((m0, c, slope)) ** 2)), (m0, c, slope)))
    start = min(starts)[1]
    best = least_squares(residual, start, bounds=([0.0, -np.inf, -np.inf], [top, np.inf, np.inf]),
                         xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=10_000)
    m0, c, beta = best.x
    return dict(m0=float(m0), b=float(np.exp(c) / scale ** beta), beta=float(beta))


def memory_at(fit, x):
    """The memory of a ``fit_memory`` fit at x (DOFs per rank), MiB."""
    return fit["m0"] + fit["b"] * x ** fit["beta"]


def leave_one_out(fit, at, columns, values):
    """Per point, the relative error of the value predicted by ``fit(*others, values of the
    others)`` (``at(fitted, *point)``) against its value: nan where the others do not
    determine a fit."""
    columns, values = [np.asarray(c, float) for c in columns], np.asarray(values, float)
    errors = []
    for i in range(len(values)):
        keep = np.arange(len(values)) != i
        fitted = fit(*(c[keep] for c in columns), values[keep])
        errors.append(at(fitted, *(c[i] for c in columns)) / values[i] - 1 if fitted else math.nan)
    return errors


def _checked(fit, at, columns, values, fitted):
    """A fit with its relative residuals and leave-one-out errors."""
    if fitted is None:
        return None
    residuals = [at(fitted, *point) / v - 1 for *point, v in zip(*columns, values)]
    return dict(fitted, residuals=residuals, loo=leave_one_out(fit, at, columns, values))


def _rms_log(errors):
    errors = np.asarray(errors, float)
    return float(np.sqrt(np.mean(np.log1p(errors) ** 2))) if len(errors) and np.all(np.isfinite(errors)) \
        else math.inf


def _timing_points(points):
    """The points the time is fitted to: the runs with no more processes than cores, where
    they are of two sizes at least; else all."""
    timing = [pt for pt in points if not pt.get("oversubscribed")]
    return timing if len({pt["n"] for pt in timing}) >= 2 else points


def fit_group(points):
    """The model of one configuration from its points (dicts with ``n``, ``p``, ``step_s``,
    ``peak_mib`` (the largest computing rank's), ``rank0_mib`` (None serially),
    ``krylov_per_newton``, ``newton_mean``, optionally ``oversubscribed``): the fits with
    residuals and leave-one-out errors; ``time_points``, the points the time was fitted to."""
    timing = _timing_points(points)
    n, p = [pt["n"] for pt in timing], [pt["p"] for pt in timing]
    t = [pt["step_s"] for pt in timing]
    plain = _checked(fit_time, time_at, (n, p), t, fit_time(n, p, t))
    timed = plain
    if len(set(p)) >= 2 and len(timing) >= 4:            # p^γ only where it predicts the left-out runs better
        scaled = _checked(lambda *a: fit_time(*a, with_p=True), time_at, (n, p), t, fit_time(n, p, t, True))
        if scaled and plain and _rms_log(scaled["loo"]) < _rms_log(plain["loo"]):
            timed = scaled
    n, p = [pt["n"] for pt in points], [pt["p"] for pt in points]
    x = [a / b for a, b in zip(n, p)]
    memory = _checked(fit_memory, memory_at, (x,), [pt["peak_mib"] for pt in points],
                      fit_memory(x, [pt["peak_mib"] for pt in points]))
    rank0 = [pt["rank0_mib"] for pt in points]
    zero = None if any(v is None for v in rank0) else _checked(fit_memory, memory_at, (n,), rank0,
                                                                fit_memory(n, rank0))
    return dict(points=points, time_points=len(timing), time=timed, memory=memory, rank0_memory=zero,
                kappa=fitted_slope(n, [pt["krylov_per_newton"] for pt in points]),
                nu=fitted_slope(n, [pt["newton_mean"] for pt in points]))


def predict(model, n=TARGET_NDOF, ranks=TARGET_RANKS, limit=MEMORY_LIMIT_MIB):
    """The extrapolation of a distributed configuration's ``fit_group`` model to n DOFs: per
    p in ``ranks`` the time per step (and, where a growth κ > 0 was fitted and the fit has no p term, times
    (p/p̄)^κ, p̄ the geometric mean of the fitted runs' p: the iterations grow with n, not
    n/p), the memory per computing rank; rank 0's memory; the smallest p whose memory per rank
    is at most ``limit`` MiB (None if none)."""
    timed, memory, zero = model["time"], model["memory"], model["rank0_memory"]
    timing = _timing_points(model["points"])
    p_mean = float(np.exp(np.mean(np.log([pt["p"] for pt in timing]))))
    growth = model["kappa"] if timed and timed["gamma"] is None and np.isfinite(model["kappa"]) \
        and model["kappa"] > 0 else None          # a falling count (a kept factorisation made anew more often) is no law of n
    rows = [dict(p=p, n_per_rank=n / p, step_s=time_at(timed, n, p) if timed else math.nan,
                 step_s_iterations=time_at(timed, n, p) * (p / p_mean) ** growth if growth is not None else math.nan,
                 memory_mib=memory_at(memory, n / p) if memory else math.nan) for p in ranks]
    smallest = None
    if memory and memory["m0"] < limit and memory["b"] > 0:
        if memory["beta"] > 0:
            smallest = max(1, math.ceil(n / ((limit - memory["m0"]) / memory["b"]) ** (1 / memory["beta"]) - 1e-9))
        elif memory_at(memory, n) <= limit:
            smallest = 1
    return dict(n=n, rows=rows, smallest_p=smallest, limit_mib=limit,
                rank0_mib=memory_at(zero, n) if zero else math.nan)


def _formula(model):
    timed, memory = model["time"], model["memory"]
    time = "—" if not timed else f"{timed['a']:.3g}·(n/p)^{timed['alpha']:.3f}" + (
        f"·p^{timed['gamma']:.3f}" if timed["gamma"] is not None else "")
    mem = "—" if not memory else f"{memory['m0']:.0f} + {memory['b']:.3g}·(n/p)^{memory['beta']:.3f}"
    return time, mem


def _worst(fit, key):
    values = [abs(v) for v in (fit or {}).get(key, []) if np.isfinite(v)]
    return f"{max(values):.1%}" if values else "—"


def markdown(groups, predictions):
    """The model section of summary.md: the fits, their checks and the prediction."""
    lines = ["## Scaling model", "",
             "Fitted per configuration to the medians of `summary.csv` by least squares in log space (n: DOFs, "
             "p: computing ranks, N − 1 under `mpiexec -n N`, 1 serially); residuals: on the runs fitted, "
             "largest |relative|; LOO: each run predicted by the fit to the others, largest |relative| "
             "(— where the others do not determine a fit). `model.json` has every value, and the solver "
             "actually used at each point (a configuration's name may stand for several: `default` is GAMG "
             "from 1e5 DOFs in 3D under mpiexec, MUMPS below; MUMPS is kept across Newton iterations on `-n 2`, "
             "factorised at each on `-n 3`, oversubscribed).", "",
             "Time is fitted to the runs with no more processes than cores (`time points`) where there are "
             "two sizes of them: an oversubscribed run's time measures the sharing of the cores, not the "
             "scaling; memory to every run.", "",
             "| scene | P | solver | kind | points | time points | time per step [s] | residual | LOO | memory per rank [MiB] | "
             "residual | LOO | rank 0 [MiB] | Krylov/Newton ∝ n^κ | Newton/step ∝ n^ν |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for key, model in groups.items():
        scene, order, solver, kind = key
        time, mem = _formula(model)
        zero = model["rank0_memory"]
        zero = "—" if not zero else f"{zero['m0']:.0f} + {zero['b']:.3g}·n^{zero['beta']:.3f}"
        lines.append(f"| {scene} | {order} | {solver} | {kind} | {len(model['points'])} | {model['time_points']} | {time} | "
                     f"{_worst(model['time'], 'residuals')} | {_worst(model['time'], 'loo')} | {mem} | "
                     f"{_worst(model['memory'], 'residuals')} | {_worst(model['memory'], 'loo')} | {zero} | "
                     f"{fmt(model['kappa'])} | {fmt(model['nu'])} |")
    lines += ["", f"### Prediction for {TARGET_NDOF:.0e} DOFs, 3D P1: an extrapolation", "",
              "**Extrapolated from runs on one 2-core machine** (`-n 3` puts three processes on two cores: "
              "oversubscribed; a cluster's network is slower than shared memory, its cores faster or slower). "
              "Assumed: the same solver configuration at every size (the library's default changes with the "
              "size: GAMG from 1e5 DOFs in 3D under mpiexec); the time per step a function of the DOFs per rank "
              "n/p (weak scaling: as many DOFs per rank cost as much on any p), times p^γ where the fit has it; "
              "the iterations growing with n as measured (κ, ν above): where the fit has no p term and κ > 0, the column "
              "'with n^κ' multiplies by (p/p̄)^κ (p̄: the fitted runs' geometric mean p), since the Krylov "
              "iterations follow n, not n/p; the memory per computing rank a function of n/p; rank 0 holds "
              "the whole mesh (it meshes, refines and distributes it), so its memory grows with n whatever p.", ""]
    if not predictions:
        lines.append("No distributed runs of the 3D block at P1 here: no prediction.")
    for (scene, order, solver, kind), pred in predictions.items():
        lines += [f"**{solver}** (mpiexec): rank 0 {fmt(pred['rank0_mib'])} MiB; smallest p with memory per "
                  f"computing rank ≤ {pred['limit_mib']} MiB: {pred['smallest_p'] or 'none'}", "",
                  "| p | n/p | time per step [s] | with n^κ [s] | memory per computing rank [MiB] |",
                  "| --- | --- | --- | --- | --- |"]
        lines += [f"| {r['p']} | {r['n_per_rank']:.3g} | {fmt(r['step_s'])} | {fmt(r['step_s_iterations'])} | "
                  f"{fmt(r['memory_mib'])} |" for r in pred["rows"]]
        lines.append("")
    return "\n".join(lines) + "\n"
