"""One measurement of ``python -m ngcontact cluster``, in a process of its own.

``python -m ngcontact.studies.cluster_case SPEC OUT`` (serially, or under ``mpiexec -n N``)
reads the case from the JSON text SPEC and writes its result to the JSON file OUT (rank 0
writes; the file appears whole or not at all):

* ``kind="run"`` (``run_case``): the first ``steps`` time steps of the reference scene
  (``scenes.reference``: the 2D plate or the 3D block pressed onto the foundation, first
  contact and its spreading) at P``order`` on refinement ``level`` with a named solver
  configuration (``SOLVERS``). Records the build time, per step the wall time, Newton and
  Krylov iterations, factorisations and the contact force, the solver actually used
  (``repr(sim.newton.solver)``) and every rank's peak resident memory.
* ``kind="factorisations"`` (``factorisations``): serially, the step Jacobian after the first
  step factorised by UMFPACK, by MUMPS (conversion, analysis and factorisation) and by MUMPS
  refactorised with its analysis kept, interleaved over ``rounds``, with the solutions of
  one random right-hand side compared.

A solver that needs PETSc where it is not installed writes ``{"skipped": reason}`` instead,
before any mesh is made. Times are wall-clock seconds; nothing here asserts a time.
"""
import json
import os
import pathlib
import sys
import time as wallclock
from contextlib import nullcontext

import ngsolve as ngs
import numpy as np

from ngcontact import parallel, petsc_solver
from ngcontact.scenes import reference

