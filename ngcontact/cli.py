"""Command line interface: ``python -m ngcontact demo | convergence | stability | hertz | bench | bench-estimate |
cluster | timesteps | timeorder | adapt | axisymmetric | imports | hertz-reference``.

It parses the arguments and calls ``demo.run`` or a study's command; bad input and a failed
Newton solve end in one line on stderr and exit status 2 (``main``); ``adapt --tol`` that does
not reach its tolerance within a scene's limits ends in one line and exit status 1.
"""
import argparse
import os
import sys
import warnings

import ngcontact

KEPT = dict(demo="{out}/run (continue with --resume)", convergence="{out}/cases (--resume skips them)",
            hertz="{out}/cases.json (--resume skips them)", bench="{out}/bench.json (--resume skips them)",
            cluster="{out}/runs (--resume skips them)",
            stability="{out}/<study>.csv of the finished studies (--resume skips them)",
            timesteps="nothing (the study runs again whole)", timeorder="nothing (the study runs again whole)",
            adapt="nothing (the study runs again whole)", axisymmetric="nothing (the study runs again whole)",
            imports="nothing (it measures again)", **{"bench-estimate": "nothing (it measures again)",
                                                      "hertz-reference": "nothing (the reference is built again whole)"})
"""Where each command keeps what it computed before an error."""


class _Help(argparse.HelpFormatter):
    """argparse's help, each option's default appended where its text does not give it (a
    flag's default is off; an option whose default is None says in its text what it does
    when not given)."""

    def _get_help_string(self, action):
        text = action.help or ""
        shown = action.default
        if (action.option_strings and "default" not in text and shown is not None and shown is not False
                and shown is not argparse.SUPPRESS):
            value = " ".join(map(str, shown)) if isinstance(shown, (list, tuple)) else str(shown)
            text += f" (default: {value.replace('%', '%%')})"
        return text


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors are one line on stderr (exit status 2), like ours, and
    whose help shows every option's default (``_Help``)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _Help)
        super().__init__(*args, **kwargs)

    def error(self, message):
        print(f"{self.prog}: error: {message} (see: {self.prog} --help)", file=sys.stderr)
        sys.exit(2)


def _directory(text):
    """An ``--out`` directory: refused if empty (a path of nothing would write into the working
    directory); whether it can be written is checked by the command, before its work."""
    if not text:
        raise argparse.ArgumentTypeError(f"an empty path ({text!r}) names no directory (the files would land in the "
                                         "working directory); give a directory, e.g. --out results")
    return text


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    """A warning (e.g. a ``PhysicsWarning``) as one line on stderr."""
    print(f"ngcontact: warning: {' '.join(str(message).split())}", file=sys.stderr)


