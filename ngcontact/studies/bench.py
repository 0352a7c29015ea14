"""Speed benchmark: time per step of the reference scene against the cost of one linear solve.

The floor for one backward Euler step is (Newton iterations) × (one assembly of the
Jacobian + one factorisation + one solve). For each order and nested refinement level
``case`` runs the first ``steps`` time steps of the reference scene (``scenes.reference``;
the plate pressed onto the foundation: contact forms and spreads, the hardest part for
Newton), splits the wall time per step into the Newton phases and the rest, and measures
one linearised solve at the final state in the same run:

  overhead = (time per step) / (mean Newton iterations × one linearised solve).

``factorizations`` per step and ``krylov_per_newton`` (GMRES iterations per Newton
iteration) show how often the kept factorisation (``linear_solver.KeptFactorization``) was
made anew. ``compare=True`` (``--compare``) runs every case a second time on the old path
(``OLD_PATH``: a factorisation at every Newton iteration, no step-length limit) and prints
both rows with the ratio of their times per step and the largest difference of their final
states (relative to the largest entry).

``python -m ngcontact bench --out DIR`` writes bench.csv, bench.json and time_per_step.png.
``import_cost`` (``python -m ngcontact imports``) times ``import ngcontact`` beyond ``import
ngsolve`` in fresh interpreters.
Times are wall-clock seconds on the machine that runs it; nothing here asserts a time.

Under ``mpiexec -n N`` every case runs on a distributed mesh (``ngcontact.parallel``; ranks
1 .. N−1 hold the elements) and rank 0 prints and writes; ``ranks`` in a row is N, the times
are rank 0's (it takes part in every collective step, and factorises in "masterinverse").
"""
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import time as wallclock
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np
from matplotlib.figure import Figure

from ngcontact import checks, parallel
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from . import common
from .common import fitted_slope, write_csv

COLUMNS = ("dim", "order", "level", "ndof", "records", "newton_mean", "newton_max", "step_s",
           "assembly_s", "factorization_s", "solve_s", "residual_s", "other_s", "one_solve_s",
           "overhead", "setup_s", "factorizations", "krylov_per_newton", "path", "speedup", "state_diff",
           "solver", "condense", "realcompile", "threads", "peak_mib", "hierarchy_s", "ranks")
"""Columns of bench.csv; times in s, per step except one_solve_s and setup_s; ``records``:
the steps computed (cut-backs included); ``factorizations``: per step; ``path``: "new" or
"old" (``OLD_PATH``); ``speedup`` (old step_s / new step_s) and ``state_diff`` (max |x_old −
x_new| / max |x_old| over the final state vectors, u and φ) on the new row of a comparison;
``peak_mib``: the peak resident memory after the case (MiB, summed over the MPI ranks;
cases run in ascending size, so it is the case's own peak unless a comparison's old path
ran before it); ``hierarchy_s``: the multigrid solver's setup (replica hierarchy) inside the
steps, s; ``ranks``: the MPI ranks of the run (1: serial)."""
OLD_PATH = dict(limit_steps=False)
"""The Simulation options of the old path (main before the kept factorisation, 71be180): full
Newton steps, and a factorisation at every Newton iteration (``solver``)."""
THREADS_FROM = 30_000
"""Below this many DOFs the steps run without TaskManager: the ds(skeleton=True) loops over
all facets lose more to threading than assembly gains (docs/speed.md)."""
MAXH = {2: 0.005, 3: 0.01}
"""Coarsest mesh size per dimension, m (level ℓ: ℓ times ``mesh.Refine()``)."""


def case(order, level, **options):
    """One benchmark row (a dict with ``COLUMNS``); see ``measure``."""
    return measure(order, level, **options)[0]


