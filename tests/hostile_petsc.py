"""Hostile inputs of class ``petsc`` (``tests/test_hostile.py``): the PETSc engine
(``solver="mumps"``, ``solver="gamg"``; ``ngcontact.petsc_solver``, ``petsc_iterative``),
its options, their combinations, PETSc's own options (``PETSC_OPTIONS``) and the command line.

The expected outcomes depend on whether PETSc is installed (``PETSC``: petsc4py, ngsPETSc and
mpi4py found, without importing them: the fork server must not start PETSc). With it, a PETSc
option solves the scene correctly (the reference scene's contact force and deflection, or the
default solver's result in the same process) or is refused by name; without it, every PETSc
option ends in one ImportError naming the option and the install line (``petsc_solver.INSTALL``),
raised before any work, and the command line prints it as one line. Combinations that cannot
run (GAMG with static condensation, ``solver=`` with the earlier options, GAMG with a
factorisation by the earlier options ``iterative=``, ``inverse=``) and bad values are refused by
name in both. ``.ci/run`` runs this class in its PETSc leg (``-k "petsc:"``).
"""
import importlib.util
import os
import sys

CLASSES = ("petsc",)

PETSC = all(importlib.util.find_spec(name) is not None for name in ("petsc4py", "ngsPETSc", "mpi4py"))
"""Whether the PETSc engine is installed here (found, not imported)."""


