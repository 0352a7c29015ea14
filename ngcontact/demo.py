"""The demo: the reference scene run through its whole load history, a progress bar and about
``LINES`` lines of the steps, then summary.json (every step) and charts
(``python -m ngcontact demo``)."""
import json
import shutil
import sys
import time as wallclock
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np
from matplotlib import ticker, tri
from matplotlib.figure import Figure

from ngcontact import checks, parallel
from ngcontact.output import results, run_directory
from ngcontact.output.progress import write
from ngcontact.scenes import reference
from ngcontact.studies.bench import THREADS_FROM

LINES = 20
"""About this many lines of steps print: one each time the time passes a multiple of T/LINES."""
CHARGE_NOISE = 1e-9
"""A charge flux within this fraction of the largest charge the run has held up to the step
(its electrode charges and Γ3's flux) is round-off of the residual (±1e-23 C/m after lift-off,
against 3e-5 C/m in contact) and prints as 0."""


def noise_floor(record, largest=0.0):
    """The noise floor of a step's charges (C; C/m in 2D): ``CHARGE_NOISE`` × the largest of
    ``largest`` (the run's so far) and the step's |electrode charges| and |Γ3's charge flux|."""
    charges = [abs(q) for q in record.electrode_charge.values()]
    if record.contact is not None:
        charges.append(abs(record.contact.charge_flux))
    return CHARGE_NOISE * max([largest, *charges])


def shown(value, floor, width, form):
    """``value`` formatted as ``form`` in ``width`` columns, or 0 where |value| <= floor."""
    return f"{'0':>{width}}" if abs(value) <= floor else format(value, form).rjust(width)


def header(dim):
    """The column titles of the line per step (2D: per metre of depth)."""
    contact, flux = ("contact [mm]", "charge flux [C/m]") if dim == 2 else ("contact [mm²]", "charge flux [C]")
    return (f"{'step':>5} {'t [s]':>7} {'newton':>6} {contact:>13} {'p_max [MPa]':>11} "
            f"{'beta_min':>8} {flux:>17}")


