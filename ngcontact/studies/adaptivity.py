"""Adaptive against uniform refinement: error, estimate and effectivity against DOFs and wall time
(``python -m ngcontact adapt``, docs/adaptivity.md).

For each scene and order the same initial mesh is refined level by level twice with
``ngcontact.adapt``: uniformly (``fraction=1``: every element refined) and adaptively (Dörfler
``fraction`` 0.5 of the estimate²), each level starting Newton from the one below, both up to
the scene's DOF limit. Scenes (``SCENES``):

* ``manufactured``: the manufactured glued contact case (``ContactManufactured``, case
  "adhesive": compliant layer, glue, conduction, a known contact set) on an elastic scaled
  PZT-5A, one static step, with smoothness 4 at the ends of the contact set (u ∈ H^{7/2−ε}
  there, f0 continuous with a kink): the exact energy error |||e||| and the effectivity
  η/|||e|||. Smoothness 3 (u ∈ H^{5/2−ε}, as a real contact solution) makes f0 jump across
  the end of the contact set, inside elements: the load's quadrature misses the jump by O(h),
  an error of the data that no estimate of the discrete problem sees (the P2 effectivity falls
  away from 1, and more quadrature orders do not restore it: docs/measurements.md, section
  adaptivity), docs/adaptivity.md;
* ``hertz``: the 2D Hertz half-disk pushed down by 0.02 R (one step): the energy error
  against an adaptive P3 reference (``REFERENCE_NDOF``; its own estimate says how close it
  is), the effectivity, and the pressure error against Hertz's closed form (itself an
  approximation at this a/R: docs/measurements.md, section adaptivity);
* ``hertz3d``: the half-ball (P1): the estimate and the pressure error;
* ``reference``: the reference plate's push, hold and pull over [0, T] (T in s: 0.25; 25 steps; the estimate every fifth step, the largest over them marks the next mesh:
  ``adapt.history``): the energy error at T (the last step's norm, C_c = F + A/k) against
  an adaptive P3 reference; its effectivity uses the estimate of that last step, which bounds
  the error of the step problem and not the error carried from the steps before.

The error measure of a scene (``measure``): the energy error where it is known, else the
estimate. ``summary`` interpolates (log-log, between levels) the DOFs and the elapsed time at
which the adaptive run reaches the measure of the finest uniform level, and their ratios;
``elapsed`` is the wall time of a whole run up to that level (building, solving and estimating
every level, refining the meshes; not the study's error measurement), one thread.
"""
import math

import ngsolve as ngs
import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import adapt, estimators
from ngcontact.geometries import plate

from ngcontact.output.progress import bar
from ngcontact.scenes import hertz, reference
from ngcontact.scenes.manufactured import ContactManufactured, t as t_symbol

from .common import table, write_csv

COLUMNS = ("scene", "order", "method", "level", "ndof", "estimate", "certified", "relative", "error", "effectivity",
           "pressure_error", "newton", "krylov", "estimate_stops", "build_s", "solve_s", "estimate_s", "elapsed_s")
METHODS = {"uniform": 1.0, "adaptive": 0.5}
"""The Dörfler fraction of each method (1: every element)."""


def _manufactured_material():
    m = ngc.pzt5a()
    return ngc.Material(m.c / 1e10, m.e, m.eps / 1e-9, name="scaled PZT-5A, elastic")


class Scene:
    """A scene of the study: ``mesh(order)`` its initial mesh, ``scene(order)`` the function
    mesh -> Simulation, ``history`` (dt, T, every) or None for one step of length ``dt``,
    ``error(sim)`` the energy error of the solved simulation (exact, or against ``reference``)
    or None, ``pressure(sim)`` the Hertz pressure error or None, and the limits of DOFs and
    levels (the uniform runs stop at the DOF limit, the adaptive ones too, or at the levels')."""

    def __init__(self, name, mesh, scene, dt=1.0, history=None, error=None, pressure=None, max_levels=40,
                 max_ndof=1.2e5):
        self.name, self.mesh, self.scene, self.dt, self.history = name, mesh, scene, dt, history
        self.error, self.pressure, self.max_levels, self.max_ndof = error, pressure, max_levels, max_ndof
        self.reference = None
        """The reference solution's Level (scenes without an exact one), once computed."""


