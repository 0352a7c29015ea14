"""Command line interface: ``python -m ngcontact demo``.

The demo runs the reference scene: a 2D PZT-5A plate 0 ≤ x ≤ L1, 0 ≤ y ≤ L2 (plane
strain, poled along y), clamped on the left (Γ1), with the grounded electrode on top
(Γa) and the contact side Γ3 at the bottom -- without a contact law yet, so Γ3 is
traction-free and charge-free. A downward pressure on top is ramped up, held (the
Kelvin-Voigt body creeps), then removed (it recovers). Units: SI, forces per metre of
depth.
"""
import argparse
import json
import pathlib
import time as wallclock

import ngsolve as ngs
import numpy as np
from matplotlib import tri
from matplotlib.figure import Figure

from geometries import plate

from .body import Body
from .loads import Loads
from .materials import pzt5a
from .timestepping import Simulation

L1, L2 = 0.1, 0.02
"""Plate length and thickness, m."""
PRESSURE = 1e6
"""Peak pressure on top, Pa."""
RELAXATION_TIME = 2e-3
"""Kelvin-Voigt relaxation time τ of A = τ F, s."""
LOAD_HISTORY = ((0.0, 0.0), (2e-3, 1.0), (12e-3, 1.0), (13e-3, 0.0), (24e-3, 0.0))
"""(time in s, fraction of PRESSURE): ramp, hold, release, recovery; interpolated linearly."""


def load_factor(t, history=LOAD_HISTORY):
    """The piecewise linear ``history`` as a CoefficientFunction of the Parameter ``t``."""
    factor = ngs.CF(history[0][1])
    for (a, fa), (b, fb) in zip(history[:-1], history[1:]):
        if fb != fa:
            ramp = ngs.IfPos(t - b, 1, ngs.IfPos(t - a, (t - a) / (b - a), 0))
            factor = factor + (fb - fa) * ramp
    return factor


def demo(order=2, out="results", maxh=0.005, steps=48):
    """Run the reference scene, print a line per step, write summary.json and two charts.

    Parameters
    ----------
    order : int, polynomial order of u and φ.
    out : str or path, output directory (created).
    maxh : float, mesh size in m.
    steps : int, number of backward Euler steps over LOAD_HISTORY.

    Returns
    -------
    dict, the contents of ``out/summary.json``: the settings, ``ndof``, ``wall_s`` (time
    stepping), ``peak_time`` (the end of the hold, whose state is plotted),
    ``max_potential`` (max |φ| at the vertices over all steps, V), and per time step
    n = 1..steps: ``times`` (s), ``load`` (pressure, Pa), ``newton_iterations``,
    ``tip_deflection`` (u_y at (L1, 0), m), ``tip_potential`` (φ at (L1, 0), V) and
    ``reaction_y`` (∫_Γ1 σν·e_y, N/m).
    """
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps}")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    mesh = plate(L1, L2, maxh=maxh)
    t = ngs.Parameter(0.0)
    pressure = PRESSURE * load_factor(t)
    body = Body(mesh, pzt5a(relaxation_time=RELAXATION_TIME), clamped="left", grounded="top",
                contact="bottom", order=order)
    sim = Simulation(body, Loads(f2={"top": (0, -pressure)}), time=t)
    tip = mesh(L1, 0.0)
    vertices = np.array([v.point for v in mesh.vertices])
    at_vertices = mesh(vertices[:, 0], vertices[:, 1])

    def observe(rec):
        row = dict(times=rec.time, load=pressure(tip), newton_iterations=int(rec.newton_iterations),
                   tip_deflection=sim.u(tip)[1], tip_potential=sim.phi(tip),
                   reaction_y=float(rec.reaction[1]),
                   max_potential=np.abs(sim.phi(at_vertices)).max())
        print(f"{rec.step:5d} {rec.time * 1e3:9.3f} {row['newton_iterations']:6d} "
              f"{row['tip_deflection']:+14.6e} {row['tip_potential']:+12.4e} "
              f"{row['reaction_y']:+12.5e}", flush=True)
        return row

    print(f"{body}\n{'step':>5} {'t [ms]':>9} {'newton':>6} {'tip u_y [m]':>14} "
          f"{'tip phi [V]':>12} {'R_y [N/m]':>12}")
    start = wallclock.perf_counter()
    with ngs.TaskManager():
        rows = [observe(sim.history[0])]
        for _ in range(steps):
            rows.append(observe(sim.step(LOAD_HISTORY[-1][0] / steps)))
    wall = wallclock.perf_counter() - start
    columns = {key: [row[key] for row in rows] for key in rows[0]}
    max_potential = max(columns.pop("max_potential"))
    load = np.array(columns["load"])
    peak = int(np.flatnonzero(np.isclose(load, load.max(), rtol=1e-9))[-1])
    _plot_history(out / "tip_deflection.png", columns)
    _plot_potential(out / "potential_at_peak.png", mesh, sim.state(peak), columns["times"][peak])
    summary = dict(order=order, maxh=maxh, ndof=body.ndof, L1=L1, L2=L2, pressure=PRESSURE,
                   relaxation_time=RELAXATION_TIME, time_steps=steps, wall_s=wall,
                   peak_time=columns["times"][peak], max_potential=max_potential,
                   **{key: values[1:] for key, values in columns.items()})
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(f"{steps} steps, ndof {body.ndof}, wall {wall:.2f} s; results in {out}")
    return summary


