"""Work–precision of the time schemes: the final-time error against solve time for fixed-k
backward Euler, fixed-k BDF2 and BDF2 with steps chosen by an error target (``run(rtol=...)``).

Scenes (``SCENES``):

* ``plate``: the reference plate (``scenes.reference``, P1, ``maxh``, Nitsche θ = 1) over
  [0, T]: the push, first contact, the hold, the reverse into a pull, lift-off, the plate
  hanging by its glue while β decays.
* ``plate-nodal``: the same with the paper's nodal constraint (``method="active_set"``): no
  Nitsche parameter, so the discrete problem does not change with the time step (Nitsche's γ
  follows the scheme's rate coefficient c, docs/time.md), the setting in which a time scheme's
  own error is seen alone.
* ``column``: the soft column glued on its bottom and lifted off by the body force
  3·10⁸ sin²(πt/0.2) N/m³ over [0, T] (the glue stretches, β falls a little), no conduction.

The reference solution is fixed-k BDF2 with ``REFERENCE_STEPS`` steps, Newton to 1e-12; its own
error is estimated by a run with half as many steps (printed, in the CSV as the row
"reference check"). Errors at T: ‖u_h − u_ref‖∞/‖u_ref‖∞, the same for φ, and
‖β_h − β_ref‖∞. Every run assembles the Γ3 Jacobian with its integrand compiled to machine code
(``realcompile=True``: the same cost per Newton iteration for every scheme; the one-off compile
happens when the simulation is built and is not in the run's time). The time charted is the
solve time ``solve_s``, the wall time of ``Simulation.run`` alone (the rejected tries of a
controlled run included, as they are work its steps cost), one thread; ``setup_s`` gives apart
what building the simulation took (mesh, forms, the compile, step 0). Runs are bitwise
reproducible; their times are not (shared machines: compare ratios within one study run).
"""
import time as wallclock
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.geometries.plate import NETGEN_RESOLUTION
from ngcontact.output.progress import bar
from ngcontact.scenes import column, reference

from .common import table, write_csv

COLUMNS = ("scene", "label", "scheme", "dt", "rtol", "steps", "rejected", "newton", "setup_s", "solve_s", "error_u",
           "error_phi", "error_beta", "failed")
LABELS = ("backward Euler, fixed k", "BDF2, fixed k", "BDF2, error-controlled")
MIN_T = 0.01
"""The plate's shortest final time, s: just after the plate first touches the foundation
(docs/measurements.md, section time_steps); before that the schemes would be compared on a
history in which nothing happens (the study costs the same minutes at any T: its step counts
are fixed)."""
MIN_MAXH = 2 * NETGEN_RESOLUTION * reference.L1
"""The plate's finest mesh size, m: halved along Γ3 (``scenes.reference``), at Netgen's
resolution there (``geometries.plate``)."""
TARGET = 1e-4
"""The final-time relative error of u at which the schemes are compared (docs/time.md)."""


@dataclass(frozen=True)
class Scene:
    """A scene of the study: ``make(scheme, newton_rtol)`` builds its Simulation; T (s); the
    fixed step counts 2^j of backward Euler and of BDF2 (j in the ranges), the tolerances of the
    controlled runs (first step T/16) and the steps of the reference."""
    name: str
    T: float
    be_halvings: range
    bdf2_halvings: range
    rtols: tuple
    reference_steps: int
    make: object


def _plate(method, maxh):
    def make(scheme, newton_rtol):
        return reference.simulation(1, maxh, scheme=scheme, keep_states=False, rtol=newton_rtol, realcompile=True,
                                    contact=reference.contact(method=method))
    return make


def _column(scheme, newton_rtol):
    contact = ngc.Contact(**dict(reference.CONTACT, conductance=0.0))
    return column.simulation(lambda t: 3e8 * ngs.sin(np.pi * t / 0.2) ** 2, contact, scheme=scheme,
                             keep_states=False, rtol=newton_rtol, realcompile=True)