def _manufactured():
    material = _manufactured_material()
    tensors = material.tensors(2)
    mms = ContactManufactured(tensors, case="adhesive", time_profile="linear", smoothness=4, tau=0.0)

    def scene(order):
        def build(mesh):
            body = ngc.Body(mesh, material, clamped="left", grounded="top", contact_side="bottom", order=order)
            time = ngs.Parameter(0.0)
            return ngc.Simulation(body, mms.loads(body, time), contact=mms.contact(time), time=time,
                                  u0=mms.cf(mms.u.subs(t_symbol, 0), time), keep_states=False,
                                  physical_checks=False)
        return build
    return Scene("manufactured", lambda order: plate(1.0, 0.5, maxh=0.25), scene, dt=0.25,
                 error=mms.energy_error)


def _referenced(scene, order, max_ndof):
    """Give ``scene`` the error against a reference: the last level of an adaptive run of
    order ``order`` to ``max_ndof`` DOFs (its own estimate, ``scene.reference.estimate``, bounds
    how far the reference is from the exact solution)."""
    def error(sim):
        if scene.reference is None:
            run_ = run(Scene(scene.name, scene.mesh, scene.scene, scene.dt, scene.history, max_ndof=max_ndof),
                       order, "adaptive")
            scene.reference = run_.last
        ref = scene.reference.sim
        return adapt.energy(sim, (ref.u, ref.phi if ref.electric else None))
    scene.error = error
    return scene


def _hertz(dim):
    def scene(order):
        return lambda mesh: hertz.simulation(order, dim=dim, mesh=mesh, keep_states=False)

    def pressure(sim):
        return hertz.errors(sim)["pressure_L2"] if sim.history[-1].contact.contact_area > 0 else float("nan")
    if dim == 2:
        made = Scene("hertz", lambda order: hertz.mesh(2, h_contact=0.1, curve=order), scene, pressure=pressure)
        return _referenced(made, 3, REFERENCE_NDOF["hertz"])
    return Scene("hertz3d", lambda order: hertz.mesh(3, h_contact=0.15, curve=order), scene, pressure=pressure,
                 max_ndof=3e4)


def _reference():
    def scene(order):
        def build(mesh):
            t = ngs.Parameter(0.0)
            body = ngc.Body(mesh, ngc.pzt5a(relaxation_time=reference.RELAXATION_TIME), clamped="left",
                            grounded="top", contact_side="bottom", order=order)
            return ngc.Simulation(body, reference.loads(t), contact=reference.contact(), time=t, keep_states=False)
        return build
    made = Scene("reference", lambda order: reference.body(1, 0.01).mesh, scene, history=(0.01, 0.25, 5),
                 max_ndof=2e4)
    return _referenced(made, 3, REFERENCE_NDOF["reference"])


REFERENCE_NDOF = {"hertz": 2e5, "reference": 6e4}
"""The DOFs of the adaptive P3 reference solutions."""
SCENES = {"manufactured": _manufactured, "hertz": lambda: _hertz(2), "hertz3d": lambda: _hertz(3),
          "reference": _reference}


def run(scene, order, method, stop_newton=None, on_level=None, marking="equilibrated", fraction=None):
    """The ``adapt.Adaptation`` of ``scene`` (a ``Scene``) at ``order`` by ``method`` ("uniform"
    or "adaptive"; the adaptive one marks by ``marking`` with the Dörfler ``fraction``, None:
    METHODS')."""
    adaptive = method == "adaptive"
    options = dict(fraction=fraction if adaptive and fraction is not None else METHODS[method],
                   max_levels=scene.max_levels, max_ndof=scene.max_ndof, stop_newton=stop_newton, on_level=on_level)
    if scene.history is None:
        return adapt.step(scene.scene(order), scene.mesh(order), scene.dt,
                          marking=marking if adaptive else "equilibrated", **options)
    if adaptive and marking != "equilibrated":
        raise ValueError(f"--marking {marking}: the history scenes (reference) mark by the equilibrated estimate only")
    dt, T, every = scene.history
    return adapt.history(scene.scene(order), scene.mesh(order), dt, T, every=every, **options)