def parser():
    """The argument parser of ``python -m ngcontact``."""
    main_parser = _Parser(prog="ngcontact", description="ngcontact: a piezoelectric "
                          "Kelvin-Voigt body in adhesive contact, on NGSolve")
    commands = main_parser.add_subparsers(dest="command", required=True)
    common = _Parser(add_help=False)
    common.add_argument("--traceback", action="store_true",
                        help="on an error, show the full traceback (also: NGCONTACT_TRACEBACK=1)")

    demo = commands.add_parser("demo", parents=[common], help="the PZT-5A plate pressed onto a glued conductive "
                               "foundation, then pulled off")
    demo.add_argument("--order", metavar="P", type=int, default=1,
                      help="polynomial order of u and φ (default 1, the paper's P1)")
    demo.add_argument("--out", metavar="DIR", type=_directory, default="results",
                      help="output directory (default results)")
    demo.add_argument("--maxh", metavar="H", type=float, help="mesh size in m (default 0.005 in 2D, 0.01 in 3D)")
    demo.add_argument("--dim", type=int, choices=(2, 3), default=2, help="2D plate (default) or 3D block")
    demo.add_argument("--refine", metavar="K", type=int, default=0,
                      help="refine the mesh K times (nested meshes; default 0)")
    demo.add_argument("--steps", metavar="N", type=int, default=200,
                      help="number of time steps over the load history, 0 to 0.5 s (default 200)")
    demo.add_argument("--theta", type=int, default=1, choices=(1, 0, -1),
                      help="Nitsche variant θ: 1 symmetric (default), 0 incomplete, -1 skew-symmetric")
    demo.add_argument("--gamma0", type=float, default=10.0, help="Nitsche parameter γ0 (default 10)")
    demo.add_argument("--scheme", choices=tuple(ngcontact.schemes.SCHEMES), default="backward_euler",
                      help="time scheme (default backward_euler, the paper's; bdf2 is second order)")
    demo.add_argument("--rtol", type=float, default=None,
                      help="choose the time steps by this local error target (with --scheme bdf2; the first step "
                           "0.5 s / STEPS; default: STEPS equal steps)")
    demo.add_argument("--no-switch-loop", dest="plain_corrections", action="store_true",
                      help="plain Newton corrections: without the inner loop that settles the contact set of "
                           "Γ3 inside each correction (on one process it is on by default)")
    demo.add_argument("--resume", action="store_true",
                      help="continue the run interrupted in OUT/run (same settings, under mpiexec the same "
                           "number of ranks) instead of starting again")

    conv = commands.add_parser("convergence", parents=[common], help="order-convergence study against (4.12): "
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
                      help="time-step variant: halve dt J times on the finest mesh, first order given")
    conv.add_argument("--dt0", metavar="S", type=float, default=0.25,
                      help="time-step variant: the largest time step, s (default 0.25; T = 1 s)")
    conv.add_argument("--scheme", choices=tuple(ngcontact.schemes.SCHEMES), default="backward_euler",
                      help="time-step variant: the time scheme (default backward_euler, the paper's; bdf2 is "
                           "second order)")
    conv.add_argument("--out", metavar="DIR", type=_directory, default="convergence", help="output directory")
    conv.add_argument("--resume", action="store_true",
                      help="reuse the runs already in OUT/cases (and the streamed fine run of --case reference)")

    stab = commands.add_parser("stability", parents=[common], help="stability maps (Nitsche γ0 × θ, penalty, "
                               "β time step, ν → 1/2, strong coupling, debonding, load cycles, laws, electrode contact, "
                               "pull-off): "
                               "<study>.csv and charts")
    stab.add_argument("--out", metavar="DIR", type=_directory, default="stability", help="output directory")
    stab.add_argument("--quick", action="store_true",
                      help="fewer runs per study (about a third), marked indicative only (default: off)")
    stab.add_argument("--resume", action="store_true", help="skip the studies whose <study>.csv is in OUT")
    stab.add_argument("--study", metavar="NAME", nargs="+", default=None,
                      help="run only these studies (default: all of nitsche_map, time_step_sweep, incompressibility, "
                           "strong_coupling, debonding, load_cycles, penalty_sweep, nonlinear_laws, electrode_map)")

    hertz = commands.add_parser("hertz", parents=[common], help="contact on a curved side against Hertz (half-disk "
                                "on a plane), obstacle normal and body normal: hertz.csv, hertz.md, a chart")
    hertz.add_argument("--out", metavar="DIR", type=_directory, default="hertz", help="output directory")
    hertz.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1, 2], help="polynomial orders")
    hertz.add_argument("--levels", metavar="N", type=int, default=4, help="nested meshes, h halving (default 4)")
    hertz.add_argument("--dim", type=int, choices=(2, 3), default=2, help="half-disk (2D) or half-ball (3D)")
    hertz.add_argument("--resume", action="store_true", help="skip the cases already in OUT/cases.json")

    bench = commands.add_parser("bench", parents=[common], help="time per step of the reference scene against one "
                                "linear solve, orders x sizes: bench.csv and a chart")
    bench.add_argument("--out", metavar="DIR", type=_directory, default="bench", help="output directory")
    bench.add_argument("--dim", type=int, choices=(2, 3), default=2, help="2D plate or 3D block")
    bench.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1, 2, 3, 4],
                       help="polynomial orders")
    bench.add_argument("--max-ndof", metavar="N", type=float, default=1e6,
                       help="largest problem size (default 1e6)")
    bench.add_argument("--steps", metavar="N", type=int, default=10,
                       help="time steps per case (default 10: first contact and its spreading)")
    bench.add_argument("--dt", metavar="DT", type=float, default=2.5e-3, help="time step, s")
    bench.add_argument("--inverse", choices=("umfpack", "sparsecholesky", "mumps"),
                       help="direct solver (default: sparsecholesky if symmetric, else umfpack; mumps: PETSc's, "
                            "docs/cluster.md)")
    bench.add_argument("--realcompile", choices=("auto", "yes", "no"), default="auto",
                       help="compile the Γ3 integrand to machine code (auto: when the run's expected Newton "
                            "iterations pay for it, ngcontact.model.machine_code)")
    bench.add_argument("--predictor", action="store_true",
                       help="start Newton from the linear extrapolation (default: from x_n)")
    bench.add_argument("--threads", choices=("auto", "yes", "no"), default="auto",
                       help="run under TaskManager (auto: from 30 000 DOFs)")
    bench.add_argument("--bare", action="store_true",
                       help="no glue, insulating foundation: symmetric Jacobian (θ = 1)")
    bench.add_argument("--path", choices=("new", "old"), default="new",
                       help="new (default): kept factorisation and limited Newton steps; old: a "
                            "factorisation at every Newton iteration, full steps")
    bench.add_argument("--solver", choices=("auto", "iterative", "multigrid", "gamg", "direct"), default="auto",
                       help="linear solver: GMRES with multigrid (iterative: NGSolve's multigrid serially, PETSc's "
                            "GAMG under mpiexec; or name one), a factorisation, or by size (auto: iterative in 3D "
                            "from 1e5 DOFs)")
    bench.add_argument("--compare", action="store_true",
                       help="run each case on both paths, one after the other: time ratio and state difference")
    bench.add_argument("--resume", action="store_true",
                       help="keep the cases already in OUT/bench.json (same dim, steps, dt) and measure the rest")
    bench.add_argument("--merge", metavar="DIR", nargs="+",
                       help="join the tables of earlier runs into --out instead of running")
    cost = commands.add_parser("bench-estimate", parents=[common], help="the equilibrated estimate's cost against "
                               "the step it certifies, on the reference scene after first contact (interleaved rounds, "
                               "medians, the split of the estimate's time)")
    cost.add_argument("--dim", type=int, choices=(2, 3), default=2, help="2D plate or 3D block")
    cost.add_argument("--order", metavar="P", type=int, default=2, help="polynomial order")
    cost.add_argument("--rounds", metavar="N", type=int, default=5, help="interleaved rounds (step, estimates)")
    cost.add_argument("--dt", metavar="DT", type=float, default=2.5e-3, help="time step, s")
    cost.add_argument("--maxh", metavar="H", type=float, default=None,
                      help="mesh size in m (default: 2D P2 and 3D P1 0.005, else 0.005 in 2D and 0.01 in 3D)")
    cost.add_argument("--refine", metavar="L", type=int, default=None,
                      help="refinements of the mesh (default: 2 for 2D P2, 1 for 3D P1, else 0)")
    _cluster_parser(commands, common)
    steps = commands.add_parser("timesteps", parents=[common], help="work–precision of the time schemes "
                                "(fixed-k backward Euler and BDF2, error-controlled BDF2) on the reference plate "
                                "(Nitsche, and the nodal constraint) and the debonding column: time_steps.csv, "
                                "summary.csv and charts")
    steps.add_argument("--out", metavar="DIR", type=_directory, default="timesteps", help="output directory")
    steps.add_argument("--scene", nargs="+", choices=("plate", "plate-nodal", "column"),
                       default=["plate", "plate-nodal", "column"], help="the scenes (default: all three)")
    steps.add_argument("--maxh", metavar="H", type=float, default=0.01, help="the plate's mesh size in m (default 0.01)")
    steps.add_argument("--T", metavar="S", type=float, default=0.25,
                       help="the plate's final time in s, 0.01 to 0.5 (default 0.25)")
    order = commands.add_parser("timeorder", parents=[common], help="the order in time of backward Euler and "
                                "BDF2 on the glued column, against Radau on its semi-discrete system (lift-off, "
                                "and debonding to β ≈ 4e-4): column_order.csv and chart")
    order.add_argument("--out", metavar="DIR", type=_directory, default="timeorder", help="output directory")
    order.add_argument("--history", nargs="+", choices=("lift", "debond"), default=["lift", "debond"],
                       help="the load histories (default: both)")
    adapt = commands.add_parser("adapt", parents=[common], help="adaptive against uniform refinement "
                                "(equilibrated estimate, Dörfler marking) on the manufactured contact case, the "
                                "Hertz scenes and the reference plate: errors.csv, summary.csv and charts")
    adapt.add_argument("--out", metavar="DIR", type=_directory, default="adapt", help="output directory")
    adapt.add_argument("--scene", nargs="+", choices=("manufactured", "hertz", "hertz3d", "reference"),
                       default=["manufactured", "hertz"], help="the scenes (default: manufactured hertz)")
    adapt.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1, 2],
                       help="polynomial orders (default 1 2; hertz3d runs P1 only)")
    adapt.add_argument("--stop-newton", metavar="F", type=float, default=None,
                       help="adaptive stopping: Newton stops once its correction is below F times the "
                            "estimate (0 < F <= 1; default: the fixed tolerances, with --tol 0.1 for the energy "
                            "goal)")
    adapt.add_argument("--marking", choices=("equilibrated", "averaging"), default=None,
                       help="what the adaptive runs mark by: the equilibrated estimate on every level (the study's "
                            "default), or the cheap averaging indicator with the equilibrated bound on the first and "
                            "last levels (the study adds it on the others, outside the loop's time; the default "
                            "with --tol)")
    adapt.add_argument("--fraction", metavar="F", type=float, default=None,
                       help="the adaptive runs' Dörfler fraction (0 < F <= 1; default 0.5)")
    adapt.add_argument("--goal", choices=("energy", "pressure", "force"), default="energy",
                       help="with --tol: what TOL bounds — the relative energy error (certified by the equilibrated "
                            "bound; the default), the relative L2 error of the contact pressure on the contact side, "
                            "or the relative error of the contact force (estimates, not bounds)")
    adapt.add_argument("--tol", metavar="TOL", type=float, default=None,
                       help="instead of the study: solve each scene's step to the relative estimate TOL "
                            "(1e-6 <= TOL < 1; adapt.solve: averaging marking, the bound certifies the last level) "
                            "and print its levels and certificate, written into OUT as each scene ends (tolerance.csv, "
                            "tolerance.json, each level's mesh as .vol); exit status 1 if a scene's limit comes first")
    axi = commands.add_parser("axisymmetric", parents=[common], help="the half-ball on a plane solved on its "
                              "meridian section (a body of revolution) against the 3D quarter-ball: pressure error "
                              "against solve time (setup apart), axisymmetric.csv, axisymmetric.md and a chart; "
                              "--adaptive: adaptive runs of both compared")
    axi.add_argument("--out", metavar="DIR", type=_directory, default="axisymmetric", help="output directory")
    axi.add_argument("--rounds", metavar="N", type=int, default=None,
                     help="interleaved repetitions, the least time of each case kept (default 2)")
    axi.add_argument("--quick", action="store_true", help="the coarsest sizes only, one round: its times are "
                     "single timings, marked indicative only (default: off)")
    axi.add_argument("--adaptive", action="store_true",
                     help="instead: adapt.solve on the section and on the quarter-ball (P2) to --tol; per level the "
                          "DOFs, force and contact radius, and whether the section lies within the 3D run's last "
                          "change (adaptive.csv, adaptive.md; default: off)")
    axi.add_argument("--tol", metavar="TOL", type=float, default=None,
                     help="with --adaptive: the relative estimate both runs are solved to (0 < TOL < 1; default 0.1)")
    imports = commands.add_parser("imports", parents=[common], help="the time of import ngcontact beyond import "
                                  "ngsolve: medians of fresh interpreters, interleaved")
    imports.add_argument("--runs", metavar="N", type=int, default=15,
                         help="fresh interpreters of each kind (default 15)")
    reference = commands.add_parser("hertz-reference", parents=[common], help="the converged reference of the 2D "
                                    "Hertz race problem (F, a, the pressure profile) on graded P3/P4 meshes, and "
                                    "the agreement of its mesh families, orders and γ0 (minutes)")
    reference.add_argument("--out", metavar="FILE", type=_directory, default="hertz_race_reference.json",
                           help="the JSON file written (default hertz_race_reference.json; the package's own is "
                                "ngcontact/studies/data/hertz_race_reference.json)")
    reference.add_argument("--levels", metavar="N", type=int, default=4,
                           help="levels of each graded mesh family, sizes halving (default 4, the stored reference's; about 25 min on 2 cores)")
    return main_parser


