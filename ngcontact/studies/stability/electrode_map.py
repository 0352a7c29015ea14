"""Newton before and after its globalisation, on the electrode contact and on the glued plate.

"before" is the previous solver and law: full Newton steps only (``Simulation(...,
globalise=False)``), the step-length cut of an open start (η = 1e-3, 2 corrections) also where
Γ3 touches at the solve's start (``StepLength.eta_touching``, ``max_cuts_touching``) and ψ
reading the gap (``Contact(gating="gap")``, the paper's ψ(u_ν − g));
"after" is the default: the line search and the path through wider conduction ramps
(``globalise=True``) and ψ reading Nitsche's contact state (``gating="pressure"``).

* Electrode map: the piezoelectric Hertz scene (``scenes.electrode``: a PZT-5A half-disk
  pushed 0.16 mm onto a grounded conducting plane in one step), the foundation's
  conductance k_e × ψ's ramp width δ, on a few meshes and orders. Besides Newton's outcome,
  the largest |φ| on Γ3 where the body presses: over the *fully pressed* facets (pressure > 0
  and both neighbours along Γ3, facets sorted by x, pressed too: the edge facets of the
  contact zone, where ψ switches within the facet, are left out) and over all pressed ones
  (|φ − φ_Γ| with φ_Γ = 0 V here).
* Glue map: the reference plate (``scenes.reference``, its contact data) pushed onto the
  foundation over the push ramp in 2, 4 or 8 steps with the glue's adhesion γ_ν
  over decades, P1 and P2; Newton's outcome and the most iterations one step took.
* The plate grounded at its clamped end (electrode "left" instead of "top"), the reference
  load and contact, steps of ``GROUNDED_DT``.

No time-step cut-backs, so that failures show; a failed solve is classified by
``common.failure_kind`` of its residuals (``reason`` keeps the first words of Newton's own
reason, which names a cycle where its detector found one).
"""
import math
import pathlib
import re
import time as wallclock

import ngsolve as ngs
import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.output.progress import bar
from ngcontact.scenes import electrode, hertz, reference

from ngcontact.studies.common import add_row, failure_kind, fmt
from .shared import STATUS_COLOURS, save, short

VARIANTS = {"before": dict(gating="gap", globalise=False), "after": dict(gating="pressure", globalise=True)}
"""The solver and law compared: (Contact.gating, Simulation's globalise)."""
PREVIOUS_CUT = {"before": dict(eta_touching=1e-3, max_cuts_touching=2)}
"""The step-length cut pinned per variant (``StepLength``'s attributes; else the defaults)."""
CONDUCTANCES = (1e-3, 1e-2, 1e-1, 1.0)
"""k_e of the electrode map, F/m²."""
RAMP_WIDTHS = (1e-6, 1e-7, 1e-8)
"""δ of the electrode map, m (widest first: the widest is the reference of ``force_change``)."""
DISCRETISATIONS = ((2e-4, 2), (5e-5, 2), (2e-4, 1))
"""(h_contact in m, order) of the electrode map."""
ADHESIONS = (1e9, 1e10, 1e11, 1e12)
"""γ_ν of the glue map, Pa/m."""
PUSH_STEPS = (2, 4, 8)
"""Time steps over the push ramp of the glue map."""
GLUE_ORDERS = (1, 2)
"""Orders of the glue map (mesh size ``glue_maxh``)."""
GROUNDED_DT = 0.00625
"""Time step of the plate grounded at its clamped end, s."""
COLUMNS = ("scene", "variant", "h", "order", "conductance", "ramp_width", "adhesion", "steps", "status",
           "failure", "failed_step", "newton_total", "worst_step", "wall_s", "force", "phi_pressed_inner")
"""The columns printed per run."""


