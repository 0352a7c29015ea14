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

``adaptive`` (``python -m ngcontact axisymmetric --adaptive``): the same scene adapted by
``adapt.solve`` on the section and on the quarter-ball to one relative target; per level of each
run the DOFs, the contact force F and radius a_h (``hertz.errors``), and whether the section's
last F and a_h lie within the 3D run's last change, |X_section − X_3D,L| <= |X_3D,L − X_3D,L−1|.
"""
import math
import time

import numpy as np
from matplotlib.figure import Figure

from ngcontact import adapt, checks
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


ADAPTIVE_SIZES = dict(section=0.05, quarter=0.16)
"""Contact mesh sizes (m, R = 1) of the first meshes of the adaptive runs."""
ADAPTIVE_TOL = 0.1
"""The relative estimate both adaptive runs are solved to by default."""
ADAPTIVE_MAX_NDOF = 4e4
"""The DOF limit of each adaptive run: the certificate (the equilibrated bound of the last level)
of the next finer 3D P2 levels ran out of memory in SuperLU (docs/axisymmetric.md)."""
ADAPTIVE_COLUMNS = ("kind", "order", "level", "ndof", "force", "a_h", "a", "relative", "certified", "change",
                    "to_section", "within", "elapsed_s")
"""Columns of adaptive.csv (a row per level of each run): ``a`` Hertz's radius at the level's force,
``relative`` the certified relative estimate (NaN on levels the averaging marking did not
certify), ``change`` |F_ℓ − F_ℓ−1|, ``to_section`` |F_section − F_ℓ| and ``within`` whether the
latter is at most the former (3D levels), ``elapsed_s`` the adaptation's wall time so far."""


def _adaptive_scene(kind, order):
    if kind == "section":
        return lambda mesh: hertz.simulation(order, mesh=mesh, axisymmetric=True, keep_states=False)
    return lambda mesh: hertz.simulation(order, mesh=mesh, dim=3, quarter=True, keep_states=False)


def adaptive_run(kind, order=2, tol=ADAPTIVE_TOL, h_contact=None, max_ndof=ADAPTIVE_MAX_NDOF, on_row=None):
    """(the rows of the levels, the ``adapt.Adaptation``) of ``adapt.solve`` on the section
    (``kind`` "section") or the quarter-ball ("quarter") from ``hertz.mesh`` at ``h_contact``
    (default ``ADAPTIVE_SIZES``), to the relative estimate ``tol``; ``on_row(row)`` after each level."""
    if kind not in ADAPTIVE_SIZES:
        raise ValueError(f"kind must be 'section' or 'quarter', got {kind!r}")
    h = ADAPTIVE_SIZES[kind] if h_contact is None else h_contact
    mesh = hertz.mesh(2, h_contact=h, curve=order, axisymmetric=True) if kind == "section" else \
        hertz.mesh(3, h_contact=h, curve=order, quarter=True)
    rows = []

    def on_level(level):
        errors = hertz.errors(level.sim)
        rows.append(dict(kind=kind, order=order, level=len(rows) + 1, ndof=level.ndof, force=errors["force"],
                         a_h=errors["a_h"], a=errors["a"], relative=level.relative, certified=level.certified,
                         elapsed_s=level.elapsed_s))
        if on_row is not None:
            on_row(rows[-1])
    result = adapt.solve(_adaptive_scene(kind, order), mesh, tol, on_level=on_level, max_ndof=max_ndof)
    return rows, result


def agreement(rows, quantity="force"):
    """The section's last ``quantity`` ("force" or "a_h") against the 3D run's last change:
    dict(quantity, section, quarter (the last level's), previous, change = |last − previous|,
    difference = |section − last|, within = difference <= change); ``within`` None with a
    single 3D level (no change to compare with)."""
    section = [r[quantity] for r in rows if r["kind"] == "section"]
    quarter = [r[quantity] for r in rows if r["kind"] == "quarter"]
    if not section or not quarter:
        raise ValueError("agreement needs the rows of both runs (kinds 'section' and 'quarter')")
    previous = quarter[-2] if len(quarter) > 1 else math.nan
    change, difference = abs(quarter[-1] - previous), abs(section[-1] - quarter[-1])
    return dict(quantity=quantity, section=section[-1], quarter=quarter[-1], previous=previous, change=change,
                difference=difference, within=bool(difference <= change) if len(quarter) > 1 else None)


