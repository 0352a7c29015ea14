"""The linear solver of Newton's corrections behind one protocol: ``Simulation(solver=...)`` takes
None, a name or an object, and every name gives the same steps."""
import re

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import ngcontact as ngc
from ngcontact.scenes import reference
from ngcontact.solve.linalg import petsc_solver, solver_choice
from ngcontact.solve.linalg.protocol import LinearSolver

DT = 0.02
"""Two steps of the reference history: the plate pressed onto the foundation (contact, glue,
conduction: a non-symmetric Jacobian)."""


def forces(sim):
    sim.run(DT, 2 * DT)
    return np.array([r.contact.force for r in sim.history[1:]])


def working(name):
    """A direct solver's name that factorises here (some of NGSolve's need a package of their own:
    "pardiso" the mkl wheel, "cudss" nvmath-python, "mumps" PETSc)."""
    if name in petsc_solver.NAMES:
        return petsc_solver.available()
    try:
        reference.simulation(1, 0.02, solver=name).step(DT)
    except ValueError as err:
        if "cannot factorise with it here" in str(err):
            return False
        raise
    return True


@pytest.fixture(scope="module")
def reference_forces():
    return forces(reference.simulation(1, 0.01))


DIRECT = [name for name in solver_choice.names() if name not in solver_choice.ITERATIVE + ("iterative",)]


@pytest.mark.parametrize("name", DIRECT)
def test_every_direct_solver_by_name_gives_the_same_steps(name, reference_forces):
    """Each name resolve takes (kept as GMRES's preconditioner) gives the contact forces of the
    default solver to 1e-8; "sparsecholesky" of this non-symmetric Jacobian is a preconditioner
    only (GMRES makes the correction exact). A name NGSolve lists but cannot load here says so."""
    if not working(name):
        with pytest.raises(ValueError, match=f"solver '{name}'|needs PETSc|PETSc"):
            forces(reference.simulation(1, 0.01, solver=name))
        pytest.skip(f"{name} cannot factorise here")
    got = forces(reference.simulation(1, 0.01, solver=name))
    assert np.abs(got - reference_forces).max() <= 1e-8 * np.abs(reference_forces).max()


KIND_HERE = {"direct": None, "iterative": "multigrid"}
"""What the kinds choose on the serial 3D block: the default factorisation, NGSolve's multigrid."""


@pytest.fixture(scope="module")
def block_forces():
    """The 3D block (P1, one refinement: its nested mesh has 2 levels) by the default solver, a
    step into contact and one of half the size (a new step size: the kept factorisation, the
    preconditioner's c are made again)."""
    sim = reference.simulation(1, 0.02, 1, dim=3)
    return np.array([sim.step(dt).contact.force for dt in (DT, DT / 2)])


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.long) if n in ("umfpack", "superlu") else n
                                  for n in solver_choice.names()])
def test_every_solver_by_name_gives_the_same_steps_on_the_3d_block(name, block_forces):
    """Every name resolve takes gives the default's contact force on the 3D block to 1e-8, in
    contact and after a change of the step size; the iterative ones ("multigrid": GMRES around
    NGSolve's multigrid on the nested mesh; "gamg": around PETSc's GAMG) by GMRES iterations."""
    if solver_choice.needs_petsc(name) and not petsc_solver.available():
        pytest.skip(f"{name} needs PETSc")
    if name not in solver_choice.ITERATIVE and not working(name):
        pytest.skip(f"{name} cannot factorise here")
    if name in solver_choice.KINDS:              # the solver the kind chooses here, which its own name runs below
        kind, chosen = (reference.simulation(1, 0.02, 1, dim=3, solver=s) for s in (name, KIND_HERE[name]))
        assert kind.solver_detail == chosen.solver_detail
        return
    sim = reference.simulation(1, 0.02, 1, dim=3, solver=name)
    records = [sim.step(dt) for dt in (DT, DT / 2)]
    got = np.array([r.contact.force for r in records])
    assert block_forces[:, 2].min() > 0
    assert np.abs(got - block_forces).max() <= 1e-8 * np.abs(block_forces).max()
    if name in solver_choice.ITERATIVE:
        assert min(r.krylov_iterations for r in records) > 0
    if name == "multigrid":
        assert "multigrid (2 levels)" in sim.solver


