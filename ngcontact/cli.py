"""Command line interface: ``python -m ngcontact demo | convergence | stability | bench``."""
import argparse
import json
import pathlib
import time as wallclock
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np
from matplotlib import tri
from matplotlib.figure import Figure

from . import scene
from .bench import THREADS_FROM
from .scene import CONTACT, L1, L2, LOAD_HISTORY, PRESSURE, RELAXATION_TIME
from .timestepping import Simulation


def demo(order=1, out="results", maxh=0.005, steps=200, theta=1, gamma0=10.0):
    """Run the reference scene (``scene``), print a line per step, write summary.json and charts.

    Parameters
    ----------
    order : int, polynomial order of u and φ (1 = the paper's P1 scheme).
    out : str or path, output directory (created).
    maxh : float, mesh size in m (halved along Γ3).
    steps : int, number of backward Euler steps over LOAD_HISTORY (k γ_ν L² = 0.625 at 200).
    theta, gamma0 : Nitsche variant and parameter.

    Returns
    -------
    dict, the contents of ``out/summary.json``: settings, ``ndof``, ``time_steps``,
    ``wall_s`` (time stepping), ``max_penetration`` (m), final ``beta_min``/``beta_max``,
    and per step n = 1..steps: ``times``, ``load`` (Pa), ``newton_iterations``,
    ``contact_length`` (m), ``max_pressure`` (Pa), ``current`` (C/m), ``tip_deflection``
    (u_y at (L1, 0), m), ``reaction_y`` and ``contact_force_y`` (N/m).
    """
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps}")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t = ngs.Parameter(0.0)
    pressure = scene.pressure(t)
    body = scene.body(order, maxh)
    mesh = body.mesh
    sim = Simulation(body, scene.loads(t), time=t, contact=scene.contact(theta, gamma0))
    tip = mesh(L1, 0.0)
    print(f"{body}, solver {sim.inverse}\n{'step':>5} {'t [s]':>7} {'newton':>6} "
          f"{'contact [mm]':>12} {'p_max [MPa]':>11} {'beta_min':>8} {'current [C/m]':>13}")
    rows = []
    start = wallclock.perf_counter()
    with ngs.TaskManager() if body.ndof >= THREADS_FROM else nullcontext():
        for _ in range(steps):
            rec = sim.step(LOAD_HISTORY[-1][0] / steps)
            c = rec.contact
            rows.append(dict(times=rec.time, load=pressure(tip), newton_iterations=int(rec.newton_iterations),
                             contact_length=c.contact_length, max_pressure=max(c.pressure.max(), 0.0),
                             current=c.current, tip_deflection=sim.u(tip)[1],
                             reaction_y=float(rec.reaction[1]), contact_force_y=float(c.force[1]),
                             max_penetration=c.max_penetration))
            print(f"{rec.step:5d} {rec.time:7.4f} {rec.newton_iterations:6d} {1e3 * c.contact_length:12.3f} "
                  f"{1e-6 * rows[-1]['max_pressure']:11.3f} {c.beta.min():8.4f} {c.current:+13.4e}",
                  flush=True)
    wall = wallclock.perf_counter() - start
    columns = {key: [row[key] for row in rows] for key in rows[0]}
    max_penetration = max(columns.pop("max_penetration"))
    history = sim.history
    peak = 1 + int(np.argmax(columns["contact_length"]))
    _plot_overview(out / "history.png", columns, history)
    _plot_gamma3(out / "beta.png", out / "pressure.png", sim, history)
    _plot_potential(out / "potential_at_peak.png", mesh, sim.state(peak), history[peak].time)
    summary = dict(order=order, maxh=maxh, ndof=body.ndof, L1=L1, L2=L2, pressure=PRESSURE,
                   relaxation_time=RELAXATION_TIME, contact=CONTACT, theta=theta, gamma0=gamma0,
                   time_steps=steps, wall_s=wall, max_penetration=max_penetration,
                   beta_min=float(history[-1].contact.beta.min()),
                   beta_max=float(history[-1].contact.beta.max()), **columns)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(f"{steps} steps, ndof {body.ndof}, {sum(columns['newton_iterations'])} Newton iterations, "
          f"wall {wall:.2f} s; results in {out}")
    return summary


