"""The pull-off of the reference plate: Newton iterations per step against the Gauss points of
Γ3 that the release front crosses in the step, for several time steps and meshes, with and
without the Signorini switch's inner loop (``Simulation(switch_loop=...)``).

After the load reverses (the reference history's pull) the contact zone opens from its inner edge while the glue
holds the plate. The semismooth Newton releases the points of Γ3 that are in tension under the
current contact set; releasing them loads the next ones, so a step whose front crosses many
points takes about one iteration per point crossed. The inner loop (``solve.switch_loop``)
follows that cascade inside each correction. The study measures both on the reference history
(P2) at fixed steps, with the default solver, and on the glued disk pulled off its plane
(``scenes.glued_disk``: its section and its 3D quarter, P1, ten steps).
"""
import math
import numbers
import time as wallclock
from collections.abc import Iterable

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import checks
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import failure_kind, line, table
from .shared import APPLIED, save

COLUMNS = ("scene", "switch_loop", "dt", "maxh", "steps", "newton_total", "first_newton", "worst_time", "worst_newton",
           "worst_crossed", "crossed_max", "per_point", "over_10", "balance", "wall_s")
"""The columns of the summary table."""
T_END = 0.2
"""The end of the history studied, s: the load has reversed into the pull (``reference``)."""


CASES = ((0.0025, 0.005), (0.005, 0.005), (0.01, 0.005), (0.02, 0.005), (0.005, 0.0025), (0.005, 0.01))
"""The (dt in s, maxh in m) cases of the study: four steps on one mesh, three meshes at one step."""
QUICK_CASES = ((0.01, 0.005),)
"""The quick run's case."""
DISKS = (("section", 1e-4), ("quarter", 5e-4))
"""The glued disk's cases (``scenes.glued_disk``: kind, maxh in m), ten steps to t = 1."""


def run(out=None, *, cases=None, order=2, quick=False, progress=True, disks=None):
    """The reference history to ``T_END`` at each (dt, maxh) of ``cases``, and the glued disk
    at each of ``disks``, each with plain Newton corrections and with the inner loop.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``pull_off.png``.
    cases : (dt in s, maxh in m) pairs; default ``CASES``, quick ``QUICK_CASES``. Checked before any run (``checked``):
        dt finite in [``smallest_dt``, T_END / 2] (at least two steps to ``T_END``, at most
        ``checks.MAX_STEPS``), maxh finite in (0, L2] (the plate's thickness) and within memory.
    order : polynomial order.
    quick : one case, no disk.
    progress : show a progress bar and a line per run.
    disks : (kind, maxh in m) of the glued disk; default ``DISKS``, none with ``quick`` or
        ``cases`` given.

    Returns
    -------
    list of dict, one per case and ``switch_loop`` (False, True): ``scene`` ("reference", or
    "disk section" / "disk quarter" with dt the step and maxh the mesh size), ``steps``,
    ``newton_total``, ``wall_s`` (the run's wall time, one run); ``first_newton``: the iterations of
    the first contact's step (the disk: its first step, from rest); the worst step after the first contact
    (``worst_time`` s, ``worst_newton`` linear solves with those of given-up tries,
    ``worst_crossed`` Gauss points of Γ3 whose contact state changed in it); ``crossed_max``;
    ``per_point``: the median of newton / crossed over the steps that cross at least 4 points;
    ``over_10``: steps after the first contact with more than 10 iterations; ``balance``: max
    |reaction + contact force − load| / peak load; ``failure`` (the kind, or "").
    """
    quick = checks.flag("quick", quick)
    given = cases is not None
    if cases is None:
        cases = QUICK_CASES if quick else CASES
    cases, order = checked(cases, order)
    disks = (() if quick or given else DISKS) if disks is None else tuple(disks)
    rows, traces = [], {}
    with bar(2 * (len(cases) + len(disks)), "pull_off", progress, unit="run") as shown:
        for loop in (False, True):
            for dt, maxh in cases:
                row, trace = _case(dt, maxh, order, loop)
                rows.append(row)
                traces[dt, maxh, loop] = trace
                shown.write(line(row, COLUMNS))
                shown.update()
            for kind, maxh in disks:
                rows.append(_disk(kind, maxh, loop))
                shown.write(line(rows[-1], COLUMNS))
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


