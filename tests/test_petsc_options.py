"""``Simulation(solver={...})``: PETSc options as a PETSc user writes them build the solvers of
the names on PETSc (``petsc_options.check``, ``solver_choice.resolve``).

Without PETSc (the default install) the refusals run: a bad dict names its option before any
work, a good one says that it needs PETSc. With PETSc (docs/cluster.md), a GAMG dict runs as
``solver="gamg"``, a MUMPS dict as the default solver, serially and under mpiexec."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.scenes import reference
from ngcontact.solve.linalg import petsc_modules, petsc_solver, solver_choice
from test_parallel import HERE, launch

GAMG = {"ksp_type": "gmres", "pc_type": "gamg", "pc_gamg_threshold": 0.01}
"""The options of ``solver="gamg"`` (``petsc_iterative.GAMG_OPTIONS``) as a dict."""
LU = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
DT = 0.02


@pytest.fixture
def petsc():
    """PETSc's module, or the test is skipped where it is not installed."""
    pytest.importorskip("petsc4py")
    if not petsc_solver.available():
        pytest.skip("PETSc is not installed (docs/cluster.md: the PETSc route)")
    return petsc_solver.load()[0]


def test_a_dict_without_petsc_says_how_to_install_it(monkeypatch):
    """With petsc4py unimportable, a valid dict raises ``PetscMissing`` naming ``solver=`` and the
    install line, before any work; the command line's check says PETSc is needed."""
    monkeypatch.setattr(petsc_modules, "_modules", None)
    monkeypatch.setitem(sys.modules, "petsc4py", None)
    monkeypatch.setattr(ngc.Body, "space", _no_work)
    with pytest.raises(petsc_solver.PetscMissing, match=r"solver=\{'ksp_type': 'gmres', 'pc_type': 'gamg'.*\} needs "
                                                        r"PETSc .* pip install --no-deps dolfinx-solver-real"):
        reference.simulation(1, 0.02, dim=3, solver=GAMG)
    assert solver_choice.needs_petsc(LU) and not solver_choice.needs_petsc("umfpack")


def _no_work(self):
    raise AssertionError("the Simulation began its work before it checked solver=")


@pytest.mark.parametrize("spec, error, message", [
    ({"pc_type": "hypre"}, ValueError, r"'pc_type' = 'hypre', which is not supported here; accepted: 'lu' .*'gamg'"),
    ({"ksp_type": "cg"}, ValueError, r"'ksp_type' = 'cg' is not supported with pc_type None; accepted: 'gmres', "
                                     r"'preonly'"),
    ({"pc_type": "cholesky", "pc_factor_mat_solver_type": "umfpack"}, ValueError,
     r"'pc_type' = 'cholesky' and 'pc_factor_mat_solver_type' = 'umfpack' disagree"),
    ({"pc_factor_mat_solver_type": "umfpack", "mat_mumps_icntl_14": 50}, ValueError,
     r"'mat_mumps_icntl_14' = 50 is not supported with pc_type None and 'umfpack'"),
    ({1: "gmres", "pc_type": "gamg"}, TypeError, r"a PETSc option's name must be a string .* got 1 \(= 'gmres'\)"),
    ({"-pc_type": "lu"}, ValueError, r"write the PETSc option '-pc_type' without the dash: 'pc_type'"),
    ({"pc_type": "gamg", "pc_gamg_threshold": "high"}, TypeError,
     r"'pc_gamg_threshold' must be a number, got 'high' \(str\)"),
    ({"pc_type": "gamg", "ksp_max_it": 2.5}, TypeError, r"'ksp_max_it' must be an int, got 2.5 \(float\)"),
    ({"pc_type": "gamg", "pc_gamg_square_graph": None}, TypeError,
     r"'pc_gamg_square_graph' must be a string, a number or a bool, got None"),
    ({"pc_type": "gamg", "ksp_type": "preonly"}, ValueError,
     r"'ksp_type' = 'preonly' is not supported with pc_type 'gamg'; accepted: 'gmres'"),
    ({"pc_type": "gamg", "snes_type": "newtonls"}, ValueError,
     r"'snes_type' = 'newtonls' is not supported with pc_type 'gamg'; accepted: pc_type, ksp_type, ksp_rtol"),
    ({"pc_type": "lu", "ksp_rtol": 1e-6}, ValueError, r"'ksp_rtol' = 1e-06 is not supported with pc_type 'lu'"),
    ({"pc_type": "lu", "pc_factor_mat_solver_type": "superlu_dist"}, ValueError,
     r"'pc_factor_mat_solver_type' = 'superlu_dist' is not supported; accepted: 'sparsecholesky', 'umfpack'"),
    ({"pc_type": "gamg", "ksp_rtol": 2.0}, ValueError, r"'ksp_rtol' = 2.0 must lie in \(0, 1\)"),
])
def test_a_bad_dict_names_its_option_before_any_work(monkeypatch, spec, error, message):
    """Checked without PETSc and before the Simulation builds its spaces: the option, its value
    and what is accepted."""
    monkeypatch.setattr(ngc.Body, "space", _no_work)
    with pytest.raises(error, match=message):
        reference.simulation(1, 0.02, solver=spec)