def _plot_overview(path, columns, history):
    """Load, contact length, min β and tip deflection over time."""
    fig = Figure(figsize=(8, 6), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    time = np.array(columns["times"])
    axes[0].plot(time, 1e-6 * np.array(columns["load"]), color="C3")
    axes[0].set_ylabel("pressure on top [MPa]")
    axes[1].plot(time, 1e3 * np.array(columns["contact_length"]), color="C0", label="contact length [mm]")
    axes[1].plot(time, 1e6 * np.array(columns["tip_deflection"]), color="C2", label="tip u_y [µm]")
    axes[1].legend()
    axes[2].plot(time, history.contact_column("beta")[1:].min(axis=1), color="C1", label="min β")
    axes[2].plot(time, history.contact_column("beta")[1:].mean(axis=1), "--", color="C1", label="mean β")
    axes[2].set(xlabel="time t [s]", ylabel="bonding field β", ylim=(-0.05, 1.05))
    axes[2].legend()
    axes[0].set_title("push: contact zone grows; pull: contact opens, glue debonds, plate lifts off")
    fig.savefig(path, dpi=120)


def _plot_gamma3(beta_path, pressure_path, sim, history):
    """β along Γ3 over time (x-t map), and the contact pressure along Γ3 at several times."""
    order = np.argsort(sim.side.midpoints[:, 0])
    x = 1e3 * sim.side.midpoints[order, 0]
    times = history.times
    beta = history.contact_column("beta")[:, order]
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    shown = ax.pcolormesh(x, times, beta, shading="nearest", cmap="magma", vmin=0, vmax=1)
    fig.colorbar(shown, ax=ax, label="bonding field β")
    ax.set(xlabel="x along Γ3 [mm]", ylabel="time t [s]", title="β on Γ3: debonding from the free end")
    fig.savefig(beta_path, dpi=120)
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    pressure = history.contact_column("pressure")[:, order]
    for n in np.linspace(1, len(history) - 1, 9).astype(int):
        ax.step(x, 1e-6 * pressure[n], where="mid", label=f"t = {times[n]:.3f} s")
    ax.set(xlabel="x along Γ3 [mm]", ylabel="normal pressure −σ_ν [MPa]",
           title="contact pressure along Γ3 (negative: glue in tension)")
    ax.legend(fontsize=7, ncol=3)
    fig.savefig(pressure_path, dpi=120)


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
           title=f"t = {time:.3g} s, largest contact zone: displacement × {scale:.3g}, "
                 "dashed: undeformed")
    fig.savefig(path, dpi=120)


