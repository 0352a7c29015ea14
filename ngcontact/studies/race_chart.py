"""Work–precision of the 2D Hertz race: error against process wall time, one panel per error
(force, pressure L2, half-width a), from the JSON lines of ``docs/race/runs.py`` (one run a
line: ``code``, ``kind``, ``order``, ``refine`` or ``tol``, ``proc_wall_s`` and the errors
``force_error``, ``pressure_L2``, ``a_error`` of ``hertz_reference``). Each configuration is one
point at the median of its repetitions; a series is a (code, kind, order). Later runs (another
file, another ``kind``) are added by passing their file too.
"""
import json
import math
import pathlib
import statistics

PANELS = (("force_error", "force |F_h − F|/F"), ("pressure_L2", "pressure ‖λ_h − p‖/‖p‖ on Γ3"),
          ("a_error", "half-width |a_h − a|/a"))
"""(key, title) of the three panels."""


def grouped(jsonl_paths):
    """{(code, kind, order, label): [runs]} of the runs in ``jsonl_paths`` that finished with
    errors; label "L<k>" for a uniform level, "tol <t>" for an adaptive run."""
    groups = {}
    for path in jsonl_paths:
        for text in pathlib.Path(path).read_text().splitlines():
            run = json.loads(text)
            if run.get("rc") not in (0, None) or "pressure_L2" not in run or run.get("timeout"):
                continue
            label = f"L{run['refine']}" if "refine" in run else f"tol {run['tol']:g}"
            groups.setdefault((run["code"], run["kind"], run["order"], label), []).append(run)
    return groups


def medians(jsonl_paths):
    """{(code, kind, order): [(median wall s, errors dict, configuration label), ...]} of the runs
    in ``jsonl_paths`` (runs without errors or that failed are left out), in the order of refinement."""
    groups = grouped(jsonl_paths)
    series = {}
    for (code, kind, order, label), runs in groups.items():
        errors = {key: runs[0][key] for key, _ in PANELS}
        point = (statistics.median(r["proc_wall_s"] for r in runs), errors, label, len(runs))
        series.setdefault((code, kind, order), []).append(point)
    for points in series.values():              # along the refinement: levels, then tolerances down
        points.sort(key=lambda p: (len(p[2]), p[2]))
    return series


def chart(jsonl_paths, out_png):
    """The three-panel log-log chart (error against median process wall time, s) of the runs in
    ``jsonl_paths`` (a path or a list of paths), written to ``out_png``; returns the path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = [jsonl_paths] if isinstance(jsonl_paths, (str, pathlib.Path)) else list(jsonl_paths)
    if not paths:
        raise ValueError("jsonl_paths: give at least one file of race runs")
    series = medians(paths)
    if not series:
        raise ValueError(f"jsonl_paths: no run with errors in {', '.join(map(str, paths))}")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    markers = {"uniform": "o", "adapt": "s"}
    colours = {"peer": "tab:red", "ngcontact": "tab:blue", "goal-pressure": "tab:green", "goal-force": "tab:purple"}
    styles = {1: ":", 2: "-", 3: "--", 4: "-."}
    for ax, (key, title) in zip(axes, PANELS):
        for (code, kind, order), points in sorted(series.items()):
            good = [(t, e[key]) for t, e, _, _ in points if e[key] is not None and e[key] > 0 and math.isfinite(e[key])]
            if not good:
                continue
            ax.loglog(*zip(*good), marker=markers.get(kind, "^"), linestyle=styles.get(order, "-"),
                      color=colours.get(kind, colours.get(code)), label=f"{code} {kind} P{order}")
        ax.set_xlabel("process wall time (s), median")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative error against the reference")
    axes[0].legend(fontsize=8)
    fig.suptitle("2D Hertz race (d = 0.0171 m): error against the converged reference vs process wall time")
    fig.tight_layout()
    out_png = pathlib.Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=110)
    plt.close(fig)
    return out_png


def table(jsonl_paths):
    """The runs of ``jsonl_paths`` as a markdown table: per configuration the DOFs, the number
    of timed runs, the median process wall and CPU times (s) and the three errors; an adaptive
    run that stopped at a limit before its tolerance is marked "not reached"."""
    paths = [jsonl_paths] if isinstance(jsonl_paths, (str, pathlib.Path)) else list(jsonl_paths)
    groups = grouped(paths)
    lines = ["| code | kind | P | level / tol | DOFs | runs | wall s | CPU s | F error | pressure L2 | a error |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for key in sorted(groups, key=lambda k: (k[0] != "peer", k[1], k[2], len(k[3]), k[3])):
        runs, (code, kind, order, label) = groups[key], key
        first = runs[0]
        label += "" if first.get("reached", True) else " (not reached)"
        cpu = [r["proc_cpu_s"] for r in runs if r.get("proc_cpu_s") is not None]
        lines.append(f"| {code} | {kind} | {order} | {label} | {first.get('ndof')} | {len(runs)} | "
                     f"{statistics.median(r['proc_wall_s'] for r in runs):.1f} | "
                     f"{statistics.median(cpu) if cpu else math.nan:.1f} | {first['force_error']:.1e} | "
                     f"{first['pressure_L2']:.1e} | {first['a_error']:.1e} |")
    return "\n".join(lines)