def run(order=1, out="results", maxh=None, steps=200, theta=1, gamma0=10.0, resume=False, dim=2, refine=0,
        scheme="backward_euler", rtol=None, progress=None, switch_loop=True):
    """Run the reference scene (``scenes.reference``) over its load history in ``steps``
    time steps, print about ``LINES`` lines of them (charge fluxes below the step's
    ``noise_floor`` as 0), write summary.json and charts into ``out``. Every
    step is streamed into ``out/run`` as it is computed (``ngcontact.output.results``; under mpiexec
    each rank writes its part), with these settings in ``out/run/demo.json``; ``resume``
    continues a run interrupted there instead of starting again: other settings, and another
    number of MPI ranks, are refused before meshing, naming them, and ``Simulation.resume``
    checks the scene itself.

    Parameters
    ----------
    order : int in [1, 10], polynomial order of u and φ (1 = the paper's P1 scheme).
    out : str or path, output directory (created).
    maxh : float in (0, 0.02], mesh size in m (2D: halved along Γ3; default 0.005 in 2D, 0.01
        in 3D); with ``refine`` and ``order`` the problem must fit in the machine's memory
        (``checks.fits_in_memory``).
    steps : int in [1, 10⁶], number of time steps over the load history
        (``scenes.reference.LOAD_HISTORY``; dt γ_ν L² per step: docs/stability.md).
    theta, gamma0 : Nitsche variant and parameter.
    dim : 2 (the plate, plane strain) or 3 (the block L1 × WIDTH × L2).
    refine : int in [0, 10], times the mesh is refined (nested meshes: on large 3D meshes the Newton
        corrections are solved by GMRES with multigrid, ``solver_choice``).
    scheme : the time scheme ("backward_euler", the paper's; "bdf2").
    rtol : steps chosen by this error target (``Simulation.run``; needs "bdf2"), the first of
        length (the history's end) / ``steps``; the chart history.png shows the steps taken.
    progress : a progress bar of the steps on stderr (default: when stderr is a terminal).
    switch_loop : Newton's corrections with the Signorini switch settled in an inner loop
        (``Simulation(switch_loop=...)``; one process only: a run under mpiexec has plain
        corrections, which ``False`` gives serially).

    Returns
    -------
    dict, the contents of ``out/summary.json``: settings, ``ndof``, ``steps``, ``wall_s``
    (time stepping, s), ``max_penetration`` (m), final ``beta_min``/``beta_max``, and per
    computed step (cut-back steps included): ``times`` (s), ``load`` (Pa), ``newton_iterations``,
    ``contact_length`` (m; the contact area in 3D, m²), ``max_pressure`` (Pa), ``charge_flux``
    (∫_Γ3 D·ν, C/m; C in 3D), ``tip_deflection`` (the vertical displacement at the middle of
    the free end of Γ3, m), ``reaction_y`` and ``contact_force_y`` (vertical components, N/m;
    N in 3D).
    """
    dim = checks.choice("dim", dim, (2, 3))
    order, steps = checks.order("order", order), checks.integer("steps", steps, 1, checks.MAX_STEPS)
    refine, resume = checks.integer("refine", refine, 0, checks.MAX_REFINE), checks.flag("resume", resume)
    progress = sys.stderr.isatty() if progress is None else checks.flag("progress", progress)
    maxh = (0.005 if dim == 2 else 0.01) if maxh is None else \
        checks.number("maxh", maxh, 0, reference.L2, low_open=True, unit="m (the plate's thickness L2)")
    contact = reference.contact(theta, gamma0)       # θ and γ0 checked before the mesh is made
    sides = (reference.L1, reference.L2) if dim == 2 else (reference.L1, reference.WIDTH, reference.L2)
    checks.fits_in_memory(f"maxh = {maxh:g} m, refine = {refine}, order = {order}",
                          checks.estimated_ndof(checks.estimated_vertices(sides, maxh), dim, refine, order))
    out = checks.writable_directory(out)
    settings = dict(order=order, maxh=maxh, dim=dim, refine=refine, steps=steps, theta=theta, gamma0=gamma0)
    switch_loop = checks.flag("switch_loop", switch_loop)
    if scheme != "backward_euler" or rtol is not None:     # (demo.json of earlier runs have neither)
        settings.update(scheme=scheme, rtol=rtol)
    if not switch_loop:
        settings.update(switch_loop=False)
    if resume:                                       # before meshing
        _check_resumable(out / "run", dict(settings, scheme=scheme, rtol=rtol, switch_loop=switch_loop))
    lead = parallel.rank() == 0                      # under mpiexec rank 0 prints and writes
    say = print if lead else _quiet
    sim = reference.simulation(order, maxh, refine, dim, contact=contact, keep_states=dim == 2, scheme=scheme,
                               switch_loop=switch_loop)
    body, mesh = sim.body, sim.body.mesh
    distributed = parallel.is_distributed(mesh)
    tip = [(reference.L1, 0.0) if dim == 2 else (reference.L1, reference.WIDTH / 2, 0.0)]
    deflection = {}                                  # step -> vertical displacement at the tip
    T = reference.LOAD_HISTORY[-1][0]
    say(f"{body}, solver {sim.solver}" + "".join(f"\n{note}" for note in sim.parallel_notes)
        + f"\na line each {T / LINES:g} s of the load history (all steps in summary.json; charge fluxes within "
        f"{CHARGE_NOISE:g} of the largest charge so far print as 0)\n{header(dim)}")
    if resume:
        sim.resume(out / "run")
        say(f"resumed at step {len(sim.history) - 1}, t = {sim.t:.4f} s")
    else:
        if lead:
            if (out / "run").exists():
                shutil.rmtree(out / "run")           # a new run replaces the old one
            (out / "run").mkdir()
            (out / "run" / "demo.json").write_text(json.dumps(settings, indent=1))
        parallel.barrier(mesh)

    area = 1e3 if dim == 2 else 1e6                  # m -> mm, m² -> mm²
    printed = dict(next=sim.t + T / LINES, largest=0.0)

    def report(rec):
        c = rec.contact
        deflection[rec.step] = parallel.point_values(mesh, sim.u, tip)[0, dim - 1]
        floor = noise_floor(rec, printed["largest"])
        printed["largest"] = floor / CHARGE_NOISE
        if lead and (rec.time >= printed["next"] - 1e-9 * T or rec.time >= T * (1 - 1e-12)):
            printed["next"] = T / LINES * (np.floor(rec.time / (T / LINES) + 1e-6) + 1)
            write(f"{rec.step:5d} {rec.time:7.4f} {rec.newton_iterations:6d} {area * c.contact_area:13.3f} "
                  f"{1e-6 * max(c.pressure.max(), 0.0):11.3f} {c.beta.min():8.4f} "
                  f"{shown(c.charge_flux, floor, 17, '+.4e')}")
    start = wallclock.perf_counter()
    complete = resume and results.complete(run_directory.run_info(out / "run"), sim.t)
    if complete:                                     # killed after its last step: its summary from the steps
        say(f"the run in {str(out / 'run')!r} is already complete: it reached T = {T:g} s at step "
            f"{len(sim.history) - 1}; nothing is left to compute, the summary and charts are written from its "
            "steps (run without --resume to compute it again)")
    with ngs.TaskManager() if body.ndof >= THREADS_FROM else nullcontext():
        history = sim.history if complete else sim.run(T / steps, T, on_step=report, out=out / "run", rtol=rtol,
                                                       progress=bool(progress and lead))
    wall = wallclock.perf_counter() - start
    for n in range(1, len(history)):                 # steps of a resumed run: from their kept states
        if n not in deflection and sim.keep_states:
            deflection[n] = parallel.point_values(mesh, sim.state(n).components[0], tip)[0, dim - 1]
    rows = [_row(rec, deflection.get(n, np.nan)) for n, rec in enumerate(history) if n > 0]
    columns = {key: [row[key] for row in rows] for key in rows[0]}
    max_penetration = max(columns.pop("max_penetration"))
    peak = 1 + int(np.argmax(columns["contact_length"]))
    midpoints = parallel.gather(mesh, sim.side.midpoints)        # in the order of the records' facets
    if lead:
        _plot_overview(out / "history.png", columns, history)
        _plot_gamma3(out / "beta.png", out / "pressure.png", midpoints, history)
    if dim == 2 and not distributed:
        _plot_potential(out / "potential_at_peak.png", mesh, sim.state(peak), history[peak].time)
    summary = dict(order=order, maxh=maxh, dim=dim, refine=refine, ndof=body.ndof, solver=sim.solver,
                   ranks=parallel.sum(mesh, 1) if distributed else 1, L1=reference.L1, L2=reference.L2,
                   pressure=reference.PRESSURE, relaxation_time=reference.RELAXATION_TIME,
                   contact=reference.CONTACT, theta=theta, gamma0=gamma0, steps=steps, wall_s=wall,
                   max_penetration=max_penetration, beta_min=float(history[-1].contact.beta.min()),
                   beta_max=float(history[-1].contact.beta.max()), **columns)
    if lead:
        (out / "summary.json").write_text(json.dumps(summary, indent=1))
    say(f"{len(rows)} steps, ndof {body.ndof}, {sum(columns['newton_iterations'])} Newton iterations, "
          f"wall {wall:.2f} s; results in {out}")
    return summary


