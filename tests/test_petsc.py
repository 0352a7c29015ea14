"""The PETSc engine (issue 27): MUMPS through ngsPETSc, serially and under mpiexec.

Without PETSc (the default install) only the refusal runs: ``inverse="mumps"`` says how to
install it. With it (docs/cluster.md: on Python >= 3.12, ``pip install --no-deps
dolfinx-solver-real ngsPETSc && pip install packaging``; ``.ci/run`` runs this file so), the
MUMPS solves equal NGSolve's, and the distributed runs equal the serial one."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import ngcontact as ngc
from ngcontact import petsc_solver
from ngcontact.geometries import plate
from ngcontact.scenes import reference
from test_parallel import HERE, launch, mpiexec

needs_petsc = pytest.mark.skipif(not petsc_solver.available(),
                                 reason="PETSc is not installed (docs/cluster.md: the PETSc route)")


def test_mumps_without_petsc_says_how_to_install_it(monkeypatch):
    """With petsc4py unimportable, ``Simulation(inverse="mumps")`` raises before any work,
    naming what is missing and the install line."""
    monkeypatch.setattr(petsc_solver, "_modules", None)
    monkeypatch.setitem(sys.modules, "petsc4py", None)
    with pytest.raises(ImportError, match=r'inverse="mumps" needs PETSc .* pip install --no-deps '
                                          r'dolfinx-solver-real ngsPETSc'):
        reference.simulation(1, 0.02, inverse="mumps")
    assert not petsc_solver.available()


@needs_petsc
def test_mumps_lu_kept_across_newton_equals_the_default_solver():
    """The reference scene (non-symmetric Jacobian: MUMPS's LU of the Jacobian, kept as GMRES's
    preconditioner), 20 steps over the push, hold and the start of the pull: the states equal
    the default solver's (LDLᵀ of the symmetric part + GMRES) to 1e-9 at every step."""
    runs = {}
    for inverse in (None, "mumps"):
        sim = reference.simulation(1, 0.005, inverse=inverse)
        sim.run(0.01, 0.2)
        runs[inverse] = (sim, np.array([s.vec.FV().NumPy() for s in map(sim.state, range(len(sim.history)))]))
    (default, a), (mumps, b) = runs[None], runs["mumps"]
    assert repr(mumps.newton.solver) == "KeptFactorization(DirectSolver('mumps'), symmetric=False)"
    assert np.abs(a - b).max() <= 1e-9 * np.abs(a).max()
    assert mumps.newton.solver.krylov_iterations > 0          # the factorisation was kept


@needs_petsc
def test_mumps_ldlt_on_a_symmetric_jacobian():
    """A body without contact has a symmetric Jacobian: MUMPS's LDLᵀ, equal to
    "sparsecholesky" to 1e-10 (the short-circuited column under a step load)."""
    states = []
    for inverse in ("sparsecholesky", "mumps"):
        body = ngc.Body(plate(L1=0.01, L2=0.03, maxh=0.004), ngc.pzt5a(relaxation_time=0.1), clamped="bottom",
                        grounded="bottom|top", order=2)
        sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -2e6)}), inverse=inverse, reuse_factorization=False)
        sim.run(0.02, 0.1)
        states.append(sim.gfu.vec.FV().NumPy().copy())
        if inverse == "mumps":
            assert repr(sim.newton.solver) == "DirectSolver('mumps', symmetric=True)"
    assert np.abs(states[0] - states[1]).max() <= 1e-10 * np.abs(states[0]).max()


@pytest.fixture(scope="module")
def serial_runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    runs = {}
    for scene in ("reference", "block"):
        command = [sys.executable, str(HERE / "distributed_scenes.py"), scene, "default", str(out / f"{scene}.json")]
        done = subprocess.run(command, capture_output=True, text=True, cwd=HERE.parent, timeout=900)
        assert done.returncode == 0, done.stderr[-3000:]
        runs[scene] = json.loads((out / f"{scene}.json").read_text())
    return runs