def measure(order, level, *, dim=2, steps=10, dt=2.5e-3, inverse=None, realcompile=None,
            predictor=False, condense=None, threads=None, bare=False, path="new", iterative=None):
    """One benchmark row (a dict with ``COLUMNS``) for the reference scene at P``order`` on
    refinement ``level``: ``steps`` time steps of ``dt`` s. ``inverse``, ``realcompile``,
    ``predictor`` and ``condense`` go to Simulation; ``threads``: run under TaskManager
    (default: from ``THREADS_FROM`` DOFs); ``bare=True``: no glue, no conduction (symmetric
    Jacobian with θ = 1: sparse Cholesky by default); ``path``: "new" (the defaults) or
    "old" (``OLD_PATH``); ``iterative``: GMRES with multigrid (True), a factorisation (False)
    or the default by size (None, ``solver_choice``). Returns the row and the final state
    vector (numpy)."""
    if path not in ("new", "old"):
        raise ValueError(f"path must be 'new' or 'old', got {path!r}")
    solver = iterative if isinstance(iterative, str) else "iterative" if iterative else \
        {"ksp_type": "preonly", **({"pc_factor_mat_solver_type": inverse} if inverse else {})} if path == "old" else \
        inverse or ("direct" if iterative is False else None)
    start = wallclock.perf_counter()
    body = reference.body(order, MAXH[dim], refine=level, dim=dim)
    threads = body.ndof >= THREADS_FROM if threads is None else threads
    with ngs.TaskManager() if threads else nullcontext():
        sim = reference.simulation(order, MAXH[dim], level, dim, contact=reference.contact(bare=bare),
                                   solver=solver, keep_states=False, realcompile=realcompile,
                                   predictor=predictor, condense=condense,
                                   **(OLD_PATH if path == "old" else {}))
        setup = wallclock.perf_counter() - start
        sim.run(dt, steps * dt)
        records = sim.history[1:]
        one_solve = one_linear_solve(sim)
    iterations = np.array([r.newton_iterations for r in records])
    mean = {phase: float(np.mean([r.timings[phase] for r in records])) for phase in records[0].timings}
    step_s = float(np.mean([r.wall_s for r in records]))
    krylov = sum(r.krylov_iterations for r in records)
    row = dict(dim=dim, order=order, level=level, ndof=body.ndof, records=len(records),
                newton_mean=float(iterations.mean()), newton_max=int(iterations.max()), step_s=step_s,
                **{f"{phase}_s": mean[phase] for phase in ("assembly", "factorization", "solve",
                                                           "residual", "other")},
                one_solve_s=one_solve, overhead=step_s / (iterations.mean() * one_solve),
                setup_s=setup, factorizations=float(np.mean([r.factorizations for r in records])),
                krylov_per_newton=krylov / max(int(iterations.sum()), 1), path=path, speedup=None,
                state_diff=None, solver=sim.solver, condense=sim.condense, realcompile=sim.realcompile,
                threads=threads, peak_mib=parallel.sum(body.mesh, peak_mib()),
                hierarchy_s=getattr(sim.newton.solver, "setup_s", 0.0), ranks=_ranks())
    return row, sim.gfu.vec.FV().NumPy().copy()


def _ranks():
    comm = parallel.world()
    return 1 if comm is None else comm.size


def _state_diff(old, new):
    """max |old − new| / max |old| over the final states (each rank's part under mpiexec)."""
    diff, size = np.abs(old - new).max(initial=0.0), np.abs(old).max(initial=0.0)
    comm = parallel.world()
    if comm is not None:
        from mpi4py import MPI
        diff, size = comm.allreduce(diff, op=MPI.MAX), comm.allreduce(size, op=MPI.MAX)
    return float(diff / size)


def one_linear_solve(sim, repeat=2):
    """Wall time (s) of one Newton correction at the current state: assembly of the Jacobian,
    factorisation and solve, done by the simulation's own Newton (the fastest of ``repeat``)."""
    newton, x = sim.newton, sim.gfu.vec
    sim.system.Apply(x, newton.r)
    times = []
    for _ in range(repeat):
        start = wallclock.perf_counter()
        newton.linear_solve(x)
        times.append(wallclock.perf_counter() - start)
    return min(times)


