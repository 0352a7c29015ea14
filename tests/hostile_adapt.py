"""Hostile inputs of class ``adapt`` (``tests/test_hostile.py``): adaptive meshes
(``ngcontact.adapt``: ``step``, ``history``, ``mark``, ``energy``), the equilibrated estimator
(``ngcontact.estimators``) and ``python -m ngcontact adapt``.

Every bad value of the adaptation's own parameters (the Dörfler fraction, the tolerance, the
limits of levels and DOFs, adaptive stopping, the time step, a history's options) is refused
before the first solve, naming the parameter; so are a scene that is not a function of the mesh
or returns something else than a Simulation on that mesh, a mesh that is not an ngsolve.Mesh or
cannot be refined, what the estimator cannot estimate (a nonlinear law, a weak normal support)
and callbacks that are not functions. Where the input is unusual but meaningful (every element
marked, a tiny fraction, a target met at once, a zero solution, static condensation, no
contact, a polygonal mesh without geometry) the adaptation completes and is checked. The CLI
cases call ``ngcontact.cli.main`` in the case's process (``command_line``); the MPI cases
launch ``mpiexec -n 2`` and are ``slow``.
"""
import functools
import os
import subprocess
import sys

CLASSES = ("adapt",)

_MPI_STEP = """
import warnings
warnings.simplefilter("ignore")
import ngsolve as ngs
import ngcontact as ngc
from ngcontact import adapt
from ngcontact.geometries import plate
from ngcontact.scenes import reference
mesh = plate(maxh=0.01, maxh_contact=0.005)
def scene(mesh):
    t = ngs.Parameter(0.0)
    body = ngc.Body(mesh, ngc.pzt5a(relaxation_time=2e-3), clamped="left", grounded="top", contact_side="bottom")
    return ngc.Simulation(body, reference.loads(t), contact=reference.contact(), time=t)
try:
    adapt.step(scene, mesh, 0.05, max_levels=2)
    print("completed")
except ValueError as err:
    print("ValueError:", err)
"""


