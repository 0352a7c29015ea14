"""Newton's starts (``starts``, ``nested``, ``rigid``): a guess changes how Newton gets to a
step's solution, never the solution; nested iteration and the informed start of force control
get there in the few iterations they are meant to; force-controlled Hertz meets the closed
form; bad guesses are refused before any work."""
import math

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.obstacles import Plane
from ngcontact.scenes import hertz
from ngcontact.solve.starts import Approach


def solved(guess=None, **options):
    """The one-step displacement-controlled Hertz half-disk, P2, one refinement (3 678 DOFs),
    stepped from ``guess``: (simulation, its StepRecord)."""
    sim = hertz.simulation(order=2, refine=1, **options)
    return sim, sim.step(1.0, guess=guess)


@pytest.fixture(scope="module")
def warm():
    return solved()


def same_state(sim, reference):
    """u of ``sim`` equals u of ``reference`` to 1e-8 of its largest value (both converged to
    Newton's 1e-10; a different contact set differs by ~1e-3)."""
    u, v = sim.u.vec.FV().NumPy(), reference.u.vec.FV().NumPy()
    assert np.max(np.abs(u - v)) <= 1e-8 * np.max(np.abs(v))


@pytest.mark.parametrize("guess", ["nested", "p1", Approach(0.006), Approach(0.03)])
def test_a_guess_changes_the_iterations_not_the_solution(warm, guess):
    """From the rigid approach by 0.006 (close to the solution's contact set), 0.03 (deeper
    than the top's 0.02: every point of Γ3 penetrates), the coarse level's solution or the P1
    solution on the same mesh, Newton reaches the warm start's state; nested iteration in at
    most 3 iterations on the finest level and "p1" in at most 5 where the warm start u = 0
    takes 8 (13 with the open start's step-length cut)."""
    sim, record = solved(guess)
    same_state(sim, warm[0])
    assert sim.starts.last == "guess" and warm[0].starts.last == "warm"
    assert warm[1].newton_iterations >= 7
    if guess in ("nested", "p1"):
        start = sim.starts.nested if guess == "nested" else sim.starts.first_order
        assert record.newton_iterations <= (3 if guess == "nested" else 5)
        assert len(start.iterations) == 1 and start.iterations[0] >= 5       # a cold solve there (6, 7)
    if guess == "p1":
        assert start.levels[0].body.mesh is sim.body.mesh and start.levels[0].body.order == 1


def test_nested_iteration_on_every_step_of_a_run():
    """``run(..., guess="nested")`` starts every step from the level below (the Hertz push in
    two steps, P1, two refinements): each finest step in at most 3 iterations, the same state as
    the warm run, and the coarse levels stepped to the same times."""
    nested, warm_run = hertz.simulation(order=1, refine=2), hertz.simulation(order=1, refine=2)
    nested.run(0.5, 1.0, guess="nested")
    warm_run.run(0.5, 1.0)
    same_state(nested, warm_run)
    assert max(r.newton_iterations for r in nested.history[1:]) <= 3
    assert max(r.newton_iterations for r in warm_run.history[1:]) >= 6
    assert [level.t for level in nested.starts.nested.levels] == pytest.approx([1.0, 1.0])


@pytest.mark.parametrize("kind", ["tuple", "cf", "gridfunction", "array"])
def test_a_displacement_guess_of_every_kind(warm, kind):
    """The guess u = (0, −0.006 (1 − y/R) − 0.014 y/R) (between the contact's approach and the
    top's motion) as a tuple, a CoefficientFunction, a GridFunction of u and u's DOF values:
    the same state as the warm start, in fewer iterations."""
    sim = hertz.simulation(order=2, refine=1)
    cf = ngs.CF((0.0, -0.006 * (1 - ngs.y) - 0.014 * ngs.y))
    gf = ngs.GridFunction(sim.body.V)
    gf.Set(cf)
    guess = dict(tuple=(0.0, -0.008), cf=cf, gridfunction=gf, array=gf.vec.FV().NumPy().copy())[kind]
    record = sim.step(1.0, guess=guess)
    same_state(sim, warm[0])
    assert record.newton_iterations < warm[1].newton_iterations


@pytest.fixture(scope="module")
def force_controlled():
    """Force-controlled Hertz (P2, one refinement, F = 0.01 N/m) from the informed start and
    from the warm start (moved onto the plane by ``Starts.touch``)."""
    informed = hertz.simulation(order=2, refine=1, control="force")
    informed_record = informed.step(1.0, guess=hertz.informed_start(0.01))
    touched = hertz.simulation(order=2, refine=1, control="force")
    touched_record = touched.step(1.0)
    return informed, informed_record, touched, touched_record


def test_force_controlled_hertz_meets_the_closed_form(force_controlled):
    """The body held only by its contact: the contact force balances the applied resultant to
    round-off (equilibrium), the contact half-width and the pressure meet Hertz's closed form
    (a = 0.1076 for F = 0.01 N/m: a_h within 2 %, pressure L2 error 7.9 % at this mesh,
    bounded by 9 %), and the informed start a²/2R converges in at most 2 iterations."""
    informed, record = force_controlled[:2]
    errors = hertz.errors(informed)
    assert errors["force"] == pytest.approx(0.01, rel=1e-9)
    assert errors["a"] == pytest.approx(math.sqrt(0.04 / (math.pi * hertz.E_STAR)), rel=1e-12)
    assert errors["a_h"] == pytest.approx(errors["a"], rel=0.02)
    assert errors["pressure_L2"] < 0.09
    assert record.newton_iterations <= 2 and informed.starts.last == "guess"