def run(out=None, *, conductances=None, ramp_widths=None, discretisations=None, adhesions=None, push_steps=None,
        glue_orders=None, glue_maxh=0.01, grounded_steps=8, force_tol=0.01, variants=None, quick=False,
        progress=True):
    """The electrode map, the glue map and the grounded plate, before and after.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``electrode_map.png`` (status of every
        electrode run), ``electrode_glue.png`` (the glue map and the grounded plate) and
        ``electrode_potential.png`` (|φ| on the pressed facets against k_e).
    conductances, ramp_widths : k_e (F/m²) and δ (m) of the electrode map; default
        ``CONDUCTANCES``, ``RAMP_WIDTHS`` (quick: k_e 1e-3, 1; δ 1e-6, 1e-8).
    discretisations : [(h_contact in m, order)] of the electrode map; default
        ``DISCRETISATIONS`` (quick: P2 at 2e-4 m only).
    adhesions, push_steps, glue_orders : γ_ν (Pa/m), steps over the push ramp and orders of
        the glue map; default ``ADHESIONS``, ``PUSH_STEPS``, ``GLUE_ORDERS`` (quick: γ_ν 1e9,
        1e12; 2 and 8 steps; P1). An empty list skips the glue map.
    glue_maxh : mesh size of the plate (m, halved on Γ3).
    grounded_steps : steps of ``GROUNDED_DT`` of the plate grounded at its clamped end (0: skip).
    force_tol : a converged electrode run whose force is off by more than this (relative)
        from the "after" run at the widest δ (same mesh, order, k_e) is "wrong".
    variants : names of ``VARIANTS`` to run; default both.
    quick : fewer runs (see above).
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per run, all with the same keys: ``scene`` ("electrode", "glue",
    "grounded"), ``variant`` ("before", "after"), ``h`` (h_contact or maxh, m), ``order``,
    ``conductance`` (F/m²), ``ramp_width`` (m), ``adhesion`` (Pa/m), ``steps``, ``status``
    ("ok", "wrong", "failed"), ``failure`` (``failure_kind``, "" if converged), ``reason``
    (Newton's, first words; "cycle p" where its cycle detector found one), ``failed_step``
    (0 if converged), ``newton`` (Newton iterations of the accepted solves, plus the failed
    solve's), ``discarded`` (those of first tries that were discarded:
    ``StepRecord.discarded_iterations``, or a failed solve's first try with shortened
    steps), ``newton_total`` (the sum), ``worst_step`` (the most iterations, discarded ones
    included, of one step), ``factorizations`` and ``krylov`` (the linear solver's
    factorisations and GMRES iterations, the failed solve's included), ``wall_s`` (building
    and running the simulation, s), ``force`` (contact force along y at the end, N/m),
    ``force_change`` (electrode: relative to the "after" run at the widest δ),
    ``phi_pressed_inner`` and ``phi_pressed`` (largest |φ − φ_Γ| in V over the fully
    pressed / all pressed facets, ``pressed_potentials``; the electrode's φ_Γ is 0 V, the
    plate's 10 V; nan without), ``pressed`` (facets with pressure > 0).
    """
    conductances = conductances if conductances is not None else (1e-3, 1.0) if quick else CONDUCTANCES
    ramp_widths = ramp_widths if ramp_widths is not None else (1e-6, 1e-8) if quick else RAMP_WIDTHS
    discretisations = discretisations if discretisations is not None else \
        ((2e-4, 2),) if quick else DISCRETISATIONS
    adhesions = adhesions if adhesions is not None else (1e9, 1e12) if quick else ADHESIONS
    push_steps = push_steps if push_steps is not None else (2, 8) if quick else PUSH_STEPS
    glue_orders = glue_orders if glue_orders is not None else (1,) if quick else GLUE_ORDERS
    variants = {name: VARIANTS[name] for name in (variants or VARIANTS)}
    total = len(variants) * (len(discretisations) * len(conductances) * len(ramp_widths)
                             + len(glue_orders) * len(adhesions) * len(push_steps) + (1 if grounded_steps else 0))
    rows = []
    with bar(total, "electrode_map", progress, unit="run") as shown:
        for h, order in discretisations:
            mesh = hertz.mesh(2, h, curve=order, radius=electrode.RADIUS)
            for variant, options in variants.items():
                for k_e in conductances:
                    for delta in ramp_widths:
                        def build():
                            return electrode.simulation(conductance=k_e, ramp_width=delta, order=order, mesh=mesh,
                                                        keep_states=False, **options)
                        row = _solve(build, [1.0], dict(scene="electrode", variant=variant, h=h, order=order,
                                                        conductance=k_e, ramp_width=delta, adhesion=0.0))
                        add_row(rows, row, shown, COLUMNS)
        _mark_wrong(rows, force_tol)
        for order in glue_orders:
            for variant, options in variants.items():
                for adhesion in adhesions:
                    for steps in push_steps:
                        def build():          # ``shared.press``'s plate, with ``globalise`` passed on
                            contact = reference.contact(adhesion=adhesion, gating=options["gating"])
                            return reference.simulation(order, glue_maxh, contact=contact, keep_states=False,
                                                        globalise=options["globalise"])
                        row = _solve(build, [reference.PUSH_END / steps] * steps, dict(
                            scene="glue", variant=variant, h=glue_maxh, order=order, adhesion=adhesion,
                            conductance=reference.CONTACT["conductance"], ramp_width=reference.CONTACT["ramp_width"]))
                        add_row(rows, row, shown, COLUMNS)
        if grounded_steps:
            for variant, options in variants.items():
                def build():
                    t = ngs.Parameter(0.0)
                    body = ngc.Body(plate(maxh=0.01, maxh_contact=0.005), ngc.pzt5a(2e-3), clamped="left",
                                    grounded="left", contact_side="bottom")
                    return ngc.Simulation(body, reference.loads(t, 2), contact=reference.contact(
                        gating=options["gating"]), time=t, globalise=options["globalise"], keep_states=False)
                row = _solve(build, [GROUNDED_DT] * grounded_steps, dict(
                    scene="grounded", variant=variant, h=0.01, order=1, adhesion=reference.CONTACT["adhesion"],
                    conductance=reference.CONTACT["conductance"], ramp_width=reference.CONTACT["ramp_width"]))
                add_row(rows, row, shown, COLUMNS)
    if out is not None:
        _plot(rows, pathlib.Path(out), force_tol, quick)
    return rows