def register(h):
    VE, TE, CHOICE, NAN, INF = h.VE, h.TE, h.CHOICE, h.NAN, h.INF

    # ------------------------------------------------------------------ scenes (built in the case's process)

    @functools.cache
    def half_disk():
        """The coarse Hertz half-disk (23 triangles)."""
        from ngcontact.scenes import hertz
        return hertz.mesh(2, h_contact=0.2)

    def other_disk():
        """A mesh like ``half_disk`` but another object."""
        from ngcontact.scenes import hertz
        return hertz.mesh(2, h_contact=0.2)

    def hertz(mesh, order=1, **options):
        from ngcontact.scenes import hertz as scene
        return scene.simulation(order, mesh=mesh, keep_states=False, **options)

    def plate(**options):
        """The coarse reference plate's scene on the mesh it is given (``h.simulation``)."""
        return lambda mesh: h.simulation(body_changes=dict(mesh=mesh), **options)

    def still(mesh):
        """The reference plate without loads or contact: the solution is 0."""
        import ngsolve as ngs
        return h.ngc.Simulation(h.body(mesh=mesh), h.ngc.Loads(), time=ngs.Parameter(0.0))

    def slanted(mesh):
        """A trapezoid (its left side slanted) on a weak normal support there, clamped on the right."""
        import ngsolve as ngs
        t = ngs.Parameter(0.0)
        body = h.ngc.Body(mesh, h.ngc.pzt5a(relaxation_time=2e-3), clamped="right", supports={"left": "normal"},
                          grounded="top", contact_side="bottom")
        return h.ngc.Simulation(body, h.scene.loads(t), contact=h.scene.contact(), time=t)

    def trapezoid():
        import ngsolve as ngs
        from netgen.occ import Face, OCCGeometry, Pnt, Segment, Wire
        points = [Pnt(0, 0, 0), Pnt(0.1, 0, 0), Pnt(0.1, 0.02, 0), Pnt(0.01, 0.02, 0)]
        face = Face(Wire([Segment(points[i], points[(i + 1) % 4]) for i in range(4)]))
        for edge, name in zip(face.edges, ("bottom", "right", "top", "left")):
            edge.name = name
        return ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=0.01))

    def bare():
        """The plate 0.1 m × 0.02 m as two triangles made point by point: no geometry."""
        import ngsolve as ngs
        from netgen.csg import Pnt
        from netgen.meshing import Element1D, Element2D, FaceDescriptor, Mesh, MeshPoint
        m = Mesh(dim=2)
        points = [m.Add(MeshPoint(Pnt(x, y, 0))) for x, y in [(0, 0), (0.1, 0), (0.1, 0.02), (0, 0.02)]]
        m.Add(FaceDescriptor(surfnr=1, domin=1, bc=1))
        m.Add(Element2D(1, [points[0], points[1], points[2]]))
        m.Add(Element2D(1, [points[0], points[2], points[3]]))
        for k, (a, b) in enumerate([(0, 1), (1, 2), (2, 3), (3, 0)]):
            m.Add(Element1D([points[a], points[b]], index=k + 1))
        for k, name in enumerate(("bottom", "right", "top", "left")):
            m.SetBCName(k, name)
        return ngs.Mesh(m)

    def nonlinear():
        return h.ngc.pzt5a(relaxation_time=2e-3).with_elasticity(lambda eps, linear: linear(eps) + 1e9 * eps)

    def summary(adaptation):
        levels = adaptation.levels
        return dict(reason=adaptation.reason, reached=adaptation.reached, levels=len(levels),
                    ndof=" ".join(str(level.ndof) for level in levels),
                    ne=" ".join(str(level.mesh.ne) for level in levels),
                    estimate=" ".join(repr(float(level.estimate)) for level in levels),
                    relative=" ".join(repr(float(level.relative)) for level in levels))

    def step(scene=hertz, mesh=half_disk, dt=1.0, **options):
        """``adapt.step`` of ``scene`` from ``mesh()`` (a function: built in the case's process)."""
        def call(ctx):
            from ngcontact import adapt
            return summary(adapt.step(scene, mesh(), dt, **options))
        return call

    def history(scene=None, mesh=None, dt=0.05, T=0.1, **options):
        def call(ctx):
            from ngcontact import adapt
            return summary(adapt.history(scene or plate(), (mesh or h.plate_mesh)(), dt, T, **options))
        return call

    def refused(label, call, kind, *words):
        h.case("adapt", label, call, h.Error(kind, *words))

    # ------------------------------------------------------------------ checks of the completed adaptations

    def numbers(value, key):
        return [float(x) for x in value[key].split()]

    def finite_estimates(v):
        estimates = numbers(v, "estimate")
        if not all(e == e and 0 <= e < INF for e in estimates):
            return f"estimates {estimates} are not finite and >= 0"
        return None

    def grows(v):
        ndof = numbers(v, "ndof")
        if any(b <= a for a, b in zip(ndof, ndof[1:])):
            return f"the DOFs do not grow level by level: {ndof}"
        return None

    def level_limit(count):
        def check(v, references):
            wrong = [finite_estimates(v), grows(v)]
            if v["reason"] != "level limit" or v["levels"] != count:
                wrong.append(f"stopped after {v['levels']} levels ({v['reason']}), not {count} at the level limit")
            return "; ".join(w for w in wrong if w) or None
        return check

    def uniform(v, references):
        ne = numbers(v, "ne")
        wrong = [finite_estimates(v)]
        if any(b < 3.99 * a for a, b in zip(ne, ne[1:])):
            wrong.append(f"fraction 1 must refine every element (each triangle into 4): elements {ne}")
        estimates = numbers(v, "estimate")
        if estimates[-1] >= estimates[0]:
            wrong.append(f"the estimate did not fall under uniform refinement: {estimates}")
        return "; ".join(w for w in wrong if w) or None

    def at_once(v, references):
        if (v["reason"], v["reached"], v["levels"]) != ("target reached", True, 1):
            return f"a target of 1e300 is met by the first level; got {v['levels']} levels ({v['reason']})"
        return finite_estimates(v)

    def exact(reason, reached):
        def check(v, references):
            if (v["reason"], v["reached"], v["levels"]) != (reason, reached, 1):
                return (f"a zero solution (estimate {v['estimate']}) is exact: one level, {reason!r}; got "
                        f"{v['levels']} levels ({v['reason']}, relative {v['relative']})")
            if numbers(v, "relative") != [0.0]:
                return f"the relative estimate of an exact solution is 0, got {v['relative']}"
            return None
        return check

    def falls(v, references):
        estimates = numbers(v, "estimate")
        wrong = [finite_estimates(v), grows(v)]
        if not estimates[-1] < 0.8 * estimates[0]:
            wrong.append(f"the estimate did not fall: {estimates}")
        return "; ".join(w for w in wrong if w) or None

    def same_estimates(v, references):
        a, b = [float(x) for x in v["condensed"].split()], [float(x) for x in v["full"].split()]
        if len(a) != len(b) or any(abs(x - y) > 1e-8 * abs(y) for x, y in zip(a, b)):
            return f"static condensation changed the estimates: {a} against {b}"
        return None

    def refused_on_every_rank(words):
        def check(v, references):
            lines = [line for line in v["stdout"].splitlines() if line.startswith("ValueError:")]
            if v["code"] != 0 or len(lines) != 2:
                return f"expected a ValueError on both ranks; exit {v['code']}: {h._line(v['stdout'] + v['stderr'])}"
            missing = h._named(lines[0], words)
            return f"the error does not name {'/'.join(missing)}: {lines[0]}" if missing else None
        return check

    def cli_refused_on_every_rank(words):
        def check(v, references):
            lines = [line for line in v["stderr"].splitlines() if line.strip()
                     and not line.startswith("ngcontact: warning:")]
            if v["code"] != 2 or "Traceback" in v["stderr"] or not lines:
                return f"expected exit status 2 and one line per rank; exit {v['code']}: {h._line(v['stderr'])}"
            missing = h._named(lines[0], words)
            return f"the line does not name {'/'.join(missing)}: {lines[0]}" if missing else None
        return check

    # ------------------------------------------------------------------ the adaptation's parameters

    for value, kind in ((NAN, VE), (INF, VE), (0.0, VE), (-0.5, VE), (1.5, VE), ("half", TE), (True, TE)):
        refused(f"step(fraction={value!r})", step(fraction=value), kind, "fraction")
    for value, kind in ((NAN, VE), (INF, VE), (0.0, VE), (-1e-3, VE), ("1e-3", TE)):
        refused(f"step(tol={value!r})", step(tol=value), kind, "tol")
    for value, kind in ((0, VE), (-3, VE), (2.5, TE), (NAN, CHOICE), (10 ** 6, VE), (True, TE)):
        refused(f"step(max_levels={value!r})", step(max_levels=value), kind, "max_levels")
    for value, kind in ((0, VE), (-1, VE), (NAN, VE), (INF, VE), ("big", TE)):
        refused(f"step(max_ndof={value!r})", step(max_ndof=value), kind, "max_ndof")
    refused("step(max_ndof=1e15): beyond the machine's memory", step(max_ndof=1e15), VE, "max_ndof")
    refused("step(max_ndof=10): below the first mesh's DOFs", step(max_ndof=10), VE, "max_ndof")
    for value, kind in ((0.0, VE), (1.5, VE), (NAN, VE), ("tenth", TE)):
        refused(f"step(stop_newton={value!r})", step(stop_newton=value), kind, "stop_newton")
    for value, kind in ((0.0, VE), (-1.0, VE), (NAN, VE), (INF, VE), ("1", TE)):
        refused(f"step(dt={value!r})", step(dt=value), kind, "dt")
    for value, kind in ((0, VE), (2.5, TE), ("all", TE)):
        refused(f"history(every={value!r})", history(every=value), kind, "every")
    for value, kind in ((NAN, VE), (-1.0, VE), ("end", TE)):
        refused(f"history(T={value!r})", history(T=value), kind, "T")
    refused("history(dt=0)", history(dt=0.0), VE, "dt")
    refused("history(out=...): every level into one directory", history(out="run"), VE, "out")
    refused("history(vtk=...): every level into one directory", history(vtk="vtk"), VE, "vtk")
    refused("history(on_step=5)", history(on_step=5), TE, "on_step")
    refused("history(bogus=1): not an option of run", history(bogus=1), TE, "bogus")

    # ------------------------------------------------------------------ scenes, meshes and callbacks

    refused("step(scene=a Simulation, not a function)", lambda ctx: step(scene=hertz(half_disk()))(ctx), TE, "scene")
    refused("step(scene -> None)", step(scene=lambda mesh: None), TE, "scene")
    refused("step(scene -> a Body)", step(scene=lambda mesh: hertz(mesh).body), TE, "scene")
    refused("step(scene -> (sim, mesh))", step(scene=lambda mesh: (hertz(mesh), mesh)), TE, "scene")
    refused("step(scene -> a Simulation on another mesh)", step(scene=lambda mesh: hertz(other_disk())), VE, "scene")

    def garbage_later():
        calls = []

        def scene(mesh):
            calls.append(mesh)
            return hertz(mesh) if len(calls) == 1 else "a simulation"
        return scene
    refused("step(scene -> garbage at the second level)", lambda ctx: step(scene=garbage_later())(ctx), TE, "scene")
    refused("step(mesh=a Netgen mesh)", step(mesh=lambda: half_disk().ngmesh), TE, "mesh")
    refused("step(mesh='mesh')", step(mesh=lambda: "mesh"), TE, "mesh")
    refused("step(mesh without geometry)", step(scene=plate(), mesh=bare, dt=0.05, max_levels=3), VE,
            "geometry", "polygonal")
    h.case("adapt", "step(mesh without geometry, polygonal=True)",
           step(scene=plate(), mesh=bare, dt=0.05, max_levels=3, polygonal=True), h.Correct(level_limit(3)))
    refused("step(polygonal='yes')", step(polygonal="yes"), TE, "polygonal")
    refused("step(on_level=5)", step(on_level=5), TE, "on_level")
    refused("step(on_level=a function of no argument)", step(on_level=lambda: None), TE, "on_level")
    refused("step(guess='bogus')", step(guess="bogus"), VE, "guess")
    refused("step(a nonlinear law): not estimable, before the solve",
            step(scene=plate(material=nonlinear()), mesh=h.plate_mesh, dt=0.05), VE, "law", "linear")
    refused("history(a nonlinear law): not estimable, before the run",
            history(scene=plate(material=nonlinear())), VE, "law", "linear")
    refused("step(weak normal support): not estimable, before the solve",
            step(scene=slanted, mesh=trapezoid, dt=0.05), VE, "normal")

    # ------------------------------------------------------------------ marking, the estimator, the energy norm

    def marked(indicators, **options):
        def call(ctx):
            import numpy as np
            from ngcontact import adapt
            return dict(marked=int(np.sum(adapt.mark(indicators, **options))))
        return call
    refused("mark('abc')", marked("abc"), TE, "indicators")
    refused("mark(a 2D array)", marked([[1.0, 2.0], [3.0, 4.0]]), VE, "indicators")
    refused("mark(a negative indicator)", marked([-3.0, 1.0, 1.0]), VE, "indicators")
    refused("mark(a NaN indicator)", marked([NAN, 1.0]), VE, "indicators")
    refused("mark(fraction=2)", marked([1.0, 2.0], fraction=2.0), VE, "fraction")

    def estimated(ctx):
        from ngcontact import estimators
        return dict(total=estimators.EquilibratedEstimator("sim")().total)
    refused("EquilibratedEstimator('sim')", estimated, TE, "sim|Simulation")

    def energy_of_garbage(ctx):
        from ngcontact import adapt
        return dict(norm=adapt.energy(h.simulation(), (1.0, 2.0)))
    refused("energy(sim, reference=(1, 2))", energy_of_garbage, TE, "reference")

    # ------------------------------------------------------------------ unusual but meaningful: completes, checked

    h.case("adapt", "step(fraction=1): uniform", step(fraction=1.0, max_levels=3), h.Correct(uniform))
    h.case("adapt", "step(fraction=1e-12): one element a level", step(fraction=1e-12, max_levels=3),
           h.Correct(level_limit(3)))
    h.case("adapt", "step(tol=1e300): met at once", step(tol=1e300), h.Correct(at_once))
    h.case("adapt", "step(max_levels=1)", step(max_levels=1), h.Correct(level_limit(1)))
    h.case("adapt", "step(a zero solution)", step(scene=still, mesh=h.plate_mesh, dt=0.05, max_levels=3),
           h.Correct(exact("nothing to refine", False)))
    h.case("adapt", "step(a zero solution, tol=0.1)", step(scene=still, mesh=h.plate_mesh, dt=0.05, tol=0.1),
           h.Correct(exact("target reached", True)))
    h.case("adapt", "step(no contact)", step(scene=plate(contact=None), mesh=h.plate_mesh, dt=0.05, max_levels=3),
           h.Correct(falls))

    def lifted(mesh):
        """The Hertz half-disk with its top moved up: it leaves the foundation, a rigid motion."""
        return hertz(mesh, depth=-0.01)
    h.case("adapt", "step(a body lifted off: stress-free)", step(scene=lifted, max_levels=3),
           h.Correct(exact("nothing to refine", False)))
    h.case("adapt", "step(a body lifted off, tol=1e-3)", step(scene=lifted, tol=1e-3),
           h.Correct(exact("target reached", True)))

    def goal_of(goal, scene):
        def call(ctx):
            from ngcontact import adapt
            result = adapt.solve(scene, half_disk(), 1e-3, goal=goal)
            return dict(reason=result.reason, reached=result.reached, levels=len(result.levels),
                        goal_estimate=" ".join(repr(float(level.goal_estimate)) for level in result.levels))
        return call

    def no_contact(v, references):
        if (v["reason"], v["reached"], v["levels"]) != ("no contact", False, 1):
            return (f"a goal of a step without contact cannot be met: one level, 'no contact', not reached; got "
                    f"{v['levels']} levels ({v['reason']}, reached {v['reached']}, estimates {v['goal_estimate']})")
        if v["goal_estimate"] != "nan":
            return f"the relative error of a zero goal is undefined, got {v['goal_estimate']}"
        return None
    for goal in ("pressure", "force"):
        h.case("adapt", f"solve(goal={goal!r}, a body lifted off)", goal_of(goal, lifted), h.Correct(no_contact))
    h.case("adapt", "step(stop_newton=1)", step(stop_newton=1.0, max_levels=3), h.Correct(level_limit(3)))
    h.case("adapt", "history(every=10**6): the last step only", history(every=10 ** 6, max_levels=2),
           h.Correct(level_limit(2)))

    def condensed(ctx):
        from ngcontact import adapt
        runs = [adapt.step(lambda mesh, c=c: hertz(mesh, 2, condense=c), half_disk(), 1.0, max_levels=2)
                for c in (True, False)]
        return dict(condensed=" ".join(repr(float(level.estimate)) for level in runs[0].levels),
                    full=" ".join(repr(float(level.estimate)) for level in runs[1].levels))
    h.case("adapt", "step(P2, condense=True) equals condense=False", condensed, h.Correct(same_estimates))

    # ------------------------------------------------------------------ the command line

    def command(arguments, *words):
        argv = ["adapt", *arguments.split()]
        h.case("adapt", f"cli: adapt {arguments}", lambda ctx, a=argv: h.command_line(a, ctx), h.CliError(*words))

    command("--scene hertz3d --orders 2", "orders?", "hertz3d")        # hertz3d runs P1 only: nothing to run
    command("--scene hertz3d --orders 2 3", "orders?", "hertz3d")
    for orders in ("0", "11", "-1", "x", "1.5", ""):
        command(f"--orders {orders}".strip(), "orders?")
    command("--scene cube", "scene")
    command("--scene", "scene")
    for value in ("0", "2", "-0.5", "nan", "inf", "x"):
        command(f"--stop-newton {value}", "stop[-_]newton")
    command("--out /proc/hostile", "/proc/hostile")
    command("--bogus", "bogus")
    command("--tol 1e-2 --goal pressure --marking equilibrated", "marking", "goal")

    # ------------------------------------------------------------------ under mpiexec (slow: two ranks start)

    def mpi(argv, env=None):
        def call(ctx):
            from test_parallel import mpiexec
            done = subprocess.run([mpiexec(), "-n", "2", sys.executable, *argv], capture_output=True, text=True,
                                  timeout=h.HANG["default"] - 5, cwd=ctx["work"],
                                  env=dict(os.environ, PYTHONWARNINGS="ignore", **(env or {})))
            return dict(code=done.returncode, stdout=done.stdout[-3000:], stderr=done.stderr[-3000:])
        return call
    h.case("adapt", "mpiexec -n 2: adapt.step on a distributed mesh", mpi(["-c", _MPI_STEP]),
           h.Correct(refused_on_every_rank(("distributed", "adapt.step"))), slow=True)
    h.case("adapt", "mpiexec -n 2: python -m ngcontact adapt", mpi(["-m", "ngcontact", "adapt", "--out", "adapt"]),
           h.Correct(cli_refused_on_every_rank(("adapt", "serially"))), slow=True)