def scenes(maxh=0.01, T=0.25):
    """The study's scenes by name (``Scene``); ``maxh`` (m) and T (s) are the plate's."""
    rtols = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
    return {"plate": Scene("plate", T, range(4, 15), range(4, 11), rtols, 8192, _plate("nitsche", maxh)),
            "plate-nodal": Scene("plate-nodal", T, range(4, 15), range(4, 11), rtols, 8192,
                                 _plate("active_set", maxh)),
            "column": Scene("column", 0.05, range(4, 13), range(4, 10), rtols, 4096, _column)}


def _run(scene, scheme, dt, rtol=None, newton_rtol=1e-10):
    """(the simulation run to T, {"setup_s": its build, "solve_s": its run}, s)."""
    start = wallclock.perf_counter()
    sim = scene.make(scheme, newton_rtol)
    built = wallclock.perf_counter()
    sim.run(dt, scene.T, rtol=rtol)
    return sim, dict(setup_s=built - start, solve_s=wallclock.perf_counter() - built)


def _errors(sim, ref):
    """Relative max-norm errors of u and φ at T, and the largest error of β."""
    X, errors = sim.X, {}
    for name, part in (("error_u", 0), ("error_phi", 1)):
        r = slice(X.Range(part).start, X.Range(part).stop)
        a, b = sim.gfu.vec.FV().NumPy()[r], ref.gfu.vec.FV().NumPy()[r]
        errors[name] = float(np.abs(a - b).max() / np.abs(b).max()) if np.abs(b).max() > 0 else float("nan")
    errors["error_beta"] = float(np.abs(sim.beta.values - ref.beta.values).max())
    return errors


def study(scene, progress=True):
    """Rows (dict, ``COLUMNS``) of every run of the ``Scene``, the reference check first."""
    T = scene.T
    cases = [(LABELS[0], "backward_euler", T / 2**j, None) for j in scene.be_halvings]
    cases += [(LABELS[1], "bdf2", T / 2**j, None) for j in scene.bdf2_halvings]
    cases += [(LABELS[2], "bdf2", T / 16, rtol) for rtol in scene.rtols]
    rows = []
    with bar(len(cases) + 2, f"work-precision, {scene.name}", progress, unit="run") as shown:
        ref, _ = _run(scene, "bdf2", T / scene.reference_steps, newton_rtol=1e-12)
        shown.update()
        check, times = _run(scene, "bdf2", 2 * T / scene.reference_steps, newton_rtol=1e-12)
        rows.append(dict(scene=scene.name, label="reference check", scheme="bdf2", dt=2 * T / scene.reference_steps,
                         steps=len(check.history) - 1, **times, failed="", **_errors(check, ref)))
        shown.update()
        for label, scheme, dt, rtol in cases:
            try:
                sim, times = _run(scene, scheme, dt, rtol)
            except (ValueError, ngc.NewtonError) as err:            # reported, not hidden: the row says why
                rows.append(dict(scene=scene.name, label=label, scheme=scheme, dt=dt, rtol=rtol, failed=str(err)[:200]))
                shown.write(f"{scene.name}: {label}, dt {dt:g}, rtol {rtol}: failed: {err}")
                shown.update()
                continue
            h = sim.history
            rows.append(dict(scene=scene.name, label=label, scheme=scheme, dt=dt, rtol=rtol, steps=len(h) - 1,
                             rejected=len(sim.rejections), newton=int(sum(h.newton_iterations)), **times,
                             failed="", **_errors(sim, ref),
                             steps_taken=[(r.time, r.dt, r.event) for r in h[1:]] if rtol else None))
            shown.update()
    return rows


def time_to(rows, label, target=TARGET, key="error_u"):
    """The solve time (s) at which ``label``'s runs reach ``target`` error, interpolated
    log-log between the two runs around it (in the order of their solve times); None if none
    reaches it."""
    runs = sorted((r for r in rows if r["label"] == label and not r.get("failed")), key=lambda r: r["solve_s"])
    for a, b in zip(runs, runs[1:]):
        if a[key] > target >= b[key]:
            f = np.log(target / a[key]) / np.log(b[key] / a[key])
            return float(np.exp(np.log(a["solve_s"]) + f * np.log(b["solve_s"] / a["solve_s"])))
    hits = [r["solve_s"] for r in runs if r[key] <= target]
    return min(hits) if hits else None


