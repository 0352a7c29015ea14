"""A body of revolution on its meridian section against the 3D quarter-ball: accuracy per second
(``python -m ngcontact axisymmetric``, docs/axisymmetric.md).

The elastic half-ball of ``scenes.hertz`` pressed 0.01 R onto a plane (a/R ≈ 0.1), solved with
default options on its meridian section (``Body(axisymmetric=True)``, ``hertz.mesh(2,
axisymmetric=True)``) and on the 3D quarter-ball with its two symmetry planes
(``hertz.mesh(3, quarter=True)``), each at a series of contact mesh sizes. The error of a run
is that of its contact pressure against a fine reference (the section at P3 on a mesh twice
finer than the finest of the series), of the facet averages ("error", the pressure the records
report) and pointwise ("pointwise_error"):

    ‖P_B(λ_h − λ_ref)‖ / ‖P_B λ_ref‖ and ‖λ_h − λ_ref‖ / ‖λ_ref‖ over Γ3
    (da = 2π r dr on the section, the area in 3D),

λ_h the enforcement's multiplier at the Gauss points of the residual on Γ3
(``ContactRecord.multiplier_points``, weights ``ContactSide.gauss_weights``), λ_ref the
reference's, interpolated in r, and P_B the facet average. The pointwise error is dominated
by the facet that holds the end of the contact zone (λ_h kinks inside it) and does not fall
steadily from one mesh to the next (docs/measurements.md, section axisymmetric). The time of a
run is its solve time, the step's own record (Newton with its factorisations,
``common.solve_seconds``), and apart what it paid once (``setup_s``: meshing, the forms, step 0,
and the compile of the Γ3 integrand where ``model.machine_code``'s rule makes one), one thread;
the runs are interleaved (section, 3D, section, ...) over ``rounds`` and the least of each time
over the rounds is kept (``common.fastest``; with one round, a single timing). ``summary``
interpolates (log-log) the solve time each kind needs to reach an error and their ratio.
"""
import math
import time

import numpy as np
from matplotlib.figure import Figure

from ngcontact import checks
from ngcontact.output.progress import bar
from ngcontact.scenes import hertz

from .common import QUICK, fastest, split_seconds, table, timing_label, write_csv

SECTION_SIZES = (0.02, 0.01, 0.005, 0.0025, 0.00125)
"""Contact mesh sizes (m, R = 1) of the meridian-section runs."""
QUARTER_SIZES = (0.08, 0.04, 0.02, 0.01, 0.005)
"""Contact mesh sizes of the 3D quarter-ball runs (the finest is the costliest run of the study)."""
COLUMNS = ("kind", "order", "h_contact", "ndof", "newton", "force", "a", "error", "pointwise_error", "setup_s",
           "solve_s")
"""Columns of axisymmetric.csv (a row per run) and of the table (a row per case, the times the
least over the rounds, with ``repeats``)."""


def solve(kind, order, h_contact):
    """(the solved simulation, its setup and solve times in s: ``common.split_seconds`` of the
    wall time from the mesh to the solved step)."""
    t0 = time.perf_counter()
    if kind == "section":
        sim = hertz.simulation(order, h_contact=h_contact, axisymmetric=True, keep_states=False)
    elif kind == "quarter":
        sim = hertz.simulation(order, h_contact=h_contact, dim=3, quarter=True, keep_states=False)
    else:
        raise ValueError(f"kind must be 'section' or 'quarter', got {kind!r}")
    sim.step(1.0)
    return (sim, *split_seconds(time.perf_counter() - t0, sim.history))


def _radius(sim):
    """The distance from the axis of the Gauss points of Γ3 (facets × points, m)."""
    points = sim.side.gauss_points
    return points[..., 0] if sim.body.axisymmetric else np.hypot(points[..., 0], points[..., 1])


def pressure_points(sim):
    """(r, λ_h, weights) at the Gauss points of Γ3 (m, Pa, m²), sorted by r."""
    r = _radius(sim).ravel()
    order = np.argsort(r, kind="stable")
    return r[order], sim.history[-1].contact.multiplier_points.ravel()[order], sim.side.gauss_weights.ravel()[order]


def pressure_error(sim, reference, averages=False):
    """‖λ_h − λ_ref‖/‖λ_ref‖ over Γ3 (module docstring); ``reference`` = ``pressure_points`` of
    the reference run. ``averages``: of the facet averages P_B λ_h − P_B λ_ref instead (the
    pressure a ``ContactRecord`` reports), which the kink of λ_h inside the facet at the end of
    the contact zone does not dominate."""
    lam, w = sim.history[-1].contact.multiplier_points, sim.side.gauss_weights      # facets × points
    exact = np.interp(_radius(sim), reference[0], reference[1], right=0.0)
    if averages:
        W = w.sum(axis=1)
        lam, exact, w = (np.sum(w * lam, axis=1) / W, np.sum(w * exact, axis=1) / W, W)
    return float(math.sqrt(np.sum(w * (lam - exact) ** 2) / np.sum(w * exact ** 2)))


def row(kind, order, h_contact, sim, seconds, reference):
    """The row of a solved run; ``seconds`` its (setup_s, solve_s)."""
    errors = hertz.errors(sim)
    return dict(kind=kind, order=order, h_contact=h_contact, ndof=sim.X.ndof,
                newton=sim.history[-1].newton_iterations, force=errors["force"], a=errors["a_h"],
                error=pressure_error(sim, reference, averages=True),
                pointwise_error=pressure_error(sim, reference), setup_s=seconds[0], solve_s=seconds[1])


