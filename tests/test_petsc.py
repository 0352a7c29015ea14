"""The PETSc engine (issue 27): MUMPS through ngsPETSc, serially and under mpiexec.

Without PETSc (the default install) only the refusal runs: ``solver="mumps"`` says how to
install it. With it (docs/cluster.md: on Python >= 3.12, ``pip install --no-deps
dolfinx-solver-real ngsPETSc && pip install packaging``; ``.ci/run`` runs this file so), the
MUMPS solves equal NGSolve's, and the distributed runs equal the serial one."""
import json
import os
import subprocess
import sys

import ngsolve as ngs
import numpy as np
import pytest
from netgen.geom2d import unit_square

import ngcontact as ngc
from ngcontact import petsc_solver
from ngcontact.solve.linalg import petsc_modules
from ngcontact.geometries import plate
from ngcontact.scenes import reference
from test_parallel import HERE, launch, mpiexec

needs_petsc = pytest.mark.skipif(not petsc_solver.available(),
                                 reason="PETSc is not installed (docs/cluster.md: the PETSc route)")


def test_mumps_without_petsc_says_how_to_install_it(monkeypatch):
    """With petsc4py unimportable, ``Simulation(solver="mumps")`` raises before any work,
    naming what is missing and the install line."""
    monkeypatch.setattr(petsc_modules, "_modules", None)
    monkeypatch.setitem(sys.modules, "petsc4py", None)
    with pytest.raises(ImportError, match=r'solver="mumps" needs PETSc .* pip install --no-deps '
                                          r'dolfinx-solver-real ngsPETSc'):
        reference.simulation(1, 0.02, solver="mumps")
    assert not petsc_solver.available()


@needs_petsc
def test_mumps_lu_kept_across_newton_equals_the_default_solver():
    """The reference scene (non-symmetric Jacobian: MUMPS's LU of the Jacobian, kept as GMRES's
    preconditioner), 20 steps over the push, hold and the start of the pull: the states equal
    the default solver's (LDLᵀ of the symmetric part + GMRES) to 1e-9 at every step."""
    runs = {}
    for solver in (None, "mumps"):
        sim = reference.simulation(1, 0.005, solver=solver)
        sim.run(0.01, 0.2)
        runs[solver] = (sim, np.array([s.vec.FV().NumPy() for s in map(sim.state, range(len(sim.history)))]))
    (default, a), (mumps, b) = runs[None], runs["mumps"]
    assert mumps.solver_detail == "KeptFactorization(DirectSolver('mumps'), symmetric=False)"
    assert np.abs(a - b).max() <= 1e-9 * np.abs(a).max()
    assert sum(r.krylov_iterations for r in mumps.history) > 0          # the factorisation was kept


@needs_petsc
def test_mumps_ldlt_on_a_symmetric_jacobian():
    """A body without contact has a symmetric Jacobian: MUMPS's LDLᵀ, equal to
    "sparsecholesky" to 1e-10 (the short-circuited column under a step load)."""
    states = []
    for name in ("sparsecholesky", "mumps"):
        body = ngc.Body(plate(L1=0.01, L2=0.03, maxh=0.004), ngc.pzt5a(relaxation_time=0.1), clamped="bottom",
                        grounded="bottom|top", order=2)
        sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -2e6)}),
                             solver={"ksp_type": "preonly", "pc_factor_mat_solver_type": name})
        sim.run(0.02, 0.1)
        states.append(sim.gfu.vec.FV().NumPy().copy())
        if name == "mumps":
            assert sim.solver_detail == "DirectSolver('mumps', symmetric=True)"
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
    norm (``linear_solver.KeptFactorization`` of a MUMPS factorisation, its GMRES PETSc's:
    ``krylov``; with more ranks than cores a factorisation per iteration); over the
    push-hold-pull history of the 2D reference plate (P2) and of the 3D block (P1), the contact
    force and the charge flux per step equal the serial run to 1e-8 of their largest values,
    Newton's iterations to ±1."""
    launch(ranks, str(HERE / "distributed_scenes.py"), scene, "default", str(tmp_path / "run.json"), timeout=900)
    distributed = json.loads((tmp_path / "run.json").read_text())
    serial = serial_runs[scene]
    kept = ranks <= os.cpu_count()          # more ranks than cores: a factorisation per iteration
    assert distributed["ranks"] == ranks
    assert distributed["solver"].startswith("KeptFactorization(DirectSolver('mumps'" if kept
                                                 else "DirectSolver('mumps'"), distributed["solver"]
    for key in ("force", "charge"):
        a, b = np.array(serial[key]), np.array(distributed[key])
        assert a.shape == b.shape and np.abs(a).max() > 0, key
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), (key, np.abs(a - b).max() / np.abs(a).max())
    assert np.abs(np.subtract(serial["newton"], distributed["newton"])).max() <= 1


