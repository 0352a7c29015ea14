"""The pull-off of the reference plate: Newton iterations per step against the Gauss points of
Γ3 that the release front crosses in the step, for several time steps and meshes.

After the load reverses (the reference history's pull) the contact zone opens from its inner edge while the glue
holds the plate. The semismooth Newton releases the points of Γ3 that are in tension under the
current contact set; releasing them loads the next ones, so a step whose front crosses many
points takes about one iteration per point crossed. The study measures that relation on the
reference history (P2) at fixed steps, with the default solver.
"""
import math
import numbers
from collections.abc import Iterable

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import checks
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import failure_kind, line, table
from .shared import APPLIED, save

COLUMNS = ("dt", "maxh", "steps", "worst_time", "worst_newton", "worst_crossed", "crossed_max", "per_point",
           "over_10", "balance")
"""The columns of the summary table."""
T_END = 0.2
"""The end of the history studied, s: the load has reversed into the pull (``reference``)."""


CASES = ((0.0025, 0.005), (0.005, 0.005), (0.01, 0.005), (0.02, 0.005), (0.005, 0.0025), (0.005, 0.01))
"""The (dt in s, maxh in m) cases of the study: four steps on one mesh, three meshes at one step."""
QUICK_CASES = ((0.01, 0.005),)
"""The quick run's case."""


def run(out=None, *, cases=None, order=2, quick=False, progress=True):
    """The reference history to ``T_END`` at each (dt, maxh) of ``cases``.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``pull_off.png``.
    cases : (dt in s, maxh in m) pairs; default ``CASES``, quick ``QUICK_CASES``. Checked before any run (``checked``):
        dt finite in [``smallest_dt``, T_END / 2] (at least two steps to ``T_END``, at most
        ``checks.MAX_STEPS``), maxh finite in (0, L2] (the plate's thickness) and within memory.
    order : polynomial order.
    quick : one case.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per case: ``steps``; the worst step after the first contact
    (``worst_time`` s, ``worst_newton`` linear solves with those of given-up tries,
    ``worst_crossed`` Gauss points of Γ3 whose contact state changed in it); ``crossed_max``;
    ``per_point``: the median of newton / crossed over the steps that cross at least 4 points;
    ``over_10``: steps after the first contact with more than 10 iterations; ``balance``: max
    |reaction + contact force − load| / peak load; ``failure`` (the kind, or "").
    """
    quick = checks.flag("quick", quick)
    if cases is None:
        cases = QUICK_CASES if quick else CASES
    cases, order = checked(cases, order)
    rows, traces = [], {}
    with bar(len(cases), "pull_off", progress, unit="run") as shown:
        for dt, maxh in cases:
            row, trace = _case(dt, maxh, order)
            rows.append(row)
            traces[dt, maxh] = trace
            shown.write(line(row, COLUMNS))
            shown.update()
    if out is not None:
        _plot(traces, out, quick)
    return rows


def smallest_dt():
    """The smallest time step of a case, s: ``MIN_DT``, and at most ``checks.MAX_STEPS`` steps to T_END."""
    return max(ngc.MIN_DT, T_END / checks.MAX_STEPS)


def checked(cases, order):
    """(cases as a list of (dt, maxh) float pairs, order), refused before any run: a TypeError
    or ValueError naming ``cases``, the pair, dt or maxh, the value and the allowed range."""
    order = checks.order("order", order)
    if isinstance(cases, (str, bytes)) or not isinstance(cases, Iterable):
        raise TypeError(f"pull_off: cases must be a list of (dt in s, maxh in m) pairs, got {cases!r}")
    cases = list(cases)
    if not cases:
        raise ValueError("pull_off: cases must hold at least one (dt in s, maxh in m) pair, got none")
    low, high = smallest_dt(), T_END / 2
    out = []
    for pair in cases:
        if isinstance(pair, (str, bytes)) or not isinstance(pair, Iterable) or len(pair := tuple(pair)) != 2:
            raise TypeError(f"pull_off: each of cases must be a (dt in s, maxh in m) pair, got {pair!r}")
        dt = pair[0]
        if isinstance(dt, bool) or not isinstance(dt, numbers.Real):
            raise TypeError(f"pull_off: cases: dt must be a number in [{low:g}, {high:g}] s, got {dt!r} "
                            f"({type(dt).__name__})")
        dt = float(dt)
        if not (math.isfinite(dt) and low <= dt <= high):
            raise ValueError(f"pull_off: cases: dt = {dt:g} s must be in [{low:g}, {high:g}] s: the history runs "
                             f"to T_END = {T_END:g} s in at least two steps (the steps after the first contact are "
                             f"what the study measures) and at most {checks.MAX_STEPS} steps")
        maxh = checks.number("cases: maxh", pair[1], 0, reference.L2, low_open=True,
                             unit="m (the plate's thickness L2)")
        checks.fits_in_memory(f"pull_off: cases: maxh = {maxh:g} m, order = {order}", checks.estimated_ndof(
            checks.estimated_vertices((reference.L1, reference.L2), maxh), 2, 0, order))
        out.append((dt, maxh))
    return out, order