def peak_mib():
    """The peak resident memory of this process so far, MiB (Linux ru_maxrss is in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def krylov_growth(rows):
    """Per order: the ratios of Krylov iterations per Newton iteration between consecutive
    refinement levels (new path rows with Krylov iterations)."""
    growth = {}
    for order in dict.fromkeys(r["order"] for r in rows):
        values = [r["krylov_per_newton"] for r in sorted(rows, key=lambda r: r["level"])
                  if r["order"] == order and r.get("path", "new") == "new"]
        growth[int(order)] = [b / a for a, b in zip(values[:-1], values[1:]) if a > 0]
    return growth


def growth_exponent(ndof, seconds, min_ndof=1e4):
    """Least-squares slope of log(seconds) against log(ndof) over the sizes >= min_ndof
    (nan with fewer than three such sizes)."""
    ndof, seconds = np.asarray(ndof, float), np.asarray(seconds, float)
    keep = ndof >= min_ndof
    return fitted_slope(ndof[keep], seconds[keep])


def levels(order, dim, max_ndof):
    """The refinement levels whose ndof stays <= max_ndof (the meshes are built to count)."""
    found, sizes = [0], [reference.body(order, MAXH[dim], dim=dim).ndof]
    while True:
        # a refinement multiplies ndof by ~2^dim: do not build a mesh far beyond max_ndof
        guess = sizes[-1] * (sizes[-1] / sizes[-2] if len(sizes) > 1 else 2 ** dim)
        if guess > 2 * max_ndof:
            return found
        size = reference.body(order, MAXH[dim], refine=found[-1] + 1, dim=dim).ndof
        if size > max_ndof:
            return found
        found.append(found[-1] + 1)
        sizes.append(size)


def run(out, *, orders=(1, 2, 3, 4), dim=2, max_ndof=1e6, steps=10, dt=2.5e-3, progress=True,
        compare=False, resume=False, **options):
    """All cases up to ``max_ndof``: prints the table as it goes, writes bench.csv,
    bench.json (rows and fitted exponents per order) and time_per_step.png into ``out``
    after each case (long runs keep what they recorded). ``compare``: each case also on the
    old path, right after the new one. ``resume``: the cases already in ``out/bench.json``
    (same dim, steps and dt) are kept and not run again. The arguments are checked
    before any case: orders in [1, 10], ``max_ndof`` finite, at least the coarsest mesh's
    DOFs of each order and within the machine's memory, steps in [1, 10⁶], dt in
    [``arguments.MIN_DT``, the history's end / steps] (the steps inside the load history)."""
    orders = common.orders("orders", orders)
    dim = checks.choice("dim", dim, (2, 3))
    max_ndof = checks.number("max_ndof", max_ndof, 1, unit="DOFs")
    checks.fits_in_memory(f"max_ndof = {max_ndof:g}", max_ndof)
    steps = checks.integer("steps", steps, 1, checks.MAX_STEPS)
    dt = checks.number("dt", dt, 0, low_open=True, unit="s")
    common.time_window(steps, dt, reference.LOAD_HISTORY[-1][0])
    progress, compare, resume = (checks.flag(name, value) for name, value in
                                 (("progress", progress), ("compare", compare), ("resume", resume)))
    coarsest = {order: reference.body(order, MAXH[dim], dim=dim).ndof for order in orders}
    below = [f"P{order}: {ndof}" for order, ndof in coarsest.items() if ndof > max_ndof]
    if below:
        raise ValueError(f"max_ndof = {max_ndof:g} is below the coarsest mesh's DOFs ({', '.join(below)}): "
                         "nothing to measure")
    writes = parallel.rank() == 0                    # under mpiexec: rank 0 prints and writes
    out = checks.writable_directory(out)
    cases = [(order, level) for order in orders for level in levels(order, dim, max_ndof)]
    rows = _done(out, dim, steps, dt) if resume else []
    with bar(len(cases), "bench cases", progress, unit="run") as shown:
        say = shown.write if writes else (lambda text: None)
        say(_header())
        for order, level in cases:
            if any((r["order"], r["level"], r.get("path", "new")) == (order, level, "new") for r in rows):
                shown.update()
                continue
            new, state = measure(order, level, dim=dim, steps=steps, dt=dt, **options)
            rows.append(new)
            say(_line(new))
            if compare:
                old, old_state = measure(order, level, dim=dim, steps=steps, dt=dt, **{**options, "path": "old"})
                new["speedup"] = old["step_s"] / new["step_s"]
                new["state_diff"] = _state_diff(old_state, state)
                rows.append(old)
                say(_line(old) + f"   old/new {new['speedup']:.2f}x, states differ by "
                            f"{new['state_diff']:.1e}")
            shown.update()
            if writes:
                _write(out, rows, dim, steps, dt)
    if not writes:
        return rows, None
    exponents = _write(out, rows, dim, steps, dt)
    print("time per step ~ ndof^a (fit over ndof >= 1e4): "
          + ", ".join(f"P{p}: a = {a:.2f}" for p, a in exponents.items()))
    print("Krylov iterations per Newton iteration, growth per level: "
          + "; ".join(f"P{p}: " + ", ".join(f"{g:.2f}x" for g in gs) for p, gs in krylov_growth(rows).items()))
    return rows, exponents


def _done(out, dim, steps, dt):
    """The rows of ``out/bench.json`` if it holds a run with the same dim, steps and dt."""
    path = out / "bench.json"
    if not path.exists():
        return []
    earlier = json.loads(path.read_text())
    if (earlier["dim"], earlier["steps"], earlier["dt"]) != (dim, steps, dt):
        raise ValueError(f"resume: {str(path)!r} holds a bench with dim {earlier['dim']}, steps "
                         f"{earlier['steps']}, dt {earlier['dt']}; run with those or write to a new --out")
    return earlier["rows"]


def merge(directories, out):
    """Join the bench.json rows of several runs (e.g. one per order) into one bench.csv,
    bench.json and time_per_step.png in ``out``; prints and returns the fitted exponents
    per order."""
    runs = []
    for directory in directories:
        path = pathlib.Path(directory) / "bench.json"
        try:
            runs.append(json.loads(path.read_text()))
        except (OSError, ValueError) as err:
            raise ValueError(f"merge: {str(path)!r} cannot be read ({type(err).__name__}): --merge takes "
                             "directories written by bench --out") from None
    if len({(r["dim"], r["steps"], r["dt"]) for r in runs}) != 1:
        raise ValueError("merge: the runs differ in dim, steps or dt")
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [row for r in runs for row in r["rows"]]
    exponents = _write(out, rows, runs[0]["dim"], runs[0]["steps"], runs[0]["dt"])
    print("time per step ~ ndof^a: " + ", ".join(f"P{p}: a = {a:.2f}" for p, a in exponents.items()))
    return exponents


def _write(out, rows, dim, steps, dt):
    new = [r for r in rows if r.get("path", "new") == "new"]
    exponents = {int(order): growth_exponent([r["ndof"] for r in new if r["order"] == order],
                                             [r["step_s"] for r in new if r["order"] == order])
                 for order in dict.fromkeys(r["order"] for r in rows)}
    write_csv(rows, out / "bench.csv", COLUMNS)
    (out / "bench.json").write_text(json.dumps(dict(dim=dim, steps=steps, dt=dt, rows=rows,
                                                    exponents=exponents), indent=1))
    _plot(out / "time_per_step.png", new, exponents, dim)
    return exponents


def _header():
    return (f"{'dim':>3} {'p':>2} {'lvl':>3} {'ndof':>9} {'newton':>11} {'step [s]':>9} {'assembly':>9} "
            f"{'factor':>9} {'solve':>8} {'residual':>9} {'other':>8} {'1 solve':>8} {'ratio':>6} "
            f"{'fact/st':>7} {'kry/it':>6} {'peak MiB':>8} path")


def _line(r):
    return (f"{r['dim']:3d} {r['order']:2d} {r['level']:3d} {r['ndof']:9d} {r['newton_mean']:6.2f} "
            f"({r['newton_max']:2d}) {r['step_s']:9.4f} {r['assembly_s']:9.4f} {r['factorization_s']:9.4f} "
            f"{r['solve_s']:8.4f} {r['residual_s']:9.4f} {r['other_s']:8.4f} {r['one_solve_s']:8.4f} "
            f"{r['overhead']:6.2f} {r['factorizations']:7.2f} {r['krylov_per_newton']:6.1f} {r.get('peak_mib', 0):8.0f} "
            f"{r['path']}")


def _plot(path, rows, exponents, dim):
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax, bx = fig.subplots(1, 2)
    for order, a in exponents.items():
        sel = [r for r in rows if r["order"] == order]
        ndof = np.array([r["ndof"] for r in sel])
        slope = f" (slope {a:.2f})" if np.isfinite(a) else ""
        ax.loglog(ndof, [r["step_s"] for r in sel], "o-", label=f"P{order}{slope}")
        bx.semilogx(ndof, [r["overhead"] for r in sel], "o-", label=f"P{order}")
    if rows:
        n = np.array([min(r["ndof"] for r in rows), max(r["ndof"] for r in rows)], float)
        t0 = min(r["step_s"] for r in rows)
        ax.loglog(n, t0 * (n / n[0]) ** 1.3, "k--", lw=0.8, label="ndof^1.3")
        ax.loglog(n, t0 * (n / n[0]), "k:", lw=0.8, label="ndof^1")
    ax.set(xlabel="ndof", ylabel="wall time per step [s]", title=f"{dim}D reference scene: time per step")
    bx.axhline(1.3, color="k", ls="--", lw=0.8, label="target 1.3")
    bx.set(xlabel="ndof", ylabel="time per step / (Newton its × one solve)", title="overhead ratio")
    for axis in (ax, bx):
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    fig.savefig(path, dpi=120)


IMPORTS = {"ngsolve": "import ngsolve", "ngcontact": "import ngsolve; import ngcontact"}
"""What ``import_cost`` times, each in a fresh interpreter: NGSolve alone, and NGSolve then ngcontact."""


def _import_seconds(statement):
    """Wall time of ``statement`` in a fresh interpreter that imports this checkout's ngcontact."""
    code = f"import time; t = time.perf_counter(); {statement}; print(time.perf_counter() - t)"
    root = str(pathlib.Path(__file__).resolve().parents[2])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root,
                          check=True)
    return float(done.stdout.split()[-1])