@needs_petsc
def test_two_mumps_runs_are_bitwise_equal(tmp_path):
    """Two processes with ``solver="mumps"`` (the kept LU and GMRES, one thread): the contact
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


class _OutOfWorkspace:
    """A PETSc PC that reports MUMPS's workspace overflow (PETSc's FACTOR_OUTMEMORY) on its
    first ``failures`` set-ups and is the real PC otherwise: whether MUMPS overflows on a real
    matrix varies from run to run under mpiexec (measured on the 3D indentation at ICNTL(14) =
    1, 10, 20 %: sometimes, not always), so the retry is tested on a failure that always comes."""

    def __init__(self, pc, failures):
        self._pc, self.failures, self.relaxations = pc, failures, []

    def setUp(self):
        self.relaxations.append(self._pc.getFactorMatrix().getMumpsIcntl(14))
        self._pc.setUp()

    def getFailedReason(self):
        PETSc, _ = petsc_solver.load()
        if len(self.relaxations) <= self.failures:
            return PETSc.PC.FailedReason.FACTOR_OUTMEMORY
        return self._pc.getFailedReason()

    def __getattr__(self, name):
        return getattr(self._pc, name)


@needs_petsc
@pytest.mark.parametrize("failures", [1, 3])
def test_a_mumps_factorisation_out_of_workspace_is_made_again(failures):
    """A factorisation that ran out of its workspace is made again with twice MUMPS's relaxation
    ICNTL(14) each time (set on the factor MUMPS uses: 30, 60, 120, 240 %), and the solve it
    ends with is the matrix's inverse (residual of a solve to 1e-12)."""
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.2))
    V = ngs.H1(mesh, order=2, dirichlet="left")
    u, v = V.TnT()
    a = ngs.BilinearForm((ngs.grad(u) * ngs.grad(v) - 0.5 * u * v) * ngs.dx).Assemble()   # indefinite
    factor = petsc_solver.MumpsFactorization(a.mat, V.FreeDofs(), symmetric=True)
    assert factor.relaxation == petsc_solver.WORKSPACE_RELAXATION
    factor.pc = proxy = _OutOfWorkspace(factor.pc, failures)
    factor._factorise()
    first = petsc_solver.WORKSPACE_RELAXATION
    assert proxy.relaxations == [first * 2 ** k for k in range(failures + 1)]
    assert factor.relaxation == first * 2 ** failures
    b = a.mat.CreateColVector()
    b.SetRandom()
    for i, free in enumerate(V.FreeDofs()):
        b[i] *= free
    x, r = b.CreateVector(), b.CreateVector()
    x.data = factor * b
    r.data = a.mat * x - b
    r = r.FV().NumPy()[np.array(V.FreeDofs(), dtype=bool)]
    assert np.linalg.norm(r) <= 1e-12 * np.linalg.norm(b.FV().NumPy())