def study(order=2, section_sizes=SECTION_SIZES, quarter_sizes=QUARTER_SIZES, rounds=2, progress=True):
    """The rows of every run (each case ``rounds`` times, interleaved) and the reference's
    (kind "reference"): see the module docstring."""
    reference_h = min(section_sizes) / 2
    ref, *ref_seconds = solve("section", 3, reference_h)
    points = pressure_points(ref)
    rows = [dict(row("reference", 3, reference_h, ref, ref_seconds, points), error=0.0, pointwise_error=0.0)]
    cases = [("section", h) for h in section_sizes] + [("quarter", h) for h in quarter_sizes]
    order_of_runs = []
    for _ in range(rounds):                      # section, quarter, section, ... in each round
        sections, quarters = [c for c in cases if c[0] == "section"], [c for c in cases if c[0] == "quarter"]
        for i in range(max(len(sections), len(quarters))):
            order_of_runs += sections[i:i + 1] + quarters[i:i + 1]
    with bar(len(order_of_runs), "section against quarter-ball", enabled=progress, unit="run") as progress_bar:
        for kind, h in order_of_runs:
            sim, *seconds = solve(kind, order, h)
            rows.append(row(kind, order, h, sim, seconds, points))
            progress_bar.set_postfix_str(f"{kind} h {h:g}: setup {seconds[0]:.1f} s, solve {seconds[1]:.1f} s")
            progress_bar.update(1)
    return rows


def cases(rows):
    """One row per case: its times the least over the rounds, ``repeats`` the rounds
    (``common.fastest``; the rest of the first run)."""
    return fastest(rows, lambda r: (r["kind"], r["h_contact"]))


def time_to(rows, kind, error):
    """The solve time (s) at which runs of ``kind`` reach ``error``, interpolated log-log between
    the cases that bracket it (the first case at or below it if none above), or None."""
    cases_ = sorted((r["solve_s"], r["error"]) for r in cases(rows) if r["kind"] == kind)
    for (t0, e0), (t1, e1) in zip(cases_, cases_[1:]):
        if e0 > error >= e1:
            return float(math.exp(math.log(t0) + (math.log(t1) - math.log(t0))
                                  * (math.log(error) - math.log(e0)) / (math.log(e1) - math.log(e0))))
    below = [t for t, e in cases_ if e <= error]
    return min(below) if below else None


def summary(rows, errors=(0.1, 0.05, 0.02, 0.01)):
    """Per error: the solve time of each kind to reach it and their ratio (quarter ÷ section)."""
    out = []
    for error in errors:
        section, quarter = time_to(rows, "section", error), time_to(rows, "quarter", error)
        out.append(dict(error=error, section_s=section, quarter_s=quarter,
                        ratio=quarter / section if section and quarter else None))
    return out


def chart(rows, path, quick=False):
    """Pressure error against solve time, both kinds (log-log), written to ``path``; ``quick``
    marks the title (``common.QUICK``). Returns the Figure."""
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    shown = [r for r in cases(rows) if r["kind"] != "reference"]
    for kind, label, marker in (("section", "meridian section (axisymmetric), P2", "o"),
                                ("quarter", "3D quarter-ball, P2", "s")):
        mine = sorted((r["solve_s"], r["error"], r["ndof"]) for r in shown if r["kind"] == kind)
        if mine:
            ax.loglog([c[0] for c in mine], [c[1] for c in mine], marker + "-", label=label)
            for t, e, n in mine:
                ax.annotate(f"{n}", (t, e), textcoords="offset points", xytext=(4, 3), fontsize=7)
    repeats = min((r["repeats"] for r in shown), default=1)
    ax.set(xlabel=f"solve time of the step [s] ({timing_label(repeats)}; setup apart)",
           ylabel="‖P_B(λ_h − λ_ref)‖ / ‖P_B λ_ref‖",
           title="half-ball on a plane, a/R ≈ 0.1: error against time (labels: DOFs)"
                 + (f"\n({QUICK})" if quick else ""))
    ax.grid(True, which="both", lw=0.3)
    ax.legend()
    fig.savefig(path, dpi=110)
    return fig


def command(out, order=2, rounds=2, quick=False, progress=True):
    """``python -m ngcontact axisymmetric``: ``axisymmetric.csv``, ``axisymmetric.md`` and
    ``axisymmetric.png`` in ``out``; ``quick``: the three coarsest sections and two coarsest
    quarter-balls, one round (its chart, table and output say so: ``common.QUICK``).
    The arguments are checked before any run: ``out`` a directory that can be written (created),
    ``order`` in [1, ``checks.MAX_ORDER``], ``rounds`` in [1, 20]."""
    order = checks.order("order", order)
    rounds = checks.integer("rounds", rounds, 1, 20)
    quick = checks.flag("quick", quick)
    out = checks.writable_directory(out, "out (the output directory)")
    sections, quarters = (SECTION_SIZES[:3], QUARTER_SIZES[:2]) if quick else (SECTION_SIZES, QUARTER_SIZES)
    rows = study(order, sections, quarters, 1 if quick else rounds, progress)
    write_csv(rows, out / "axisymmetric.csv", COLUMNS)
    times = (f"times in s: setup_s what a run paid once (meshing, forms, step 0, compiling), solve_s its step; each "
             f"{timing_label(1 if quick else rounds)}")
    text = (f"{QUICK} (the coarsest sizes, one round)\n" if quick else "") + times + "\n\n" + \
        table(cases(rows), (*COLUMNS, "repeats")) + "\n\n" + \
        table(summary(rows), ("error", "section_s", "quarter_s", "ratio"))
    (out / "axisymmetric.md").write_text(text + "\n")
    chart(rows, out / "axisymmetric.png", quick)
    print(text)
    return rows