def _cluster_parser(commands, common):
    """The options of ``python -m ngcontact cluster``."""
    from ngcontact.studies import cluster_case
    cluster = commands.add_parser("cluster", parents=[common], help="serial against MPI ranks per solver, each run "
                                  "launched as its own process (python or mpiexec -n N): time per step, memory per "
                                  "rank and contact forces per solver and number of ranks, a scaling model (runs.csv, "
                                  "summary.md, model.json, charts); --factorisations: UMFPACK against MUMPS; not under "
                                  "mpiexec")
    cluster.add_argument("--out", metavar="DIR", type=_directory, default="cluster",
                         help="output directory (default cluster)")
    cluster.add_argument("--scene", choices=("plate", "block"), default="plate",
                         help="the reference scene: the 2D plate (default) or the 3D block")
    cluster.add_argument("--orders", metavar="P", type=int, nargs="+", default=[1],
                         help="polynomial orders (default 1)")
    cluster.add_argument("--levels", metavar="L", type=int, nargs="+", default=[1],
                         help="refinements of the scene's mesh (plate maxh 5 mm, block 10 mm; default 1)")
    cluster.add_argument("--ranks", metavar="N", type=int, nargs="+", default=[1, 2, 3],
                         help="MPI ranks per run, 1: serial; N ranks compute on N - 1 (default 1 2 3)")
    cluster.add_argument("--solvers", nargs="+", choices=tuple(cluster_case.SOLVERS), default=["default"],
                         help="solver configurations (default: default); those that cannot run on a number of ranks "
                              "are skipped with a note")
    cluster.add_argument("--steps", metavar="N", type=int, default=4,
                         help="time steps from t = 0 (default 4: first contact and its spreading)")
    cluster.add_argument("--dt", metavar="DT", type=float, default=2.0 ** -8,
                         help="time step, s (default 2^-8 = 0.00390625: binary-exact, so that every step has the same "
                              "1/dt and no solver is rebuilt by round-off)")
    cluster.add_argument("--repeat", metavar="K", type=int,
                         help="rounds of all configurations, interleaved (default 1; --factorisations: 3)")
    cluster.add_argument("--threads", choices=("auto", "yes", "no"), default="auto",
                         help="serial runs' steps under TaskManager (auto: from 30 000 DOFs); mpiexec: one per rank")
    cluster.add_argument("--realcompile", choices=("auto", "yes", "no"), default="yes",
                         help="compile the Γ3 integrand to machine code as each simulation is built (yes, the "
                              "default: the steps do not include it), when the run pays for it (auto), or not")
    cluster.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs")
    cluster.add_argument("--factorisations", action="store_true",
                         help="instead: the serial step Jacobian factorised by UMFPACK, MUMPS and MUMPS with its "
                              "analysis kept, interleaved (factorisations.csv, factorisations.md)")