def main(argv=None):
    """Entry point of ``python -m ngcontact`` and of the ``ngcontact`` script."""
    parser = argparse.ArgumentParser(prog="ngcontact", description="ngcontact: a piezoelectric "
                                     "Kelvin-Voigt body on NGSolve")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("demo", help="the PZT-5A plate pressed onto a glued conductive "
                              "foundation, then pulled off")
    run.add_argument("--order", metavar="P", type=int, default=1,
                     help="polynomial order of u and φ (default 1, the paper's P1)")
    run.add_argument("--out", metavar="DIR", default="results",
                     help="output directory (default results)")
    run.add_argument("--maxh", metavar="H", type=float, default=0.005,
                     help="mesh size in m (default 0.005)")
    run.add_argument("--steps", metavar="N", type=int, default=200,
                     help="number of time steps (default 200)")
    run.add_argument("--theta", type=int, default=1, choices=(1, 0, -1), help="Nitsche variant")
    run.add_argument("--gamma0", type=float, default=10.0, help="Nitsche parameter γ0 (default 10)")
    conv = commands.add_parser("convergence", help="order-convergence study against (4.12): "
                               "errors.csv and charts")
    conv.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1, 2],
                      help="polynomial orders (default 1 2)")
    conv.add_argument("--levels", metavar="N", type=int, default=3,
                      help="number of nested meshes, h halving (default 3)")
    conv.add_argument("--case", choices=("viscous", "adhesive", "reference"), default="viscous",
                      help="manufactured solution (viscous: time-dependent contact with "
                           "conduction; adhesive: compliant layer and glue) or the reference "
                           "scene against a fine solution (default viscous)")
    conv.add_argument("--smoothness", metavar="K", type=int, default=4,
                      help="manufactured cases: u ~ (x - x_c)_+^K at the contact-set ends (default 4)")
    conv.add_argument("--dt-halvings", metavar="J", type=int, default=0,
                      help="time-step variant: halve k J times on the finest mesh, first order given")
    conv.add_argument("--out", metavar="DIR", default="convergence", help="output directory")
    stab = commands.add_parser("stability", help="stability maps (Nitsche γ0 × θ, penalty, β time "
                               "step, ν → 1/2, strong coupling, debonding, load cycles): "
                               "<study>.csv and charts")
    stab.add_argument("--out", metavar="DIR", default="stability", help="output directory")
    stab.add_argument("--quick", action="store_true", help="fewer runs per study (about a third)")
    bench = commands.add_parser("bench", help="time per step of the reference scene against one "
                                "linear solve, orders x sizes: bench.csv and a chart")
    bench.add_argument("--out", metavar="DIR", default="bench", help="output directory")
    bench.add_argument("--dim", type=int, choices=(2, 3), default=2, help="2D plate or 3D block")
    bench.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1, 2, 3, 4])
    bench.add_argument("--max-ndof", metavar="N", type=float, default=1e6,
                       help="largest problem size (default 1e6)")
    bench.add_argument("--steps", metavar="N", type=int, default=10,
                       help="time steps per case (default 10: first contact and its spreading)")
    bench.add_argument("--dt", metavar="K", type=float, default=2.5e-3, help="time step, s")
    bench.add_argument("--inverse", choices=("umfpack", "pardiso", "sparsecholesky"),
                       help="direct solver (default: sparsecholesky if symmetric, else umfpack)")
    bench.add_argument("--realcompile", choices=("auto", "yes", "no"), default="auto",
                       help="compile the Γ3 integrand to machine code (auto: ndof >= 50 000 in 2D, 2 000 in 3D)")
    bench.add_argument("--predictor", action="store_true",
                       help="start Newton from the linear extrapolation (default: from x_n)")
    bench.add_argument("--threads", choices=("auto", "yes", "no"), default="auto",
                       help="run under TaskManager (auto: from 30 000 DOFs)")
    bench.add_argument("--bare", action="store_true",
                       help="no glue, insulating foundation: symmetric Jacobian (θ = 1)")
    bench.add_argument("--merge", metavar="DIR", nargs="+",
                       help="join the tables of earlier runs into --out instead of running")
    args = parser.parse_args(argv)
    if args.command == "bench" and args.merge:
        from . import bench as study
        exponents = study.merge(args.merge, args.out)
        print("time per step ~ ndof^a: " + ", ".join(f"P{p}: a = {a:.2f}" for p, a in exponents.items()))
    elif args.command == "bench":
        from . import bench as study
        study.run(args.out, orders=args.orders, dim=args.dim, max_ndof=args.max_ndof, steps=args.steps,
                  dt=args.dt, inverse=args.inverse, predictor=args.predictor,
                  realcompile=dict(auto=None, yes=True, no=False)[args.realcompile],
                  threads=dict(auto=None, yes=True, no=False)[args.threads], bare=args.bare)
    elif args.command == "demo":
        demo(order=args.order, out=args.out, maxh=args.maxh, steps=args.steps, theta=args.theta,
             gamma0=args.gamma0)
    elif args.command == "stability":
        stability(args.out, args.quick)
    else:
        convergence(args.orders, args.levels, args.case, args.smoothness, args.dt_halvings, args.out)


def convergence(orders, levels, case, smoothness, dt_halvings, out):
    """The ``convergence`` command: run the study, write errors.csv and the charts."""
    from . import convergence as study
    out = pathlib.Path(out)
    if dt_halvings:
        runs = study.time_study(orders[0], levels - 1, dt_halvings, smoothness=smoothness)
        paths = study.save(runs, out, f"time steps, P{orders[0]}, level {levels - 1}", by="k")
        print(f"fitted rate in k: {study.fitted_rate(runs, orders[0], by='k'):.2f}")
    else:
        runs = (study.reference_study(orders, levels) if case == "reference" else
                study.manufactured_study(orders, levels, case, smoothness=smoothness))
        paths = study.save(runs, out, f"{case}: error (4.12) and its parts")
        for order in orders:
            rates = {p: study.fitted_rate(runs, order, p) for p in ("u", "phi", "total")}
            print(f"P{order}: fitted rates " + ", ".join(f"{p} {r:.2f}" for p, r in rates.items()))
    print(f"wrote {out / 'errors.csv'} and " + ", ".join(p.name for p in paths))


def stability(out, quick=False):
    """The ``stability`` command: run every study of ``ngcontact.stability``, write
    <study>.csv and the charts to ``out`` and print a short table per study."""
    from . import stability as study
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    start = wallclock.perf_counter()
    for name, run in study.STUDIES.items():
        if name == "penalty_sweep" and not study.penalty_available():
            print("\npenalty_sweep: skipped, Contact has no method='penalty'")
            continue
        print(f"\n{name}", flush=True)
        began = wallclock.perf_counter()
        rows = run(out, quick=quick)
        study.write_csv(rows, out / f"{name}.csv")
        print(f"{study.summary(name, rows)}\n({wallclock.perf_counter() - began:.1f} s)", flush=True)
    print(f"\nwall {wallclock.perf_counter() - start:.1f} s; results in {out}")