@needs_petsc
def test_a_mumps_factorisation_that_stays_out_of_workspace_says_so():
    """Past ``MAX_RELAXATION`` % the overflow is an ArithmeticError naming the relaxation reached."""
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.3))
    V = ngs.H1(mesh, order=1, dirichlet="left")
    u, v = V.TnT()
    a = ngs.BilinearForm((ngs.grad(u) * ngs.grad(v) + u * v) * ngs.dx).Assemble()
    factor = petsc_solver.MumpsFactorization(a.mat, V.FreeDofs(), symmetric=True)
    factor.pc = _OutOfWorkspace(factor.pc, 100)
    top = petsc_solver.WORKSPACE_RELAXATION
    while 2 * top <= petsc_solver.MAX_RELAXATION:
        top *= 2
    with pytest.raises(ArithmeticError, match=rf"FACTOR_OUTMEMORY.*LDLᵀ .*ICNTL\(14\) = {top} %"):
        factor._factorise()


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


def _block(solver, steps=5, **options):
    """The 3D reference block (P1, maxh 10 mm, refined once: 3 260 DOFs), ``steps`` steps of
    2.5 ms into first contact, then one of half the size (a new rate coefficient)."""
    sim = reference.simulation(1, 0.01, 1, dim=3, keep_states=False, solver=solver, realcompile=False,
                               **options)
    sim.run(2.5e-3, steps * 2.5e-3)
    sim.step(1.25e-3)
    return sim


@pytest.fixture(scope="module")
def block_direct():
    return _block("direct")


@needs_petsc
def test_gamg_steps_equal_the_factorised_ones(block_direct):
    """GMRES with Γ3 MUMPS solves around block GAMG (``petsc_iterative``): five steps of the 3D
    block into first contact (glue, conduction: non-symmetric), then one of half the size,
    reach the kept factorisation's states, contact forces and β to 1e-8, with GMRES's
    iterations recorded and no failure."""
    from ngcontact.solve.linalg.petsc_iterative import GamgSolver
    gamg = _block("gamg")
    assert gamg.solver_options["options.iterative"] == "gamg" and "GAMG" in gamg.solver
    a, b = block_direct.gfu.vec.FV().NumPy(), gamg.gfu.vec.FV().NumPy()
    n_u = block_direct.body.V.ndof
    for part in (slice(0, n_u), slice(n_u, None)):
        assert np.abs(a[part] - b[part]).max() <= 1e-8 * np.abs(a[part]).max()
    forces = [np.array([r.contact.force for r in sim.history[1:]]) for sim in (block_direct, gamg)]
    assert np.abs(forces[0]).max() > 0
    assert np.abs(forces[0] - forces[1]).max() <= 1e-8 * np.abs(forces[0]).max()
    assert np.abs(block_direct.beta.values - gamg.beta.values).max() <= 1e-8
    records = gamg.history[1:]
    assert sum(r.krylov_iterations for r in records) > 0 and sum(r.krylov_failures for r in records) == 0


@needs_petsc
def test_a_gmres_that_does_not_converge_falls_back_to_a_factorisation(block_direct, monkeypatch):
    """GMRES held to 2 iterations cannot converge: every correction is then solved by a fresh
    MUMPS factorisation of J, the step records say so (``krylov_failures``), and the states
    equal the factorised run's to 1e-8. If the factorisation fails too, the error names both
    reasons."""
    from ngcontact.solve.linalg import petsc_iterative
    monkeypatch.setattr(petsc_iterative.GamgSolver, "__init__", _with_maxiter(petsc_iterative.GamgSolver.__init__, 2))
    gamg = _block("gamg", steps=2)
    records = gamg.history[1:]
    assert all(r.krylov_failures == r.newton_iterations > 0 for r in records)
    direct = _block("direct", steps=2)
    a, b = direct.gfu.vec.FV().NumPy(), gamg.gfu.vec.FV().NumPy()
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max()

    def fails(*args, **kwargs):
        raise ArithmeticError("the MUMPS factorisation failed (PETSc's reason: FACTOR_OUTMEMORY; ...)")
    monkeypatch.setattr(petsc_iterative, "MumpsFactorization", fails)
    with pytest.raises(ArithmeticError, match=r"GMRES did not converge in 2 iterations \(PETSc's reason DIVERGED_MAX_IT\) and "
                                              r"the MUMPS factorisation failed \(PETSc's reason: FACTOR_OUTMEMORY"):
        _block("gamg", steps=1)


