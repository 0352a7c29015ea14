"""Hostile inputs of classes ``newcli`` and ``adaptsolve`` (``tests/test_hostile.py``).

``newcli``: the newer command-line paths and the study entry points they call. ``--out`` that
cannot be written, is a file or is empty ('' would write into the working directory), on every
command; ``axisymmetric --rounds`` out of range; ``adapt --tol`` below its floor
(``studies.adaptivity.TOL_FLOOR``) or not a tolerance, with adaptive stopping or a fraction out of
(0, 1], a marking that does not exist, scenes and orders that leave nothing to solve (hertz3d
runs P1 only) or a load history: each ``CliError`` (exit status 2, one line naming the
option, before any work). ``adapt --tol`` that its scene's DOF limit stops before the tolerance
exits with status 1 and one line saying NOT reached (``CliError`` with code 1); ``--marking`` with ``--tol`` is
used (``Ran``). ``pull_off.run(cases=)``: a time step past the history's end, 0, NaN, one step
or more than ``checks.MAX_STEPS``, mesh sizes out of range, malformed cases: a named error
before any run.

``adaptsolve``: ``adapt.solve`` (and ``step``, ``history``) given a scene whose Simulation has
already stepped is refused before its first solve, naming it and the fix; a fresh scene is
solved and certified.

The CLI cases call ``ngcontact.cli.main`` in the case's process (``h.command_line``); the
cases that must run an adaptation give the Hertz scene a DOF limit of 400 on its coarsest disk
(``small_hertz``), so that each costs a few seconds.
"""
import os
from dataclasses import dataclass

from support import small_hertz

CLASSES = ("newcli", "adaptsolve")

SMALL_NDOF = 400
"""The DOF limit of the Hertz disk in the cases that run ``adapt --tol`` (its coarsest mesh)."""


@dataclass(frozen=True)
class Ran:
    """The call returned a value for which ``check(value)`` is None (else what is wrong); unlike
    ``Correct`` it needs no reference runs."""
    check: object

    def problem(self, outcome, references):
        if outcome.kind != "returned":
            return f"expected a completed run; {outcome.describe()}"
        return self.check(outcome.value)