def main(argv=None):
    """Entry point of ``python -m ngcontact`` and of the ``ngcontact`` script. Bad input
    (a ValueError or TypeError naming the parameter), a missing optional engine (an
    ImportError: PETSc for ``--inverse mumps``, what to install) and a failed Newton solve
    (``ngcontact.NewtonError``: where it failed, where the steps before it are kept, what to
    try) print one line and exit with status 2, as argparse does for its own errors; under
    mpiexec rank 0 prints it and every rank exits. Options that need an engine that is not
    installed, and commands that would run nothing, are refused before any work
    (``_refuse_before_work``). ``--traceback`` (or NGCONTACT_TRACEBACK=1) shows the full
    traceback instead. Warnings (``PhysicsWarning``) print one line each. A computation that
    ran but missed its target (``adapt --tol`` not reached) prints one line and exits with
    status 1."""
    args = parser().parse_args(argv)
    warnings.showwarning = _one_line_warning
    try:
        _refuse_before_work(args)
        _dispatch(args)
    except (ValueError, TypeError, ImportError, ngcontact.NewtonError) as err:
        if args.traceback or os.environ.get("NGCONTACT_TRACEBACK", "") not in ("", "0"):
            raise
        if ngcontact.parallel.rank() == 0:
            text = (_newton_line(err, args) if isinstance(err, ngcontact.NewtonError) else
                    _missing_line(err) if isinstance(err, ImportError) else str(err))
            print(f"ngcontact {args.command}: error: {' '.join(text.split())}", file=sys.stderr)
        sys.exit(2)


