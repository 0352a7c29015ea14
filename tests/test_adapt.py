"""Adaptive meshes (issue 25, item 2): Dörfler marking, refinement of a copy of the mesh with
curved boundaries kept, the loops for one step and for a load history, and their refusals."""
import math

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact import adapt, meshes
from ngcontact.scenes import hertz, reference


def test_doerfler_marks_the_fewest_elements_that_hold_the_fraction():
    eta = np.array([1.0, 3.0, 2.0, 0.5, 0.0])               # squares 1, 9, 4, 0.25, 0 of 14.25
    assert adapt.mark(eta, 0.5).tolist() == [False, True, False, False, False]       # 9 >= 7.125
    assert adapt.mark(eta, 0.9).tolist() == [False, True, True, False, False]        # 13 >= 12.8
    assert adapt.mark(eta, 0.95).tolist() == [True, True, True, False, False]        # 14 >= 13.54
    assert adapt.mark(eta, 1.0).tolist() == [True, True, True, True, False]          # never the zero ones
    assert not adapt.mark(np.zeros(3), 0.5).any()


@pytest.mark.parametrize("fraction", [0, -0.1, 1.5, float("nan")])
def test_a_marking_fraction_outside_zero_one_is_refused(fraction):
    with pytest.raises(ValueError, match="fraction must be a finite number in \\(0, 1\\]"):
        adapt.mark(np.ones(3), fraction)


def test_refined_bisects_a_copy_and_keeps_the_curved_boundary():
    """A marked refinement of the Hertz half-disk (curved to order 2): the original mesh is
    untouched, the copy has more elements, the same boundary names, its new boundary points lie
    on the circle and its area is at least as close to the half-disk's π/2."""
    mesh = hertz.mesh(2, h_contact=0.2, curve=2)
    ne, area = mesh.ne, ngs.Integrate(1.0, mesh)
    marked = np.zeros(mesh.ne, dtype=bool)
    marked[:5] = True
    finer = meshes.refined(mesh, marked)
    assert mesh.ne == ne and finer.ne > ne and set(finer.GetBoundaries()) == set(mesh.GetBoundaries())
    assert finer.GetCurveOrder() == 2
    assert abs(ngs.Integrate(1.0, finer) - math.pi / 2) <= abs(area - math.pi / 2)
    on_arc = {v.nr for el in finer.Elements(ngs.BND) if el.mat == "contact" for v in el.vertices}
    radii = [math.hypot(finer.vertices[v].point[0], finer.vertices[v].point[1] - hertz.R) for v in on_arc]
    assert len(on_arc) > len({v.nr for el in mesh.Elements(ngs.BND) if el.mat == "contact" for v in el.vertices})
    assert max(abs(r - hertz.R) for r in radii) < 1e-12
    assert meshes.refinements(finer) is None               # not a uniform hierarchy: no multigrid
    with pytest.raises(ValueError, match="marked must be a boolean array with one entry per volume element"):
        meshes.refined(mesh, np.ones(3, dtype=bool))


def test_a_mesh_without_geometry_is_refused_unless_its_boundary_is_polygonal():
    from netgen.meshing import Element1D, Element2D, FaceDescriptor, Mesh, MeshPoint
    from netgen.csg import Pnt
    m = Mesh(dim=2)
    points = [m.Add(MeshPoint(Pnt(x, y, 0))) for x, y in [(0, 0), (1, 0), (1, 1), (0, 1)]]
    m.Add(FaceDescriptor(surfnr=1, domin=1, bc=1))
    m.Add(Element2D(1, [points[0], points[1], points[2]]))
    m.Add(Element2D(1, [points[0], points[2], points[3]]))
    for a, b in [(0, 1), (1, 2), (2, 3), (3, 0)]:
        m.Add(Element1D([points[a], points[b]], index=1))
    mesh = ngs.Mesh(m)
    with pytest.raises(ValueError, match="no geometry to place new boundary points on .*polygonal=True"):
        meshes.refined(mesh, np.ones(mesh.ne, dtype=bool))
    assert meshes.refined(mesh, np.ones(mesh.ne, dtype=bool), polygonal=True).ne == 8


def _hertz(mesh, order=1):
    return hertz.simulation(order, mesh=mesh, keep_states=False)