def _block(solver, steps=5):
    """The 3D reference block (P1, maxh 20 mm, refined once: 728 DOFs), ``steps`` steps of 2.5 ms
    (in contact from the fourth), then one of half the size (a new rate coefficient)."""
    sim = reference.simulation(1, 0.02, 1, dim=3, keep_states=False, solver=solver, realcompile=False)
    sim.run(2.5e-3, steps * 2.5e-3)
    sim.step(1.25e-3)
    return sim


def test_a_gamg_dict_runs_as_the_gamg_solver(petsc):
    """The options of ``solver="gamg"`` as a dict: the same Newton iterations per step, GMRES's
    within 10 % (the same here), the same contact forces to 1e-8; the fingerprint's fields name
    the dict."""
    runs = [_block(solver) for solver in ("gamg", GAMG)]
    newton, krylov = ([[getattr(r, field) for r in sim.history[1:]] for sim in runs]
                      for field in ("newton_iterations", "krylov_iterations"))
    assert newton[0] == newton[1]
    assert abs(sum(krylov[1]) - sum(krylov[0])) <= 0.1 * sum(krylov[0])
    forces = [np.array([r.contact.force for r in sim.history[1:]]) for sim in runs]
    assert forces[0][-1][2] > 0
    assert np.abs(forces[0] - forces[1]).max() <= 1e-8 * np.abs(forces[0]).max()
    assert runs[1].solver_options == {
        "options.inverse": None, "options.reuse_factorization": False, "options.iterative": "gamg",
        "options.petsc": {"pc_gamg_threshold": 0.01}}
    assert "options.petsc" not in runs[0].solver_options


def test_a_gamg_dict_reaches_the_preconditioners_and_no_other_simulation(petsc):
    """GAMG's options of the dict reach both GAMG preconditioners (their level smoothers),
    ``ksp_max_it`` GMRES, and are gone from PETSc's options database afterwards: a later
    ``solver="gamg"`` has PETSc's smoother. An option GAMG does not read, or a value it refuses,
    is a ValueError naming it."""
    spec = {"pc_type": "gamg", "mg_levels_ksp_type": "richardson", "pc_gamg_agg_nsmooths": 0, "ksp_max_it": 150}
    sim = reference.simulation(1, 0.02, 1, dim=3, keep_states=False, solver=spec, realcompile=False)
    sim.step(2.5e-3)
    solver = sim.newton.solver
    assert solver.maxiter == 150
    assert [block[0].getMGSmoother(1).getType() for block in solver._bulk] == ["richardson"] * 2
    assert not any(petsc.Options().hasName(f"ngcontact_{part}_mg_levels_ksp_type") for part in ("u", "phi"))
    plain = reference.simulation(1, 0.02, 1, dim=3, keep_states=False, solver="gamg", realcompile=False)
    plain.step(2.5e-3)
    assert plain.newton.solver._bulk[0][0].getMGSmoother(1).getType() == "chebyshev"
    with pytest.raises(ValueError, match=r"PETSc did not read the option\(s\) 'pc_gamg_no_such_option' for the GAMG "
                                         r"preconditioner of u \(prefix -ngcontact_u_\)"):
        reference.simulation(1, 0.02, 1, dim=3, solver={"pc_type": "gamg", "pc_gamg_no_such_option": 1},
                             realcompile=False).step(2.5e-3)
    with pytest.raises(ValueError, match=r"PETSc stopped in the GAMG preconditioner of u .* with the options "
                                         r"\{'pc_gamg_type': 'bogus'\} \(.*Unknown GAMG type bogus given"):
        reference.simulation(1, 0.02, 1, dim=3, solver={"pc_type": "gamg", "pc_gamg_type": "bogus"},
                             realcompile=False).step(2.5e-3)


def _forces(sim):
    sim.run(DT, 2 * DT)
    return np.array([r.contact.force for r in sim.history[1:]])