def _with_maxiter(init, maxiter):
    def patched(self, *args, **kwargs):
        init(self, *args, **dict(kwargs, maxiter=maxiter))
    return patched


@needs_petsc
def test_gamg_preconditioner_follows_the_rate_coefficient():
    """After the step of half the size (a new rate coefficient c), u's GAMG operator is the
    preconditioner form assembled at the new c (the integrand is compiled once with c as the
    scheme's Parameter: a value frozen at the first c would differ by c's viscous part), while
    φ's GAMG (the permittivity, without c) is the one made at the first step."""
    import ngsolve as ngs
    from ngcontact.model import forms
    sim = reference.simulation(1, 0.01, 1, dim=3, keep_states=False, solver="gamg", realcompile=False)
    sim.step(2.5e-3)
    solver = sim.newton.solver
    first_u, first_phi = solver._bulk[0][0], solver._bulk[1][0]
    sim.step(1.25e-3)
    assert solver._bulk[1][0] is first_phi and solver._bulk[0][0] is not first_u
    X, rate = sim.system.X, sim.system.coefficients.rate.Get()
    (u, phi), (v, xi) = X.TnT()

    def u_block(c):
        form = ngs.BilinearForm(X, symmetric=True)
        form += sum(forms.preconditioner_forms(sim.body, u, v, phi, xi, c)) * ngs.dx
        form.Assemble()
        P = petsc_solver.PetscMatrix(form.mat, sim.newton.freedofs).mat
        return P.createSubMatrix(solver.fields[0], solver.fields[0])

    used = solver._bulk[0][0].getOperators()[0]
    expected, stale = u_block(rate), u_block(rate / 2)      # the first step's c: 1/2.5 ms
    difference = used.copy()
    difference.axpy(-1.0, expected)
    assert difference.norm() <= 1e-12 * expected.norm()
    stale.axpy(-1.0, expected)
    assert stale.norm() > 1e-6 * expected.norm()       # the two rates' forms differ: the check can fail


@needs_petsc
def test_gamg_preconditioner_is_the_surface_bulk_surface_product():
    """M r of ``GamgSolver._apply`` (J's strips J[:, Γ3] and J[Γ3, :] for J) is the module's
    y = S r; y += B (r − J y); y += S (r − J y) written with all of J, to round-off, on the 3D
    block in contact; and it is not B r alone (the check can fail)."""
    sim = reference.simulation(1, 0.01, 1, dim=3, keep_states=False, solver="gamg", realcompile=False)
    sim.run(2.5e-3, 5 * 2.5e-3)
    solver = sim.newton.solver
    assert solver._surface is not None and solver.surface_rows.getSize() > 0
    J, rows = solver.J.mat, solver.surface_rows
    r = J.createVecLeft()
    r.setArray(np.random.default_rng(3).standard_normal(r.getLocalSize()))
    y = r.duplicate()
    solver._apply(r, y)

    def add_surface(source, target):
        x, z = solver._surface_matrix.createVecs()
        part = source.getSubVector(rows)
        part.copy(x)
        source.restoreSubVector(rows, part)
        solver._surface.apply(x, z)
        part = target.getSubVector(rows)
        part.axpy(1.0, z)
        target.restoreSubVector(rows, part)

    expected, d = r.duplicate(), r.duplicate()
    expected.set(0.0)
    add_surface(r, expected)
    J.mult(expected, d)
    d.aypx(-1.0, r)
    solver.add_bulk(d, expected)
    J.mult(expected, d)
    d.aypx(-1.0, r)
    add_surface(d, expected)
    bulk_only = r.duplicate()
    bulk_only.set(0.0)
    solver.add_bulk(r, bulk_only)
    assert (y - expected).norm() <= 1e-12 * expected.norm()
    assert (bulk_only - expected).norm() > 1e-3 * expected.norm()


