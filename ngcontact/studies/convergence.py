"""Order-convergence studies against the paper's estimate (4.12): O(h + k) for P1.

The error quantity of (4.12) is max_n (‖u_n − u_n^h‖_V + ‖φ_n − φ_n^h‖_W + ‖β_n − β_n^h‖_L²(Γ3))
with ‖v‖_V = ‖ε(v)‖ and ‖ξ‖_W = ‖∇ξ‖ (L²(Ω)). Each part is recorded, as a maximum over
the steps and at the final time, for every order and level, with ndof, Newton iterations
and the run's time: its solve time (the time steps' records, ``common.solve_seconds``) and,
apart, what it paid once (``setup_s``: mesh, data, forms, step 0; the error measurement is in
neither). The work–precision chart plots the solve time. Two kinds of exact solution:

* ``manufactured_study``: ``scenes.manufactured.ContactManufactured`` (known contact set,
  the contact, adhesion and conduction laws satisfied exactly), on the plate [0, 1] × [0, 0.5]
  refined by ``mesh.Refine()`` (nested, h halves per level).
* ``reference_study``: the reference scene (``scenes.reference``), against a fine solution
  computed with the same time steps at level ``levels`` (one finer than the finest compared)
  and order ``max(orders)``. In SI units ‖ε(u)‖ (m) and ‖∇φ‖ (V) cannot be added, so each
  part is divided by the largest norm of the reference solution's part over the run: the
  total is a sum of relative errors. The coarse solutions are compared with it on the fine
  mesh: nested meshes make every coarse finite element function exactly representable
  there, and ``GridFunction.Set`` on the fine mesh (point search across meshes) transfers it
  exactly; β, piecewise constant on coarse facets that are unions of fine facets, is read
  at the fine facet midpoints.
"""
import math
import time as wallclock
from dataclasses import asdict, dataclass, field

import ngsolve as ngs
import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import checks, parallel
from ngcontact.geometries import plate
from ngcontact.output.progress import bar
from ngcontact.scenes import reference
from ngcontact.scenes.manufactured import ContactManufactured, t as t_symbol

from . import common
from .common import CaseStore, fitted_slope, write_csv

PARTS = ("u", "phi", "beta")
CASES = ("viscous", "adhesive", "reference")
"""The cases of ``command``: manufactured solutions, or the reference scene."""
MANUFACTURED_PLATE, MANUFACTURED_MAXH, REFERENCE_MAXH = (1.0, 0.5), 0.25, 0.01
"""The plate (L1, L2) and coarsest mesh size of the manufactured cases, and the coarsest
mesh size of the reference case, m (the defaults of the studies)."""
MAX_SMOOTHNESS, MAX_HALVINGS = 12, 12
"""Bounds of ``command``'s smoothness (exponent of the manufactured u at the contact-set
ends) and dt halvings (the finest run has 4 · 2^11 steps)."""


@dataclass
class Run:
    """One solve of a study: errors are dicts over PARTS and "total" (= their sum); h the
    mesh size (m or the plate's unit), dt the time step (s); setup_s and solve_s its times
    (s, the module docstring; nan for a run kept by a version that did not split them)."""
    order: int
    level: int
    h: float
    dt: float
    ndof: int
    error_max: dict
    error_final: dict
    newton_iterations: list = field(default_factory=list)
    setup_s: float = math.nan
    solve_s: float = math.nan
    rates: dict = field(default_factory=dict)


def _run(data):
    """A Run from its CaseStore dict (the fields it knows: a kept run's total ``wall_s`` is
    dropped, it mixed the one-off costs into the solve)."""
    return Run(**{k: v for k, v in data.items() if k in Run.__dataclass_fields__})


def scaled_pzt(tau=0.3):
    """PZT-5A in scaled units (c / 1e10, e, ε / 1e-9) with A = τ F: strong coupling, O(1) data."""
    m = ngc.pzt5a()
    return ngc.Material(m.c / 1e10, m.e, m.eps / 1e-9, tau * m.c / 1e10, name="scaled PZT-5A")