def _check_resumable(directory, settings):
    """Raise unless ``directory`` holds a demo run to continue with these ``settings`` (its
    ``demo.json``) on as many MPI ranks as it was written by (``Simulation.resume`` then checks
    the scene itself)."""
    if not (directory / "run.json").exists():
        raise ValueError(f"resume: {str(directory)!r} holds no run to continue; run without --resume")
    run_directory.check_ranks(run_directory.run_info(directory), parallel.size(), directory, "resume")
    try:
        stored = json.loads((directory / "demo.json").read_text())
    except (OSError, ValueError):
        stored = {}                                  # none or unreadable: resume's scene check decides
    if stored:                                       # a demo.json names scheme and rtol where not the defaults
        stored = dict(dict(scheme="backward_euler", rtol=None, switch_loop=True), **stored)
    changed = [key for key in settings if key in stored and stored[key] != settings[key]]
    if changed:
        def given(key, value):
            if key == "switch_loop":
                return "no --no-switch-loop" if value else "--no-switch-loop"
            return f"no --{key}" if value is None else f"--{key} {value}"
        raise ValueError(f"resume: {str(directory)!r} holds a demo run with "
                         + ", ".join(given(key, stored[key]) for key in changed) + "; this one has "
                         + ", ".join(given(key, settings[key]) for key in changed)
                         + ": resume with the settings of the interrupted run, or run without --resume")


