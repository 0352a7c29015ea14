"""The iterative linear solver (GMRES preconditioned by Γ3 solves around block multigrid on
nested meshes): the same steps as the factorisations, preconditioner quality, its choice by
size, and its errors. Speed and scaling are measured by ``python -m ngcontact bench --dim 3``.
The P1 pair on the finer block (about a minute) runs with ``-m slow``; the default run checks P1
multigrid against the factorisation on a coarser block (``tests/test_linalg.py``)."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact import meshes
from ngcontact.solve.linalg.gmres import gmres
from ngcontact.solve.linalg import multigrid, solver_choice
from ngcontact.geometries import block
from ngcontact.scenes import reference as scene


def run(solver, order=1, maxh=0.01, refine=1, steps=5):
    sim = scene.simulation(order, maxh, refine, dim=3, keep_states=False, solver=solver)
    sim.run(2.5e-3, steps * 2.5e-3)
    sim.step(1.25e-3)                         # a new step size: the hierarchy's finest level follows
    return sim


class Pairs(dict):
    """(factorised, iterative) simulations of five steps, per order, made when first asked for."""
    SIZES = {1: (0.01, 1), 2: (0.025, 0)}
    """(maxh, refinements): P1's multigrid needs nested meshes; P2's BDDC does not (516 DOFs)."""

    def __missing__(self, order):
        self[order] = (run("direct", order, *self.SIZES[order]), run("iterative", order, *self.SIZES[order]))
        return self[order]


@pytest.fixture(scope="module")
def pairs():
    return Pairs()


@pytest.mark.parametrize("order", [pytest.param(1, marks=pytest.mark.slow), pytest.param(2, marks=pytest.mark.long)], ids=["P1", "P2"])
def test_iterative_steps_equal_the_factorised_ones(pairs, order):
    """Five steps of the 3D reference block into first contact (glue, conduction: the
    non-symmetric coupled Jacobian), then one of half the size, by GMRES with multigrid reach
    the states, contact forces and β of the kept factorisation to 1e-8, with the Krylov
    iterations recorded."""
    direct, iterative = pairs[order]
    assert iterative.solver_options["options.iterative"] == "multigrid"
    assert ("multigrid (2 levels)" if order == 1 else "block BDDC") in iterative.solver
    a, b = direct.gfu.vec.FV().NumPy(), iterative.gfu.vec.FV().NumPy()
    n_u = direct.body.V.ndof
    assert np.abs(a[:n_u] - b[:n_u]).max() <= 1e-8 * np.abs(a[:n_u]).max()
    assert np.abs(a[n_u:] - b[n_u:]).max() <= 1e-8 * np.abs(a[n_u:]).max()
    forces = [np.array([r.contact.force for r in sim.history[1:]]) for sim in (direct, iterative)]
    assert np.abs(forces[0]).max() > 0                              # the block is in contact
    assert np.abs(forces[0] - forces[1]).max() <= 1e-8 * np.abs(forces[0]).max()
    assert np.abs(direct.beta.values - iterative.beta.values).max() <= 1e-8
    assert sum(r.krylov_iterations for r in iterative.history) > 0


@pytest.mark.slow
def test_preconditioner_carries_the_gamma3_terms(pairs):
    """At a contact state, GMRES preconditioned with the Γ3 solves needs far fewer iterations
    than with the bulk multigrid alone (whose forms have no Γ3 terms), and both solve J w = r
    to the asked accuracy (compared with a factorisation)."""
    sim = pairs[1][1]
    system, X = sim.system, sim.X
    system.AssembleLinearization(sim.gfu.vec)
    J, free = system.mat, X.FreeDofs()
    hierarchy = sim.newton.solver.hierarchy
    r = sim.gfu.vec.CreateVector()
    mask = np.array(list(free), dtype=bool)
    r.FV().NumPy()[:] = np.where(mask, np.random.default_rng(1).normal(size=len(r)), 0.0)
    weights = sim.newton.norm.weights
    counts = {}
    for name, layer in (("with", X.GetDofs(sim.body.region("contact_side")) & free), ("without", ngs.BitArray(len(r)))):
        if name == "without":
            layer.Clear()
        pre = multigrid.Preconditioner(hierarchy, J, free, layer, electric=True)
        w = r.CreateVector()
        converged, counts[name] = gmres(J, pre, r, w, weights, 1e-8, 400)
        assert converged
        exact = r.CreateVector()
        exact.data = J.Inverse(free, inverse="umfpack") * r
        assert np.abs(w.FV().NumPy() - exact.FV().NumPy()).max() <= 1e-5 * np.abs(exact.FV().NumPy()).max()
    assert counts["with"] < 0.6 * counts["without"], counts


def test_chosen_by_size_and_dimension(monkeypatch):
    """Default: iterative in 3D from ITERATIVE_FROM DOFs on nested meshes, not in 2D, not
    below the threshold, not on a mesh without its coarse mesh, not with condensation."""
    body3 = scene.body(1, 0.02, refine=1, dim=3)
    body2 = scene.body(1, 0.02, refine=1)
    assert not solver_choice.iterative_by_default(body3, condense=False)       # small
    monkeypatch.setattr(solver_choice, "ITERATIVE_FROM", 100)
    assert solver_choice.iterative_by_default(body3, condense=False)
    assert not solver_choice.iterative_by_default(body3, condense=True)
    assert not solver_choice.iterative_by_default(body2, condense=False)
    plain = ngc.Body(ngs.Mesh(body3.mesh.ngmesh), body3.material, clamped="left", grounded="top",
                     contact_side="bottom")
    assert meshes.refinements(plain.mesh) is None
    assert not solver_choice.iterative_by_default(plain, condense=False)
    t = ngs.Parameter(0)
    sim = ngc.Simulation(body3, scene.loads(t, 3), contact=scene.contact(), time=t)
    assert sim.solver_options["options.iterative"] == "multigrid"
    sim = ngc.Simulation(body3, scene.loads(t, 3), contact=scene.contact(), time=t, solver="direct")
    assert sim.solver_options["options.iterative"] != "multigrid"


def test_bad_input_names_the_parameter():
    body = scene.body(1, 0.02, refine=1, dim=3)
    t = ngs.Parameter(0)

    def make(**options):
        return ngc.Simulation(body, scene.loads(t, 3), contact=scene.contact(), time=t, **options)
    with pytest.raises(ValueError, match="iterative must be True, False, None or one of 'multigrid', 'gamg', got 'yes'"):
        make(iterative="yes")
    with pytest.raises(TypeError, match="iterative must be True, False or None"):
        make(iterative=1.5)
    with pytest.raises(ValueError, match="takes no inverse"), pytest.warns(DeprecationWarning):
        make(iterative=True, inverse="umfpack")
    with pytest.raises(ValueError, match="condense=False"):
        make(solver="iterative", condense=True)
    plain = ngc.Body(ngs.Mesh(block(maxh=0.02).ngmesh), body.material, clamped="left", grounded="top",
                     contact_side="bottom")
    with pytest.raises(ValueError, match="nested_mesh"):
        ngc.Simulation(plain, scene.loads(t, 3), contact=scene.contact(), time=t, solver="iterative")
    with pytest.raises(ValueError, match="refine must be an integer"):
        meshes.nested_mesh(block(maxh=0.02).ngmesh, refine=-1)


def test_a_mesh_changed_after_nesting_is_refused():
    """Refining the mesh again after nested_mesh leaves it without a hierarchy (its levels would
    not be the mesh's): the multigrid solver is refused before any work instead of
    preconditioning with another mesh's DOFs."""
    mesh = block(maxh=0.03)
    assert ngc.meshes.hierarchy(mesh) is not None
    mesh.Refine()
    body = ngc.Body(mesh, ngc.pzt5a(relaxation_time=2e-3), clamped="left", grounded="top", contact_side="bottom")
    assert body.hierarchy is None and ngc.meshes.refinements(mesh) is None
    t = ngs.Parameter(0)
    with pytest.raises(ValueError, match="needs nested meshes"):
        ngc.Simulation(body, scene.loads(t, 3), contact=scene.contact(), time=t, solver="iterative",
                       realcompile=False)


def test_a_hierarchy_given_to_the_body_is_the_one_multigrid_uses():
    """A mesh refined by hand is nested when the Body is given its ``meshes.Hierarchy``: the
    multigrid solver then takes its 2 levels and gives the factorisation's state; a hierarchy
    whose finest level is not the mesh is refused by name."""
    from netgen.geom2d import unit_square
    ngmesh = unit_square.GenerateMesh(maxh=0.25)
    coarse = ngmesh.Copy()
    mesh = ngs.Mesh(ngmesh)
    mesh.Refine()
    assert meshes.hierarchy(mesh) is None
    given = meshes.Hierarchy(coarse, 1, mesh.nv)
    material = ngc.pzt5a(relaxation_time=2e-3)
    body = ngc.Body(mesh, material, clamped="left", grounded="bottom", hierarchy=given)
    loads = ngc.Loads(f2={"right": (0.0, -1e5)})
    mg, direct = (ngc.Simulation(body, loads, solver=s, realcompile=False) for s in ("multigrid", None))
    mg.step(1e-3), direct.step(1e-3)
    assert "multigrid (2 levels)" in mg.solver
    assert np.abs(mg.gfu.vec.FV().NumPy() - direct.gfu.vec.FV().NumPy()).max() <= \
        1e-7 * np.abs(direct.gfu.vec.FV().NumPy()).max()
    with pytest.raises(ValueError, match="hierarchy must be an ngcontact.meshes.Hierarchy whose finest level"):
        ngc.Body(mesh, material, clamped="left", grounded="bottom", hierarchy=meshes.Hierarchy(coarse, 2, mesh.nv + 1))