def study(names=("manufactured", "hertz"), orders=(1, 2), stop_newton=None, progress=True, marking="equilibrated",
          fraction=None):
    """Rows (``COLUMNS``) of every level of every (scene, order, method), and the references
    ({scene: its reference Level}). A level the loop did not certify (``marking="averaging"``)
    gets its equilibrated bound here, outside the loop's time (``certified`` False)."""
    rows, references = [], {}
    cases = [(name, order, method) for name in names for order in orders for method in METHODS
             if not (name == "hertz3d" and order > 1)]
    scenes = {name: SCENES[name]() for name in names}
    with bar(len(cases), "adaptivity", progress, unit="run") as shown:
        for name, order, method in cases:
            scene = scenes[name]
            mine = []

            def record(level, scene=scene, order=order, method=method, mine=mine):
                error = scene.error(level.sim) if scene.error else float("nan")
                # the estimate of the state the error is measured at: a history's last step
                certified = level.certified
                estimate = level.estimate if certified else estimators.EquilibratedEstimator(level.sim)().total
                final = estimate if scene.history is None else estimators.EquilibratedEstimator(level.sim)().total
                mine.append(dict(scene=scene.name, order=order, method=method, level=len(mine), ndof=level.ndof,
                                 estimate=estimate, certified=certified,
                                 relative=level.relative if certified else estimate / adapt.energy(level.sim),
                                 error=error,
                                 effectivity=final / error if error == error and error > 0 else float("nan"),
                                 pressure_error=scene.pressure(level.sim) if scene.pressure else float("nan"),
                                 newton=level.newton, krylov=level.krylov, estimate_stops=level.estimate_stops,
                                 build_s=level.build_s, solve_s=level.solve_s, estimate_s=level.estimate_s,
                                 elapsed_s=level.elapsed_s,
                                 mesh=level.mesh))
            result = run(scene, order, method, stop_newton, on_level=record, marking=marking, fraction=fraction)
            rows += mine
            shown.write(f"{name} P{order} {method}: {len(result.levels)} levels, {result.last.ndof} DOFs, "
                        f"η {result.last.estimate:.3g} ({result.reason})")
            shown.update()
    for name, scene in scenes.items():
        if scene.reference is not None:
            references[name] = scene.reference
    return rows, references


def measure(rows):
    """The error measure of the rows' scene: the exact error where known, else the estimate."""
    return "error" if all(r["error"] == r["error"] for r in rows) else "estimate"


def _reach(rows, value, key, what):
    """The ``what`` (ndof or elapsed_s) at which the rows (one run, by level) reach ``value`` of
    ``key``, interpolated log-log; None if they never do."""
    for a, b in zip(rows, rows[1:]):
        if a[key] > value >= b[key]:
            f = math.log(value / a[key]) / math.log(b[key] / a[key])
            return math.exp(math.log(a[what]) + f * math.log(b[what] / a[what]))
    hits = [r[what] for r in rows if r[key] <= value]
    return min(hits) if hits else None


def summary(rows):
    """Per (scene, order): the finest uniform level's measure and DOFs; the DOFs and elapsed
    time at which the adaptive run reaches that measure, and the ratios: ``dof_ratio``, and
    three time ratios against three uniform costs: ``time_ratio_loop`` (the uniform loop to its
    finest level with an estimate on each, as the adaptive one), ``time_ratio_solves`` (the
    uniform builds and solves alone, every level: a convergence study) and
    ``time_ratio_finest`` (the finest uniform level's build and solve alone, as if its mesh had
    been known)."""
    out = []
    for scene, order in dict.fromkeys((r["scene"], r["order"]) for r in rows):
        mine = [r for r in rows if (r["scene"], r["order"]) == (scene, order)]
        key = measure(mine)
        uniform = [r for r in mine if r["method"] == "uniform"]
        adaptive = [r for r in mine if r["method"] == "adaptive"]
        finest = uniform[-1]
        ndof = _reach(adaptive, finest[key], key, "ndof")
        elapsed = _reach(adaptive, finest[key], key, "elapsed_s")
        costs = dict(loop=finest["elapsed_s"], solves=sum(r["build_s"] + r["solve_s"] for r in uniform),
                     finest=finest["build_s"] + finest["solve_s"])
        out.append(dict(scene=scene, order=order, measure=key, uniform_value=finest[key], uniform_ndof=finest["ndof"],
                        adaptive_ndof=ndof, dof_ratio=finest["ndof"] / ndof if ndof else None,
                        adaptive_elapsed_s=elapsed, **{f"uniform_{k}_s": v for k, v in costs.items()},
                        **{f"time_ratio_{k}": v / elapsed if elapsed else None for k, v in costs.items()},
                        effectivity_range=_effectivities(mine)))
    return out