def test_a_mumps_dict_gives_the_default_solvers_steps(petsc):
    """The reference scene (non-symmetric Jacobian), two steps into contact: MUMPS's LU by
    ``ksp_type`` "preonly" (a factorisation at every Newton iteration) and by PETSc's default
    "gmres" (kept as GMRES's preconditioner), with a MUMPS option, give the default solver's
    contact forces to 1e-8. "cholesky" of this Jacobian is refused; an ICNTL that MUMPS does not
    have, or a value it refuses, is named."""
    expected = _forces(reference.simulation(1, 0.01))
    for spec, kept in ((LU, False), ({"pc_type": "lu", "mat_mumps_icntl_7": 2}, True)):
        sim = reference.simulation(1, 0.01, solver=spec)
        got = _forces(sim)
        assert np.abs(got - expected).max() <= 1e-8 * np.abs(expected).max()
        fields = sim.solver_options
        assert fields["options.inverse"] == "mumps" and fields["options.reuse_factorization"] is kept
        assert fields.get("options.petsc") == ({"mat_mumps_icntl_7": 2} if kept else None)
    assert sim.solver_detail == "KeptFactorization(DirectSolver('mumps'), symmetric=False)"
    with pytest.warns(DeprecationWarning, match=r"solver=\{'ksp_type': 'preonly', 'pc_factor_mat_solver_type': "
                                                 r"'mumps'\}"):
        earlier = reference.simulation(1, 0.01, inverse="mumps", reuse_factorization=False)
    dict_made = reference.simulation(1, 0.01, solver={"ksp_type": "preonly", "pc_factor_mat_solver_type": "mumps"})
    assert earlier.solver_options == dict_made.solver_options
    with pytest.raises(ValueError, match=r"'pc_type' = 'cholesky' \(LDLᵀ\) needs a symmetric Jacobian.*use 'lu'"):
        reference.simulation(1, 0.01, solver={"pc_type": "cholesky"})
    with pytest.raises(ValueError, match=r"PETSc did not read the option\(s\) 'mat_mumps_icntl_99' for the MUMPS"):
        _forces(reference.simulation(1, 0.01, solver={"pc_type": "lu", "mat_mumps_icntl_99": 1}))
    with pytest.raises(ValueError, match=r"PETSc stopped in the MUMPS factorisation with the options "
                                         r"\{'mat_mumps_icntl_7': 99\} \(.*Valid values are"):
        _forces(reference.simulation(1, 0.01, solver={"pc_type": "lu", "mat_mumps_icntl_7": 99}))


def test_a_cholesky_dict_on_a_symmetric_jacobian(petsc):
    """A body without contact has a symmetric Jacobian: ``pc_type`` "cholesky" is MUMPS's LDLᵀ,
    equal to "sparsecholesky" to 1e-10 (the short-circuited column under a step load)."""
    states = []
    for solver in ("sparsecholesky", {"pc_type": "cholesky", "ksp_type": "preonly"}):
        body = ngc.Body(plate(L1=0.01, L2=0.03, maxh=0.004), ngc.pzt5a(relaxation_time=0.1), clamped="bottom",
                        grounded="bottom|top", order=2)
        sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -2e6)}), solver=solver)
        sim.run(0.02, 0.06)
        states.append(sim.gfu.vec.FV().NumPy().copy())
    assert sim.solver_detail == "DirectSolver('mumps', symmetric=True)"
    assert np.abs(states[0] - states[1]).max() <= 1e-10 * np.abs(states[0]).max()


@pytest.mark.parametrize("spec", ["gamg", "lu"])
def test_a_dict_under_mpiexec_equals_the_serial_run(petsc, tmp_path, monkeypatch, spec):
    """``mpiexec -n 3`` (two ranks compute, shared DOFs) with a GAMG or a MUMPS LU dict: the 3D block's
    contact forces equal the serial run with the same dict to 1e-8. The scripts import the
    package this test imports (an installed copy may be older)."""
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(HERE.parent), os.environ.get("PYTHONPATH")])))
    script = str(HERE / "distributed_scenes.py")
    serial = tmp_path / "serial.json"
    done = subprocess.run([sys.executable, script, "block", f"petsc-{spec}", str(serial)], capture_output=True,
                          text=True, cwd=HERE.parent, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    launch(3, script, "block", f"petsc-{spec}", str(tmp_path / "run.json"), timeout=600)
    runs = [json.loads(path.read_text()) for path in (serial, tmp_path / "run.json")]
    assert runs[1]["ranks"] == 3 and runs[1]["solver"].startswith("GamgSolver" if spec == "gamg" else
                                                                   "DirectSolver('mumps')")
    a, b = (np.array(run["force"]) for run in runs)
    assert np.abs(a).max() > 0 and np.abs(a - b).max() <= 1e-8 * np.abs(a).max()