THREADS = {name: os.environ.get(name) for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
"""The thread variables as the worker started (``petsc_solver.load`` sets them to 1 where
unset, for MUMPS; NGSolve's OpenBLAS has read them before)."""

SCENES = {"plate": 2, "block": 3}
"""The reference scene's variants: the 2D plate and the 3D block, by dimension."""
SOLVERS = {"default": {}, "mumps": dict(solver="mumps"), "masterinverse": dict(solver="masterinverse"),
           "gamg": dict(solver="gamg"), "multigrid": dict(solver="multigrid"), "umfpack": dict(solver="umfpack")}
"""The solver configurations by name, as Simulation options: ``default`` (what the library
chooses: serially a kept factorisation, NGSolve's multigrid for large 3D meshes; under
mpiexec MUMPS where PETSc is installed, else "masterinverse", GAMG for large 3D meshes),
``mumps`` (PETSc's MUMPS), ``masterinverse`` (NGSolve gathers the matrix on rank 0),
``gamg`` (PETSc's GMRES with Γ3 MUMPS solves around block GAMG), ``multigrid`` (NGSolve's, on
nested meshes), ``umfpack`` (the kept UMFPACK factorisation)."""
SERIAL_ONLY = {"multigrid": "NGSolve cannot refine a distributed mesh: no nested meshes",
               "umfpack": "a serial factorisation of one rank's matrix"}
"""The configurations that cannot run under mpiexec, and why (docs/cluster.md)."""
DISTRIBUTED_ONLY = {"masterinverse": "it gathers a distributed matrix on rank 0; serially there is none"}
"""The configurations that cannot run serially, and why."""
NEEDS_PETSC = ("mumps", "gamg")
"""The configurations that need PETSc (``petsc_solver``)."""


def dim_of(scene):
    """The dimension of ``scene`` ("plate" or "block"; a ValueError naming them otherwise)."""
    if scene not in SCENES:
        raise ValueError(f"scene must be one of {', '.join(map(repr, SCENES))}, got {scene!r}")
    return SCENES[scene]


def run_case(scene, order, level, solver, steps, dt, threads=None, realcompile=True):
    """One run (``kind="run"``; module docstring) as a dict. ``threads``: a serial run's steps
    under NGSolve's TaskManager (None: from ``bench.THREADS_FROM`` DOFs, as the bench; its
    build unless False); under mpiexec one thread per rank. ``realcompile`` goes to Simulation (True:
    the Γ3 integrand compiled to machine code as the simulation is built, so that the steps do
    not include it; None: when the run pays for it, ``machine_code``)."""
    from .bench import MAXH, THREADS_FROM, peak_mib      # not at import: the CLI's parser reads SOLVERS
    dim, serial = dim_of(scene), parallel.world() is None
    if solver in NEEDS_PETSC:
        petsc_solver.load(f"the solver configuration {solver!r}")       # ImportError before any work
    start = wallclock.perf_counter()
    with ngs.TaskManager() if serial and threads is not False else nullcontext():
        sim = reference.simulation(order, MAXH[dim], level, dim, keep_states=False, realcompile=realcompile,
                                   **SOLVERS[solver])
    build_s = wallclock.perf_counter() - start
    ndof = sim.body.ndof
    threads = serial and (ndof >= THREADS_FROM if threads is None else bool(threads))
    with ngs.TaskManager() if threads else nullcontext():
        sim.run(dt, steps * dt)
    records = sim.history[1:]
    memory = parallel.every(sim.body.mesh, peak_mib())
    return dict(kind="run", scene=scene, dim=dim, order=order, level=level, solver=solver, steps=steps, dt=dt,
                ranks=parallel.size(), ndof=ndof, solver_used=sim.solver_detail, threads=threads,
                realcompile=sim.realcompile,
                notes=list(sim.parallel_notes), build_s=build_s, time=[r.time for r in records],
                step_s=[r.wall_s for r in records], newton=[r.newton_iterations for r in records],
                krylov=[r.krylov_iterations for r in records], factorizations=[r.factorizations for r in records],
                force=[np.asarray(r.contact.force, float).tolist() for r in records], peak_mib=memory)


def factorisations(scene, order, level, rounds, dt, seed=0):
    """The factorisation comparison (``kind="factorisations"``; module docstring) as a dict:
    per round the seconds of UMFPACK's factorisation (``matrix.Inverse(freedofs,
    inverse="umfpack")``), of a new ``petsc_solver.MumpsFactorization`` and of its
    ``Update()`` (the analysis kept), each followed by one solve (timed apart), and the largest
    difference of the MUMPS solutions from UMFPACK's relative to its largest entry. The
    Jacobian is assembled at the state after the first step of ``dt`` s (solved with MUMPS),
    without static condensation."""
    from .bench import MAXH, peak_mib
    parallel.refuse_under_mpiexec("the factorisation comparison")
    dim = dim_of(scene)
    petsc_solver.load("the factorisation comparison")
    start = wallclock.perf_counter()
    with ngs.TaskManager():
        sim = reference.simulation(order, MAXH[dim], level, dim, keep_states=False, solver="mumps", condense=False)
        build_s = wallclock.perf_counter() - start
        sim.step(dt)
        sim.system.AssembleLinearization(sim.gfu.vec)
    matrix, free = sim.system.mat, sim.newton.freedofs
    rhs = matrix.CreateColVector()
    rhs.FV().NumPy()[:] = np.random.default_rng(seed).standard_normal(len(rhs))
    times = {name: [] for name in ("umfpack_s", "mumps_s", "update_s", "umfpack_solve_s", "mumps_solve_s",
                                    "update_solve_s")}
    diffs = {"mumps_diff": [], "update_diff": []}
    for _ in range(rounds):
        _, made = _timed(times, "umfpack", lambda: matrix.Inverse(free, inverse="umfpack"))
        reference_solution = _solve(times, "umfpack", made, rhs)
        del made
        _, made = _timed(times, "mumps", lambda: petsc_solver.MumpsFactorization(matrix, free))
        diffs["mumps_diff"].append(_diff(_solve(times, "mumps", made, rhs), reference_solution))
        _timed(times, "update", made.Update)
        diffs["update_diff"].append(_diff(_solve(times, "update", made, rhs), reference_solution))
        del made
    return dict(kind="factorisations", scene=scene, dim=dim, order=order, level=level, ndof=sim.body.ndof,
                free=int(free.NumSet()), nonzeros=int(matrix.nze), rounds=rounds, build_s=build_s,
                step_s=sim.history[-1].wall_s, peak_mib=peak_mib(), solver_used=sim.solver_detail,
                threads_at_start=THREADS,
                **times, **diffs)


def _timed(times, name, make):
    """(seconds, result) of ``make()``, the seconds appended to ``times[name + "_s"]``."""
    start = wallclock.perf_counter()
    result = make()
    seconds = wallclock.perf_counter() - start
    times[f"{name}_s"].append(seconds)
    return seconds, result


def _solve(times, name, inverse, rhs):
    """inverse * rhs as a numpy copy, its seconds appended to ``times[name + "_solve_s"]``."""
    x = rhs.CreateVector()
    start = wallclock.perf_counter()
    x.data = inverse * rhs
    times[f"{name}_solve_s"].append(wallclock.perf_counter() - start)
    return x.FV().NumPy().copy()


def _diff(x, reference_solution):
    """max |x − reference| / max |reference|."""
    return float(np.abs(x - reference_solution).max() / np.abs(reference_solution).max())


def main(spec, out):
    """Run the case of the JSON text ``spec`` and write its dict to the file ``out`` (rank 0,
    renamed into place); a missing PETSc is written as ``{"skipped": reason}``."""
    spec = json.loads(spec)
    kind = spec.pop("kind")
    try:
        result = run_case(**spec) if kind == "run" else factorisations(**spec)
    except ImportError as err:
        result = dict(kind=kind, skipped=str(err))
    if parallel.rank() == 0:
        out = pathlib.Path(out)
        temporary = out.with_suffix(".tmp")
        temporary.write_text(json.dumps(result))
        temporary.replace(out)


if __name__ == "__main__":
    main(*sys.argv[1:3])