def _effectivities(rows):
    values = [r["effectivity"] for r in rows if r["effectivity"] == r["effectivity"]]
    return f"{min(values):.2f}-{max(values):.2f}" if values else ""


def charts(rows, out):
    """error (or estimate) against DOFs and against elapsed time, one panel per scene; and a few
    adaptive meshes of each 2D scene (of rows that hold their ``mesh``: not those read back from
    errors.csv)."""
    names = list(dict.fromkeys(r["scene"] for r in rows))
    for what, label, name in (("ndof", "DOFs", "adapt_dofs.png"), ("elapsed_s", "elapsed wall time (s)",
                                                                     "adapt_time.png")):
        fig = Figure(figsize=(5.0 * len(names), 4.4))
        for k, scene in enumerate(names):
            ax = fig.add_subplot(1, len(names), k + 1)
            mine = [r for r in rows if r["scene"] == scene]
            key = measure(mine)
            for order in dict.fromkeys(r["order"] for r in mine):
                for method, style in (("uniform", "o--"), ("adaptive", "s-")):
                    run_ = [r for r in mine if r["order"] == order and r["method"] == method]
                    if run_:
                        ax.loglog([r[what] for r in run_], [r[key] for r in run_], style, markersize=4,
                                  label=f"P{order} {method}")
                if key == "error":
                    run_ = [r for r in mine if r["order"] == order and r["method"] == "adaptive"]
                    ax.loglog([r[what] for r in run_], [r["estimate"] for r in run_], ":", color="grey",
                              linewidth=0.8, label=f"P{order} adaptive, estimate" if order == 1 else None)
            ax.set_xlabel(label)
            ax.set_ylabel("energy error |||e|||" if key == "error" else "estimate η (J^½)")
            ax.set_title(scene)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / name, dpi=110)
    for scene in names:
        adaptive = [r for r in rows if r["scene"] == scene and r["method"] == "adaptive"
                    and r.get("mesh") is not None and r["mesh"].dim == 2]
        if not adaptive:
            continue
        order = max(r["order"] for r in adaptive)
        levels = [r for r in adaptive if r["order"] == order]
        shown = [levels[0], levels[len(levels) // 2], levels[-1]]
        fig = Figure(figsize=(4.2 * len(shown), 3.6))
        for k, r in enumerate(shown):
            ax = fig.add_subplot(1, len(shown), k + 1)
            mesh = r["mesh"]
            points = np.array([v.point for v in mesh.vertices])
            triangles = [[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)]
            ax.triplot(points[:, 0], points[:, 1], triangles, linewidth=0.3, color="k")
            ax.set_aspect("equal")
            ax.set_title(f"level {r['level']}: {r['ndof']} DOFs", fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
        fig.suptitle(f"{scene}, P{order}: adaptive meshes")
        fig.tight_layout()
        fig.savefig(out / f"meshes_{scene}.png", dpi=110)


def main(out, scenes=("manufactured", "hertz"), orders=(1, 2), stop_newton=None, marking="equilibrated",
         fraction=None):
    """Run the study into the directory ``out``: errors.csv (every level), summary.csv,
    references.csv (the reference solutions: DOFs, their own estimate), the charts; the summary
    printed. Returns (rows, summary)."""
    from ngcontact import checks, parallel
    from .common import orders as checked_orders
    parallel.refuse_under_mpiexec("adapt")
    scenes = [scenes] if isinstance(scenes, str) else list(scenes)
    for name in scenes:
        if name not in SCENES:
            raise ValueError(f"--scene must be among {', '.join(SCENES)}, got {name!r}")
    scenes = list(dict.fromkeys(scenes))
    orders = checked_orders("--orders", list(orders))
    if stop_newton is not None:
        stop_newton = checks.number("--stop-newton", stop_newton, 0, 1, low_open=True)
    if not any(name != "hertz3d" or order == 1 for name in scenes for order in orders):     # study's cases
        raise ValueError(f"--scene {' '.join(scenes)} with --orders {' '.join(map(str, orders))}: nothing to run "
                         "(hertz3d runs P1 only); add --orders 1 or another --scene")
    if "hertz3d" in scenes and any(order > 1 for order in orders):
        print(f"note: hertz3d runs P1 only; its P{', P'.join(str(p) for p in orders if p > 1)} skipped")
    if marking not in adapt.MARKINGS:
        raise ValueError(f"--marking must be one of {', '.join(adapt.MARKINGS)}, got {marking!r}")
    if marking != "equilibrated" and "reference" in scenes:
        raise ValueError(f"--marking {marking}: the reference plate (a history) marks by the equilibrated estimate "
                         "only; run it without --marking")
    if fraction is not None:
        fraction = checks.number("--fraction", fraction, 0, 1, low_open=True)
    out = checks.writable_directory(out)
    rows, references = study(scenes, orders, stop_newton, marking=marking, fraction=fraction)
    write_csv(rows, out / "errors.csv", COLUMNS)
    result = summary(rows)
    write_csv(result, out / "summary.csv")
    if references:
        write_csv([dict(scene=name, order=level.sim.body.order, ndof=level.ndof, estimate=level.estimate,
                        elapsed_s=level.elapsed_s) for name, level in references.items()], out / "references.csv")
    charts(rows, out)
    print(table(result, ["scene", "order", "measure", "uniform_value", "uniform_ndof", "adaptive_ndof", "dof_ratio",
                         "adaptive_elapsed_s", "time_ratio_loop", "time_ratio_solves", "time_ratio_finest",
                         "effectivity_range"]))
    for name, level in references.items():
        print(f"{name}: reference P{level.sim.body.order}, {level.ndof} DOFs, its estimate {level.estimate:.3g}")
    return rows, result


TOL_FLOOR = 1e-6
"""The smallest ``--tol``: extrapolated from the certified tolerances of the P2 Hertz disk against
its DOFs (fitted to measurements on it: docs/measurements.md, section adaptivity), 1e-6 lies far
beyond a scene's DOF limit (``Scene.max_ndof``, 1.2e5) and needs the memory of the largest
machines (``checks.MEMORY_PER_DOF``), and the energy of the error there nears the round-off of a
state solved to Newton's relative residual of 1e-10. A smaller tol could not be met on any
machine; one between it and what a scene's limit reaches ends "NOT reached" (exit status 1 on
the command line)."""


def to_tolerance(tol, scenes=("hertz",), orders=(2,), fraction=None, progress=True, marking=None, stop_newton=None,
                 out=None, goal="energy"):
    """``adapt.solve`` on each step scene's initial mesh to the relative estimate ``tol`` (in
    [``TOL_FLOOR``, 1)): print every level (DOFs, averaging indicator, the bound where
    certified, times) and the certificate reached, or that it was not and why (a limit came
    first); returns {(scene, order): Adaptation}. ``marking``, ``stop_newton`` and ``fraction``
    go to ``adapt.solve`` (None: its defaults, averaging marking and, for the energy goal,
    Newton stopped at 0.1 of the expected estimate). ``out``: a directory (or None) that receives, as each adaptation
    ends, ``tolerance.csv`` (every level of every adaptation so far: scene, order, level, ndof,
    indicator, estimate and relative where certified (J^½; (J/m)^½ in 2D), wall times in s),
    ``tolerance.json`` (per adaptation: tol, reached, reason, the last level's ndof and
    relative estimate, and the levels) and each level's mesh, ``<scene>_P<order>_level<k>.vol``
    (Netgen's format). Checked before any work; hertz3d runs P1 only, and scenes and
    orders that leave nothing to run are refused. ``goal`` (``adapt.GOALS``): what ``tol``
    bounds, the energy (certified) or the contact pressure or force (their estimates, the level's
    ``goal_estimate``; no certificate)."""
    from ngcontact import checks, parallel
    from .common import orders as checked_orders
    parallel.refuse_under_mpiexec("adapt")
    tol = checks.number("--tol", tol, TOL_FLOOR, 1, high_open=True)
    scenes = [scenes] if isinstance(scenes, str) else list(dict.fromkeys(scenes))
    for name in scenes:
        if name not in SCENES:
            raise ValueError(f"--scene must be among {', '.join(SCENES)}, got {name!r}")
        if name == "reference":
            raise ValueError("--tol solves one step to a tolerance; the reference plate is a load history: "
                             "run it without --tol")
    orders = checked_orders("--orders", list(orders))
    if not any(name != "hertz3d" or order == 1 for name in scenes for order in orders):
        raise ValueError(f"--scene {' '.join(scenes)} with --orders {' '.join(map(str, orders))}: nothing to solve "
                         "to --tol (hertz3d runs P1 only); add --orders 1 or another --scene")
    options = {}
    if fraction is not None:
        options["fraction"] = checks.number("--fraction", fraction, 0, 1, low_open=True)
    if stop_newton is not None:
        options["stop_newton"] = checks.number("--stop-newton", stop_newton, 0, 1, low_open=True)
    if marking is not None:
        if marking not in adapt.MARKINGS:
            raise ValueError(f"--marking must be one of {', '.join(adapt.MARKINGS)}, got {marking!r}")
        options["marking"] = marking
    options["goal"] = checks.choice("--goal", goal, adapt.GOALS)
    if goal != "energy" and marking == "equilibrated":
        raise ValueError(f"--marking equilibrated with --goal {goal}: the goal marks by its own estimate and the "
                         "averaging indicator; drop --marking or use --goal energy")
    if out is not None:
        out = checks.writable_directory(out)
    results, written = {}, []
    for name in scenes:
        scene = SCENES[name]()
        for order in orders:
            if name == "hertz3d" and order > 1:
                print(f"note: hertz3d runs P1 only; P{order} skipped")
                continue
            result = adapt.solve(scene.scene(order), scene.mesh(order), tol, dt=scene.dt,
                                 max_ndof=scene.max_ndof, **options)
            rows = [dict(level=k, ndof=level.ndof, indicator=level.indicator,
                         estimate=level.estimate if level.certified else "", relative=level.relative
                         if level.certified else "", build_s=level.build_s, solve_s=level.solve_s,
                         estimate_s=level.estimate_s, elapsed_s=level.elapsed_s,
                         **({} if goal == "energy" else {f"{goal}_estimate": level.goal_estimate,
                                                         "edge_bisections": level.edge_bisections}))
                    for k, level in enumerate(result.levels)]
            print(f"{name} P{order}, tol {tol:g}:")
            print(table(rows, list(rows[0])))
            last = result.last
            pressure = f", Hertz pressure error {scene.pressure(last.sim):.3%}" if scene.pressure else ""
            if result.reached and goal != "energy":
                print(f"reached: relative {goal} estimate {last.goal_estimate:.3g} <= {tol:g} at {last.ndof} DOFs in "
                      f"{last.elapsed_s:.2f} s (an estimate, not a bound){pressure}")
            elif result.reached:
                print(f"certified: relative estimate {last.relative:.3g} <= {tol:g} at {last.ndof} DOFs in "
                      f"{last.elapsed_s:.2f} s{pressure}")
            elif result.reason == "no contact":
                print(f"NOT reached (no contact): Γ3 carries no contact {goal} at {last.ndof} DOFs, so its relative "
                      f"error is undefined (adapt for goal 'energy' instead)")
            else:
                achieved = last.relative if goal == "energy" else last.goal_estimate
                named = "" if goal == "energy" else f"{goal} "
                print(f"NOT reached ({result.reason}{limit(result, scene)}): relative {named}estimate {achieved:.3g} "
                      f"> {tol:g} at {last.ndof} DOFs in {last.elapsed_s:.2f} s{pressure}")
            results[(name, order)] = result
            if out is not None:
                written.append(dict(scene=name, order=order, tol=tol, goal=goal, reached=result.reached,
                                    reason=result.reason, ndof=last.ndof, relative=last.relative,
                                    goal_estimate=last.goal_estimate, levels=rows))
                _write_tolerance(out, written, result)
    return results


def _write_tolerance(out, written, result):
    """The files of ``to_tolerance`` in the directory ``out`` after an adaptation (``result``,
    the last of ``written``: its meshes; the tables of all so far)."""
    import json
    last = written[-1]
    for k, level in enumerate(result.levels):
        level.mesh.ngmesh.Save(str(out / f"{last['scene']}_P{last['order']}_level{k}.vol"))
    rows = [dict(scene=w["scene"], order=w["order"], **row) for w in written for row in w["levels"]]
    write_csv(rows, out / "tolerance.csv")

    def plain(value):
        return None if isinstance(value, float) and not math.isfinite(value) else value
    tables = [{k: ([{c: plain(v) for c, v in row.items()} for row in w[k]] if k == "levels" else plain(w[k]))
               for k in w} for w in written]
    (out / "tolerance.json").write_text(json.dumps(tables, indent=1))


def limit(result, scene):
    """The limit that stopped an adaptation that did not reach its target, for a line ("" for
    another reason)."""
    if result.reason == "DOF limit":
        return f" {scene.max_ndof:.3g}"
    if result.reason == "level limit":
        return f" {len(result.levels)}"
    return ""