@needs_petsc
def test_gamg_compiles_its_preconditioner_forms_on_large_meshes(monkeypatch):
    """With ``realcompile=None`` the preconditioner forms' integrand is compiled to machine code
    from ``machine_code.BULK_COMPILED_FROM`` elements of the mesh on, interpreted below; both
    give u's GAMG operator to round-off."""
    from ngcontact.model import machine_code
    from ngcontact.solve.linalg import petsc_iterative
    sim = reference.simulation(1, 0.01, 1, dim=3, keep_states=False, solver="gamg", realcompile=False)
    sim.step(2.5e-3)
    solver = sim.newton.solver
    interpreted = solver._bulk[0][0].getOperators()[0]
    asked, original = [], petsc_iterative.compiled

    def recording(cf, realcompile, **kwargs):
        asked.append(realcompile)
        return original(cf, realcompile, **kwargs)
    monkeypatch.setattr(petsc_iterative, "compiled", recording)
    solver.realcompile = None
    for threshold in (sim.body.mesh.ne + 1, sim.body.mesh.ne):
        monkeypatch.setattr(machine_code, "BULK_COMPILED_FROM", threshold)
        solver._integrand = solver._bulk = None
        solver._preconditioners(sim.newton.freedofs)
    assert asked == [False, True]
    used = solver._bulk[0][0].getOperators()[0]
    difference = used.copy()
    difference.axpy(-1.0, interpreted)
    assert difference.norm() <= 1e-12 * interpreted.norm()


@pytest.mark.parametrize("order, dim", [(1, 2), (3, 2), (1, 3), (2, 3)])
def test_rigid_motions_from_the_vertices_are_the_interpolated_motions(order, dim):
    """GAMG's near null space, read from the vertex coordinates (``rigid_motion_values``),
    equals ``GridFunction.Set`` of the translations and rotations on the product space to
    round-off (the higher-order DOFs 0), and the elastic bulk form K_el maps each rotation
    to a force 10⁻¹⁰ of its size on a stretch (a rigid motion has no strain; the vertex values
    of a wrong component or a DOF offset would not)."""
    import ngsolve as ngs
    from ngcontact.solve.linalg.petsc_blocks import rigid_motion_values
    sim = reference.simulation(order, 0.02 if dim == 3 else 0.01, 0, dim, keep_states=False)
    X = sim.system.X
    x, y, z = ngs.x, ngs.y, ngs.z
    motions = [(1, 0), (0, 1), (-y, x)] if dim == 2 else \
        [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-y, x, 0), (0, -z, y), (z, 0, -x)]
    values = list(rigid_motion_values(sim.body, X))
    assert len(values) == len(motions)
    gf, force = ngs.GridFunction(X), sim.system.K_el.mat.CreateColVector()
    stretch = ngs.GridFunction(X)
    stretch.components[0].Set(ngs.CF((x,) + (0,) * (dim - 1)))
    force.data = sim.system.K_el.mat * stretch.vec
    scale = np.abs(force.FV().NumPy()[:sim.body.V.ndof]).max()
    for motion, vector in zip(motions, values):
        gf.vec[:] = 0.0
        gf.components[0].Set(ngs.CF(motion))
        assert np.abs(gf.vec.FV().NumPy() - vector).max() <= 1e-12
        gf.vec.FV().NumPy()[:] = vector
        force.data = sim.system.K_el.mat * gf.vec
        assert np.abs(force.FV().NumPy()[:sim.body.V.ndof]).max() <= 1e-10 * scale


