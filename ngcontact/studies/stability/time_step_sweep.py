"""The explicit β update (4.5) against the implicit one as dt γ_ν L² crosses 1, on the
reference plate pulled off its glue (the paper's k is dt)."""
import numpy as np
from matplotlib.figure import Figure

from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import line, newton_total, run as run_quietly, table
from .shared import save

COLUMNS = ("update", "dt_gamma_L2", "records", "beta_unclipped_min", "beta_min", "clipped", "beta_rise",
           "beta_error")
"""The columns of the summary table."""
RATE = reference.CONTACT["adhesion"] * reference.CONTACT["bond_length"] ** 2
"""γ_ν L² of the scene's glue, 1/s: dt γ_ν L² > 1 is beyond the explicit update's bound."""


def pulled_plate(update, maxh, pull):
    """The reference plate, glued (scene contact data), pulled off from rest: the top load
    ramps to ``pull`` × the scene's pressure (negative: upwards) over a ramp and is held."""
    history = ((0.0, 0.0), (0.01, pull), (1e3, pull))
    return reference.simulation(1, maxh, load_history=history, keep_states=False,
                                contact=reference.contact(beta_update=update))


def beta_run(update, dt, T, maxh, pull):
    """Step the pulled plate to T without cut-backs; returns (sim, failure)."""
    sim = pulled_plate(update, maxh, pull)
    return sim, run_quietly(sim, dt, T)


def extrapolated_beta(dt, T, maxh, pull):
    """Richardson extrapolation 2 β(dt) − β(2 dt) of the implicit update (first order in dt),
    at the times of the 2 dt grid; returns (times, β, side)."""
    coarse, fine = (beta_run("implicit", k, T, maxh, pull) for k in (2 * dt, dt))
    for sim, failure in (coarse, fine):
        if failure:
            raise RuntimeError(f"the reference β run failed: {failure}")
    beta = 2 * fine[0].history.contact_column("beta")[::2] - coarse[0].history.contact_column("beta")
    return coarse[0].history.times, beta, coarse[0].side


def run(out=None, *, dt_gamma_L2s=None, reference_dt_gamma_L2=0.125, T=0.32, pull=-0.2, maxh=0.01,
        quick=False, progress=True):
    """The explicit β update (4.5) against the implicit one for dt γ_ν L² from below to above 1.

    The glued reference plate is pulled off from rest (the top load a fifth of the scene's pressure upwards, reached by a ramp,
    then held): the glue stretches, β decays from the free end and the plate lifts off
    (R_ν = L there, so the explicit decay factor per step is 1 − dt γ_ν L²).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``time_step_sweep.png``.
    dt_gamma_L2s : values of dt γ_ν L² (dt = value / (γ_ν L²)); default 0.5 ... 8 in factors
        of 2 (quick: 0.5, 2, 8).
    reference_dt_gamma_L2 : the reference is the Richardson extrapolation 2 β(dt) − β(2 dt)
        of the implicit update with dt γ_ν L² = this (quick: twice it); the sweep's dt must be
        multiples of 2 dt.
    T : final time, s (a multiple of every dt).
    pull : the held top load as a fraction of the scene's pressure (negative: pull).
    maxh : mesh size, m.
    quick : fewer and coarser steps.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per (update, dt): ``records`` (steps computed), ``failure``, ``newton``,
    ``beta_min`` and ``beta_max`` (over facets and steps), ``beta_unclipped_min`` (min of the
    update before clipping), ``clipped`` (facet-steps clipped) and ``clipped_steps``, ``beta_rise``
    (largest increase of β in a step: 0 for a monotone decay), ``beta_mean_final``,
    ``beta_error`` (max over the common times of ‖β − β_ref‖_L²(Γ3) / |Γ3|^½).
    """
    if dt_gamma_L2s is None:
        dt_gamma_L2s = (0.5, 2.0, 8.0) if quick else (0.5, 1.0, 2.0, 4.0, 8.0)
    if quick:
        reference_dt_gamma_L2 *= 2
    rows, traces = [], {}
    with bar(1 + 2 * len(dt_gamma_L2s), "time_step_sweep", progress, unit="run") as shown:
        ref_times, ref_beta, side = extrapolated_beta(reference_dt_gamma_L2 / RATE, T, maxh, pull)
        shown.update()
        measure = side.measure
        for update in ("explicit", "implicit"):
            for value in dt_gamma_L2s:
                dt = value / RATE
                sim, failure = beta_run(update, dt, T, maxh, pull)
                h = sim.history
                beta, unclipped = h.contact_column("beta"), h.contact_column("beta_unclipped")
                every = int(round(dt * RATE / (2 * reference_dt_gamma_L2)))
                diff = beta - ref_beta[::every][:len(beta)]
                clipped = h.contact_column("beta_clipped")
                row = dict(update=update, dt=dt, dt_gamma_L2=value, records=len(beta) - 1,
                           failure=failure["failure"] if failure else "", newton=newton_total(sim, failure),
                           beta_min=float(beta.min()), beta_max=float(beta.max()),
                           beta_unclipped_min=float(unclipped.min()), clipped=int(clipped.sum()),
                           clipped_steps=int(np.count_nonzero(clipped)),
                           beta_rise=float(max(np.diff(beta, axis=0).max(), 0.0)),
                           beta_mean_final=float(beta[-1].mean()),
                           beta_error=float(np.sqrt((diff ** 2 @ measure) / measure.sum()).max()))
                rows.append(row)
                traces[update, value] = (h.times, beta, unclipped)
                shown.write(line(row, COLUMNS + ("newton",)))
                shown.update()
    if out is not None:
        _plot(rows, traces, (ref_times, ref_beta), side, out, quick)
    return rows