def _missing_line(err):
    """An ImportError in one line: ours say what needs the engine and how to install it; a bare
    "No module named ..." gets what is missing."""
    if isinstance(err, ModuleNotFoundError) and str(err).startswith("No module named"):
        top = (err.name or "?").split(".")[0]
        return f"this command needs the Python module {top!r}, which is not installed here ({sys.executable})"
    return str(err)


def _needs_petsc(option):
    """An ImportError naming ``option`` and how to install PETSc if it is not installed."""
    from ngcontact.studies.common import petsc_missing
    missing = petsc_missing()
    if missing:
        raise ImportError(f"{option} needs PETSc (petsc4py with MUMPS) and ngsPETSc; not installed here: "
                          f"{', '.join(missing)}; {ngcontact.petsc_solver.INSTALL}")


def _refuse_before_work(args):
    """The refusals that need the command line as a whole: bench's --inverse with an iterative
    --solver; an option that needs PETSc where it is not installed (bench --inverse mumps,
    --solver gamg, --solver iterative under mpiexec; cluster --factorisations; cluster's
    solvers are sorted out by ``cluster.plan``)."""
    if args.command == "bench" and not args.merge:
        choice = ngcontact.solve.linalg.solver_choice
        if args.inverse and args.solver in ("iterative",) + choice.ITERATIVE:
            raise ValueError(f"--inverse {args.inverse} with --solver {args.solver}: the iterative solvers solve by "
                             "GMRES with their own preconditioner and take no --inverse; drop one of the two")
        if args.inverse and choice.needs_petsc(args.inverse):
            _needs_petsc(f"--inverse {args.inverse}")
        if choice.needs_petsc(args.solver):
            under = " under mpiexec (PETSc's GAMG)" if args.solver not in choice.ITERATIVE else ""
            _needs_petsc(f"--solver {args.solver}{under}")
    elif args.command == "cluster" and args.factorisations:
        _needs_petsc("--factorisations (MUMPS)")


