"""``python -m ngcontact cluster``: serial against MPI ranks per solver (time per step, memory
per rank, a scaling model; docs/cluster.md), run reproducibly from a plain shell.

Every run is a process of its own (``cluster_case``): ``python`` for one rank, ``mpiexec -n N
python`` (the mpiexec next to ``sys.executable``) for N; under mpiexec rank 0 holds no
elements, so N ranks compute on p = N − 1. Per size (scene, order, refinement level) the
configurations (ranks × solver) run in turn, ``repeat`` rounds of them (A B A B: the
machine's drift spread over all). A configuration that cannot run (``masterinverse``
serially, ``multigrid`` or ``umfpack`` under mpiexec, a PETSc solver without PETSc) is
skipped with a note; if none can run, the command is refused before any run.

``run`` writes into ``out``: ``runs/<run>.json`` (what the worker recorded: per step the
wall time, Newton and Krylov iterations and contact force; every rank's peak memory) and
``logs/<run>.log`` (its output), ``runs.csv`` (a row per run), and, by ``cluster_report``,
``summary.csv``/``summary.md`` (medians per size and configuration, ratios to the serial
default and to masterinverse's rank 0, the force difference to the serial run), the charts
and ``model.json`` (``cluster_model``: the scaling model and its extrapolation to 10⁷
DOFs). ``factorisations`` (``--factorisations``) writes ``factorisations.csv``/``.md``:
UMFPACK against MUMPS on the serial step Jacobian.

Runs already in ``out`` are part of the tables; ``resume`` keeps them instead of measuring
them again. Times are wall-clock seconds; nothing here asserts a time.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np

from ngcontact import checks, parallel, petsc_solver
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from . import cluster_report, common
from .bench import MAXH
from .cluster_case import DISTRIBUTED_ONLY, NEEDS_PETSC, SCENES, SERIAL_ONLY, SOLVERS

WORKER = "ngcontact.studies.cluster_case"
"""The module each run executes (``python -m``)."""
DT = 2.0 ** -8
"""The default time step, s: a power of two, so that t_n − t_{n−1} is exact and every
step has the same rate coefficient 1/dt. With a step that is not a power of two, round-off in
t_n − t_{n−1} changes 1/dt from step to step, and with it the system's generation: the kept
factorisations are made anew and GAMG's preconditioner rebuilt and compiled again, which costs
seconds a step (docs/measurements.md, section cluster)."""
MAX_RANKS = 1024
"""The most MPI ranks a run may ask for."""
SHOWN = ("order", "level", "ndof", "ranks", "solver", "round", "step_s", "newton_mean", "krylov_per_newton",
         "peak_mib", "status")
"""The columns of the line printed per run."""
FACTORISATION_COLUMNS = ("scene", "order", "level", "ndof", "free", "nonzeros", "rounds", "umfpack_s",
                         "umfpack_min", "umfpack_max", "mumps_s", "mumps_min", "mumps_max", "update_s", "update_min",
                         "update_max", "umfpack_over_mumps", "umfpack_over_update", "umfpack_solve_s",
                         "mumps_solve_s", "mumps_diff", "update_diff", "peak_mib")
"""Columns of factorisations.csv: medians over the rounds (s) with their min and max, the
ratios of the medians, the solves' medians and the largest solution differences."""


def mpiexec():
    """The mpiexec next to this Python (the mpich wheel's, in the environment's bin/), else
    the one on PATH; a ValueError if there is none."""
    found = pathlib.Path(sys.executable).parent / "mpiexec"
    found = str(found) if found.exists() else shutil.which("mpiexec")
    if not found:
        raise ValueError("ranks above 1 need mpiexec next to this Python or on PATH (pip install mpich mpi4py)")
    return found


def _names(name, values, allowed):
    """A nonempty list of ``values``, each one of ``allowed`` (a ValueError naming ``name``
    and them otherwise)."""
    if isinstance(values, str) or not isinstance(values, (list, tuple, range)) or not values:
        raise ValueError(f"{name} must be a nonempty list of {', '.join(map(repr, allowed))}, got {values!r}")
    return [checks.choice(name, value, tuple(allowed)) for value in values]