def pressed_potentials(side, pressure, potential, foundation=0.0):
    """(largest |φ − φ_Γ| over the fully pressed facets, over all pressed facets, pressed
    facets), φ_Γ = ``foundation`` (V): a facet is pressed where its pressure is > 0, fully
    pressed where its two neighbours along Γ3 (facets sorted by x) are pressed too; nan
    where there is none."""
    order = np.argsort(side.midpoints[:, 0])
    pressed = np.asarray(pressure)[order] > 0
    phi = np.abs(np.asarray(potential) - foundation)[order]
    inner = np.zeros_like(pressed)
    inner[1:-1] = pressed[1:-1] & pressed[:-2] & pressed[2:]
    largest = [float(phi[kept].max()) if kept.any() else math.nan for kept in (inner, pressed)]
    return largest[0], largest[1], int(pressed.sum())


def _solve(build, dts, row):
    """Build a simulation and take the steps ``dts`` (s) without cut-backs: the row of
    ``run`` (``row`` gives the scene's keys)."""
    began = wallclock.perf_counter()
    sim = build()
    for name, value in PREVIOUS_CUT.get(row["variant"], {}).items():
        setattr(sim.newton.step_length, name, value)
    row = dict(row, steps=len(dts), status="ok", failure="", reason="", failed_step=0, newton=0, discarded=0,
               newton_total=0, worst_step=0, factorizations=0, krylov=0, wall_s=math.nan, force=math.nan,
               force_change=math.nan,
               phi_pressed_inner=math.nan, phi_pressed=math.nan, pressed=0)
    per_step, linear = [], [0, 0]
    try:
        for dt in dts:
            record = sim.step(dt)
            per_step.append((record.newton_iterations, record.discarded_iterations))
            linear = [linear[0] + record.factorizations, linear[1] + record.krylov_iterations]
    except ngc.NewtonError as err:
        discarded = len(err.residuals_limited) - 1 if err.residuals_limited else 0
        per_step.append((err.iteration, discarded))
        linear = [linear[0] + err.factorizations, linear[1] + err.krylov_iterations]
        row.update(status="failed", failure=failure_kind(err.residuals), failed_step=len(per_step),
                   reason=_reason(err.reason))
    row["wall_s"] = wallclock.perf_counter() - began
    newton, discarded = (int(sum(column)) for column in zip(*per_step))
    row.update(newton=newton, discarded=discarded, newton_total=newton + discarded,
               worst_step=int(max(a + b for a, b in per_step)), factorizations=int(linear[0]), krylov=int(linear[1]))
    if row["status"] == "ok":
        c = sim.history[-1].contact
        inner, pressed, count = pressed_potentials(sim.side, c.pressure, c.potential,
                                                   float(sim.contact.foundation_potential))
        row.update(force=float(c.force[1]), phi_pressed_inner=inner, phi_pressed=pressed, pressed=count)
    return row