def summary(rows):
    return table(rows, COLUMNS)


def _plot(rows, traces, reference_beta, side, out, quick=False):
    tip = int(np.argmax(side.midpoints[:, 0]))
    fig = Figure(figsize=(13, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    for i, update in enumerate(("explicit", "implicit")):
        runs = [r for r in rows if r["update"] == update]
        x = [r["dt_gamma_L2"] for r in runs]
        axes[0].loglog(x, [r["beta_error"] for r in runs], "o-", color=f"C{i}", label=update)
        axes[1].plot(x, [r["beta_unclipped_min"] for r in runs], "o-", color=f"C{i}", label=update)
    axes[0].set(xlabel="dt γ_ν L²", ylabel="max_n ‖β − β_ref‖ / |Γ3|^½", title="error against the reference β")
    axes[1].axhline(0, color="k", lw=0.6)
    axes[1].set(xscale="log", xlabel="dt γ_ν L²", ylabel="min of β_n before clipping",
                title="explicit (4.5) leaves [0, 1] for dt γ_ν L² > 1")
    values = sorted({r["dt_gamma_L2"] for r in rows})
    for ax in axes[:2]:
        ax.set_xticks(values, [f"{k:g}" for k in values], minor=False)
        ax.set_xticks([], minor=True)
    times, beta = reference_beta
    axes[2].plot(times, beta[:, tip], "k-", lw=2, label="reference")
    shown = sorted({value for _, value in traces})
    for j, value in enumerate(shown[::2] if len(shown) > 3 else shown):
        for update, style in (("explicit", "o--"), ("implicit", "s-")):
            t, b, unclipped = traces[update, value]
            axes[2].plot(t, b[:, tip], style, color=f"C{j + 2}", ms=3, lw=0.8, label=f"{update} {value:g}")
            if update == "explicit":
                axes[2].plot(t, unclipped[:, tip], ".", color=f"C{j + 2}", ms=4)
    axes[2].set(xlabel="time t [s]", ylabel="β at the free end", title="dots: explicit before clipping")
    for ax in axes:
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7)
    save(fig, out / "time_step_sweep.png", quick)