def _integers(name, values, low, high):
    """A nonempty list of integers in [low, high] without repeats."""
    if isinstance(values, str) or not isinstance(values, (list, tuple, range)) or not values:
        raise ValueError(f"{name} must be a nonempty list of integers in [{low}, {high}], got {values!r}")
    return list(dict.fromkeys(checks.integer(name, v, low, high) for v in values))


def _sizes(scene, orders, levels):
    """The (order, level) pairs, checked against the machine's memory (``checks``)."""
    dim = SCENES[checks.choice("scene", scene, tuple(SCENES))]
    sides = (reference.L1, reference.L2) if dim == 2 else (reference.L1, reference.WIDTH, reference.L2)
    orders = common.orders("orders", orders)
    levels = _integers("levels", levels, 0, checks.MAX_REFINE)
    for order in orders:
        checks.fits_in_memory(f"scene {scene}, order {order}, level {max(levels)}", checks.estimated_ndof(
            checks.estimated_vertices(sides, MAXH[dim]), dim, max(levels), order))
    return [(order, level) for order in orders for level in levels]


def plan(ranks, solvers):
    """(the (ranks, solver) configurations that can run, notes on those skipped: a solver that
    cannot run on that number of ranks, or that needs PETSc where it is not installed)."""
    configurations, notes = [], []
    missing = common.petsc_missing()
    for n in ranks:
        for solver in solvers:
            why = SERIAL_ONLY.get(solver) if n > 1 else DISTRIBUTED_ONLY.get(solver)
            if not why and solver in NEEDS_PETSC and missing:
                why = f"it needs PETSc; not installed here: {', '.join(missing)}"
            if why:
                notes.append(f"skipped: {solver} on {n} rank{'s' if n > 1 else ''} ({why})")
            else:
                configurations.append((n, solver))
    return configurations, notes


def run(out, *, scene="plate", orders=(1,), levels=(1,), ranks=(1, 2, 3), solvers=("default",), steps=4,
        dt=DT, repeat=1, threads=None, realcompile=True, resume=False, progress=True):
    """Measure every size × configuration ``repeat`` times (module docstring); returns the
    summary rows. Arguments: ``scene`` "plate" or "block"; ``orders`` in [1, 10]; ``levels``
    (refinements) in [0, 10]; ``ranks`` the MPI ranks N of each configuration (1: serial);
    ``solvers`` names of ``cluster_case.SOLVERS``; ``steps`` time steps of ``dt`` s from t = 0
    (``DT``; the defaults reach first contact at the second step, the third on the block at
    level 0); ``threads`` a serial run's steps under TaskManager (None: from 3·10⁴ DOFs);
    ``realcompile`` Simulation's (True: compiled as it is built, not inside the steps; None:
    automatic); all checked before any run: the steps must stay inside the load history (dt
    at most the history's end / steps), and at least one configuration must be able to run (``plan``).
    Refused under mpiexec (it launches mpiexec itself)."""
    parallel.refuse_under_mpiexec("python -m ngcontact cluster")
    sizes = _sizes(scene, orders, levels)
    ranks = _integers("ranks", ranks, 1, MAX_RANKS)
    solvers = list(dict.fromkeys(_names("solvers", solvers, SOLVERS)))
    steps = checks.integer("steps", steps, 1, checks.MAX_STEPS)
    dt = checks.number("dt", dt, 0, low_open=True, unit="s")
    common.time_window(steps, dt, reference.LOAD_HISTORY[-1][0])
    repeat = checks.integer("repeat", repeat, 1, 1000)
    threads = checks.flag("threads", threads, none=True)
    realcompile = checks.flag("realcompile", realcompile, none=True)
    resume, progress = checks.flag("resume", resume), checks.flag("progress", progress)
    configurations, notes = plan(ranks, solvers)
    if not configurations:
        raise ValueError(f"solvers {' '.join(solvers)} on ranks {' '.join(map(str, ranks))}: no configuration can "
                         "run here (" + "; ".join(note.removeprefix("skipped: ") for note in notes)
                         + (f"; PETSc: {petsc_solver.INSTALL}" if any("PETSc" in note for note in notes) else "")
                         + "); choose other --solvers or --ranks")
    if any(n > 1 for n, _ in configurations):
        mpiexec()
    out = checks.writable_directory(out)
    for folder in ("runs", "logs"):
        (out / folder).mkdir(exist_ok=True)
    _same_window(out, steps, dt, realcompile)
    missing = {}                                   # configurations a worker found unable to run (no PETSc)
    with bar(len(sizes) * repeat * len(configurations), "cluster runs", progress, unit="run") as shown:
        say = shown.write if progress else print
        for note in notes:
            say(note)
        for order, level in sizes:
            for round_ in range(1, repeat + 1):
                for n, solver in configurations:
                    if (n, solver) not in missing:
                        spec = dict(kind="run", scene=scene, order=order, level=level, solver=solver, steps=steps,
                                    dt=dt, threads=threads, realcompile=realcompile)
                        result = _measured(out, spec, n, round_, resume)
                        if "skipped" in result:
                            missing[n, solver] = result["skipped"]
                            say(f"skipped: {solver} on {n} rank(s): {result['skipped']}")
                        else:
                            say(common.line(cluster_report.row(result), SHOWN))
                    shown.update()
            summary = cluster_report.write(out)
    if not any(s["runs"] or s.get("failed") for s in summary):       # every run skipped: nothing was measured
        reasons = sorted(set(missing.values())) or [f"see {out / 'logs'}"]
        raise ValueError(f"no run completed ({'; '.join(reasons)}); solvers {' '.join(solvers)} on ranks "
                         f"{' '.join(map(str, ranks))}")
    print(common.table(summary, cluster_report.SHOWN))
    text = (out / "summary.md").read_text()
    print(text[text.index("## Scaling model"):].strip())
    return summary