def _disk(kind, maxh, loop, steps=10):
    """The glued disk (``scenes.glued_disk``) in ``steps`` steps: Newton iterations per step."""
    from ngcontact.scenes import glued_disk
    start = wallclock.perf_counter()
    sim = glued_disk.simulation(kind, maxh, keep_states=False, switch_loop=loop)
    newton, failure = [], ""
    try:
        for _ in range(steps):
            record = sim.step(1.0 / steps)
            newton.append(record.newton_iterations + record.discarded_iterations)
    except ngc.NewtonError as err:
        failure = failure_kind(err.residuals)
    nan = float("nan")
    worst = int(np.argmax(newton)) if newton else 0
    return dict(scene=f"disk {kind}", switch_loop=loop, dt=1.0 / steps, maxh=maxh, order=1, failure=failure,
                steps=len(newton), newton_total=int(sum(newton)), first_newton=newton[0] if newton else 0,
                worst_time=(worst + 1) / steps if newton else nan,
                worst_newton=max(newton, default=0), worst_crossed=0, crossed_max=0, per_point=nan,
                over_10=sum(n > 10 for n in newton), balance=nan, wall_s=wallclock.perf_counter() - start)


def _case(dt, maxh, order, loop=False):
    start = wallclock.perf_counter()
    sim = reference.simulation(order, maxh, keep_states=False, switch_loop=loop)
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
        return dict(scene="reference", switch_loop=loop, dt=dt, maxh=maxh, order=order, failure=failure, steps=0,
                    newton_total=0, first_newton=0, worst_time=nan, worst_newton=0, worst_crossed=0, crossed_max=0, per_point=nan,
                    over_10=0, balance=nan, wall_s=wallclock.perf_counter() - start), ((), (), ())
    load = APPLIED * np.interp(h.times[1:], *np.array(reference.LOAD_HISTORY).T)
    balance = h.reactions[1:, 1] + h.contact_column("force")[1:, 1] - load
    times, newton, crossed, touching = (np.array(c) for c in zip(*steps))
    first = int(np.argmax(touching))
    after = np.arange(len(steps)) > first
    if not after.any():                # no step after the first contact (a failure ended the case there)
        after = np.arange(len(steps)) == len(steps) - 1
    worst = int(np.flatnonzero(after)[np.argmax(newton[after])])
    fronts = after & (crossed >= 4)
    row = dict(scene="reference", switch_loop=loop, dt=dt, maxh=maxh, order=order, failure=failure,
               steps=len(steps), newton_total=int(newton.sum()), first_newton=int(newton[first]),
               worst_time=float(times[worst]), worst_newton=int(newton[worst]), worst_crossed=int(crossed[worst]),
               crossed_max=int(crossed[after].max()),
               per_point=float(np.median(newton[fronts] / crossed[fronts])) if fronts.any() else float("nan"),
               over_10=int(np.count_nonzero(newton[after] > 10)),
               balance=float(np.abs(balance).max() / APPLIED), wall_s=wallclock.perf_counter() - start)
    return row, (times, newton, crossed)


def summary(rows):
    return table(rows, COLUMNS)


def _plot(traces, out, quick=False):
    fig = Figure(figsize=(10, 4), layout="constrained")
    left, right = fig.subplots(1, 2)
    colours = {}
    for (dt, maxh, loop), (times, newton, crossed) in traces.items():
        i = colours.setdefault((dt, maxh), len(colours))
        label = f"dt = {1e3 * dt:g} ms, h = {1e3 * maxh:g} mm" + (", inner loop" if loop else "")
        style = dict(color=f"C{i}", ms=3 if loop else 4, mfc=None if loop else "none")
        left.plot(times, newton, "o-" if loop else "o--", lw=0.7, label=label, **style)
        right.plot(crossed, newton, "o", alpha=0.7, **style)
    left.axvline(reference.LOAD_HISTORY[2][0], color="k", lw=0.6, ls=":")
    left.set(xlabel="time t [s] (dotted: the load reverses)", ylabel="Newton iterations per step",
             title="the reference history, P2 (hollow, dashed: plain corrections)")
    right.set(xlabel="Gauss points of Γ3 whose contact state changed in the step", ylabel="Newton iterations",
              title="filled: with the inner loop")
    left.legend(fontsize=7)
    for ax in (left, right):
        ax.grid(True, lw=0.3)
    save(fig, out / "pull_off.png", quick)