def _row(rec, deflection):
    """The summary's values of a step: its record, and the tip's vertical ``deflection`` (m)."""
    c = rec.contact
    vertical = len(rec.reaction) - 1
    load = reference.PRESSURE * float(np.interp(rec.time, *zip(*reference.LOAD_HISTORY)))
    return dict(times=rec.time, dt=np.nan if rec.dt is None else rec.dt, load=load, newton_iterations=int(rec.newton_iterations),
                contact_length=c.contact_area, max_pressure=max(c.pressure.max(), 0.0),
                charge_flux=c.charge_flux, tip_deflection=float(deflection),
                reaction_y=float(rec.reaction[vertical]), contact_force_y=float(c.force[vertical]),
                max_penetration=c.max_penetration)


def _plot_overview(path, columns, history):
    """Load, contact length, tip deflection, min and mean β over time, one quantity per panel;
    and the time steps k where they vary (chosen by the error control, or cut back): a run of
    fixed steps (k varying by round-off only, ``steps_vary``) names its k in the title."""
    time = np.array(columns["times"])
    dt = np.array(columns["dt"], dtype=float)
    varies = steps_vary(dt)
    fig = Figure(figsize=(8, 9.6 if varies else 8.4), layout="constrained")
    axes = fig.subplots(5 if varies else 4, 1, sharex=True, height_ratios=(1, 1, 1, 1, 0.8)[:5 if varies else 4])
    axes[0].plot(time, 1e-6 * np.array(columns["load"]), color="C3")
    axes[0].set_ylabel("pressure on top [MPa]")
    area, unit = (1e3, "contact length [mm]") if len(history[0].reaction) == 2 else (1e6, "contact area [mm²]")
    axes[1].plot(time, area * np.array(columns["contact_length"]), color="C0")
    axes[1].set_ylabel(unit)
    axes[2].plot(time, 1e6 * np.array(columns["tip_deflection"]), color="C2")
    axes[2].axhline(0.0, color="k", linewidth=0.5)
    axes[2].set_ylabel("tip displacement,\nvertical [µm]")
    beta = history.contact_column("beta")[1:]
    axes[3].plot(time, beta.min(axis=1), color="C1", label="min β")
    axes[3].plot(time, beta.mean(axis=1), "--", color="C1", label="mean β")
    axes[3].set(ylabel="bonding field β [–]", ylim=(-0.05, 1.05))
    axes[3].legend()
    title = "push: contact zone grows; pull: contact opens, glue debonds, plate lifts off"
    if varies:
        k = axes[4]
        finite = dt[np.isfinite(dt)]
        if finite.max() >= 10 * finite.min():
            k.semilogy(time, dt, ".-", color="C4", markersize=2, linewidth=0.8)
            k.set_ylabel("time step k [s]")
        else:                                        # cut-backs of a fixed step: less than a decade
            k.plot(time, 1e3 * dt, ".-", color="C4", markersize=2, linewidth=0.8)
            k.yaxis.set_major_formatter(ticker.ScalarFormatter(useOffset=False))
            k.set_ylabel("time step k [ms]")
        for rec in history[1:]:
            if rec.event:
                k.axvline(rec.time, color="grey", linestyle=":", linewidth=0.7)
    elif dt[np.isfinite(dt)].size:
        title += f"\n(fixed time step k = {1e3 * np.nanmedian(dt):.4g} ms, {np.isfinite(dt).sum()} steps)"
    axes[-1].set_xlabel("time t [s]")
    axes[0].set_title(title)
    fig.savefig(path, dpi=120)


def steps_vary(dt, relative=1e-9):
    """Whether the time steps ``dt`` (s; NaN entries ignored) vary by more than ``relative`` of
    the largest: by the error control or by cut-backs, not by the round-off of t_n − t_{n−1}
    (a fixed step varies only at the level of round-off, far below ``relative``)."""
    finite = np.asarray(dt, dtype=float)
    finite = finite[np.isfinite(finite)]
    return finite.size > 1 and finite.max() - finite.min() > relative * finite.max()


def _quiet(*args, **kwargs):
    """``print`` on the ranks other than 0."""


