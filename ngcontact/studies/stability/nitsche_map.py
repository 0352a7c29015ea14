"""Nitsche γ0 × θ on the reference plate pushed onto the foundation: where Newton fails,
where it converges to a wrong force, penetration, pressure oscillation along Γ3, and the
condition number of the Jacobian."""
import math

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import add_row, fmt, newton_total, table
from .shared import STATUS_COLOURS, press, pressure_oscillation, reference_force, save, scaled_condition_number, short

COLUMNS = ("theta", "gamma0", "status", "failure", "newton", "force_error", "max_penetration",
           "pressure_oscillation", "cond")
"""The columns of the summary table."""


def run(out=None, *, gamma0s=None, thetas=(1, 0, -1), maxh=0.01, order=1, steps=4,
        reference_gamma0=1000.0, force_tol=0.01, quick=False, progress=True):
    """γ0 × θ on the reference plate pushed onto the foundation (scene contact data).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``nitsche_map.png`` (status of every run)
        and ``nitsche_sweep.png`` (the recorded quantities against γ0).
    gamma0s : γ0 values; default 15 (quick: 8) log-spaced values in [1e-3, 1e4].
    thetas : Nitsche variants.
    maxh, order : mesh size (m, halved on Γ3) and polynomial order.
    steps : time steps over the push ramp, no cut-backs.
    reference_gamma0 : the reference force is the θ = −1 solution with this γ0 on the
        same mesh, so that the error measures the method, not the mesh.
    force_tol : relative force error above which a converged run counts as "wrong".
    quick : fewer γ0 values.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per (θ, γ0): ``status`` ("ok", "wrong" or "failed"), ``failure``
    (``failure_kind``, "" if converged), ``failed_step``, ``newton`` (total iterations,
    with the failed attempt), ``force`` (N/m), ``force_error`` (relative), ``max_penetration``
    (m), ``pressure_oscillation`` (``shared.pressure_oscillation``), ``contact_area`` (m per
    metre of depth) and ``cond`` (``shared.scaled_condition_number`` at the final state).
    """
    if gamma0s is None:
        gamma0s = np.logspace(-3, 4, 8 if quick else 15)
    rows = []
    with bar(1 + len(thetas) * len(gamma0s), "nitsche_map", progress, unit="run") as shown:
        force = reference_force(maxh, order, steps, reference_gamma0)
        shown.update()
        for theta in thetas:
            for gamma0 in gamma0s:
                sim, failure = press(reference.contact(theta, float(gamma0)), maxh=maxh, order=order, steps=steps)
                row = dict(theta=theta, gamma0=float(gamma0), status="failed",
                           failure=failure["failure"] if failure else "",
                           failed_step=failure["failed_step"] if failure else 0,
                           newton=newton_total(sim, failure), force=math.nan, force_error=math.nan,
                           max_penetration=math.nan, pressure_oscillation=math.nan,
                           contact_area=math.nan, cond=math.nan)
                if not failure:
                    c = sim.history[-1].contact
                    error = abs(c.force[1] - force) / abs(force)
                    row.update(status="ok" if error <= force_tol else "wrong", force=float(c.force[1]),
                               force_error=float(error), max_penetration=c.max_penetration,
                               pressure_oscillation=pressure_oscillation(sim.side, c.pressure),
                               contact_area=c.contact_area, cond=scaled_condition_number(sim))
                add_row(rows, row, shown, COLUMNS[:-1])
    if out is not None:
        _plot(rows, out, force_tol, steps, quick)
    return rows


def ok_range(rows, theta):
    """(smallest, largest) γ0 of the longest run of consecutive γ0 values of a sweep with
    status "ok" for this θ; (nan, nan) if there is none."""
    runs = sorted((r for r in rows if r["theta"] == theta), key=lambda r: r["gamma0"])
    best, current = [], []
    for r in runs:
        current = current + [r["gamma0"]] if r["status"] == "ok" else []
        best = max(best, current, key=len)
    return (best[0], best[-1]) if best else (math.nan, math.nan)


def summary(rows):
    """The table and the γ0 range where each θ converges with the right force."""
    ranges = {theta: ok_range(rows, theta) for theta in dict.fromkeys(r["theta"] for r in rows)}
    return table(rows, COLUMNS) + "\nconverged with the force within tolerance for γ0 in: " + ", ".join(
        f"θ = {theta}: [{fmt(a)}, {fmt(b)}]" for theta, (a, b) in ranges.items())


def _plot(rows, out, force_tol, steps, quick=False):
    thetas = list(dict.fromkeys(r["theta"] for r in rows))
    gamma0s = sorted({r["gamma0"] for r in rows})
    codes = {s: i for i, s in enumerate(STATUS_COLOURS)}
    grid = np.zeros((len(thetas), len(gamma0s)))
    fig = Figure(figsize=(9, 2.8), layout="constrained")
    ax = fig.add_subplot()
    for r in rows:
        i, j = thetas.index(r["theta"]), gamma0s.index(r["gamma0"])
        grid[i, j] = codes[r["status"]]
        label = str(r["newton"]) if r["status"] != "failed" else short(r["failure"])
        ax.text(j, i, label, ha="center", va="center", fontsize=8)
    ax.imshow(grid, cmap=ListedColormap(list(STATUS_COLOURS.values())), vmin=-0.5,
              vmax=len(STATUS_COLOURS) - 0.5, aspect="auto")
    ax.set_xticks(range(len(gamma0s)), [f"{g:.3g}" for g in gamma0s], fontsize=8)
    ax.set_yticks(range(len(thetas)), [f"θ = {t}" for t in thetas])
    ax.set(xlabel="γ0", title=f"green: converged, force within {100 * force_tol:g} %; orange: "
           "converged, force wrong; red: Newton failed\n(numbers: Newton iterations; c2: cycles "
           "with period 2, nc: no convergence)")
    save(fig, out / "nitsche_map.png", quick)

    fig = Figure(figsize=(11, 6.5), layout="constrained")
    axes = fig.subplots(2, 3, sharex=True)
    panels = [("newton", "Newton iterations (× = failed)", "linear"),
              ("force_error", "contact force error (relative)", "log"),
              ("max_penetration", "max penetration u_ν − g [m]", "log"),
              ("pressure_oscillation", "pressure oscillation along Γ3", "linear"),
              ("cond", "cond of the scaled Jacobian", "log"),
              ("contact_area", "contact length [m]", "linear")]
    for i, theta in enumerate(thetas):
        runs = [r for r in rows if r["theta"] == theta]
        g = np.array([r["gamma0"] for r in runs])
        ok = np.array([r["status"] != "failed" for r in runs])
        for ax, (key, _, scale) in zip(axes.flat, panels):
            y = np.array([r[key] for r in runs], dtype=float)
            kept = ok & (y > 0) if scale == "log" else ok
            ax.plot(g[kept], y[kept], "o-", color=f"C{i}", ms=4, label=f"θ = {theta}")
            if key == "newton":
                ax.plot(g[~ok], y[~ok], "x", color=f"C{i}", ms=9, mew=2)
    axes[0, 1].axhline(force_tol, color="k", lw=0.6, ls="--")
    for ax, (_, label, scale) in zip(axes.flat, panels):
        ax.set(xscale="log", yscale=scale, ylabel=label)
        ax.grid(True, lw=0.3)
    for ax in axes[1]:
        ax.set_xlabel("γ0")
    axes[0, 0].legend()
    fig.suptitle(f"the reference plate pushed onto the foundation ({steps} steps, no cut-backs)")
    save(fig, out / "nitsche_sweep.png", quick)