def _same_window(out, steps, dt, realcompile):
    """Refuse to add runs of other ``steps``, ``dt`` or ``realcompile`` to a directory holding
    runs (the tables compare runs of one window of the load history, compiled alike)."""
    for path in sorted((out / "runs").glob("*.json")):
        earlier = json.loads(path.read_text())
        if (earlier.get("steps"), earlier.get("dt"), earlier.get("realcompile_option")) != (steps, dt, realcompile):
            raise ValueError(f"{str(out)!r} holds runs of steps {earlier.get('steps')}, dt {earlier.get('dt')}, "
                             f"realcompile {earlier.get('realcompile_option')} ({path.name}); run with those (--steps, "
                             "--dt, --realcompile) or write to a new --out")


def _key(spec, ranks, round_):
    """A run's file name stem."""
    return (f"{spec['scene']}_p{spec['order']}_l{spec['level']}_n{ranks}_{spec['solver']}"
            f"_t{'auto' if spec['threads'] is None else int(spec['threads'])}_r{round_}")


def _measured(out, spec, ranks, round_, resume):
    """The worker's result of one run (launched, or read back when ``resume`` and it is on
    disk), with ``round`` and, if the worker failed, ``failed`` (its last output line)."""
    key = _key(spec, ranks, round_)
    path, log = out / "runs" / f"{key}.json", out / "logs" / f"{key}.log"
    if resume and path.exists():
        result = json.loads(path.read_text())
        if "failed" not in result:
            return result
    returncode = launch(spec, ranks, path, log)
    if returncode == 0 and path.exists():
        result = json.loads(path.read_text())
    else:
        lines = [line for line in log.read_text(errors="replace").splitlines() if line.strip()] or ["no output"]
        result = dict(spec, failed=f"exit status {returncode}: {lines[-1].strip()}")
    if "skipped" in result:                         # not a run: nothing kept
        path.unlink(missing_ok=True)
        return result
    result.update(round=round_, ranks=ranks, threads_option=spec["threads"], realcompile_option=spec["realcompile"])
    path.write_text(json.dumps(result))
    return result