def _case(dt, maxh, order):
    sim = reference.simulation(order, maxh, keep_states=False)
    contact_set = sim.pieces
    steps, previous, failure = [], None, ""
    try:
        for _ in range(int(round(T_END / dt))):
            record = sim.step(dt)
            active = contact_set()["the contact set"] > 0
            crossed = 0 if previous is None else int(np.count_nonzero(active != previous))
            previous = active
            steps.append((record.time, record.newton_iterations + record.discarded_iterations, crossed,
                          bool(active.any())))
    except ngc.NewtonError as err:     # a failed step ends the case: the study reports it
        failure = failure_kind(err.residuals)
    h = sim.history
    if not steps:                      # the first step failed: nothing measured
        nan = float("nan")
        return dict(dt=dt, maxh=maxh, order=order, failure=failure, steps=0, worst_time=nan, worst_newton=0,
                    worst_crossed=0, crossed_max=0, per_point=nan, over_10=0, balance=nan), ((), (), ())
    load = APPLIED * np.interp(h.times[1:], *np.array(reference.LOAD_HISTORY).T)
    balance = h.reactions[1:, 1] + h.contact_column("force")[1:, 1] - load
    times, newton, crossed, touching = (np.array(c) for c in zip(*steps))
    first = int(np.argmax(touching))
    after = np.arange(len(steps)) > first
    if not after.any():                # no step after the first contact (a failure ended the case there)
        after = np.arange(len(steps)) == len(steps) - 1
    worst = int(np.flatnonzero(after)[np.argmax(newton[after])])
    fronts = after & (crossed >= 4)
    row = dict(dt=dt, maxh=maxh, order=order, failure=failure, steps=len(steps),
               worst_time=float(times[worst]), worst_newton=int(newton[worst]), worst_crossed=int(crossed[worst]),
               crossed_max=int(crossed[after].max()),
               per_point=float(np.median(newton[fronts] / crossed[fronts])) if fronts.any() else float("nan"),
               over_10=int(np.count_nonzero(newton[after] > 10)),
               balance=float(np.abs(balance).max() / APPLIED))
    return row, (times, newton, crossed)


def summary(rows):
    return table(rows, COLUMNS)


def _plot(traces, out, quick=False):
    fig = Figure(figsize=(10, 4), layout="constrained")
    left, right = fig.subplots(1, 2)
    for i, ((dt, maxh), (times, newton, crossed)) in enumerate(traces.items()):
        label = f"dt = {1e3 * dt:g} ms, h = {1e3 * maxh:g} mm"
        left.plot(times, newton, "o-", color=f"C{i}", ms=3, lw=0.7, label=label)
        right.plot(crossed, newton, "o", color=f"C{i}", ms=4, alpha=0.7)
    left.axvline(reference.LOAD_HISTORY[2][0], color="k", lw=0.6, ls=":")
    left.set(xlabel="time t [s] (dotted: the load reverses)", ylabel="Newton iterations per step",
             title="the reference history, P2")
    right.set(xlabel="Gauss points of Γ3 whose contact state changed in the step", ylabel="Newton iterations")
    left.legend(fontsize=7)
    for ax in (left, right):
        ax.grid(True, lw=0.3)
    save(fig, out / "pull_off.png", quick)