def test_gamg_without_petsc_says_how_to_install_it(monkeypatch):
    """``solver='gamg'`` without PETSc: an ImportError naming it and the install line."""
    monkeypatch.setattr(petsc_modules, "_modules", None)
    monkeypatch.setitem(sys.modules, "petsc4py", None)
    with pytest.raises(ImportError, match=r"solver='gamg' needs PETSc .* pip install --no-deps dolfinx-solver-real"):
        reference.simulation(1, 0.02, dim=3, solver="gamg")


@needs_petsc
@pytest.mark.parametrize("ranks", [2, 3])
@pytest.mark.parametrize("scene", ["block", "indenter3d"])
def test_distributed_gamg_equals_the_serial_run(serial_runs, serial_indenter, tmp_path, scene, ranks):
    """``solver="gamg"`` under ``mpiexec -n 2|3`` (GMRES, Γ3 MUMPS solves and GAMG on every
    rank): the 3D block over the push-hold-pull history and the 3D indentation (supports, a
    moving obstacle) give the serial run's contact force per step to 1e-8, without a GMRES
    failure (the block's first step, 50 ms into deep first contact, takes 13 Newton iterations
    after 50 discarded ones with every solver; asked for the step's final accuracy after each
    rise of the residual, GMRES failed there 1-2 times and a factorisation solved:
    ``inexact.forcing_term``, ``krylov_failures``); u's GAMG block is ordered node by node on
    every rank where every node has all components free (the block), not under rollers."""
    launch(ranks, str(HERE / "distributed_scenes.py"), scene, "gamg", str(tmp_path / "run.json"), timeout=900)
    distributed = json.loads((tmp_path / "run.json").read_text())
    serial = serial_runs[scene] if scene == "block" else serial_indenter
    assert distributed["solver"].startswith("GamgSolver(") and distributed["ranks"] == ranks
    assert distributed["krylov_failures"] == 0
    # GAMG's u block node by node with block size 3 on every rank; the indenter's rollers hold
    # one component of the bottom's nodes: component by component there (``node_by_node``)
    assert distributed["u_block_size"] == ranks * [3 if scene == "block" else 1]
    a, b = np.array(serial["force"]), np.array(distributed["force"])
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), np.abs(a - b).max() / np.abs(a).max()


@needs_petsc
def test_gamg_orders_u_node_by_node():
    """``petsc_blocks.node_by_node``: on the 3D block (clamped: every free node has its 3
    components free) GAMG's u rows are the free u DOFs node by node, (x, y, z) of one scalar
    DOF of VectorH1 (its DOFs d, d + n, d + 2n) in consecutive rows, block size 3, and u's GAMG
    operator is that reordering of the preconditioner form's u block (to 0); with the
    component tags scrambled the rows stay as they were (block size 1)."""
    from ngcontact.model import forms
    from ngcontact.solve.linalg import petsc_blocks
    from ngcontact.petsc_solver import PetscMatrix, load
    sim = reference.simulation(1, 0.01, 1, 3, keep_states=False, solver="gamg")
    sim.run(2 ** -8, 2 ** -8)
    solver = sim.newton.solver
    rows = solver.fields[0]
    assert rows.getBlockSize() == 3
    free = np.flatnonzero(np.array(list(sim.newton.freedofs), dtype=bool))     # PETSc row i: free DOF i
    dofs = free[rows.getIndices()].reshape(-1, 3)
    n = sim.body.V.ndof // 3
    assert len(dofs) * 3 == np.count_nonzero(free < sim.body.V.ndof) > 2000
    assert np.all(dofs[:, 1] == dofs[:, 0] + n) and np.all(dofs[:, 2] == dofs[:, 0] + 2 * n)
    PETSc, _ = load()
    (u, phi), (v, xi) = sim.system.X.TnT()
    form = ngs.BilinearForm(sim.system.X, symmetric=True)
    form += sum(forms.preconditioner_forms(sim.body, u, v, phi, xi, sim.system.coefficients.rate)) * ngs.dx
    form.Assemble()
    P = PetscMatrix(form.mat, sim.newton.freedofs).mat
    operator = solver._bulk[0][0].getOperators()[0]
    ptr, cols, values = operator.getValuesCSR()
    expected = P.createSubMatrix(rows, rows).getValuesCSR()
    assert operator.getBlockSize() == 3 and np.array_equal(ptr, expected[0]) and np.array_equal(cols, expected[1])
    assert np.abs(values - expected[2]).max() <= 1e-12 * np.abs(values).max()
    plain = petsc_blocks.index_set(PETSc, solver.J.vectors, form.mat.CreateColVector(),
                                       np.r_[np.ones(sim.body.V.ndof), np.zeros(sim.system.X.ndof - sim.body.V.ndof)], 1.0)
    scrambled = petsc_blocks.node_by_node(PETSc, solver.J.vectors, form.mat.CreateColVector(), plain, 3,
                                             sim.body.V.ndof - 3)
    assert scrambled is plain and scrambled.getBlockSize() == 1