def summary(rows, target=TARGET):
    """One row per scene: the time to ``target`` of each label and the ratios of backward
    Euler's time to the others'."""
    out = []
    for name in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == name]
        times = {label: time_to(mine, label, target) for label in LABELS}
        be = times[LABELS[0]]
        out.append(dict(scene=name, be_s=be, bdf2_s=times[LABELS[1]], controlled_s=times[LABELS[2]],
                        be_over_bdf2=be / times[LABELS[1]] if be and times[LABELS[1]] else None,
                        be_over_controlled=be / times[LABELS[2]] if be and times[LABELS[2]] else None,
                        reference_check=next(r["error_u"] for r in mine if r["label"] == "reference check")))
    return out


def chart(rows, path, target=TARGET):
    """Final-time error of u against solve time, one panel per scene, one line per scheme, the
    target dashed."""
    names = list(dict.fromkeys(r["scene"] for r in rows))
    fig = Figure(figsize=(5.2 * len(names), 4.6))
    for i, name in enumerate(names):
        ax = fig.add_subplot(1, len(names), i + 1)
        for label, marker in zip(LABELS, "os^"):
            runs = sorted((r for r in rows if r["scene"] == name and r["label"] == label and not r.get("failed")),
                          key=lambda r: -(r["rtol"] or r["dt"]))          # in the order of k or rtol
            ax.loglog([r["solve_s"] for r in runs], [r["error_u"] for r in runs], marker=marker, label=label)
        ax.axhline(target, color="grey", linestyle="--", linewidth=0.8, label=f"target {target:g}")
        ax.set_xlabel("solve time: Simulation.run, one run each (s; setup apart)")
        ax.set_ylabel("relative error of u at T (max norm)")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Work–precision of the time schemes (P1)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def step_chart(rows, path):
    """The step sizes the error-controlled runs chose over time, events marked; one panel
    per scene."""
    names = [n for n in dict.fromkeys(r["scene"] for r in rows)
             if any(r.get("steps_taken") for r in rows if r["scene"] == n)]
    fig = Figure(figsize=(5.2 * max(1, len(names)), 4.2))
    for i, name in enumerate(names):
        ax = fig.add_subplot(1, len(names), i + 1)
        for r in rows:
            if r["scene"] == name and r.get("steps_taken"):
                times, dts, _ = zip(*r["steps_taken"])
                ax.semilogy(times, dts, ".-", markersize=3, linewidth=0.8, label=f"rtol {r['rtol']:g}")
                for time, _, event in r["steps_taken"]:
                    if event:
                        ax.axvline(time, color="grey", linewidth=0.6, linestyle=":")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("step k (s)")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Steps chosen by BDF2's error estimate (dotted: located events)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(out, maxh=0.01, T=0.25, which=("plate", "plate-nodal", "column"), target=TARGET):
    """Run the study into the directory ``out``: time_steps.csv, time_steps.png,
    time_steps_dt.png, summary.csv, and the summary printed."""
    from ngcontact import checks, parallel
    parallel.refuse_under_mpiexec("timesteps")
    maxh = checks.number("--maxh", maxh, MIN_MAXH, reference.L2, unit="m")
    checks.fits_in_memory(f"--maxh {maxh:g}", checks.estimated_ndof(
        checks.estimated_vertices((reference.L1, reference.L2), maxh), 2, 0, 1))
    T = checks.number("--T", T, MIN_T, reference.LOAD_HISTORY[-1][0], unit="s (the load history: the plate touches "
                      "the foundation at t = 0.008 s, the history ends at 0.5 s)")
    known = scenes(maxh, T)
    which = [which] if isinstance(which, str) else list(which)
    for name in which:
        if name not in known:
            raise ValueError(f"--scene must be among {', '.join(known)}, got {name!r}")
    out = checks.writable_directory(out)
    rows = [row for name in which for row in study(known[name])]
    write_csv(rows, out / "time_steps.csv", COLUMNS)
    chart(rows, out / "time_steps.png", target)
    step_chart(rows, out / "time_steps_dt.png")
    result = summary(rows, target)
    write_csv(result, out / "summary.csv")
    print(table(result, list(result[0])))
    return rows, result
