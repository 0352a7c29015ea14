"""Newton's corrections with the Signorini switch settled in an inner loop (``solve.switch_loop``):
its rank-one data against NGSolve's Jacobian, the pull-off in a few iterations to the same
state, bitwise reproducibility, and the switch that turns it off."""
import numpy as np
import pytest
import scipy.sparse as sp

from ngcontact.scenes import reference
from ngcontact.solve.linalg.matrices import csr
from ngcontact.solve.switch_loop import SignoriniPoints

DT, END = 0.005, 0.2


def _history(switch_loop, maxh=0.005, contact=None):
    sim = reference.simulation(2, maxh, keep_states=False, switch_loop=switch_loop, contact=contact)
    iterations = [sim.step(DT).newton_iterations for _ in range(int(round(END / DT)))]
    return sim, iterations


def test_the_signorini_points_give_the_contact_part_of_the_jacobian():
    """Σ_q (ω_q/γ_q) χ_q a_q b_qᵀ e − θ Σ_q (ω_q/γ_q) S_q σ̃_ν'(e)_q (the Signorini term's Jacobian
    from the rows σ_ν'(·)_q, u_ν(q), the weights and the state's P_q, γ_q and slope) equals NGSolve's
    Γ3 Jacobian times a random e to 1e-7 on the reference plate (P2, Signorini with the compliant
    layer, no glue or conduction) in contact, with points of Γ3 both pressed and free."""
    sim = reference.simulation(2, 0.005, keep_states=False, contact=reference.contact(bare=True))
    for _ in range(12):
        sim.step(DT)
    theta = sim.gamma3.enforcement.theta
    points = SignoriniPoints(sim.gamma3, sim.contact, sim.gfu)
    S, N, gamma, a = points.linear(theta)
    P, slope = points.at_state()
    active = P <= 0
    assert 0 < active.sum() < len(active)
    b = S + sp.diags(slope - gamma) @ N
    c = points.weights / gamma
    e = np.random.default_rng(0).standard_normal(sim.X.ndof)
    model = a.T @ (c * active * (b @ e)) - theta * S.T @ (c * ((b + sp.diags(gamma) @ N) @ e))
    boundary = sim.system.boundary
    boundary.linearize(sim.gfu.vec)
    exact = csr(boundary.mat) @ e
    assert np.linalg.norm(model - exact) <= 1e-7 * np.linalg.norm(exact), np.linalg.norm(model - exact)


def test_a_pull_off_takes_a_few_newton_iterations_and_ends_where_plain_newton_does():
    """The reference history (P2, 5 ms, 5 mm, to 0.2 s): with the loop no step over 6 Newton
    iterations (measured 5; without it 14, in the release steps after 0.15 s), the loop switched
    points, and the final state is plain Newton's to 1e-9 of its size."""
    looped, with_loop = _history(True)
    plain, without = _history(False)
    assert max(with_loop) <= 6 and max(without[30:]) >= 10, (with_loop, without)
    assert sum(with_loop) < 0.75 * sum(without)
    assert looped.newton.switch_loop.switches > 0 and plain.newton.switch_loop is None
    a, b = looped.gfu.vec.FV().NumPy(), plain.gfu.vec.FV().NumPy()
    assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()


def test_a_push_from_rest_takes_the_glue_pressed_and_the_first_contact_no_more_than_6_iterations():
    """The reference history at 10 ms (P2, 5 mm, to 0.2 s): its first step, from rest, presses Γ3's
    glue (every point at the kink u_ν = 0 moves into the foundation), so R_ν is linearised on its
    pressed side; with the loop active at first contact once the step length cuts no more, no
    step takes over 6 Newton iterations (measured: the first contact 5, plain corrections 7), and
    the final state is plain Newton's to 1e-9 of its size."""
    sim = reference.simulation(2, 0.005, keep_states=False)
    looped = [sim.step(0.01).newton_iterations]
    assert sim.contact.rest_side.Get() == 1.0
    looped += [sim.step(0.01).newton_iterations for _ in range(19)]
    plain = reference.simulation(2, 0.005, keep_states=False, switch_loop=False)
    without = [plain.step(0.01).newton_iterations for _ in range(20)]
    assert max(looped) <= 6 and without[0] >= 7, (looped, without)
    a, b = sim.gfu.vec.FV().NumPy(), plain.gfu.vec.FV().NumPy()
    assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()


def test_a_pull_from_rest_keeps_the_glue_glued():
    """The glued disk's section pulled off its plane from rest (``scenes.glued_disk``): the first
    correction lifts Γ3 at the stud, so R_ν keeps its glued slope at the kink u_ν = 0, and the
    first step takes 2 Newton iterations (5 with the pressed slope there)."""
    from ngcontact.scenes import glued_disk
    sim = glued_disk.simulation("section", 1e-4, keep_states=False)
    assert sim.step(0.1).newton_iterations <= 2
    assert sim.contact.rest_side.Get() == 0.0


def test_runs_with_the_loop_are_bitwise_alike():
    """Two runs of the reference history with the loop (10 mm, to 0.2 s) give the same bits."""
    first, second = (_history(True, maxh=0.01)[0].gfu.vec.FV().NumPy().copy() for _ in range(2))
    assert np.array_equal(first, second)


def test_the_switch_loop_is_an_option_of_its_own():
    """``switch_loop`` is True or False (a TypeError names it otherwise); False leaves Newton
    without the loop, and the run's fingerprint says which."""
    with pytest.raises(TypeError, match="switch_loop"):
        reference.simulation(1, 0.01, switch_loop="yes")
    off = reference.simulation(1, 0.01, switch_loop=False)
    on = reference.simulation(1, 0.01)
    assert off.newton.switch_loop is None and on.newton.switch_loop is not None
    assert on.fingerprint(0.1)["options.switch_loop"] is True and off.fingerprint(0.1)["options.switch_loop"] is False


def test_the_demo_takes_plain_corrections_and_resumes_only_with_them(tmp_path):
    """``demo.run(switch_loop=False)`` (``--no-switch-loop``) runs with plain corrections; a
    resume without the flag is refused naming it, with it the run goes on."""
    from ngcontact import demo
    demo.run(out=tmp_path, maxh=0.02, steps=2, switch_loop=False, progress=False)
    with pytest.raises(ValueError, match="--no-switch-loop"):
        demo.run(out=tmp_path, maxh=0.02, steps=2, resume=True, progress=False)
    demo.run(out=tmp_path, maxh=0.02, steps=2, resume=True, switch_loop=False, progress=False)
    with pytest.raises(TypeError, match="switch_loop"):
        demo.run(out=tmp_path / "other", maxh=0.02, steps=2, switch_loop="no", progress=False)