def test_whether_a_fallback_factorisation_fits_depends_on_the_machine_not_the_moment(monkeypatch):
    """``factorisation_fits`` compares ``FACTOR_BYTES`` · n^(4/3) (3D) or n log n (2D) with half
    of the node's physical memory, whatever is free at the moment (an earlier version read
    MemAvailable, so a busy machine changed the run): on a 24 GB node a 3D Jacobian fits up to
    (0.5 · 24e9 / 210)^(3/4) DOFs and not 1 % beyond; reading /proc/meminfo fails the test."""
    from ngcontact import checks
    from ngcontact.solve.linalg import petsc_iterative
    mesh = ngs.Mesh(unit_square.GenerateMesh(maxh=0.5))
    monkeypatch.setattr(petsc_iterative, "node_memory", lambda: 24e9)
    real_open = open

    def no_meminfo(path, *args, **kwargs):
        assert "meminfo" not in str(path), "the free memory of the moment was read"
        return real_open(path, *args, **kwargs)
    monkeypatch.setattr("builtins.open", no_meminfo)
    limit = (0.5 * 24e9 / 210.0) ** 0.75
    assert petsc_iterative.factorisation_fits(int(0.99 * limit), 3, mesh)
    assert not petsc_iterative.factorisation_fits(int(1.01 * limit), 3, mesh)
    n2 = 3.0e6                                            # 2D: 320 n log n = 1.43e10 > 1.2e10
    assert not petsc_iterative.factorisation_fits(int(n2), 2, mesh)
    assert petsc_iterative.factorisation_fits(int(2.0e6), 2, mesh)            # 9.3e9
    assert checks.node_memory() == os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


@needs_petsc
def test_a_fallback_factorisation_that_would_not_fit_is_not_made(block_direct, monkeypatch):
    """Where a factorisation of J is not expected to fit in memory (``factorisation_fits``: a 3D
    Jacobian of 10⁷ DOFs never does here, one of 10⁴ does), a GMRES held to 15 iterations
    leaves its last iterate as the correction (``oversized`` counts them, the records count the
    failures), and Newton still reaches the factorised run's states to 1e-8."""
    from ngcontact.solve.linalg import petsc_iterative
    mesh = block_direct.body.mesh
    assert petsc_iterative.factorisation_fits(10 ** 4, 3, mesh) and not petsc_iterative.factorisation_fits(10 ** 7, 3, mesh)
    monkeypatch.setattr(petsc_iterative, "factorisation_fits", lambda ndof, dim, mesh: False)
    monkeypatch.setattr(petsc_iterative.GamgSolver, "__init__", _with_maxiter(petsc_iterative.GamgSolver.__init__, 15))
    gamg = _block("gamg")
    assert gamg.newton.solver.oversized == sum(r.krylov_failures for r in gamg.history) > 0
    assert gamg.newton.solver.factorizations == sum(r.newton_iterations for r in gamg.history)   # Γ3 blocks only
    a, b = block_direct.gfu.vec.FV().NumPy(), gamg.gfu.vec.FV().NumPy()
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max()
