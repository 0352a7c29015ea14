"""Complete debonding, then contact: the soft column (``scenes.column``) lifted off its glue
until β = 0 everywhere, then pushed onto the foundation, against the same column without glue."""
import math

import numpy as np
from matplotlib.figure import Figure

from ngcontact.output.progress import bar
from ngcontact.scenes import column, reference

from ngcontact.studies.common import fmt, run as run_quietly
from .shared import save

LOAD_HISTORY = ((0.0, 0.0), (0.01, 1.0), (0.1, 1.0), (0.12, -1.0), (1e3, -1.0))
"""(time in s, fraction of the body force): lift, hold, reverse into a push, hold."""


def run(out=None, *, force=3e8, dt=2e-3, T=0.2, beta_update="explicit", quick=False, progress=True):
    """The glued column against the same column without glue.

    The body force lifts the column (force × H = 6 MPa against the glue's strength
    γ_ν L = 5 MPa: the glue stretches beyond L), β decays to 0 everywhere, the force
    reverses (t in s: 0.1 to 0.12) and pushes the column onto the foundation. Scene contact data
    without conduction; cut-backs are allowed (6).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``debonding.png``.
    force : body force, N/m³.
    dt, T : time step and final time, s.
    beta_update : "explicit" or "implicit".
    quick : twice the time step.
    progress : show a progress bar and the summary line.

    Returns
    -------
    list of dict, one per step: ``time``, ``body_force`` (N/m³, upwards), ``beta_max``,
    ``beta_mean``, ``force_glued`` and ``force_free`` (the foundation's force on the
    column, N/m, y), ``newton_glued``, ``newton_free``, ``cutbacks`` (both runs, over the
    whole run).
    """
    if quick:
        dt *= 2
    runs = {}
    with bar(2, "debonding", progress, unit="run") as shown:
        for name, adhesion in (("glued", reference.CONTACT["adhesion"]), ("free", 0.0)):
            contact = reference.contact(adhesion=adhesion, conductance=0.0, beta_update=beta_update)
            sim = column.simulation(lambda t: force * reference.load_factor(t, LOAD_HISTORY), contact,
                                    keep_states=False)
            failure = run_quietly(sim, dt, T, max_cutbacks=6)
            if failure:
                raise RuntimeError(f"the {name} column failed: {failure}")
            runs[name] = sim
            shown.update()
        glued, free = (runs[k].history for k in ("glued", "free"))
        if len(glued) != len(free) or not np.allclose(glued.times, free.times):
            raise RuntimeError("the glued and glue-free runs took different time steps (cut-backs)")
        times = np.array(LOAD_HISTORY)
        beta = glued.contact_column("beta")
        rows = [dict(time=float(g.time), body_force=float(force * np.interp(g.time, *times.T)),
                     beta_max=float(b.max()), beta_mean=float(b.mean()),
                     force_glued=float(g.contact.force[1]), force_free=float(f.contact.force[1]),
                     newton_glued=int(g.newton_iterations), newton_free=int(f.newton_iterations),
                     cutbacks=len(runs["glued"].cutbacks) + len(runs["free"].cutbacks))
                for g, f, b in zip(glued[1:], free[1:], beta[1:])]
        shown.write(summary(rows))
    if out is not None:
        _plot(rows, out, quick)
    return rows


def headline(rows, beta_tol=1e-8):
    """Final β_max, the time from which β_max < ``beta_tol``, and the largest difference of
    the glued and glue-free contact forces from then on, relative to the largest force."""
    debonded = [r for r in rows if r["beta_max"] < beta_tol]
    scale = max(abs(r["force_free"]) for r in rows)
    return dict(beta_max_final=rows[-1]["beta_max"],
                debonded_at=debonded[0]["time"] if debonded else math.nan,
                force_difference=max((abs(r["force_glued"] - r["force_free"]) for r in debonded),
                                     default=math.nan) / scale,
                contact_force_final=rows[-1]["force_glued"])


def summary(rows):
    return "\n".join(f"{k}: {fmt(v)}" for k, v in headline(rows).items())


def _plot(rows, out, quick=False):
    t = np.array([r["time"] for r in rows])
    fig = Figure(figsize=(7.5, 5.5), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    axes[0].plot(t, [1e-3 * r["force_glued"] for r in rows], "-", lw=2, label="glued")
    axes[0].plot(t, [1e-3 * r["force_free"] for r in rows], "--", label="no glue")
    axes[0].set(ylabel="foundation force on Γ3 [kN/m]",
                title="column lifted (glue in tension, then debonded), then pushed down")
    axes[0].legend()
    axes[1].semilogy(t, np.maximum([r["beta_max"] for r in rows], 1e-300), "C1", label="max β")
    axes[1].semilogy(t, np.maximum([r["beta_mean"] for r in rows], 1e-300), "C1:", label="mean β")
    axes[1].set(xlabel="time t [s]", ylabel="bonding field β", ylim=(1e-18, 2))
    axes[1].legend()
    for ax in axes:
        ax.grid(True, lw=0.3)
    save(fig, out / "debonding.png", quick)