def launch(spec, ranks, path, log):
    """Run the worker on ``spec`` (``python`` or ``mpiexec -n ranks python``), its output into
    the file ``log``, its result into ``path``; returns its exit status."""
    path.unlink(missing_ok=True)
    command = ([mpiexec(), "-n", str(ranks)] if ranks > 1 else []) + \
        [sys.executable, "-m", WORKER, json.dumps(spec), str(path)]
    with open(log, "w") as output:
        return subprocess.run(command, stdout=output, stderr=subprocess.STDOUT, env=dict(os.environ)).returncode


def factorisations(out, *, scene="block", orders=(1,), levels=(3,), repeat=3, dt=DT, resume=False, progress=True):
    """UMFPACK against MUMPS: per order and level, serially, the step Jacobian after the first step
    of ``dt`` s factorised ``repeat`` times each by UMFPACK, by MUMPS and by MUMPS with its
    analysis kept, interleaved (``cluster_case.factorisations``); writes ``factorisations/``,
    ``factorisations.csv`` and ``factorisations.md`` into ``out``, prints the table and returns
    its rows: every case run into ``out``, this call's and earlier ones'. Needs PETSc (a
    case without it is reported skipped)."""
    parallel.refuse_under_mpiexec("python -m ngcontact cluster --factorisations")
    sizes = _sizes(scene, orders, levels)
    repeat = checks.integer("repeat", repeat, 1, 1000)
    dt = checks.number("dt", dt, 0, low_open=True, unit="s")
    common.time_window(1, dt, reference.LOAD_HISTORY[-1][0])
    resume, progress = checks.flag("resume", resume), checks.flag("progress", progress)
    out = checks.writable_directory(out)
    for folder in ("factorisations", "logs"):
        (out / folder).mkdir(exist_ok=True)
    with bar(len(sizes), "factorisations", progress, unit="case") as shown:
        say = shown.write if progress else print
        for order, level in sizes:
            stem = f"{scene}_p{order}_l{level}_k{repeat}"
            path = out / "factorisations" / f"{stem}.json"
            if not (resume and path.exists()):
                spec = dict(kind="factorisations", scene=scene, order=order, level=level, rounds=repeat, dt=dt)
                launch(spec, 1, path, out / "logs" / f"factorisations_{stem}.log")
            if not path.exists():
                say(f"failed: P{order} level {level}, see logs/factorisations_{stem}.log")
            elif "skipped" in (result := json.loads(path.read_text())):
                say(f"skipped: P{order} level {level}: {result['skipped']}")
            shown.update()
    rows = _factorisation_rows(out)
    if rows:
        common.write_csv(rows, out / "factorisations.csv", FACTORISATION_COLUMNS)
        (out / "factorisations.md").write_text("# UMFPACK against MUMPS, the serial step Jacobian\n\n"
                                               + cluster_report.markdown_table(rows, FACTORISATION_COLUMNS) + "\n")
        print(common.table(rows, FACTORISATION_COLUMNS))
    return rows


def _factorisation_rows(out):
    """The rows of every case run into ``out`` (this call's and earlier calls' into the same
    directory, e.g. P1 and P2 run one after the other), by scene, order, level, rounds."""
    results = [json.loads(path.read_text()) for path in (out / "factorisations").glob("*.json")]
    rows = [_factorisation_row(result) for result in results if "skipped" not in result]
    return sorted(rows, key=lambda row: (row["scene"], row["order"], row["level"], row["rounds"]))


def _factorisation_row(result):
    """A row of factorisations.csv from a worker's result."""
    row = {key: result[key] for key in ("scene", "order", "level", "ndof", "free", "nonzeros", "rounds", "peak_mib")}
    for name in ("umfpack", "mumps", "update"):
        values = result[f"{name}_s"]
        row.update({f"{name}_s": float(np.median(values)), f"{name}_min": min(values), f"{name}_max": max(values)})
    row.update(umfpack_over_mumps=row["umfpack_s"] / row["mumps_s"],
               umfpack_over_update=row["umfpack_s"] / row["update_s"],
               **{f"{name}_solve_s": float(np.median(result[f"{name}_solve_s"])) for name in ("umfpack", "mumps")},
               mumps_diff=max(result["mumps_diff"]), update_diff=max(result["update_diff"]))
    return row