def _plot_history(path, columns):
    """Tip deflection over time, with the applied pressure on a twin axis."""
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    ms = 1e3 * np.array(columns["times"])
    ax.plot(ms, 1e3 * np.array(columns["tip_deflection"]), "o-", color="C0", ms=3)
    ax.set(xlabel="time t [ms]", ylabel="tip deflection $u_y(L_1, 0)$ [mm]",
           title=f"PZT-5A plate, Kelvin-Voigt τ = {RELAXATION_TIME * 1e3:g} ms: creep and recovery")
    ax.yaxis.label.set_color("C0")
    twin = ax.twinx()
    twin.plot(ms, 1e-6 * np.array(columns["load"]), "--", color="C3")
    twin.set_ylabel("pressure on top [MPa]", color="C3")
    fig.savefig(path, dpi=120)


def _plot_potential(path, mesh, state, time):
    """The deformed plate (displacement magnified) coloured by the potential φ."""
    xy = np.array([v.point for v in mesh.vertices])
    cells = [[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)]
    coarse = tri.Triangulation(xy[:, 0], xy[:, 1], cells)
    fine = tri.UniformTriRefiner(coarse).refine_triangulation(subdiv=2)
    points = mesh(fine.x, fine.y)
    u, phi = (gf(points) for gf in state.components)
    scale = 0.1 * L1 / np.abs(u).max()
    fig = Figure(figsize=(8, 2.8), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0, L1, L1, 0, 0], [0, 0, L2, L2, 0], "k--", lw=0.8)
    shown = ax.tripcolor(fine.x + scale * u[:, 0], fine.y + scale * u[:, 1], fine.triangles,
                         phi[:, 0], shading="gouraud", cmap="viridis")
    fig.colorbar(shown, ax=ax, shrink=0.8, label="potential φ [V]")
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
           title=f"t = {time * 1e3:.3g} ms, end of the hold: displacement × {scale:.3g}, "
                 "dashed: undeformed")
    fig.savefig(path, dpi=120)


def main(argv=None):
    """Entry point of ``python -m ngcontact`` and of the ``ngcontact`` script."""
    parser = argparse.ArgumentParser(prog="ngcontact", description="ngcontact: a piezoelectric "
                                     "Kelvin-Voigt body on NGSolve")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("demo", help="the PZT-5A plate: ramp, hold (creep), release")
    run.add_argument("--order", metavar="P", type=int, default=2,
                     help="polynomial order of u and φ (default 2)")
    run.add_argument("--out", metavar="DIR", default="results",
                     help="output directory (default results)")
    run.add_argument("--maxh", metavar="H", type=float, default=0.005,
                     help="mesh size in m (default 0.005)")
    run.add_argument("--steps", metavar="N", type=int, default=48,
                     help="number of time steps (default 48)")
    args = parser.parse_args(argv)
    demo(order=args.order, out=args.out, maxh=args.maxh, steps=args.steps)
