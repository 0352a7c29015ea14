"""The penalty method over decades of its factor, against Nitsche (θ = 1) with γ0 equal to
the factor (ε and γ have the same scaling, factor · p² · stiffness / h): penetration ~ 1/ε,
contact force, condition number."""
import math

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import add_row, fitted_slope, newton_total, table
from .shared import press, reference_force, save, scaled_condition_number

COLUMNS = ("method", "factor", "converged", "failure", "newton", "max_penetration", "force_error", "cond")
"""The columns of the summary table."""
METHODS = (lambda factor: ngc.Penalty(factor=factor), lambda factor: ngc.Nitsche(theta=1, gamma0=factor))
"""The two methods swept, as functions of the factor (ε's or γ0)."""
LABELS = {ngc.Penalty.name: "penalty, ε = factor·p²·stiffness/h", ngc.Nitsche.name: "Nitsche θ = 1, γ0 = factor"}
"""Chart labels by the methods' names."""


def run(out=None, *, factors=None, maxh=0.01, order=1, steps=4, quick=False, progress=True):
    """The penalty factor against Nitsche's γ0 on the pushed reference plate.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``penalty_sweep.png``.
    factors : penalty factors = γ0 values; default 1e-3 ... 1e6 (quick: every other decade).
    maxh, order, steps : as in ``nitsche_map.run``.
    quick : fewer factors.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per (method, factor): ``converged``, ``failure``, ``newton``,
    ``max_penetration`` (m), ``force`` (N/m), ``force_error`` (against θ = −1, γ0 = 1000),
    ``cond``.
    """
    if factors is None:
        factors = np.logspace(-3, 5, 5) if quick else np.logspace(-3, 6, 10)
    rows = []
    with bar(1 + 2 * len(factors), "penalty_sweep", progress, unit="run") as shown:
        force = reference_force(maxh, order, steps)
        shown.update()
        for method in METHODS:
            for factor in factors:
                sim, failure = press(reference.contact(method=method(float(factor))), maxh=maxh, order=order,
                                     steps=steps)
                row = dict(method=method(float(factor)).name, factor=float(factor), converged=failure is None,
                           failure=failure["failure"] if failure else "", newton=newton_total(sim, failure),
                           max_penetration=math.nan, force=math.nan, force_error=math.nan, cond=math.nan)
                if not failure:
                    c = sim.history[-1].contact
                    row.update(max_penetration=c.max_penetration, force=float(c.force[1]),
                               force_error=float(abs(c.force[1] - force) / abs(force)),
                               cond=scaled_condition_number(sim))
                add_row(rows, row, shown, COLUMNS)
    if out is not None:
        _plot(rows, out, quick)
    return rows


def penetration_slope(rows):
    """Fitted slope of the penalty's max penetration against its factor (−1: ~ 1/ε)."""
    penalty = [r for r in rows if r["method"] == ngc.Penalty.name]
    return fitted_slope([r["factor"] for r in penalty], [r["max_penetration"] for r in penalty])


def summary(rows):
    return table(rows, COLUMNS) + ("\nfitted slope of the penetration against the penalty factor: "
                                   f"{penetration_slope(rows):.3f}")


def _plot(rows, out, quick=False):
    fig = Figure(figsize=(12, 3.8), layout="constrained")
    axes = fig.subplots(1, 4)
    for i, (name, label) in enumerate(LABELS.items()):
        runs = [r for r in rows if r["method"] == name]
        f = np.array([r["factor"] for r in runs])
        ok = np.array([r["converged"] for r in runs])
        for ax, key in zip(axes, ("max_penetration", "force_error", "cond", "newton")):
            y = np.array([r[key] for r in runs], dtype=float)
            ax.plot(f[ok], np.abs(y[ok]), "o-", color=f"C{i}", ms=4, label=label)
        failed = [r["newton"] for r in runs if not r["converged"]]
        axes[3].plot(f[~ok], failed, "x", color=f"C{i}", ms=9, mew=2)
    f = np.array(sorted({r["factor"] for r in rows}))
    pen = [r for r in rows if r["method"] == ngc.Penalty.name and r["max_penetration"] > 0]
    if pen:
        r0 = pen[0]
        axes[0].plot(f, r0["max_penetration"] * r0["factor"] / f, "k:", lw=0.8, label="slope −1")
    for ax, label, scale in zip(axes, ("|max penetration| [m]", "contact force error (relative)",
                                       "cond of the scaled Jacobian", "Newton iterations (× = failed)"),
                                ("log", "log", "log", "linear")):
        ax.set(xscale="log", yscale=scale, xlabel="factor", ylabel=label)
        ax.grid(True, lw=0.3)
    axes[0].legend(fontsize=7)
    save(fig, out / "penalty_sweep.png", quick)