def _mark_wrong(rows, force_tol):
    """``force_change`` of the converged electrode runs against the "after" run at the widest
    δ of the same mesh, order and k_e; beyond ``force_tol``: status "wrong"."""
    runs = [r for r in rows if r["scene"] == "electrode"]
    for r in runs:
        same = [q for q in runs if q["variant"] == "after" and q["status"] != "failed"
                and (q["h"], q["order"], q["conductance"]) == (r["h"], r["order"], r["conductance"])]
        if r["status"] == "failed" or not same:
            continue
        reference_force = max(same, key=lambda q: q["ramp_width"])
        if reference_force["ramp_width"] != max(q["ramp_width"] for q in runs):
            continue                          # the widest ramp failed after: no reference
        r["force_change"] = r["force"] / reference_force["force"] - 1
        if abs(r["force_change"]) > force_tol:
            r["status"] = "wrong"


def _reason(reason):
    """Newton's reason for a failure, its first words; "cycle p" where its cycle detector
    found one of period p."""
    cycle = re.match(r"cycles: the iterates repeat with period (\d+)", reason)
    return f"cycle {cycle.group(1)}" if cycle else reason.split(":")[0].split(" (")[0][:60]


def _label(r, key="newton_total"):
    """A cell of the maps and tables: the iteration count ``key``, or the short failure
    label, followed by Newton's cycle where ``failure_kind`` does not name it (nc/c2: the
    residuals settle into Newton's cycle of period 2 too slowly for ``failure_kind``)."""
    if r["status"] != "failed":
        return str(r[key])
    label = short(r["failure"])
    if r["reason"].startswith("cycle ") and r["reason"] != r["failure"]:
        label += "/" + short(r["reason"])
    return label


def _grid(rows, down, across, key, labels=("before", "after")):
    """A text table: a row per value of ``down``, the cells of ``across`` for each variant."""
    ds = sorted({r[down] for r in rows})
    acs = sorted({r[across] for r in rows}, reverse=across == "ramp_width")
    cells = {(r["variant"], r[down], r[across]): _label(r, key) for r in rows}
    head = [f"{down} \\ {across}"] + [f"{v}: {fmt(a)}" for v in labels for a in acs]
    body = [[fmt(d)] + [cells.get((v, d, a), "") for v in labels for a in acs] for d in ds]
    widths = [max(len(line[i]) for line in [head] + body) for i in range(len(head))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(line, widths)) for line in [head] + body)


def _worst(runs):
    done = [r for r in runs if r["status"] != "failed"]
    return max(done, key=lambda r: r["newton_total"]) if done else None


