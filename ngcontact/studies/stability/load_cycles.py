"""Push-pull cycles on the reference scene (glue, conduction) that open and close the contact
repeatedly: Newton iterations, cut-backs, cycling, and the force balance at every step."""
import numpy as np
from matplotlib.figure import Figure

from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import failure_kind, line, newton_total, run as run_quietly, table
from .shared import APPLIED, save

COLUMNS = ("dt", "records", "newton", "newton_max", "cutbacks", "cycling", "switches", "openings", "balance")
"""The columns of the summary table."""


def cycle_history(cycles, period, low):
    """Load factors (time, fraction of the scene's pressure): push to 1, reverse to ``low``."""
    history = [(0.0, 0.0)]
    for i in range(cycles):
        history += [(i * period + period / 2, 1.0), ((i + 1) * period, low)]
    return tuple(history)


DTS = (0.005, 0.01, 0.02, 0.025, 0.05)
"""The nominal time steps of the study (s)."""
QUICK_DTS = (0.01, 0.025)
"""Those of the quick run (s)."""


def run(out=None, *, dts=None, cycles=4, period=0.1, low=-0.2, maxh=0.01, quick=False, progress=True):
    """The top load goes 0 → 1 → ``low`` (× 2 MPa) every ``period`` s, ``cycles`` times.

    Cut-backs are allowed (6); each cut-back's failed attempt is classified by
    ``failure_kind``.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``load_cycles.png``.
    dts : nominal time steps (s); default ``DTS``, quick ``QUICK_DTS``.
    cycles, period, low : the load history.
    maxh : mesh size, m.
    quick : fewer time steps, two cycles.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per nominal time step ``dt``: ``records`` (steps computed), ``newton``
    (total), ``newton_max`` (per step), ``cutbacks``, ``cycling`` (cut-backs whose failed
    attempt cycled), ``switches`` (facets entering or leaving the contact zone, summed over
    steps), ``openings`` (steps after which the contact zone is empty while it was not
    before), ``balance`` (max over steps of |reaction + contact force − load| / peak load),
    ``beta_min_final``.
    """
    if dts is None:
        dts = QUICK_DTS if quick else DTS
    if quick:
        cycles = 2
    history = cycle_history(cycles, period, low)
    rows, traces = [], {}
    with bar(len(dts), "load_cycles", progress, unit="run") as shown:
        for dt in dts:
            sim = reference.simulation(1, maxh, load_history=history, keep_states=False)
            failure = run_quietly(sim, dt, cycles * period, max_cutbacks=6)
            h = sim.history
            in_contact = h.contact_column("contact_set")[1:] > 0.5
            area = h.contact_column("contact_area")[1:]
            load = APPLIED * np.interp(h.times[1:], *np.array(history).T)
            balance = h.reactions[1:, 1] + h.contact_column("force")[1:, 1] - load
            row = dict(dt=dt, failure=failure["failure"] if failure else "", records=len(h) - 1,
                       newton=newton_total(sim, failure), newton_max=int(h.newton_iterations[1:].max()),
                       cutbacks=len(sim.cutbacks),
                       cycling=sum(failure_kind(c["residuals"]).startswith("cycle") for c in sim.cutbacks),
                       switches=int(np.count_nonzero(np.diff(in_contact, axis=0))),
                       openings=int(np.count_nonzero((area[1:] == 0) & (area[:-1] > 0))),
                       balance=float(np.abs(balance).max() / APPLIED),
                       beta_min_final=float(h[-1].contact.beta.min()))
            rows.append(row)
            traces[dt] = (h.times[1:], area, h.newton_iterations[1:], [c["time"] for c in sim.cutbacks])
            shown.write(line(row, COLUMNS))
            shown.update()
    if out is not None:
        _plot(traces, history, out, quick)
    return rows


def summary(rows):
    return table(rows, COLUMNS)


def _plot(traces, history, out, quick=False):
    fig = Figure(figsize=(9, 7), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    times, factors = np.array(history).T
    axes[0].plot(times, 1e-6 * reference.PRESSURE * factors, "k")
    axes[0].set(ylabel="pressure on top [MPa]", title="push-pull cycles on the reference scene")
    for i, (dt, (t, area, newton, cut)) in enumerate(traces.items()):
        axes[1].plot(t, 1e3 * area, "o-", color=f"C{i}", ms=3, lw=0.7, label=f"dt = {1e3 * dt:g} ms")
        axes[2].plot(t, newton, "o-", color=f"C{i}", ms=3, lw=0.7)
        for c in cut:
            axes[2].axvline(c, color=f"C{i}", lw=0.8, ls=":")
    axes[1].set(ylabel="contact length [mm]")
    axes[1].legend(fontsize=7, ncol=len(traces))
    axes[2].set(xlabel="time t [s]", ylabel="Newton iterations per step\n(dotted: cut-back)")
    for ax in axes:
        ax.grid(True, lw=0.3)
    save(fig, out / "load_cycles.png", quick)