def _with_total(errors):
    return {**errors, "total": sum(errors[p] for p in PARTS)}


def _measured_run(sim, dt, T, measure):
    """Step ``sim`` to T with ``Simulation.run`` (cut-backs included), measuring the error
    parts after every step; returns (max, final, the seconds the measurement took)."""
    worst = dict.fromkeys(PARTS, 0.0)
    last = {}
    spent = [0.0]

    def after(record):
        t0 = wallclock.perf_counter()
        last.update(measure())
        worst.update({p: max(worst[p], last[p]) for p in PARTS})
        spent[0] += wallclock.perf_counter() - t0
    sim.run(dt, T, on_step=after)
    return _with_total(worst), _with_total(last), spent[0]


def _stored(store, args):
    """_manufactured_run(*args), or its Run from the CaseStore ``store``."""
    key = "manufactured " + " ".join(map(str, args))
    return (store or CaseStore(None)).get(key, lambda: _manufactured_run(*args), asdict, _run)


def manufactured_study(orders=(1, 2), levels=3, case="viscous", dt=0.25, T=1.0, maxh=MANUFACTURED_MAXH,
                       time_profile="linear", smoothness=4, theta=1, gamma0=10.0, progress=True, store=None):
    """Errors against ``ContactManufactured`` for every order and level (0 .. levels-1);
    ``store``: a CaseStore that keeps (and, resuming, reuses) each finished run."""
    cases = [(order, level) for order in orders for level in range(levels)]
    runs = []
    with bar(len(cases), f"convergence ({case})", progress, unit="run") as shown:
        for order, level in cases:
            runs.append(_stored(store, (order, level, case, dt, T, maxh, time_profile, smoothness, theta, gamma0)))
            shown.write(_line(runs[-1]))
            shown.update()
    return add_rates(runs)


def time_study(order=2, level=2, halvings=4, case="viscous", dt0=0.25, T=1.0, maxh=MANUFACTURED_MAXH,
               smoothness=4, progress=True, store=None, scheme="backward_euler"):
    """Errors for dt = dt0 / 2^j (j < halvings) on one mesh: the time-step part of (4.12);
    ``scheme``: the time scheme (``ngcontact.schemes``)."""
    runs = []
    extra = () if scheme == "backward_euler" else (scheme,)      # the keys of earlier stores unchanged
    with bar(halvings, "convergence in dt", progress, unit="run") as shown:
        for j in range(halvings):
            runs.append(_stored(store, (order, level, case, dt0 / 2**j, T, maxh, "nonlinear", smoothness, 1, 10.0)
                                + extra))
            shown.write(_line(runs[-1]))
            shown.update()
    return add_rates(runs, by="dt")


def _manufactured_run(order, level, case, dt, T, maxh, time_profile, smoothness, theta, gamma0,
                      scheme="backward_euler"):
    start = wallclock.perf_counter()
    mesh = plate(*MANUFACTURED_PLATE, maxh=maxh, refine=level)
    body = ngc.Body(mesh, scaled_pzt(), clamped="left", grounded="top", contact_side="bottom", order=order)
    mms = ContactManufactured(body.tensors, case=case, time_profile=time_profile, smoothness=smoothness)
    time = ngs.Parameter(0.0)
    with ngs.TaskManager():
        sim = ngc.Simulation(body, mms.loads(body, time), contact=mms.contact(time, theta, gamma0), time=time,
                             u0=mms.cf(mms.u.subs(t_symbol, 0), time), keep_states=False, scheme=scheme,
                             physical_checks=False)      # unit-size manufactured fields: scale-free

        worst, final, measured = _measured_run(sim, dt, T, lambda: dict(zip(PARTS, mms.errors(sim)
                                                                              + (mms.beta_error(sim),))))
    setup, solve = common.split_seconds(wallclock.perf_counter() - start, sim.history, measured)
    return Run(order, level, maxh / 2**level, dt, body.ndof, worst, final,
               [int(n) for n in sim.history.newton_iterations[1:]], setup, solve)