def import_cost(runs=15, progress=True):
    """Medians over ``runs`` rounds of ``IMPORTS``, each round one fresh interpreter of each,
    interleaved (the first of a round alternates; one warm-up round is dropped): {"ngsolve": s,
    "ngcontact": s (NGSolve and ngcontact), "beyond": their difference, s, "runs": runs}.
    Prints the three lines; nothing here asserts a time."""
    runs = checks.integer("runs", runs, 1, 1000)
    times = {name: [] for name in IMPORTS}
    with bar(2 * (runs + 1), "fresh interpreters", progress, unit="run") as shown:
        for round_ in range(runs + 1):
            for name in list(IMPORTS)[::1 if round_ % 2 else -1]:
                seconds = _import_seconds(IMPORTS[name])
                shown.update(1)
                if round_:
                    times[name].append(seconds)
    result = {name: statistics.median(values) for name, values in times.items()}
    result |= dict(beyond=result["ngcontact"] - result["ngsolve"], runs=runs)
    print(f"{IMPORTS['ngsolve']:<34s} median {result['ngsolve']:.3f} s ({runs} fresh interpreters, interleaved)")
    print(f"{IMPORTS['ngcontact']:<34s} median {result['ngcontact']:.3f} s")
    print(f"{'ngcontact beyond ngsolve':<34s} {result['beyond']:+.3f} s")
    return result