def test_a_floating_body_is_moved_onto_the_obstacle(force_controlled):
    """Without a guess the open start is singular; ``touch`` moves it rigidly onto the plane and
    Newton reaches the informed start's state."""
    informed, _, touched, record = force_controlled
    assert touched.starts.last == "touch" and record.newton_iterations > 2
    same_state(touched, informed)


def test_a_motion_nothing_holds_is_refused():
    """The half-disk held in y only on its top: its horizontal translation moves Γ3 along the
    plane, which the contact cannot hold: a ValueError naming the motion, when it is built."""
    body = ngc.Body(hertz.mesh(2, 0.05), hertz.material(), supports={"top": "y"}, contact_side="contact")
    t = ngs.Parameter(0.0)
    with pytest.raises(ValueError, match=r"the rigid motion .*translation along x.* held by neither the supports"):
        ngc.Simulation(body, ngc.Loads(f2={"top": (0, -0.01 * t)}), time=t,
                       contact=ngc.Contact(obstacle=Plane((0, 0), (0, 1))))


@pytest.fixture(scope="module")
def small():
    return hertz.simulation(order=1, h_contact=0.05)


@pytest.mark.parametrize("guess, error, words", [
    ("coarse", ValueError, r"guess must be .*'nested' or 'p1'; got the string 'coarse'"),
    ("nested", ValueError, r"guess='nested' needs coarser levels of the mesh and it was not refined"),
    ("p1", ValueError, r"guess='p1' starts a body of order >= 2 from P1 on its mesh; the body has order 1"),
    (3, TypeError, r"guess must be .*; got int"),
    (np.zeros(5), ValueError, r"guess: an array of u's DOF values must be real of shape"),
    ((0.0, 0.0, 1.0), ValueError, r"guess must have 2 components, got 3"),
    ((0.0, math.nan), ValueError, r"guess must be a finite number"),
    (ngs.CF((0.0, ngs.log(ngs.x - 5))), ValueError, r"guess is not finite"),
    (Approach(0.01, direction=(0, 0, 1)), ValueError, r"guess=Approach: direction must have 2 components, got 3"),
])
def test_a_bad_guess_is_refused_before_any_work(small, guess, error, words):
    """Each bad guess is an error naming ``guess``; the simulation stays at t = 0 with only its
    initial record."""
    with pytest.raises(error, match=words):
        small.step(0.5, guess=guess)
    assert small.t == 0.0 and len(small.history) == 1


def test_a_bad_array_guess_and_approach():
    """A NaN in u's DOF values, and approaches that are not numbers or have no direction."""
    sim = hertz.simulation(order=1, h_contact=0.05)
    values = np.zeros(sim.body.V.ndof)
    values[3] = math.nan
    with pytest.raises(ValueError, match="guess is not finite"):
        sim.step(0.5, guess=values)
    with pytest.raises(TypeError, match="Approach: depth must be a finite number"):
        Approach("deep")
    with pytest.raises(ValueError, match="Approach: direction must be a nonzero finite vector"):
        Approach(0.01, direction=(0, 0))
    with pytest.raises(ValueError, match="control must be 'displacement' or 'force'"):
        hertz.simulation(control="traction")
    with pytest.raises(ValueError, match="force must be a finite number"):
        hertz.simulation(control="force", force=-1.0)
    assert sim.t == 0.0


def approaching_obstacle():
    """The half-disk (P2, one refinement) with its top moved down by 0.02 R t and the plane
    coming up from 0.01 R below its place (the gap along the body's normal, 0.01 R (1 − t)
    more): Newton's residual reads the time Parameter."""
    mesh = hertz.mesh(2, None, 1, curve=2)
    body = ngc.Body(mesh, hertz.material(), grounded="top", supports={"top": "all"}, contact_side="contact",
                    order=2)
    t, n = ngs.Parameter(0.0), ngs.specialcf.normal(2)
    gap = (ngs.y + 0.01 * (1 - t)) / ngs.IfPos(-n[1], -n[1], 1.0)
    return ngc.Simulation(body, ngc.Loads(displacement={"top": (0.0, -0.02 * t)}), contact=ngc.Contact(gap=gap),
                          time=t)


def test_a_failed_coarse_level_falls_back_at_the_right_time(monkeypatch):
    """A coarse level whose Newton fails (made to fail after moving the shared time Parameter
    back to 0, as a failed step's restore does) leaves the warm start, the reason in
    ``starts.last``, and the finest level solved at t_n: the warm start's state (at t = 0 the
    obstacle would be 0.01 R further)."""
    warm_sim, sim = approaching_obstacle(), approaching_obstacle()
    warm_sim.step(1.0)
    level = sim.starts.nested.levels[0]

    def fail(target, guess=None):
        sim.time.Set(0.0)
        raise ngc.NewtonError("did not converge", iteration=3, residuals=[1.0, 0.9], step=1, time=target)

    monkeypatch.setattr(level, "advance", fail)
    sim.step(1.0, guess="nested")
    assert sim.starts.last.startswith("level 0 of 2: ")
    assert warm_sim.history[-1].contact.contact_area > 0
    same_state(sim, warm_sim)


@pytest.mark.long
def test_the_hertz_study_starts_each_level_from_the_one_below():
    """``python -m ngcontact hertz``'s cases from level 1 on: the finest level in at most 3
    Newton iterations, the coarse levels' counted apart, and the errors of the warm start."""
    from ngcontact.studies import hertz as study
    row, _ = study.case(1, 2, "obstacle")
    warm = hertz.simulation(1, refine=2)
    warm.run(1.0, 1.0)
    assert row["newton"] <= 3 and row["coarse_newton"] >= 8
    assert row["pressure_L2"] == pytest.approx(hertz.errors(warm)["pressure_L2"], rel=1e-6)