def reference_study(orders=(1, 2), levels=3, steps=80, T=0.25, maxh=REFERENCE_MAXH, reference_order=None,
                    reference_level=None, progress=True, store=None):
    """Relative errors of the reference scene against a fine solution, ``steps`` time steps
    over [0, T] for each (``T``: contact growth, release, the start of debonding).
    ``store``: a CaseStore; the fine run streams into its directory (and resumes from it) and
    each finished case is kept there."""
    store = store or CaseStore(None)
    reference_order = reference_order or max(orders)
    reference_level = levels if reference_level is None else reference_level
    dt = T / steps
    cases = [(order, level) for order in orders for level in range(levels)]
    with bar(len(cases) + 1, "convergence (reference scene)", progress, unit="run") as shown:
        shown.write(f"reference: order {reference_order}, level {reference_level}")
        fine = reference.simulation(reference_order, maxh, reference_level)
        streamed = None if store.dir is None else store.dir / f"fine P{reference_order} L{reference_level} {steps} {T}"
        if streamed is not None and store.resume and (streamed / "run.json").exists():
            fine.resume(streamed)
        with ngs.TaskManager():
            if fine.t < T * (1 - 1e-12):
                fine.run(dt=dt, T=T, out=streamed)
        shown.update()
        fine_states = [fine.state(n) for n in range(len(fine.history))]
        fine_side, mesh = fine.side, fine.body.mesh

        def norm(cf):
            return math.sqrt(ngs.Integrate(ngs.InnerProduct(cf, cf), mesh))
        scale = dict(u=max(norm(ngs.Sym(ngs.Grad(g.components[0]))) for g in fine_states),
                     phi=max(norm(ngs.grad(g.components[1])) for g in fine_states),
                     beta=math.sqrt(np.dot(np.ones_like(fine_side.measure), fine_side.measure)))
        runs = []

        def solved(order, level):
            start = wallclock.perf_counter()
            sim = reference.simulation(order, maxh, level)
            transfer = ngs.GridFunction(fine.body.X)
            with ngs.TaskManager():
                def measure():
                    n = len(sim.history) - 1
                    for i in range(2):
                        transfer.components[i].Set(sim.gfu.components[i])
                    ref = fine_states[n]
                    eu = ngs.Sym(ngs.Grad(ref.components[0]) - ngs.Grad(transfer.components[0]))
                    dphi = ngs.grad(ref.components[1]) - ngs.grad(transfer.components[1])
                    beta_c = _facet_lookup(sim.side, fine_side.midpoints, sim.beta.values)
                    beta_f = fine.history[n].contact.beta
                    return dict(u=norm(eu) / scale["u"], phi=norm(dphi) / scale["phi"],
                                beta=math.sqrt(np.dot((beta_f - beta_c) ** 2, fine_side.measure)) / scale["beta"])
                worst, final, measured = _measured_run(sim, dt, T, measure)
            setup, solve = common.split_seconds(wallclock.perf_counter() - start, sim.history, measured)
            return Run(order, level, maxh / 2**level, dt, sim.body.ndof, worst, final,
                       [int(k) for k in sim.history.newton_iterations[1:]], setup, solve)
        for order, level in cases:
            key = f"reference P{order} L{level} {steps} {T} {maxh} fine P{reference_order} L{reference_level}"
            runs.append(store.get(key, lambda: solved(order, level), asdict, _run))
            shown.write(_line(runs[-1]))
            shown.update()
    return add_rates(runs)


def _facet_lookup(side, points, values):
    """Values of a facet field of ``side`` at points lying on its facets (nested meshes)."""
    out = np.empty(len(points))
    a, b = side.facet_vertices[:, 0], side.facet_vertices[:, 1]
    for i, p in enumerate(points):
        d = b - a
        s = np.einsum("fd,fd->f", p - a, d) / np.einsum("fd,fd->f", d, d)
        dist = np.linalg.norm(a + s[:, None] * d - p, axis=1) + np.where((s < 0) | (s > 1), 1.0, 0.0)
        out[i] = values[np.argmin(dist)]
    return out