def register(h):
    VE, TE = h.VE, h.TE
    h.HANG.setdefault("petsc", 120.0)     # s: with PETSc, a case's process starts PETSc and MUMPS first
    Error, Correct, CliError = h.Error, h.Correct, h.CliError

    def missing(option):
        """Without PETSc: an ImportError naming the option and the install line, before any work."""
        return Error("ImportError", option, "pip install")

    def petsc(option, *outcomes):
        """``outcomes`` where PETSc is installed, else ``missing(option)``."""
        return outcomes if PETSC else (missing(option),)

    # ------------------------------------------------------------------ scenes (built in the case's process)

    def options_set(environment):
        """PETSc's options database from ``PETSC_OPTIONS`` (read when PETSc starts: in the case's
        process, which has not started it)."""
        if environment is not None:
            os.environ["PETSC_OPTIONS"] = environment

    def reference(contact=None, environment=None, **options):
        def call(ctx):
            options_set(environment)
            return h.reference_run(h.scene.contact(**contact) if contact else None, **options)
        return call

    def free(**options):
        def call(ctx):
            import ngsolve as ngs
            t = ngs.Parameter(0.0)
            sim = h.ngc.Simulation(h.body(), h.scene.loads(t), time=t, **options)
            sim.run(0.05, 0.1, max_cutbacks=0)
            return dict(h.measure(sim, h.applied(sim.t)), target=0.1)
        return call

    def floating(load, **options):
        """The plate held in x only, pushed onto (load < 0) or pulled off the foundation: held
        vertically by the contact alone (class ``held``)."""
        def call(ctx):
            import ngsolve as ngs
            t = ngs.Parameter(0.0)
            held = h.ngc.Body(h.plate_mesh(), h.ngc.pzt5a(relaxation_time=2e-3), supports={"left": "x"},
                              grounded="top", contact_side="bottom")
            sim = h.ngc.Simulation(held, h.ngc.Loads(f2={"top": (0.0, load * t / 0.1)}),
                                   contact=h.ngc.Contact(gap=2e-5), time=t, **options)
            sim.run(0.05, 0.1, max_cutbacks=0)
            return dict(h.measure(sim, -load * h.scene.L1), target=0.1)
        return call

    def against_default(order=1, material=None, **options):
        """The coarse reference scene at ``order`` with the PETSc ``options`` (first: a refusal
        comes before any other work), then with the default solver: both results."""
        def call(ctx):
            values = {}
            for name, chosen in (("petsc", options), ("default", {})):
                sim = h.scene.simulation(order, 0.01, material=material() if material else None, **chosen)
                sim.run(0.05, 0.1, max_cutbacks=0)
                v = h.measure(sim, h.applied(sim.t))
                values.update({f"{name}_force": v["force"], f"{name}_tip": v["tip"], f"{name}_time": v["time"]})
            return values
        return call

    def same(v, references):
        wrong = []
        for key in ("force", "tip"):
            a, b = v[f"petsc_{key}"], v[f"default_{key}"]
            if not abs(a - b) <= 1e-8 * abs(b):
                wrong.append(f"{key} {a!r} with PETSc, {b!r} with the default solver")
        if v["petsc_time"] != v["default_time"]:
            wrong.append(f"the PETSc run ended at t = {v['petsc_time']}, the default one at {v['default_time']}")
        return "; ".join(wrong) or None

    def nonlinear():
        return h.ngc.pzt5a(relaxation_time=2e-3).with_elasticity(lambda eps, linear: linear(eps) + 1e9 * eps)

    def without(module, call):
        """``call`` with ``module`` unimportable (a partial install)."""
        def hidden(ctx):
            from ngcontact.solve.linalg import petsc_modules
            petsc_modules._modules = None
            sys.modules[module] = None
            return call(ctx)
        return hidden

    def succeeded(v, references):
        if v["code"] != 0:
            lines = [line for line in v["stderr"].splitlines() if line.strip()]
            return f"exit status {v['code']}: {h._line(lines[-1] if lines else 'nothing on stderr')}"
        return None

    def command(arguments, option, *refusal, runs=True, slow=False):
        """A CLI case: with PETSc it completes (``runs``; ``slow`` then) or is refused naming
        ``refusal``; without, one line naming ``option`` and the install line."""
        argv = arguments.split()
        full = argv[:1] + h.CHEAP.get(argv[0], []) + argv[1:]
        if PETSC:
            expect = Correct(succeeded) if runs else CliError(*refusal)
        else:
            expect = CliError(*refusal) if refusal and not runs else CliError(option, "pip install")
        h.case("petsc", f"cli: {arguments}", lambda ctx, a=full: h.command_line(a, ctx), expect,
               slow=slow and PETSC and runs)

    DEFAULT, FREE = Correct(h.matches("default")), Correct(h.matches("free"))
    SINGULAR = ("singular", "held only by the contact")
    REPORTED = (h.NewtonFailure(*SINGULAR), Error(VE, "|".join(SINGULAR)))

    # ------------------------------------------------------------------ MUMPS: solves, or says how to install it

    PREONLY = {"ksp_type": "preonly", "pc_factor_mat_solver_type": "mumps"}    # a factorisation per iteration
    h.case("petsc", "solver='mumps'", reference(solver="mumps"), *petsc("mumps", DEFAULT))
    h.case("petsc", "solver={'ksp_type': 'preonly', 'pc_factor_mat_solver_type': 'mumps'}",
           reference(solver=PREONLY), *petsc("mumps", DEFAULT))
    h.case("petsc", "solver='mumps', theta=-1", reference(dict(theta=-1), solver="mumps"), *petsc("mumps", DEFAULT))
    h.case("petsc", "solver='mumps', active_set", reference(dict(method="active_set"), solver="mumps"),
           *petsc("mumps", DEFAULT))
    h.case("petsc", "solver='mumps', penalty", reference(dict(method="penalty"), solver="mumps"),
           *petsc("mumps", DEFAULT))
    h.case("petsc", "solver='mumps', gamma0=1e15", reference(dict(gamma0=1e15), solver="mumps"),
           *petsc("mumps", *h.SOUND("gamma0", h.matches("default"))))
    h.case("petsc", "solver='mumps', no contact", free(solver="mumps"), *petsc("mumps", FREE))
    h.case("petsc", "solver='mumps', P3, condense=True", against_default(3, solver="mumps", condense=True),
           *petsc("mumps", Correct(same)))
    h.case("petsc", "solver='mumps', a nonlinear law", against_default(material=nonlinear, solver="mumps"),
           *petsc("mumps", Correct(same)))
    h.case("petsc", "solver='mumps', held by the contact, pulled off", floating(2e6, solver="mumps"),
           *petsc("mumps", *REPORTED))
    h.case("petsc", "solver='mumps', held by the contact, pushed", floating(-2e6, solver="mumps"),
           *petsc("mumps", Correct(h.balanced), *REPORTED))

    # ------------------------------------------------------------------ GAMG

    h.case("petsc", "solver='gamg'", reference(solver="gamg"), *petsc("gamg", DEFAULT))
    h.case("petsc", "solver='gamg', theta=-1", reference(dict(theta=-1), solver="gamg"), *petsc("gamg", DEFAULT))
    h.case("petsc", "solver='gamg', active_set", reference(dict(method="active_set"), solver="gamg"),
           *petsc("gamg", DEFAULT))
    h.case("petsc", "solver='gamg', penalty", reference(dict(method="penalty"), solver="gamg"),
           *petsc("gamg", DEFAULT))
    h.case("petsc", "solver='gamg', no contact", free(solver="gamg"), *petsc("gamg", FREE))
    h.case("petsc", "solver='gamg', a nonlinear law", against_default(material=nonlinear, solver="gamg"),
           *petsc("gamg", Correct(same)))
    # P3 has interior DOFs: condensation is automatic (condense=None) and must give way to GAMG
    h.case("petsc", "solver='gamg', P3 (condense automatic)", against_default(3, solver="gamg"),
           *petsc("gamg", Correct(same)))
    h.case("petsc", "solver='gamg', held by the contact, pulled off", floating(2e6, solver="gamg"),
           *petsc("gamg", *REPORTED))

    # ------------------------------------------------------------------ combinations and values refused in both

    def refused(label, call, kind, *words):
        h.case("petsc", label, call, Error(kind, *words))

    refused("solver='gamg', condense=True", reference(solver="gamg", condense=True), VE, "condense")
    refused("solver='GAMG'", reference(solver="GAMG"), VE, "solver")
    refused("solver='petsc'", reference(solver="petsc"), VE, "solver")
    refused("solver='MUMPS'", reference(solver="MUMPS"), VE, "solver")
    refused("solver='lu' (no such solver)", reference(solver="lu"), VE, "solver")
    refused("solver=b'mumps'", reference(solver=b"mumps"), TE, "solver")
    refused("solver=['mumps']", reference(solver=["mumps"]), TE, "solver")
    refused("solver='mumps', inverse='mumps'", reference(solver="mumps", inverse="mumps"), VE, "solver", "inverse")
    # the earlier options (inverse=, iterative=): their combinations and values, refused as before
    refused("iterative='gamg', inverse='mumps'", reference(iterative="gamg", inverse="mumps"), VE, "inverse", "gamg")
    refused("iterative=True, inverse='mumps'", reference(iterative=True, inverse="mumps"), VE, "inverse")
    refused("iterative='multigrid', inverse='mumps'", reference(iterative="multigrid", inverse="mumps"), VE,
            "inverse")
    refused("iterative='GAMG'", reference(iterative="GAMG"), VE, "iterative")
    refused("iterative='petsc'", reference(iterative="petsc"), VE, "iterative")
    refused("iterative=1", reference(iterative=1), TE, "iterative")
    refused("inverse='MUMPS'", reference(inverse="MUMPS"), VE, "inverse")
    refused("inverse='lu' (no such solver)", reference(inverse="lu"), VE, "inverse")
    refused("inverse=b'mumps'", reference(inverse=b"mumps"), TE, "inverse")
    refused("inverse=['mumps']", reference(inverse=["mumps"]), TE, "inverse")

    # ------------------------------------------------------------------ partial installs (both: the missing module named)

    h.case("petsc", "solver='mumps' without ngsPETSc", without("ngsPETSc", reference(solver="mumps")),
           Error("ImportError", "ngsPETSc", "mumps", "pip install"))
    h.case("petsc", "solver='gamg' without petsc4py", without("petsc4py", reference(solver="gamg")),
           Error("ImportError", "petsc4py", "gamg", "pip install"))
    h.case("petsc", "solver='mumps' without mpi4py", without("mpi4py", reference(solver="mumps")),
           Error("ImportError", "mpi4py", "mumps", "pip install"))

    # ------------------------------------------------------------------ PETSc's own options (PETSC_OPTIONS)

    def options(environment, expect_mumps, expect_gamg=None, reuse=True):
        if expect_mumps is not None:
            solver = "mumps" if reuse else PREONLY
            h.case("petsc", f"PETSC_OPTIONS='{environment}', solver={solver!r}",
                   reference(environment=environment, solver=solver), *petsc("mumps", *expect_mumps))
        if expect_gamg is not None:
            h.case("petsc", f"PETSC_OPTIONS='{environment}', solver='gamg'",
                   reference(environment=environment, solver="gamg"), *petsc("gamg", *expect_gamg))

    def named(*words):
        return (Error(VE, "PETSC_OPTIONS", *words),)

    # an option without a prefix reaches the factorisation: one that makes it no MUMPS LU is refused
    options("-pc_type jacobi", named("jacobi"), (DEFAULT,))
    options("-pc_type jacobi", named("jacobi"), reuse=False)
    options("-pc_factor_mat_solver_type petsc", named("petsc"))
    options("-mat_mumps_icntl_14 abc", named("abc"))
    options("-ngcontact_u_pc_gamg_threshold abc", None, named("abc"))
    options("-ngcontact_gamma3_mat_mumps_icntl_14 abc", None, named("abc"))
    options("-ngcontact_u_pc_type none", None, (h.NewtonFailure(), DEFAULT, *named("none")))
    options("-mat_mumps_icntl_4 2", (DEFAULT,))                    # the documented use: MUMPS's diagnostics
    options("-ksp_type cg", (DEFAULT,), (DEFAULT,))                  # no solver of ngcontact reads it

    # ------------------------------------------------------------------ the command line

    command("bench --inverse mumps", "mumps")
    command("bench --solver gamg", "gamg")
    command("bench --inverse mumps --solver gamg", "mumps", "inverse", runs=False)
    # with PETSc these are whole (small) cluster studies, the runs and the report: about 40 s each
    command("cluster --solvers mumps --repeat 1", "mumps", slow=True)
    command("cluster --solvers gamg --repeat 1", "gamg", slow=True)