class ScipyLU:
    """Newton's corrections by SciPy's sparse LU of the free block: the protocol, written here."""
    name = "scipy splu"

    def __init__(self):
        self.factorizations = 0

    def solve(self, matrix, freedofs, r, w, generation=None, timer=None, weights=None, tol=None, changing=None):
        free = np.flatnonzero(np.array(list(freedofs), dtype=bool))
        rows, cols, values = matrix.COO()
        J = sp.csc_matrix((np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=(matrix.height,) * 2)
        x = np.zeros(matrix.height)
        x[free] = spla.splu(J[free][:, free]).solve(r.FV().NumPy()[free])
        w.FV().NumPy()[:] = x
        self.factorizations += 1


def test_a_solver_object_runs_the_reference_scene_without_an_edit_of_the_package(reference_forces):
    mine = ScipyLU()
    assert isinstance(mine, LinearSolver)
    sim = reference.simulation(1, 0.01, solver=mine)
    got = forces(sim)
    assert np.abs(got - reference_forces).max() <= 1e-8 * np.abs(reference_forces).max()
    assert sim.solver == mine.name and mine.factorizations == sum(r.newton_iterations for r in sim.history[1:])
    assert sim.history[-1].factorizations > 0 and "scipy splu" in repr(sim)


def test_the_solver_is_checked_before_any_work():
    with pytest.raises(ValueError, match=r"solver must be None, an object .* or one of 'sparsecholesky', "
                                         r"'umfpack'.*; got 'lu'"):
        reference.simulation(1, 0.02, solver="lu")
    with pytest.raises(TypeError, match="solver must be None, a name or an object with a solve"):
        reference.simulation(1, 0.02, solver=42)
    with pytest.raises(ValueError, match="give the linear solver by solver= alone"):
        reference.simulation(1, 0.02, solver="umfpack", inverse="umfpack")
    with pytest.raises(ValueError, match="give the linear solver by solver= alone"):
        reference.simulation(1, 0.02, solver="umfpack", reuse_factorization=False)


EARLIER = [(dict(inverse="umfpack"), "umfpack"), (dict(iterative=False), "direct"),
           (dict(reuse_factorization=False), {"ksp_type": "preonly"}),
           (dict(inverse="umfpack", reuse_factorization=False),
            {"ksp_type": "preonly", "pc_factor_mat_solver_type": "umfpack"})]


@pytest.mark.parametrize("earlier, solver", EARLIER)
def test_the_earlier_options_warn_and_build_what_their_solver_builds(earlier, solver):
    """inverse=, iterative= and reuse_factorization= still work, with a DeprecationWarning naming
    the solver= that builds the same solver (the same fingerprint fields)."""
    with pytest.warns(DeprecationWarning, match=re.escape(f"solver={solver!r}")):
        a = reference.simulation(1, 0.02, **earlier)
    b = reference.simulation(1, 0.02, solver=solver)
    assert a.solver_detail == b.solver_detail
    assert a.solver_options == b.solver_options


def test_iterative_true_is_the_kind_iterative_on_the_3d_block():
    with pytest.warns(DeprecationWarning, match="solver='iterative'"):
        a = reference.simulation(1, 0.02, 1, dim=3, iterative=True)
    b = reference.simulation(1, 0.02, 1, dim=3, solver="iterative")
    assert a.solver == b.solver and "block multigrid" in b.solver


def test_a_factorisation_at_every_iteration_by_options_gives_the_same_steps(reference_forces):
    """{"ksp_type": "preonly"}: the factorisation chosen by symmetry, made at every Newton
    iteration (one per iteration, no GMRES); {"pc_type": "lu", "pc_factor_mat_solver_type":
    "superlu"} names NGSolve's SuperLU, kept as GMRES's preconditioner: no PETSc needed."""
    # plain corrections: the switch loop makes the first correction from rest twice (its rest side)
    every = reference.simulation(1, 0.01, solver={"ksp_type": "preonly"}, switch_loop=False)
    got = forces(every)
    assert np.abs(got - reference_forces).max() <= 1e-8 * np.abs(reference_forces).max()
    assert [r.factorizations for r in every.history[1:]] == [r.newton_iterations for r in every.history[1:]]
    assert all(r.krylov_iterations == 0 for r in every.history[1:])
    named = reference.simulation(1, 0.01, solver={"pc_type": "lu", "pc_factor_mat_solver_type": "superlu"})
    assert "superlu" in named.solver and "kept" in named.solver
    got = forces(named)
    assert np.abs(got - reference_forces).max() <= 1e-8 * np.abs(reference_forces).max()
