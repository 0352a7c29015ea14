#!/usr/bin/env python3
"""The chart of docs/adaptivity.md, "Against a uniform-mesh code: time to a pressure error",
drawn from the data stored beside it (``race_hertz.csv``), so that it can be drawn again
without the peer.

The CSV holds two kinds of rows:

* ``kind`` "timed": the runs of the race (main 21ab644, DOLFINx 0.11.0.post0, five interleaved
  rounds, one thread each; the table of docs/adaptivity.md): the peer on its uniform meshes and
  ``adapt.solve(scene, mesh, tol)`` for four tolerances, with their DOFs, pressure error and the
  wall time of the whole process (imports included) over the rounds: least, median, largest.
* ``kind`` "level": every level of ngcontact's adaptive run to tol 0.002, its DOFs and pressure
  error (no time: the race kept none per level), written by ``--levels`` with this checkout (the
  levels are bitwise reproducible; they match the race's rows at 6 927, 16 002, 25 464 and
  39 210 DOFs).

    python docs/adaptivity/race_hertz.py [--levels]
"""
import argparse
import csv
import pathlib

HERE = pathlib.Path(__file__).parent
COLUMNS = ("kind", "code", "run", "dofs", "pressure_error", "wall_min_s", "wall_median_s", "wall_max_s", "rounds",
           "tol", "certified")
MARKERS = {"P1": "s", "P2": "o", "P3": "^"}


def levels():
    """The "level" rows: ngcontact's adaptive P2 run on the race's scene (the half-disk, the top
    moved down by d = 0.0171 R, ``adapt.solve`` with its defaults from ``hertz.mesh(2,
    h_contact=0.1, curve=2)``) to tol 0.002, its pressure error level by level."""
    from ngcontact import adapt
    from ngcontact.scenes import hertz
    result = adapt.solve(lambda mesh: hertz.simulation(2, mesh=mesh, depth=0.0171, keep_states=False),
                         hertz.mesh(2, h_contact=0.1, curve=2), 0.002)
    return [dict(kind="level", code="ngcontact", run=f"adapt.solve level {k}", dofs=level.ndof,
                 pressure_error=hertz.errors(level.sim)["pressure_L2"], tol="", certified=level.certified)
            for k, level in enumerate(result.levels)]


def read(path=HERE / "race_hertz.csv"):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def chart(rows, path=HERE / "race_hertz.png"):
    """Left: pressure error against the process's wall time, the least of the rounds (the bar
    reaches the largest); right: pressure error against DOFs, with every adaptive level."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=(12.5, 5.6), layout="constrained")
    by_time, by_dofs = fig.subplots(1, 2, sharey=True)
    timed = [r for r in rows if r["kind"] == "timed"]
    for ax, x in ((by_time, "wall_min_s"), (by_dofs, "dofs")):
        for order, marker in MARKERS.items():
            runs = sorted((r for r in timed if r["code"] == "peer" and r["run"].startswith(order)),
                          key=lambda r: float(r[x]))
            ax.plot([float(r[x]) for r in runs], [100 * float(r["pressure_error"]) for r in runs], marker + "-",
                    color="C0", alpha=0.5 + 0.25 * "123".index(order[1]), label=f"FEniCSx peer, uniform {order}")
        ours = sorted((r for r in timed if r["code"] == "ngcontact"), key=lambda r: float(r["tol"]), reverse=True)
        ax.plot([float(r[x]) for r in ours], [100 * float(r["pressure_error"]) for r in ours], "D", color="C3",
                label="ngcontact adapt.solve, certified: the energy estimate ≤ tol "
                      f"({', '.join(r['tol'] for r in ours)})")
        for level in (3.0, 1.5):
            ax.axhline(level, color="grey", ls=":", lw=0.8,
                       label="3 % and 1.5 %: the errors of the table below the chart" if level == 3.0 else None)
    for r in timed:                                   # the spread of the rounds
        by_time.plot([float(r["wall_min_s"]), float(r["wall_max_s"])], [100 * float(r["pressure_error"])] * 2,
                     "-", color="C3" if r["code"] == "ngcontact" else "C0", lw=0.8, alpha=0.6)
    for r in timed:                                   # each point by what it plots
        dofs = f"{int(r['dofs']):,}".replace(",", " ")
        by_time.annotate(f"{100 * float(r['pressure_error']):.2f} %, {dofs} DOFs",
                         (float(r["wall_min_s"]), 100 * float(r["pressure_error"])), textcoords="offset points",
                         xytext=(5, 3), fontsize=6.5)
    steps = [r for r in rows if r["kind"] == "level"]
    by_dofs.plot([int(r["dofs"]) for r in steps], [100 * float(r["pressure_error"]) for r in steps], ".-",
                 color="C1", lw=1, label="ngcontact adapt.solve to tol 0.002, every level (certified or not)")
    rounds = {r["rounds"] for r in timed}
    by_time.set(xscale="log", yscale="log", ylabel="pressure error ‖λ_h − p_Hertz‖ / ‖p_Hertz‖ [%]",
                xlabel=f"wall time of the process, imports included [s]: least of {'/'.join(rounds)} rounds "
                       "(bar: to the largest)",
                title="against time (the race's runs; labels: error, DOFs)")
    by_dofs.set(xscale="log", xlabel="DOFs", title="against DOFs (with every adaptive level)")
    for ax in (by_time, by_dofs):
        ax.grid(True, which="both", lw=0.3)
    handles, labels = by_dofs.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=8)
    fig.suptitle("2D Hertz, displacement control d = 0.0171 R: pressure error")
    fig.savefig(path, dpi=110)
    return fig


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", action="store_true", help="recompute the adaptive levels' rows (seconds)")
    args = parser.parse_args()
    rows = read()
    if args.levels:
        rows = [r for r in rows if r["kind"] != "level"] + levels()
        with open(HERE / "race_hertz.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
    chart(rows)