def test_one_step_adapts_towards_the_contact_zone():
    """Hertz P1 from a coarse half-disk: the estimate falls level by level, the refinement
    concentrates at an end of the contact zone (the smallest element lies on Γ3 within 0.05 R of
    x = ±a, a the half-width of the computed contact zone: where the solution is least smooth),
    each level's simulation is built on its own mesh (every object of it made for that mesh),
    and the loop stops at its level limit, saying so."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=1)
    result = adapt.step(_hertz, mesh, 1.0, max_levels=5, fraction=0.5)
    assert result.reason == "level limit" and not result.reached and len(result.levels) == 5
    estimates = [level.estimate for level in result.levels]
    assert estimates[-1] < 0.5 * estimates[0], estimates
    ndofs = [level.ndof for level in result.levels]
    assert all(b > a for a, b in zip(ndofs, ndofs[1:]))
    last = result.last
    assert last.sim.body.mesh is last.mesh and last.sim.side.mesh is last.mesh
    assert last.sim.X.ndof == last.ndof and len(last.indicators) == last.mesh.ne
    sizes = [ngs.Integrate(1.0, last.mesh, ngs.VOL, element_wise=True)[k] for k in range(last.mesh.ne)]
    smallest = int(np.argmin(sizes))
    centre = np.mean([last.mesh.vertices[v.nr].point for v in last.mesh[ngs.ElementId(ngs.VOL, smallest)].vertices],
                     axis=0)
    a = last.sim.history[-1].contact.contact_area / 2
    assert abs(abs(centre[0]) - a) < 0.05 * hertz.R and centre[1] < 0.05 * hertz.R, (centre, a)


def test_a_target_reached_stops_and_a_dof_limit_stops_with_the_best_mesh():
    mesh = hertz.mesh(2, h_contact=0.1, curve=1)
    first = adapt.step(_hertz, mesh, 1.0, max_levels=2)
    target = 0.999 * first.levels[-1].relative
    reached = adapt.step(_hertz, mesh, 1.0, tol=first.levels[0].relative * 1.01)
    assert reached.reached and reached.reason == "target reached" and len(reached.levels) == 1
    limit = first.levels[1].ndof * 1.2
    limited = adapt.step(_hertz, mesh, 1.0, tol=1e-9, max_ndof=limit)
    assert not limited.reached and limited.reason == "DOF limit" and len(limited.levels) == 2
    assert limited.last.ndof <= limit
    assert target > 0


def _hertz_moved(depth):
    return lambda mesh: hertz.simulation(2, dim=2, depth=depth, mesh=mesh, keep_states=False)


def test_a_stress_free_step_is_exact_to_roundoff_on_its_first_level():
    """The Hertz half-disk lifted off the foundation (its top moved up 1 cm: a rigid motion):
    its energy and bound are round-off (about 1e-16 of (|x|ᵀ|K||x|)^½), whose ratio (0.86 here) is
    no relative error. It stops on the first level as exact (relative 0): "target reached" with
    a tol, "nothing to refine" without; before, it refined for noise to the level limit. The
    pressed half-disk (the race's step) is no round-off: relative 0.098 there. ``history`` the
    same, over its estimated steps."""
    lifted = adapt.solve(_hertz_moved(-0.01), hertz.mesh(2, h_contact=0.05, curve=2), 1e-3)
    assert (lifted.reason, lifted.reached, len(lifted.levels), lifted.last.relative) == ("target reached", True, 1, 0.0)
    assert 0 < lifted.last.estimate < 1e-15 and adapt.energy(lifted.last.sim) < 1e-15
    bare = adapt.step(_hertz_moved(-0.01), hertz.mesh(2, h_contact=0.05, curve=2), 1.0, max_levels=3)
    assert (bare.reason, len(bare.levels)) == ("nothing to refine", 1)
    pressed = adapt.solve(_hertz_moved(0.0171), hertz.mesh(2, h_contact=0.05, curve=2), 1e-3, max_levels=1)
    assert pressed.reason == "level limit" and 0.05 < pressed.last.relative < 0.2, pressed.last.relative
    history = adapt.history(_hertz_moved(-0.01), hertz.mesh(2, h_contact=0.05, curve=2), 0.5, 1.0, tol=1e-3)
    assert (history.reason, len(history.levels), history.last.relative) == ("target reached", 1, 0.0)


@pytest.mark.parametrize("goal", ["energy", "pressure"])
def test_a_newton_failure_on_a_level_names_it_and_keeps_the_levels_before(goal):
    """Newton limited to one iteration from the second mesh on: the NewtonError of the level
    that fails says which level (its DOFs) and carries the levels solved before it in
    ``.levels`` (before, they were lost with the exception)."""
    first = hertz.mesh(2, h_contact=0.05, curve=2)

    def scene(mesh):
        return hertz.simulation(2, dim=2, depth=0.0171, mesh=mesh, keep_states=False,
                                maxit=1 if mesh.ne > first.ne else 50)
    with pytest.raises(ngc.NewtonError) as caught:
        adapt.solve(scene, first, 1e-4, goal=goal)
    levels = caught.value.levels
    assert len(levels) >= 1 and levels[0].ndof == _hertz_moved(0.0171)(first).X.ndof
    assert all(isinstance(level, adapt.Level) and level.sim is not None for level in levels)
    note = " ".join(caught.value.__notes__)
    assert f"on level {len(levels) + 1} (" in note and f"the {len(levels)} level(s) solved before it" in note


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(tol=-1.0), ValueError, "tol must be a finite number > 0"),
    (dict(tol="small"), TypeError, "tol must be a number"),
    (dict(fraction=0.0), ValueError, "fraction must be"),
    (dict(max_levels=0), ValueError, "max_levels must be an integer >= 1"),
    (dict(max_levels=2.5), TypeError, "max_levels must be an integer"),
])
def test_bad_adaptation_input_is_refused_before_any_work(kwargs, error, words):
    calls = []

    def scene(mesh):
        calls.append(mesh)
        return _hertz(mesh)
    with pytest.raises(error, match=words):
        adapt.step(scene, hertz.mesh(2, h_contact=0.2), 1.0, **kwargs)
    assert calls == []


@pytest.mark.parametrize("value", ["fast", "Default", "none"])
def test_a_stop_newton_word_other_than_default_is_refused_by_solve(value):
    """``adapt.solve``'s ``stop_newton`` takes a number, None or "default"; any other word is
    refused before the first build, naming the three."""
    calls = []
    with pytest.raises(TypeError, match=r"stop_newton must be a number in \(0, 1\], None .* or 'default'"):
        adapt.solve(lambda mesh: calls.append(mesh) or _hertz(mesh), hertz.mesh(2, h_contact=0.2), 1e-2,
                    stop_newton=value)
    assert calls == []


def test_a_scene_must_build_on_the_mesh_it_is_given():
    other = hertz.mesh(2, h_contact=0.2)
    with pytest.raises(ValueError, match="scene\\(mesh\\) must build its Simulation on the mesh it is given"):
        adapt.step(lambda mesh: _hertz(other), hertz.mesh(2, h_contact=0.2), 1.0)
    with pytest.raises(TypeError, match="scene\\(mesh\\) must return an ngcontact.Simulation"):
        adapt.step(lambda mesh: None, hertz.mesh(2, h_contact=0.2), 1.0)


def test_a_history_is_adapted_by_its_largest_indicators_and_run_again():
    """The reference plate's push and hold (P1, coarse): two meshes; the second is refined where
    the indicators over the history were largest and its largest estimate is lower."""
    def scene(mesh):
        t = ngs.Parameter(0.0)
        body = ngc.Body(mesh, ngc.pzt5a(relaxation_time=reference.RELAXATION_TIME), clamped="left",
                        grounded="top", contact_side="bottom")
        return ngc.Simulation(body, reference.loads(t), contact=reference.contact(), time=t, keep_states=False)
    mesh = reference.body(1, 0.01).mesh
    result = adapt.history(scene, mesh, 0.02, 0.12, max_levels=2, every=2)
    first, second = result.levels
    assert second.ndof > first.ndof and second.estimate < first.estimate
    assert len(second.sim.history) == len(first.sim.history) == 7


def test_the_sample_points_of_a_curved_contact_side_lie_on_its_facets():
    """Γ3's sample points (``ContactSide``) are mapped onto each facet: on the Hertz arc curved to
    order 3 and refined where marked, every one lies on the circle to the curving's accuracy (a
    point on a facet's chord lies up to h²/8R inside it, and a point search from there failed:
    'Meshpoint not in mesh'), and on straight facets they are the equidistant chord points."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=3)
    marked = np.zeros(mesh.ne, dtype=bool)
    marked[::3] = True
    finer = meshes.refined(mesh, marked)
    side = _hertz(finer, order=3).side
    points = side.sample_points
    off = np.abs(np.hypot(points[..., 0], points[..., 1] - hertz.R) - hertz.R)          # (facets, points)
    chords = np.linalg.norm(side.facet_vertices[:, 1] - side.facet_vertices[:, 0], axis=1)
    sagitta = chords ** 2 / (8 * hertz.R)                  # how far a chord's midpoint lies inside the arc
    assert np.max(off / sagitta[:, None]) < 0.02, np.max(off / sagitta[:, None])        # P3 curving: 0.009
    assert np.allclose(side.sample_points[:, 0], side.facet_vertices[:, 0], atol=1e-12)
    assert np.allclose(side.sample_points[:, -1], side.facet_vertices[:, 1], atol=1e-12)
    flat = reference.body(2, 0.05).mesh
    body = ngc.Body(flat, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom", order=2)
    plate_side = ngc.Simulation(body, contact=reference.contact(), keep_states=False).side
    s = np.linspace(0, 1, 5)
    chord = (1 - s)[None, :, None] * plate_side.facet_vertices[:, :1] + s[None, :, None] * plate_side.facet_vertices[:, 1:]
    assert np.allclose(plate_side.sample_points, chord, atol=1e-14)


def test_the_energy_norm_of_a_difference_with_a_solution_on_another_mesh():
    """adapt.energy(sim, reference): 0 against the simulation's own state, |||x_h||| against a
    zero state on another mesh, and the triangle inequality against a state on a finer mesh."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=1)
    coarse = adapt.step(_hertz, mesh, 1.0, max_levels=2)
    a, b = coarse.levels[0].sim, coarse.levels[1].sim
    assert adapt.energy(a, (a.u, None)) == 0.0
    zero = ngs.GridFunction(b.u.space)
    assert abs(adapt.energy(a, (zero, None)) - adapt.energy(a)) <= 1e-12 * adapt.energy(a)
    difference = adapt.energy(a, (b.u, None))
    assert 0 < difference and abs(adapt.energy(a) - adapt.energy(b)) <= difference * 1.01 + 1e-12


def test_a_level_keeps_its_build_time_and_the_solves_adaptive_stopping_ended():
    mesh = hertz.mesh(2, h_contact=0.1, curve=1)
    plain = adapt.step(_hertz, mesh, 1.0, max_levels=3)
    stopped = adapt.step(_hertz, mesh, 1.0, max_levels=3, stop_newton=1.0)
    assert all(level.build_s > 0 for level in plain.levels)
    assert [level.estimate_stops for level in plain.levels] == [0, 0, 0]
    assert stopped.levels[0].estimate_stops == 0                     # no estimate yet on the first mesh
    assert sum(level.estimate_stops for level in stopped.levels) >= 1
    assert all(level.elapsed_s > sum(l.solve_s for l in plain.levels[:i + 1]) for i, level in enumerate(plain.levels))


@pytest.mark.filterwarnings("ignore::ngcontact.PhysicsWarning")     # the coarse disk's penetration
@pytest.mark.parametrize("where", ["step", "solve"])
def test_a_scene_that_has_already_stepped_is_refused_before_the_first_solve(where):
    """A scene that steps its Simulation before returning it: each level would start from a
    state computed on its own mesh (another step problem per level) and the certificate would
    be that of a later step than the one asked for; refused naming the steps, the time and the
    fix, before the adaptation solves anything (the scene's own step is the only one taken)."""
    steps = []

    def stepped(mesh):
        sim = _hertz(mesh)
        sim.step(0.5)
        steps.append(sim)
        return sim
    call = adapt.solve if where == "solve" else lambda s, m, tol: adapt.step(s, m, 1.0, tol=tol)
    with pytest.raises(ValueError, match=r"scene\(mesh\) returned a Simulation that has already stepped \(1 step\(s\), "
                                         r"t = 0.5 s\).*return the Simulation before it steps.*adapt.history"):
        call(stepped, hertz.mesh(2, h_contact=0.2), 0.1)
    assert len(steps) == 1 and len(steps[0].history) == 2


@pytest.mark.parametrize("goal", ["energy", "pressure"])
def test_a_level_compiles_its_jacobian_by_the_iterations_of_the_level_below(goal, monkeypatch):
    """Each level after the first expects the Newton iterations of the level below
    (``MachineCode.expect``) before its solve, so that a large 3D level compiles Γ3's Jacobian
    when those iterations pay for it (a level is one step: the simulation's own rule, which
    counts the iterations made, compiles after it); the first level expects nothing. Here every
    expected iteration pays (the compile made free and interpreted), and each later level's
    Jacobian is compiled before its solve."""
    from ngcontact.model import machine_code
    import ngcontact.gamma3.terms as terms
    expected = []
    original = machine_code.MachineCode.expect

    def expect(rule, iterations):
        original(rule, iterations)
        expected.append((iterations, rule.system.machine_code))
    monkeypatch.setattr(machine_code.MachineCode, "expect", expect)
    monkeypatch.setattr(machine_code, "COMPILE_S", 0.0)
    monkeypatch.setattr(terms, "compiled", lambda cf, realcompile, maxderiv=2: cf.Compile())   # no C++ compiler
    result = adapt.solve(_hertz, hertz.mesh(2, h_contact=0.1, curve=1), 1e-6, max_levels=3, goal=goal)
    newtons = [level.newton for level in result.levels]
    assert len(result.levels) == 3 and expected == [(n, True) for n in newtons[:-1]], (expected, newtons)