def add_rates(runs, by="h"):
    """Observed rates log(e_i / e_{i+1}) / log(x_i / x_{i+1}) between consecutive runs of an
    order, x = h or dt."""
    for order in {r.order for r in runs}:
        seq = [r for r in runs if r.order == order]
        for prev, run in zip(seq[:-1], seq[1:]):
            ratio = math.log(getattr(prev, by) / getattr(run, by))
            run.rates = {p: (math.log(prev.error_max[p] / run.error_max[p]) / ratio
                             if prev.error_max[p] > 0 and run.error_max[p] > 0 else float("nan"))
                         for p in (*PARTS, "total")}
    return runs


def fitted_rate(runs, order, part="total", by="h", last=3):
    """Least-squares slope of log(error) against log(h or dt) over the last runs of an order
    (nan from fewer than three runs)."""
    seq = [r for r in runs if r.order == order][-last:]
    return fitted_slope([getattr(r, by) for r in seq], [r.error_max[part] for r in seq])


def _line(run):
    errors = "  ".join(f"{p} {run.error_max[p]:.3e}" for p in (*PARTS, "total"))
    return (f"order {run.order} level {run.level} h {run.h:.4g} dt {run.dt:.4g} ndof {run.ndof:7d}  "
            f"{errors}  newton {sum(run.newton_iterations)}  setup {run.setup_s:.2f} s  solve {run.solve_s:.2f} s")


def rows(runs):
    """The runs as flat rows, the columns of errors.csv: order, level, h, dt, ndof, each
    error part (max over steps, and final), empirical rates, Newton iterations, setup_s and
    solve_s (the module docstring)."""
    return [dict(order=r.order, level=r.level, h=r.h, dt=r.dt, ndof=r.ndof,
                 **{f"error_{p}": r.error_max[p] for p in (*PARTS, "total")},
                 **{f"error_{p}_final": r.error_final[p] for p in (*PARTS, "total")},
                 **{f"rate_{p}": r.rates.get(p, float("nan")) for p in (*PARTS, "total")},
                 newton_iterations=sum(r.newton_iterations), setup_s=r.setup_s, solve_s=r.solve_s) for r in runs]


CHARTS = {"h": [("h", "mesh size h", "error_vs_h.png"), ("ndof", "ndof", "error_vs_ndof.png"),
                 ("solve_s", "solve time: the time steps [s] (one run each; setup apart)", "work_precision.png")],
          "dt": [("dt", "time step dt [s]", "error_vs_dt.png")]}
"""The charts of ``plot`` by the variable of the study: (the Run's field on x, its label, the file)."""


def chart(runs, attr, label, title):
    """The Figure of the errors of ``runs`` against their field ``attr`` (h or dt with slope
    guides; ``solve_s``: the work–precision chart, the solve time and not the one-off costs)."""
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for i, order in enumerate(sorted({r.order for r in runs})):
        seq = [r for r in runs if r.order == order]
        xs = np.array([getattr(r, attr) for r in seq])
        for part, style in (("total", "o-"), ("u", "s--"), ("beta", "^:")):
            ys = np.array([r.error_max[part] for r in seq])
            if np.all(ys > 0):
                ax.loglog(xs, ys, style, color=f"C{i}", ms=4,
                          label=f"P{order} {'(4.12) total' if part == 'total' else part}")
        if attr in ("h", "dt"):
            slope = order if attr == "h" else 1
            e0 = seq[0].error_max["u"] or seq[0].error_max["total"]
            ax.loglog(xs, e0 * (xs / xs[0]) ** slope, color=f"C{i}", lw=0.6, alpha=0.6)
    ax.set(xlabel=label, ylabel="max over steps of the error", title=title)
    if attr in ("h", "dt"):
        ax.text(0.02, 0.02, "thin lines: slope guides h^p (dt^1)", transform=ax.transAxes, fontsize=7)
    ax.legend(fontsize=6, ncol=2)
    return fig


def plot(runs, out, title, by="h"):
    """The charts of ``CHARTS[by]`` in ``out``: error vs h, vs ndof, vs solve time
    (work–precision; the one-off costs apart in errors.csv); or vs dt. Returns their paths."""
    paths = []
    for attr, label, name in CHARTS[by]:
        chart(runs, attr, label, title).savefig(out / name, dpi=120)
        paths.append(out / name)
    return paths