@needs_petsc
@pytest.mark.parametrize("ranks", [2, 3])
@pytest.mark.parametrize("scene", ["reference", "block"])
def test_distributed_mumps_equals_the_serial_run(serial_runs, tmp_path, scene, ranks):
    """``mpiexec -n 2|3``: MUMPS is the default on a distributed mesh where PETSc is installed
    (not "masterinverse"), kept as the preconditioner of PETSc's GMRES in Newton's weighted
    norm (``petsc_solver.KeptMumps``; with more ranks than cores a factorisation per
    iteration); over the push-hold-pull history of the 2D reference plate (P2) and
    of the 3D block (P1), the contact force and the charge flux per step equal the serial run
    to 1e-8 of their largest values, Newton's iterations to ±1."""
    launch(ranks, str(HERE / "distributed_scenes.py"), scene, "default", str(tmp_path / "run.json"), timeout=900)
    distributed = json.loads((tmp_path / "run.json").read_text())
    serial = serial_runs[scene]
    kept = ranks <= os.cpu_count()          # more ranks than cores: a factorisation per iteration
    assert distributed["ranks"] == ranks
    assert distributed["solver"].startswith("KeptMumps(" if kept else "DirectSolver('mumps'"), distributed["solver"]
    for key in ("force", "charge"):
        a, b = np.array(serial[key]), np.array(distributed[key])
        assert a.shape == b.shape and np.abs(a).max() > 0, key
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), (key, np.abs(a - b).max() / np.abs(a).max())
    assert np.abs(np.subtract(serial["newton"], distributed["newton"])).max() <= 1


@needs_petsc
def test_two_mumps_runs_are_bitwise_equal(tmp_path):
    """Two processes with ``inverse="mumps"`` (the kept LU and GMRES, one thread): the contact
    force, the charge flux and Newton's iterations of every step are bitwise equal."""
    runs = []
    for name in ("a", "b"):
        out = tmp_path / f"{name}.json"
        done = subprocess.run([sys.executable, str(HERE / "distributed_scenes.py"), "reference", "mumps", str(out)],
                              capture_output=True, text=True, cwd=HERE.parent, timeout=900)
        assert done.returncode == 0, done.stderr[-3000:]
        runs.append(json.loads(out.read_text()))
    assert runs[0]["solver"] == "KeptFactorization(DirectSolver('mumps'), symmetric=False)"
    for key in ("force", "charge", "newton"):
        assert runs[0][key] == runs[1][key], key


@needs_petsc
def test_a_mumps_factorisation_out_of_workspace_is_made_again(serial_indenter, tmp_path):
    """The 3D indentation's symmetric indefinite Jacobian (LDLᵀ) on 2 ranks needs more than
    MUMPS's default workspace relaxation ICNTL(14) = 20 % (INFOG(1) = −9, PETSc's
    FACTOR_OUTMEMORY: it failed so before ``WORKSPACE_RELAXATION`` and the retry): started at
    20 %, the factorisation is made again at 40 % and the run equals the serial one to 1e-8."""
    env = dict(os.environ, PYTHONWARNINGS="ignore", RELAXATION="20")
    done = subprocess.run([mpiexec(), "-n", "2", sys.executable, str(HERE / "distributed_scenes.py"), "indenter3d",
                           "mumps", str(tmp_path / "run.json")], capture_output=True, text=True, timeout=900,
                          env=env, cwd=HERE.parent)
    assert done.returncode == 0, done.stderr[-3000:]
    run = json.loads((tmp_path / "run.json").read_text())
    assert run["solver"] == "KeptMumps(symmetric=True)" and run["relaxation"] == 40
    a, b = np.array(serial_indenter["force"]), np.array(run["force"])
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max()


@pytest.fixture(scope="module")
def serial_indenter(tmp_path_factory):
    out = tmp_path_factory.mktemp("indenter") / "serial.json"
    done = subprocess.run([sys.executable, str(HERE / "distributed_scenes.py"), "indenter3d", "default", str(out)],
                          capture_output=True, text=True, cwd=HERE.parent, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(out.read_text())


@needs_petsc
@pytest.mark.parametrize("symmetric", [False, True])
def test_a_failed_mumps_factorisation_says_why(symmetric):
    """A singular matrix (the Laplacian's pattern with zero values): an ArithmeticError with
    PETSc's reason by name, MUMPS's INFOG(1) (−10: numerically singular), the kind of
    factorisation and the number of rows."""
    import ngsolve as ngs
    from netgen.geom2d import unit_square
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.3))
    V = ngs.H1(mesh, order=1, dirichlet=".*")
    u, v = V.TnT()
    a = ngs.BilinearForm(ngs.grad(u) * ngs.grad(v) * ngs.dx).Assemble()
    a.mat.AsVector()[:] = 0.0
    kind = "LDLᵀ" if symmetric else "LU"
    with pytest.raises(ArithmeticError, match=rf"PETSc's reason: FACTOR_NUMERIC_ZEROPIVOT; MUMPS's INFOG\(1\) = -10.*"
                                              rf"{kind} of {V.FreeDofs().NumSet()} rows"):
        petsc_solver.MumpsFactorization(a.mat, V.FreeDofs(), symmetric=symmetric)