def register(h):
    VE, TE, NAN, INF = h.VE, h.TE, h.NAN, h.INF

    def command(argv, *words, label=None, before=None):
        """A ``newcli`` case: ``python -m ngcontact ARGV`` (a list: '' stays an argument) ends in
        one line naming ``words``, exit status 2."""
        def call(ctx, argv=argv):
            if before is not None:
                before(ctx)
            return h.command_line(list(argv), ctx)
        h.case("newcli", label or " ".join(a if a else "''" for a in argv), call, h.CliError(*words))

    # ------------------------------------------------------------------ --out: unwritable, a file, empty

    def a_file(ctx):
        with open(os.path.join(ctx["work"], "afile"), "w") as f:
            f.write("not a directory")

    command(["axisymmetric", "--quick", "--out", "/proc/hostile"], "/proc/hostile", "out")
    command(["axisymmetric", "--quick", "--out", "afile"], "afile", "out", "exists",
            label="axisymmetric --quick --out <a file>", before=a_file)
    command(["axisymmetric", "--quick", "--out", "/proc/hostile/a/b"], "/proc/hostile/a/b")
    for name in ("axisymmetric", "adapt", "timesteps", "timeorder", "demo", "convergence", "stability", "hertz",
                 "bench", "cluster"):
        command([name, "--out", ""], "out", "empty")
    for name in ("adapt", "timesteps", "timeorder"):
        command([name, "--out", "afile"], "afile", label=f"{name} --out <a file>", before=a_file)
    for value in ("0", "21", "-1", "x", "1.5"):
        command(["axisymmetric", "--quick", "--rounds", value], "rounds")

    # ------------------------------------------------------------------ adapt --tol and its options

    for value in ("1e-300", "1e-7", "0", "-1", "nan", "inf", "1", "2", "x"):
        command(["adapt", "--tol", value], "tol")
    for value in ("5", "0", "-1", "nan", "inf", "x"):
        command(["adapt", "--tol", "0.1", "--stop-newton", value], "stop[-_]newton")
    for value in ("0", "2", "nan", "x"):
        command(["adapt", "--tol", "0.1", "--fraction", value], "fraction")
    command(["adapt", "--tol", "0.1", "--marking", "bogus"], "marking")
    command(["adapt", "--tol", "0.1", "--scene", "hertz3d", "--orders", "2"], "scene", "orders?", "hertz3d")
    command(["adapt", "--tol", "0.1", "--scene", "hertz3d", "--orders", "2", "3"], "scene", "orders?", "hertz3d")
    command(["adapt", "--tol", "0.1", "--scene", "hertz", "reference"], "tol", "reference")
    command(["adapt", "--tol", "0.1", "--orders", "0"], "orders?")
    command(["adapt", "--tol", "0.1", "--scene", "cube"], "scene")

    def small(argv, record=False):
        """``python -m ngcontact ARGV`` with the scene "hertz" of ``small_hertz``; with
        ``record``, the adaptations' levels: whether each was certified."""
        def call(ctx):
            from ngcontact import adapt
            from ngcontact.studies import adaptivity
            adaptivity.SCENES["hertz"] = lambda: small_hertz(SMALL_NDOF)
            certified = []
            if record:
                solve = adapt.solve

                def recorded(*args, **options):
                    result = solve(*args, **options)
                    certified.append(" ".join(str(level.certified) for level in result.levels))
                    return result
                adapt.solve = recorded
            return dict(h.command_line(list(argv), ctx), certified=" / ".join(certified))
        return call

    h.case("newcli", f"adapt --tol 1e-3 --scene hertz --orders 1 (DOF limit {SMALL_NDOF}): not reached",
           small(["adapt", "--tol", "1e-3", "--scene", "hertz", "--orders", "1"]),
           h.CliError("tol", "NOT reached", "hertz P1", "DOF limit", code=1, within=h.HANG["cli"]))

    def every_level_certified(v):
        if v["code"] not in (0, 1):
            return f"exit status {v['code']}: {h._line(v['stderr'])}"
        levels = v["certified"].split()
        if not levels or set(levels) != {"True"}:
            return f"--marking equilibrated not used: certified by level {v['certified'] or '(no run)'}"
        return None
    h.case("newcli", f"adapt --tol 0.05 --marking equilibrated --scene hertz --orders 1 (DOF limit {SMALL_NDOF})",
           small(["adapt", "--tol", "0.05", "--marking", "equilibrated", "--scene", "hertz", "--orders", "1"],
                 record=True), Ran(every_level_certified))

    # ------------------------------------------------------------------ pull_off.run(cases=)

    def pull_off(cases, order=2):
        def call(ctx):
            from ngcontact.studies.stability import pull_off
            return pull_off.run(cases=cases, order=order, progress=False)
        return call

    for dt in (0.5, 0.2, 0.15, 0.0, -0.01, NAN, INF, 1e-9):
        h.case("newcli", f"pull_off.run(cases=[({dt!r}, 0.005)])", pull_off([(dt, 0.005)]), h.Error(VE, "cases", "dt"))
    for maxh in (0.0, -0.005, NAN, INF, 0.05, 1e-7):
        h.case("newcli", f"pull_off.run(cases=[(0.01, {maxh!r})])", pull_off([(0.01, maxh)]),
               h.Error(VE, "cases", "maxh"))
    h.case("newcli", "pull_off.run(cases=[])", pull_off([]), h.Error(VE, "cases"))
    h.case("newcli", "pull_off.run(cases='x')", pull_off("x"), h.Error(TE, "cases"))
    h.case("newcli", "pull_off.run(cases=[0.01])", pull_off([0.01]), h.Error(TE, "cases"))
    h.case("newcli", "pull_off.run(cases=[(0.01, 0.005, 1)])", pull_off([(0.01, 0.005, 1)]), h.Error(TE, "cases"))
    h.case("newcli", "pull_off.run(cases=[('a', 0.005)])", pull_off([("a", 0.005)]), h.Error(TE, "cases", "dt"))
    h.case("newcli", "pull_off.run(cases=[(None, 0.005)])", pull_off([(None, 0.005)]), h.Error(TE, "cases", "dt"))
    h.case("newcli", "pull_off.run(order=0)", pull_off([(0.01, 0.005)], order=0), h.Error(VE, "order"))

    def two_steps(v):
        row = v.get("row") if isinstance(v, dict) else None
        return None if row == "2 steps, balanced" else f"the two-step pull-off: {v}"

    def pulled(ctx):
        from ngcontact.studies.stability import pull_off
        rows = pull_off.run(cases=[(0.1, 0.01)], order=1, progress=False)
        ok = len(rows) == 2 and all(row["failure"] == "" and row["steps"] == 2 and row["balance"] < 1e-8
                                    for row in rows)
        row = rows[-1]
        return dict(row="2 steps, balanced" if ok else repr(row))
    h.case("newcli", "pull_off.run(cases=[(0.1, 0.01)], order=1): two steps", pulled, Ran(two_steps))

    # ------------------------------------------------------------------ adapt.solve after stepping

    def hertz(mesh):
        from ngcontact.scenes import hertz as scene
        return scene.simulation(1, mesh=mesh, keep_states=False)

    def stepped(how):
        def scene(mesh):
            import warnings
            sim = hertz(mesh)
            with warnings.catch_warnings():          # the coarse disk's penetration
                warnings.simplefilter("ignore")
                if how == "step":
                    sim.step(0.5)
                else:
                    sim.run(0.5, 1.0)
            return sim
        return scene

    def adaptation(where, scene, **options):
        def call(ctx):
            from ngcontact import adapt
            from ngcontact.scenes import hertz as disk
            mesh = disk.mesh(2, h_contact=0.2)
            if where == "history":
                result = adapt.history(scene, mesh, 0.5, 1.0, **options)
            elif where == "step":
                result = adapt.step(scene, mesh, 1.0, **options)
            else:
                result = adapt.solve(scene, mesh, **options)
            return dict(reached=result.reached, reason=result.reason, certified=result.last.certified,
                        relative=float(result.last.relative))
        return call

    for how in ("step", "run"):
        h.case("adaptsolve", f"adapt.solve(a scene that has stepped (Simulation.{how}), tol=0.5)",
               adaptation("solve", stepped(how), tol=0.5), h.Error(VE, "stepped", "u0", "adapt.history"))
    h.case("adaptsolve", "adapt.step(a scene that has stepped, max_levels=2)",
           adaptation("step", stepped("step"), max_levels=2), h.Error(VE, "stepped"))
    h.case("adaptsolve", "adapt.history(a scene that has stepped, max_levels=2)",
           adaptation("history", stepped("step"), max_levels=2), h.Error(VE, "stepped"))

    def certified(v):
        if not (v["reached"] and v["certified"] and v["reason"] == "target reached" and v["relative"] <= 0.5):
            return f"not certified to 0.5: {v}"
        return None
    h.case("adaptsolve", "adapt.solve(a fresh scene, tol=0.5): certified", adaptation("solve", hertz, tol=0.5),
           Ran(certified))