def _plot_gamma3(beta_path, pressure_path, midpoints, history):
    """β along Γ3 over time (x-t map), and the contact pressure along Γ3 at several times
    (in 3D: means over the facets in each of 40 slices across the width)."""
    x, average = _along_x(midpoints[:, 0])
    times = history.times
    beta = average(history.contact_column("beta"))
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    shown = ax.pcolormesh(x, times, beta, shading="nearest", cmap="magma", vmin=0, vmax=1)
    fig.colorbar(shown, ax=ax, label="bonding field β")
    ax.set(xlabel="x along Γ3 [mm]", ylabel="time t [s]", title="β on Γ3: debonding from the free end")
    fig.savefig(beta_path, dpi=120)
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    pressure = average(history.contact_column("pressure"))
    shown_steps = np.linspace(1, len(history) - 1, 9).astype(int)
    for n in shown_steps:
        ax.step(x, 1e-6 * pressure[n], where="mid", label=f"t = {times[n]:.3f} s")
    # the axis follows the bulk of the values, not a one-facet spike at the edge of the
    # contact zone, so that the glue's tension stays visible; a clipped spike is labelled
    values = 1e-6 * pressure[shown_steps]
    low, high = np.percentile(values, [1, 99])
    pad = 0.1 * (high - low or 1.0)
    ax.set_ylim(min(low, 0.0) - pad, max(high, 0.0) + pad)
    peak = np.unravel_index(np.argmax(values), values.shape)
    if values[peak] > high + pad:
        ax.annotate(f"clipped: {values[peak]:.3g} MPa", (x[peak[1]], high + pad), xytext=(0, -14),
                    textcoords="offset points", ha="center", fontsize=7, arrowprops=dict(arrowstyle="->"))
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlabel="x along Γ3 [mm]", ylabel="normal pressure −σ_ν [MPa]",
           title="contact pressure along Γ3 (negative: glue in tension)")
    ax.legend(fontsize=7, ncol=3)
    fig.savefig(pressure_path, dpi=120)


def _along_x(x, slices=40):
    """(x of each column in mm, a function that maps per-facet columns to columns along x):
    the facets sorted by x when they are a line (2D), else the mean over ``slices`` slices."""
    if len(np.unique(np.round(x, 12))) == len(x):
        order = np.argsort(x)
        return 1e3 * x[order], lambda values: values[:, order]
    edges = np.linspace(x.min(), x.max(), slices + 1)
    which = np.clip(np.digitize(x, edges) - 1, 0, slices - 1)
    used = np.unique(which)
    count = np.bincount(which, minlength=slices)[used]

    def average(values):
        return np.stack([np.bincount(which, weights=row, minlength=slices)[used] / count for row in values])
    return 1e3 * 0.5 * (edges[used] + edges[used + 1]), average


def _plot_potential(path, mesh, state, time):
    """The deformed plate (displacement magnified) coloured by the potential φ."""
    xy = np.array([v.point for v in mesh.vertices])
    cells = [[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)]
    coarse = tri.Triangulation(xy[:, 0], xy[:, 1], cells)
    fine = tri.UniformTriRefiner(coarse).refine_triangulation(subdiv=2)
    points = mesh(fine.x, fine.y)
    u, phi = (gf(points) for gf in state.components)
    scale = 0.1 * reference.L1 / np.abs(u).max()
    fig = Figure(figsize=(8, 2.8), layout="constrained")
    ax = fig.add_subplot()
    L1, L2 = reference.L1, reference.L2
    ax.plot([0, L1, L1, 0, 0], [0, 0, L2, L2, 0], "k--", lw=0.8)
    foundation = -scale * reference.CONTACT["gap"]            # the gap, magnified like u
    ax.axhspan(foundation - 0.1 * L2, foundation, color="0.8", hatch="///", lw=0)
    ax.text(0.99 * L1, foundation - 0.05 * L2, "foundation (gap magnified as u)", ha="right", va="center",
            fontsize=7)
    ax.xaxis.set_major_locator(ticker.MaxNLocator(6))
    shown = ax.tripcolor(fine.x + scale * u[:, 0], fine.y + scale * u[:, 1], fine.triangles,
                         phi[:, 0], shading="gouraud", cmap="viridis")
    fig.colorbar(shown, ax=ax, shrink=0.8, label="potential φ [V]")
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
           title=f"t = {time:.3g} s, largest contact zone: displacement × {scale:.3g}, dashed: undeformed")
    fig.savefig(path, dpi=120)