def summary(rows):
    """Before/after tables (total Newton iterations, or the failure) of the electrode map
    per mesh and order and of the glue map per order (worst iterations of a step), the
    grounded plate, the worst iteration count after, and the largest |φ| on fully pressed
    facets for k_e >= 0.1."""
    text = []
    electrode_rows = [r for r in rows if r["scene"] == "electrode"]
    for h, order in dict.fromkeys((r["h"], r["order"]) for r in electrode_rows):
        runs = [r for r in electrode_rows if (r["h"], r["order"]) == (h, order)]
        failed = {v: sum(r["status"] == "failed" for r in runs if r["variant"] == v) for v in VARIANTS}
        text.append(f"electrode, h_contact = {h:g} m, P{order}: Newton iterations (with discarded ones) or "
                    f"failure; failed before {failed['before']}, after {failed['after']} of "
                    f"{len(runs) // 2}; wrong force {sum(r['status'] == 'wrong' for r in runs)}")
        text.append(_grid(runs, "conductance", "ramp_width", "newton_total"))
    after = _worst([r for r in electrode_rows if r["variant"] == "after"])
    if after:
        text.append(f"worst after: {after['newton_total']} iterations ({after['discarded']} discarded) at k_e = "
                    f"{after['conductance']:g}, δ = {after['ramp_width']:g}, h_contact = {after['h']:g}, "
                    f"P{after['order']}")
    for v in VARIANTS:
        strong = [r for r in electrode_rows if r["variant"] == v and r["conductance"] >= 0.1
                  and math.isfinite(r["phi_pressed_inner"])]
        if strong:
            top = max(strong, key=lambda r: r["phi_pressed_inner"])
            edge = max(r["phi_pressed"] for r in strong)
            text.append(f"largest |φ| {v}, k_e >= 0.1, fully pressed facets: {top['phi_pressed_inner']:.3g} V "
                        f"(k_e = {top['conductance']:g}, δ = {top['ramp_width']:g}, h_contact = {top['h']:g}, "
                        f"P{top['order']}); all pressed facets: {edge:.3g} V")
    glue = [r for r in rows if r["scene"] == "glue"]
    for order in dict.fromkeys(r["order"] for r in glue):
        runs = [r for r in glue if r["order"] == order]
        text.append(f"glue, plate maxh = {runs[0]['h']:g} m, P{order}: most iterations in one step or failure")
        text.append(_grid(runs, "adhesion", "steps", "worst_step"))
    for r in (r for r in rows if r["scene"] == "grounded"):
        state = f"ok, worst step {r['worst_step']} iterations" if r["status"] != "failed" else \
            f"failed at step {r['failed_step']} ({r['failure']}; {r['reason']})"
        text.append(f"plate grounded at its clamped end, {r['steps']} steps of {GROUNDED_DT:g} s, {r['variant']}: "
                    f"{state}")
    return "\n".join(text)


def _status_map(ax, runs, down, across, key, title):
    ds = sorted({r[down] for r in runs})
    acs = sorted({r[across] for r in runs}, reverse=across == "ramp_width")
    codes = {s: i for i, s in enumerate(STATUS_COLOURS)}
    grid = np.full((len(ds), len(acs)), np.nan)
    for r in runs:
        i, j = ds.index(r[down]), acs.index(r[across])
        grid[i, j] = codes[r["status"]]
        ax.text(j, i, _label(r, key), ha="center", va="center", fontsize=9)
    ax.imshow(grid, cmap=ListedColormap(list(STATUS_COLOURS.values())), vmin=-0.5,
              vmax=len(STATUS_COLOURS) - 0.5, aspect="auto")
    ax.set_xticks(range(len(acs)), [f"{a:g}" for a in acs], fontsize=8)
    ax.set_yticks(range(len(ds)), [f"{d:g}" for d in ds], fontsize=8)
    ax.set_title(title, fontsize=9)