def adaptive(order=2, tol=ADAPTIVE_TOL, sizes=None, max_ndof=ADAPTIVE_MAX_NDOF, progress=True):
    """The section and then the quarter-ball adapted to ``tol`` (``adaptive_run``; ``sizes``:
    their first contact mesh sizes, default ``ADAPTIVE_SIZES``): (the rows of every level, with
    the 3D levels' ``change``, ``to_section`` and ``within``; the reasons the runs stopped by
    kind; the ``agreement`` of the force and of a_h)."""
    order = checks.order("order", order)
    tol = checks.number("tol", tol, 0, 1, low_open=True, high_open=True)
    sizes = {**ADAPTIVE_SIZES, **(sizes or {})}
    rows, reasons = [], {}
    with bar(None, "adaptive section and quarter-ball", enabled=progress, unit="level") as progress_bar:
        def on_row(row):
            progress_bar.set_postfix_str(f"{row['kind']} level {row['level']}: {row['ndof']} DOFs, "
                                         f"F {row['force']:.6e} N")
            progress_bar.update(1)
        for kind in ("section", "quarter"):
            mine, result = adaptive_run(kind, order, tol, sizes[kind], max_ndof, on_row)
            rows += mine
            reasons[kind] = result.reason
    section = [r for r in rows if r["kind"] == "section"][-1]
    previous = None
    for r in rows:
        r.update(change=math.nan, to_section=math.nan, within="")
        if r["kind"] == "quarter":
            if previous is not None:
                r.update(change=abs(r["force"] - previous), to_section=abs(section["force"] - r["force"]))
                r["within"] = bool(r["to_section"] <= r["change"])
            previous = r["force"]
    return rows, reasons, [agreement(rows, "force"), agreement(rows, "a_h")]


def _shown(rows):
    """The rows with F to 7 digits and a_h to 5 (``common.table`` keeps 4: too few to see the changes)."""
    digits = dict(force="{:.6e}", a_h="{:.5f}", a="{:.5f}", change="{:.2e}", to_section="{:.2e}")
    return [{k: (digits[k].format(v) if k in digits and not math.isnan(v) else v) for k, v in r.items()}
            for r in rows]


def adaptive_text(rows, reasons, agreements, tol):
    """The printed table of ``adaptive`` and its comparison lines."""
    lines = [f"adaptive P{rows[0]['order']}, target relative estimate {tol:g}; "
             f"section: {reasons['section']}, quarter-ball: {reasons['quarter']}", "",
             table(_shown(rows), ADAPTIVE_COLUMNS), ""]
    for a in agreements:
        name = "F (N)" if a["quantity"] == "force" else "a_h (m)"
        if a["within"] is None:
            lines.append(f"{name}: the 3D run stopped at its first level: no change to compare with (lower the tol)")
            continue
        lines.append(f"{name}: section {a['section']:.6e}, 3D {a['quarter']:.6e} (previous level {a['previous']:.6e}):"
                     f" |section - 3D| = {a['difference']:.2e} {'<=' if a['within'] else '>'} 3D last change "
                     f"{a['change']:.2e}: {'within' if a['within'] else 'NOT within'} the 3D run's last change")
    return "\n".join(lines)


def command_adaptive(out, order=2, tol=ADAPTIVE_TOL, progress=True):
    """``python -m ngcontact axisymmetric --adaptive``: ``adaptive`` written to ``adaptive.csv``
    and ``adaptive.md`` in ``out`` and printed. The arguments are checked before any run:
    ``out`` a directory that can be written (created), ``order`` in [1, ``checks.MAX_ORDER``],
    ``tol`` in (0, 1)."""
    order = checks.order("order", order)
    tol = checks.number("--tol", tol, 0, 1, low_open=True, high_open=True)
    out = checks.writable_directory(out, "out (the output directory)")
    rows, reasons, agreements = adaptive(order, tol, progress=progress)
    write_csv(rows, out / "adaptive.csv", ADAPTIVE_COLUMNS)
    text = adaptive_text(rows, reasons, agreements, tol)
    (out / "adaptive.md").write_text(text + "\n")
    print(text)
    return rows, reasons, agreements