def save(runs, out, title, by="h"):
    """errors.csv and the charts in ``out``; returns the chart paths."""
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows(runs), out / "errors.csv")
    return plot(runs, out, title, by)


def command(orders, levels, case, smoothness, dt_halvings, out, resume=False, scheme="backward_euler", dt0=0.25):
    """``python -m ngcontact convergence``: run the study, write errors.csv and the charts
    into ``out``, print the fitted rates (from three levels or more); with ``dt_halvings``
    the time-step variant with the time ``scheme`` from the step ``dt0`` (s)."""
    parallel.refuse_under_mpiexec("convergence")
    orders = common.orders("--orders", orders)
    levels = checks.integer("--levels", levels, 1, checks.MAX_REFINE)
    case = checks.choice("--case", case, CASES)
    smoothness = checks.integer("--smoothness", smoothness, 3, MAX_SMOOTHNESS)
    dt_halvings = checks.integer("--dt-halvings", dt_halvings, 0, MAX_HALVINGS)
    ngc.schemes.scheme_class(scheme)
    dt0 = checks.number("--dt0", dt0, 0, 1.0, low_open=True, unit="s")
    if dt_halvings and 2 ** (dt_halvings - 1) / dt0 > checks.MAX_STEPS:      # T = 1 s (time_study)
        raise ValueError(f"--dt0 {dt0:g} s halved {dt_halvings - 1} times (--dt-halvings {dt_halvings}): the finest "
                         f"run takes {2 ** (dt_halvings - 1) / dt0:.3g} steps over T = 1 s; at most "
                         f"{checks.MAX_STEPS:,} (--dt0 at least {2 ** (dt_halvings - 1) / checks.MAX_STEPS:g} s)")
    resume = checks.flag("resume", resume)
    manufactured = checks.estimated_vertices(MANUFACTURED_PLATE, MANUFACTURED_MAXH)
    if dt_halvings:                    # the finest run: the first order on level levels - 1
        order, finest, vertices = orders[0], levels - 1, manufactured
    elif case == "reference":          # the fine solution, on level levels (Γ3 at maxh / 2)
        order, finest = max(orders), levels
        vertices = checks.estimated_vertices((reference.L1, reference.L2), REFERENCE_MAXH) + \
            checks.estimated_vertices((reference.L1, REFERENCE_MAXH / 2), REFERENCE_MAXH / 2)
    else:
        order, finest, vertices = max(orders), levels - 1, manufactured
    checks.fits_in_memory(f"--levels {levels}, order {order}",
                          checks.estimated_ndof(vertices, 2, finest, order))
    out = checks.writable_directory(out)
    store = CaseStore(out, resume)                      # each finished run, for --resume
    if dt_halvings:
        runs = time_study(orders[0], levels - 1, dt_halvings, smoothness=smoothness, store=store, scheme=scheme,
                          dt0=dt0)
        paths = save(runs, out, f"time steps ({scheme}), P{orders[0]}, level {levels - 1}", by="dt")
        rate = fitted_rate(runs, orders[0], by='dt')
        print(f"fitted rate in dt: {rate:.2f}" if rate == rate else "no fitted rate in dt: fewer than 3 points")
    else:
        runs = (reference_study(orders, levels, store=store) if case == "reference" else
                manufactured_study(orders, levels, case, smoothness=smoothness, store=store))
        paths = save(runs, out, f"{case}: error (4.12) and its parts")
        for order in orders:
            rates = {p: fitted_rate(runs, order, p) for p in ("u", "phi", "total")}
            if levels < 3:
                print(f"P{order}: no fitted rates from {levels} level(s) (3 or more are needed)")
            else:
                print(f"P{order}: fitted rates " + ", ".join(f"{p} {r:.2f}" for p, r in rates.items()))
    print(f"wrote {out / 'errors.csv'} and " + ", ".join(p.name for p in paths))