def _plot(rows, out, force_tol, quick=False):
    electrode_rows = [r for r in rows if r["scene"] == "electrode"]
    legend = ("green: converged; orange: converged, force off by more than "
              f"{100 * force_tol:g} % from the after run at the widest δ; red: Newton failed\n"
              "(nc: no convergence, cN: cycle with period N, stag: stagnation, div: diverged; "
              "nc/c2: Newton's own detector found a cycle with period 2)")
    if electrode_rows:
        groups = list(dict.fromkeys((r["h"], r["order"]) for r in electrode_rows))
        fig = Figure(figsize=(9, 2.4 * len(groups) + 0.8), layout="constrained")
        axes = np.array(fig.subplots(len(groups), 2, squeeze=False))
        for (h, order), pair in zip(groups, axes):
            for ax, variant in zip(pair, VARIANTS):
                runs = [r for r in electrode_rows if (r["h"], r["order"], r["variant"]) == (h, order, variant)]
                _status_map(ax, runs, "conductance", "ramp_width", "newton_total",
                            f"{variant}: h_contact = {h:g} m, P{order}")
                ax.set(xlabel="ramp width δ [m]", ylabel="k_e [F/m²]")
        fig.suptitle("electrode contact, one step: Newton iterations (discarded included)\n" + legend, fontsize=9)
        save(fig, out / "electrode_map.png", quick)

        fig = Figure(figsize=(13, 4.2), layout="constrained")
        axes = fig.subplots(1, 2, sharey=True)
        for ax, key, label in zip(axes, ("phi_pressed_inner", "phi_pressed"),
                                  ("fully pressed facets", "all pressed facets")):
            for i, (h, order) in enumerate(groups):
                for j, delta in enumerate(sorted({r["ramp_width"] for r in electrode_rows}, reverse=True)):
                    for variant, marker, style in (("before", "x", ":"), ("after", "o", "-")):
                        runs = [r for r in electrode_rows if (r["h"], r["order"], r["ramp_width"], r["variant"])
                                == (h, order, delta, variant) and math.isfinite(r[key])]
                        if runs:
                            ax.plot([r["conductance"] for r in runs], [r[key] for r in runs], marker + style,
                                    color=f"C{i}", alpha=1 - 0.3 * j, ms=5,
                                    label=f"{variant}, h = {h:g}, P{order}, δ = {delta:g}")
            ax.set(xscale="log", yscale="log", xlabel="k_e [F/m²]", ylabel="largest |φ| [V]", title=label)
            ax.grid(True, lw=0.3)
        fig.legend(*axes[0].get_legend_handles_labels(), fontsize=7, loc="outside right center")
        fig.suptitle("electrode contact: the potential where the body presses on the grounded plane "
                     "(converged runs)", fontsize=9)
        save(fig, out / "electrode_potential.png", quick)

    glue = [r for r in rows if r["scene"] == "glue"]
    grounded = [r for r in rows if r["scene"] == "grounded"]
    if glue or grounded:
        orders = list(dict.fromkeys(r["order"] for r in glue))
        fig = Figure(figsize=(9, 2.4 * max(len(orders), 1) + 1.0), layout="constrained")
        axes = np.array(fig.subplots(max(len(orders), 1), 2, squeeze=False))
        for order, pair in zip(orders, axes):
            for ax, variant in zip(pair, VARIANTS):
                runs = [r for r in glue if (r["order"], r["variant"]) == (order, variant)]
                _status_map(ax, runs, "adhesion", "steps", "worst_step",
                            f"{variant}: plate, maxh = {runs[0]['h']:g} m, P{order}")
                ax.set(xlabel="steps over the push (0.1 s)", ylabel="γ_ν [Pa/m]")
        notes = "; ".join(
            f"{r['variant']}: " + (f"ok, worst step {r['worst_step']}" if r["status"] != "failed" else
                                    f"failed at step {r['failed_step']} ({_label(r)})") for r in grounded)
        fig.suptitle("glue map: most Newton iterations in one step (discarded included); red: failed\n"
                     + (f"plate grounded at its clamped end, {grounded[0]['steps']} steps of {GROUNDED_DT:g} s: "
                        f"{notes}" if grounded else ""), fontsize=9)
        save(fig, out / "electrode_glue.png", quick)
