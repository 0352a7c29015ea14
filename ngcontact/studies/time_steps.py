"""Work–precision of the time schemes: the final-time error against wall time for fixed-k
backward Euler, fixed-k BDF2 and BDF2 with steps chosen by an error target (``run(rtol=...)``).

Scene: the reference plate (``scenes.reference``, P1, ``maxh``) over [0, T]: the push, first
contact, the hold, the reverse into a pull, lift-off (T = 0.25 s). The reference solution is
fixed-k BDF2 with 8× more steps than the finest run (``REFERENCE_REFINEMENT``), Newton to
1e-12; its own error is estimated by the finest fixed-k BDF2 run against it (printed). Errors at T, relative:
‖u_h − u_ref‖∞/‖u_ref‖∞ and the same for φ. Each run's wall time is the whole
``Simulation.run`` (setup apart), one thread.
"""
import time as wallclock

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.progress import bar
from ngcontact.scenes import reference

from .common import write_csv

REFERENCE_REFINEMENT = 3
"""The reference run halves the finest run's k this many more times."""
T_DEFAULT = 0.25
COLUMNS = ("label", "scheme", "dt", "rtol", "steps", "rejected", "newton", "wall_s", "error_u", "error_phi", "failed")


def _run(maxh, T, scheme, dt, rtol=None, event_dt=None, newton_rtol=1e-10):
    sim = reference.simulation(1, maxh, scheme=scheme, keep_states=False, rtol=newton_rtol)
    start = wallclock.perf_counter()
    sim.run(dt, T, rtol=rtol, event_dt=event_dt)
    wall = wallclock.perf_counter() - start
    return sim, wall


def _error(sim, ref, part):
    X = sim.X
    r = slice(X.Range(part).start, X.Range(part).stop)
    a, b = sim.gfu.vec.FV().NumPy()[r], ref.gfu.vec.FV().NumPy()[r]
    return float(np.abs(a - b).max() / np.abs(b).max())


def study(maxh=0.01, T=T_DEFAULT, halvings=range(4, 11), rtols=(1e-2, 1e-3, 1e-4, 1e-5), progress=True):
    """Rows (dict, ``COLUMNS``) of every run, and the reference's check (dict)."""
    cases = [("backward Euler, fixed k", "backward_euler", T / 2**j, None) for j in halvings]
    cases += [("BDF2, fixed k", "bdf2", T / 2**j, None) for j in halvings]
    cases += [("BDF2, error-controlled", "bdf2", T / 2**halvings[0], rtol) for rtol in rtols]
    rows = []
    with bar(len(cases) + 1, "work-precision", progress, unit="run") as shown:
        ref, _ = _run(maxh, T, "bdf2", T / 2**(halvings[-1] + REFERENCE_REFINEMENT), newton_rtol=1e-12)
        shown.update()
        for label, scheme, dt, rtol in cases:
            try:
                sim, wall = _run(maxh, T, scheme, dt, rtol)
            except (ValueError, ngc.NewtonError) as err:            # reported, not hidden: the row says why
                rows.append(dict(label=label, scheme=scheme, dt=dt, rtol=rtol, failed=str(err)[:200]))
                shown.write(f"{label}, dt {dt:g}, rtol {rtol}: failed: {err}")
                shown.update()
                continue
            h = sim.history
            rows.append(dict(label=label, scheme=scheme, dt=dt, rtol=rtol, steps=len(h) - 1,
                             rejected=len(sim.rejections), newton=int(sum(h.newton_iterations)), wall_s=wall,
                             error_u=_error(sim, ref, 0), error_phi=_error(sim, ref, 1), failed="",
                             steps_taken=[(r.time, r.dt, r.event) for r in h[1:]] if rtol else None))
            shown.update()
    finest = [r for r in rows if r["label"] == "BDF2, fixed k" and not r.get("failed")][-1]
    check = dict(reference_steps=len(ref.history) - 1, finest_fixed_bdf2_error_u=finest["error_u"])
    return rows, check


def time_to(rows, label, target, key="error_u"):
    """The wall time (s) at which ``label``'s runs reach ``target`` error, interpolated
    log-log between the two runs around it; None if none reaches it."""
    runs = sorted((r for r in rows if r["label"] == label and not r.get("failed")), key=lambda r: r["wall_s"])
    for a, b in zip(runs, runs[1:]):
        if a[key] > target >= b[key]:
            f = np.log(target / a[key]) / np.log(b[key] / a[key])
            return float(np.exp(np.log(a["wall_s"]) + f * np.log(b["wall_s"] / a["wall_s"])))
    hits = [r["wall_s"] for r in runs if r[key] <= target]
    return min(hits) if hits else None


def chart(rows, path, target=1e-4):
    """Final-time error of u against wall time, one line per scheme, the target dashed."""
    fig = Figure(figsize=(6.4, 4.6))
    ax = fig.add_subplot()
    for label, marker in (("backward Euler, fixed k", "o"), ("BDF2, fixed k", "s"), ("BDF2, error-controlled", "^")):
        runs = sorted((r for r in rows if r["label"] == label and not r.get("failed")),
                      key=lambda r: -(r["rtol"] or r["dt"]))          # in the order of k or rtol
        ax.loglog([r["wall_s"] for r in runs], [r["error_u"] for r in runs], marker=marker, label=label)
    ax.axhline(target, color="grey", linestyle="--", linewidth=0.8)
    ax.set_xlabel("wall time of the run (s)")
    ax.set_ylabel("relative error of u at T (max norm)")
    ax.set_title("Reference plate, P1: work–precision of the time schemes")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def step_chart(rows, path):
    """The step sizes the error-controlled runs chose over time, events marked."""
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot()
    for r in rows:
        if r.get("steps_taken"):
            times, dts, _ = zip(*r["steps_taken"])
            ax.semilogy(times, dts, ".-", markersize=3, linewidth=0.8, label=f"rtol {r['rtol']:g}")
            for time, _, event in r["steps_taken"]:
                if event:
                    ax.axvline(time, color="grey", linewidth=0.6, linestyle=":")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("step k (s)")
    ax.set_title("Steps chosen by BDF2's error estimate (dotted: located events)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(out, maxh=0.01, T=T_DEFAULT, target=1e-4):
    """Run the study into the directory ``out``: time_steps.csv, time_steps.png, and a summary."""
    from ngcontact import checks, parallel
    parallel.refuse_under_mpiexec("timesteps")
    maxh = checks.number("--maxh", maxh, 0, reference.L2, low_open=True, unit="m")
    T = checks.number("--T", T, 0, reference.LOAD_HISTORY[-1][0], low_open=True, unit="s")
    out = checks.writable_directory(out)
    rows, check = study(maxh, T)
    write_csv(rows, out / "time_steps.csv", COLUMNS)
    chart(rows, out / "time_steps.png", target)
    step_chart(rows, out / "time_steps_dt.png")
    times = {label: time_to(rows, label, target) for label in
             ("backward Euler, fixed k", "BDF2, fixed k", "BDF2, error-controlled")}
    print(f"reference: fixed-k BDF2, {check['reference_steps']} steps; fixed-k BDF2 at the smallest k is "
          f"{check['finest_fixed_bdf2_error_u']:.2e} from it")
    for label, t in times.items():
        print(f"{label}: time to {target:g}: " + ("not reached" if t is None else f"{t:.2f} s"))
    return rows, times