def _newton_line(err, args):
    """A NewtonError in one line: where, the last residuals, what is kept, what to try."""
    where = f"step {err.step} (t = {err.time:.6g} s), " if err.step is not None else ""
    if getattr(err, "levels", None) is not None:                   # (an adaptation's level: ``adapt``)
        where = f"adapt level {len(err.levels) + 1}, " + where
    last = ", ".join(f"{r:.3e}" for r in err.residuals[-3:])
    kept = KEPT[args.command].format(out=getattr(args, "out", None))       # (bench-estimate, imports: no --out)
    tried = ", ".join(f"{dt:.3g}" for dt in err.tried)
    return (f"Newton {err.reason} at {where}iteration {err.iteration} (last residuals {last}"
            + (f"; dt = {tried} s tried" if tried else "") + f"); the steps before it are kept in {kept}"
            + (f"; try: {err.hint.lstrip('; ')}" if err.hint else ""))


def _dispatch(args):
    """Call the command's function."""
    choice = dict(auto=None, yes=True, no=False)
    if args.command == "demo":
        from ngcontact import demo
        demo.run(order=args.order, out=args.out, maxh=args.maxh, steps=args.steps, theta=args.theta,
                 gamma0=args.gamma0, resume=args.resume, dim=args.dim, refine=args.refine, scheme=args.scheme,
                 rtol=args.rtol, switch_loop=not args.plain_corrections)
    elif args.command == "convergence":
        from ngcontact.studies import convergence
        convergence.command(args.orders, args.levels, args.case, args.smoothness, args.dt_halvings, args.out,
                            args.resume, scheme=args.scheme, dt0=args.dt0)
    elif args.command == "stability":
        from ngcontact.studies import stability
        stability.command(args.out, args.quick, args.resume, args.study)
    elif args.command == "hertz":
        from ngcontact.studies import hertz
        hertz.command(args.out, args.orders, args.levels, args.dim, args.resume)
    elif args.command == "timeorder":
        from ngcontact.studies import column_order
        column_order.main(args.out, histories=tuple(args.history))
    elif args.command == "timesteps":
        from ngcontact.studies import time_steps
        time_steps.main(args.out, maxh=args.maxh, T=args.T, which=args.scene)
    elif args.command == "adapt":
        from ngcontact.studies import adaptivity
        if args.tol is not None:
            results = adaptivity.to_tolerance(args.tol, scenes=tuple(args.scene), orders=tuple(args.orders),
                                              fraction=args.fraction, marking=args.marking,
                                              stop_newton=args.stop_newton, out=args.out, goal=args.goal)
            named = "" if args.goal == "energy" else f"{args.goal} "
            missed = [f"{name} P{order} ({result.reason}: relative {named}estimate "
                      f"{result.last.relative if args.goal == 'energy' else result.last.goal_estimate:.3g})"
                      for (name, order), result in results.items() if not result.reached]
            if missed:       # a run that did not certify its tol is not a success
                advice = ("no contact on Γ3: adapt for --goal energy" if all(
                    result.reason == "no contact" for result in results.values() if not result.reached)
                    else "ask for a larger --tol")
                print(f"ngcontact adapt: --tol {args.tol:g} NOT reached for {', '.join(missed)}; the levels computed "
                      f"are printed above; {advice}", file=sys.stderr)
                sys.exit(1)
        elif args.goal != "energy":
            raise ValueError(f"--goal {args.goal} is what --tol bounds; add --tol (e.g. --tol 1e-3) or drop --goal")
        else:
            adaptivity.main(args.out, scenes=tuple(args.scene), orders=tuple(args.orders),
                            stop_newton=args.stop_newton, marking=args.marking or "equilibrated",
                            fraction=args.fraction)
    elif args.command == "axisymmetric":
        from ngcontact import checks
        from ngcontact.studies import axisymmetric
        if args.adaptive:
            if args.quick or args.rounds is not None:
                extra = "--quick" if args.quick else "--rounds"
                raise ValueError(f"--adaptive runs each adaptation once to --tol: {extra} is the uniform study's; drop "
                                 "it (a cheaper adaptive run: a larger --tol)")
            axisymmetric.command_adaptive(args.out, tol=axisymmetric.ADAPTIVE_TOL if args.tol is None else args.tol)
        elif args.tol is not None:
            raise ValueError("--tol is the target of --adaptive; add --adaptive or drop --tol")
        else:
            axisymmetric.command(args.out, rounds=checks.integer("--rounds", 2 if args.rounds is None else args.rounds,
                                                                 1, 20), quick=args.quick)
    elif args.command == "cluster":
        from ngcontact.studies import cluster
        rounds = dict(repeat=args.repeat) if args.repeat is not None else {}     # the defaults: 3 and 1
        if args.factorisations:
            cluster.factorisations(args.out, scene=args.scene, orders=args.orders, levels=args.levels, dt=args.dt,
                                   resume=args.resume, **rounds)
        else:
            cluster.run(args.out, scene=args.scene, orders=args.orders, levels=args.levels, ranks=args.ranks,
                        solvers=args.solvers, steps=args.steps, dt=args.dt, threads=choice[args.threads],
                        realcompile=choice[args.realcompile], resume=args.resume, **rounds)
    elif args.command == "imports":
        from ngcontact.studies import bench
        bench.import_cost(args.runs)
    elif args.command == "bench-estimate":
        from ngcontact import checks
        from ngcontact.studies import estimate_cost
        estimate_cost.command(args.dim, checks.order("--order", args.order),
                              checks.integer("--rounds", args.rounds, 1, 50), args.dt, args.maxh, args.refine)
    elif args.command == "hertz-reference":
        from ngcontact.studies import hertz_reference
        hertz_reference.command(args.out, args.levels)
    elif args.merge:
        from ngcontact.studies import bench
        bench.merge(args.merge, args.out)
    else:
        from ngcontact.studies import bench
        bench.run(args.out, orders=args.orders, dim=args.dim, max_ndof=args.max_ndof, steps=args.steps,
                  dt=args.dt, inverse=args.inverse, predictor=args.predictor,
                  realcompile=choice[args.realcompile], threads=choice[args.threads], bare=args.bare,
                  path=args.path, compare=args.compare, resume=args.resume,
                  iterative=dict(auto=None, iterative=True, direct=False).get(args.solver, args.solver))
