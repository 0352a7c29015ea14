"""One step: transactional, one Newton loop for every method, its own space per simulation.

* ``Simulation.step(dt)`` either advances t, u, φ, β and the history together, or leaves
  them bitwise as they were and raises; a retried step then gives what an uninterrupted
  run gives.
* The cut-back policy (``advance``) is the one ``run`` uses, and the demo and studies run
  through ``run``.
* The factorisation is kept and updated; the solver reported is the one used.
"""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.solve.linalg.linear_solver import DirectSolver, KeptFactorization
from ngcontact.scenes import reference

DT = 2.5e-3
FIRST_CONTACT = 4          # the reference scene's plate first touches the foundation at step 4


def state(sim):
    """Everything a step may change, as copies."""
    return dict(t=sim.t, time=sim.time.Get(), x=sim.gfu.vec.FV().NumPy().copy(),
                beta=sim.beta.values.copy(), unclipped=sim.beta.unclipped.copy(), records=len(sim.history))


def assert_same(a, b):
    assert a["t"] == b["t"] and a["time"] == b["time"] and a["records"] == b["records"]
    for key in ("x", "beta", "unclipped"):
        assert np.array_equal(a[key], b[key]), key


@pytest.mark.parametrize("contact", [reference.contact(), reference.contact(bare=True, method="active_set")],
                         ids=["nitsche, glue", "nodal active set"])
def test_failed_step_leaves_the_state_bitwise_and_the_retry_matches(contact):
    """maxit = 2 fails at first contact; t, u, φ, β (and the nodal multipliers) and the history
    are untouched, and the retried step equals the same step of an uninterrupted run."""
    sim = reference.simulation(1, 0.01, contact=contact)
    plain = reference.simulation(1, 0.01, contact=contact)
    for _ in range(FIRST_CONTACT - 1):
        sim.step(DT)
        plain.step(DT)
    before = state(sim)
    hook = sim.enforcement.newton_hook
    multipliers = hook.lam.copy() if hook is not None else None
    sim.newton.maxit = 2
    with pytest.raises(ngc.NewtonError, match="did not converge in 2 iterations"):
        sim.step(DT)
    assert_same(state(sim), before)
    if hook is not None:
        assert np.array_equal(hook.lam, multipliers)
    sim.newton.maxit = 50
    retried, uninterrupted = sim.step(DT), plain.step(DT)
    assert retried.newton_iterations > 2 and uninterrupted.newton_iterations > 2
    # the kept factorisation of GMRES is not part of the state: the same step to the tolerance
    assert np.abs(retried.state - uninterrupted.state).max() <= 1e-8 * np.abs(uninterrupted.state).max()
    assert retried.contact.contact_area > 0 and retried.time == uninterrupted.time


def test_interrupted_step_is_rolled_back():
    """Any exception inside a step (here a KeyboardInterrupt in the middle of Newton, after
    β was updated and the state moved) rolls it back."""
    sim = reference.simulation(1, 0.01, predictor=True)
    for _ in range(FIRST_CONTACT):
        sim.step(DT)
    before = state(sim)
    apply, calls = sim.system.Apply, []

    def interrupted(x, r):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        apply(x, r)
    sim.system.Apply = interrupted
    with pytest.raises(KeyboardInterrupt):
        sim.step(DT)
    assert_same(state(sim), before)
    sim.system.Apply = apply
    again = reference.simulation(1, 0.01, predictor=True)
    for _ in range(FIRST_CONTACT + 1):
        again.step(DT)
    assert np.abs(sim.step(DT).state - again.history[-1].state).max() <= 1e-8 * np.abs(again.history[-1].state).max()


def test_cutbacks_reach_the_target_through_the_same_steps():
    """advance(t) with the cut-back policy: a step too large for maxit = 5 at first contact
    is halved until it converges (plain Newton corrections: with the Signorini switch's inner
    loop the step converges in 5); the records are the steps themselves, callback included."""
    sim = reference.simulation(1, 0.01, maxit=5, switch_loop=False)
    for _ in range(FIRST_CONTACT - 1):
        sim.step(DT)
    seen = []
    records = sim.advance(sim.t + 4 * DT, on_step=lambda record: seen.append((record.time, sim.t)))
    assert len(records) > 1 and sim.cutbacks and sim.cutbacks[0]["dt"] == pytest.approx(4 * DT)
    assert [r.time for r in records] == [t for t, _ in seen] == [t for _, t in seen]
    assert records[-1].time == pytest.approx((FIRST_CONTACT + 3) * DT, abs=1e-15)
    assert sim.history[-len(records):] == records


def test_a_body_shared_by_two_simulations_is_left_alone():
    """Static condensation marks DOFs on the simulation's own space, not on the Body's."""
    body = reference.body(3, 0.01)
    coupling = body.X.FreeDofs(coupling=True).NumSet()
    t = ngs.Parameter(0)
    condensed = ngc.Simulation(body, reference.loads(t), contact=reference.contact(), time=t)
    assert condensed.condense and condensed.X.FreeDofs(coupling=True).NumSet() > coupling
    assert body.X.FreeDofs(coupling=True).NumSet() == coupling
    plain = ngc.Simulation(body, reference.loads(t), condense=False, time=t)
    assert not plain.condense and plain.X.FreeDofs(coupling=True).NumSet() == coupling


def test_the_solver_reported_is_the_one_used():
    assert reference.simulation(1, 0.01, solver={"ksp_type": "preonly"}).solver == "umfpack"
    kept = reference.simulation(1, 0.01)
    assert "GMRES" in kept.solver and "sparsecholesky" in kept.solver and "symmetric part" in kept.solver
    assert kept.solver_detail == "KeptFactorization(DirectSolver('sparsecholesky'), symmetric=True)"
    bare = reference.simulation(1, 0.01, contact=reference.contact(bare=True))
    assert "sparsecholesky" in bare.solver and "symmetric=True" not in bare.solver_detail
    nodal = reference.simulation(1, 0.01, contact=reference.contact(bare=True, method="active_set"))
    assert "spsolve" in nodal.solver and nodal.solver == nodal.enforcement.newton_hook.solver


@pytest.mark.parametrize("name", ["umfpack", "sparsecholesky"])
def test_factorisation_is_updated_in_place(name):
    """Factorising the same matrix object again updates the factorisation (NGSolve's Update):
    the solution equals a fresh factorisation's, for new values of the matrix."""
    sim = reference.simulation(1, 0.01, contact=reference.contact(bare=True))
    sim.run(DT, (FIRST_CONTACT + 1) * DT)
    system, x, free = sim.system, sim.gfu.vec, sim.X.FreeDofs()
    kept, r = DirectSolver(name), x.CreateVector()
    r.FV().NumPy()[:] = np.random.default_rng(0).normal(size=len(r))
    system.AssembleLinearization(x)
    kept.factor(system.mat, free)
    first = kept.inverse
    system.mat.AsVector().data *= 2.0                              # new values, same object
    w, w0 = x.CreateVector(), x.CreateVector()
    kept.solve(system.mat, free, r, w)
    fresh = DirectSolver(name)
    fresh.solve(system.mat, free, r, w0)
    assert kept.factorizations == 2 and kept.inverse is first      # updated, not replaced
    assert np.abs(w.FV().NumPy() - w0.FV().NumPy()).max() <= 1e-10 * np.abs(w0.FV().NumPy()).max()


def test_kept_factorisation_solves_by_gmres_and_refactorises_when_it_pays():
    """GMRES preconditioned by the factorisation of an earlier Jacobian reaches the solution
    of the current one (to its tolerance, in Newton's norm), with no new factorisation while
    the Jacobian changed only in its Γ3 terms; a new time step size makes a new one."""
    sim = reference.simulation(1, 0.01)
    sim.run(DT, (FIRST_CONTACT + 2) * DT)
    solver, system, x, free = sim.newton.solver, sim.system, sim.gfu.vec, sim.X.FreeDofs()
    r, w = x.CreateVector(), x.CreateVector()
    system.Apply(x, r)
    system.AssembleLinearization(x)
    exact = (system.mat.Inverse(free, inverse="umfpack") * r).Evaluate().FV().NumPy()
    before = solver.factorizations
    solver.solve(system.mat, free, r, w, generation=system.generation, weights=sim.newton.norm.weights, tol=1e-10)
    weights = sim.newton.norm.weights
    error = np.sqrt(np.dot(weights * (w.FV().NumPy() - exact), w.FV().NumPy() - exact) / np.dot(weights * exact, exact))
    assert error < 1e-8 and solver.factorizations == before and solver.krylov_iterations > 0
    solver.solve(system.mat, free, r, w, generation=system.generation + 1, weights=weights, tol=1e-10)
    assert solver.factorizations == before + 1


def test_gmres_that_does_not_converge_falls_back_to_a_fresh_factorisation():
    """With a budget of one GMRES iteration and a tolerance no single iteration reaches, the
    kept solver refactorises, then solves with a factorisation of the matrix itself: the
    result is UMFPACK's, and both failures are counted for the step's record. (Right after a
    factorisation GMRES gets the whole budget: a new factorisation would not help.)"""
    sim = reference.simulation(1, 0.01)
    sim.run(DT, (FIRST_CONTACT + 1) * DT)
    system, x, free = sim.system, sim.gfu.vec, sim.X.FreeDofs()
    r, w = x.CreateVector(), x.CreateVector()
    system.Apply(x, r)
    system.AssembleLinearization(x)
    exact = (system.mat.Inverse(free, inverse="umfpack") * r).Evaluate().FV().NumPy()
    solver = KeptFactorization(DirectSolver("sparsecholesky"), symmetric=True)
    solver.solve(system.mat, free, r, w, generation=0, tol=1e-10)          # factorises, converges
    assert solver.factorizations == 1 and solver.krylov_failures == 0
    solver.max_budget = 1
    solver.solve(system.mat, free, r, w, generation=0, tol=1e-14)
    assert solver.krylov_failures == 2 and solver.fallbacks == 1 and solver.factorizations == 3
    assert np.abs(w.FV().NumPy() - exact).max() <= 1e-10 * np.abs(exact).max()


def test_a_failed_solve_keeps_the_linear_solvers_history():
    """maxit = 2 at first contact: the error gives, per Newton iteration, what the linear
    solver did, summing to its totals."""
    sim = reference.simulation(1, 0.01)
    sim.run(DT, (FIRST_CONTACT - 1) * DT)
    sim.newton.maxit = 2
    with pytest.raises(ngc.NewtonError) as err:
        sim.step(DT)
    e = err.value
    assert len(e.linear_history) == 2 and len(e.residuals) == 3
    for name in ("factorizations", "krylov_iterations", "krylov_failures"):
        assert sum(h[name] for h in e.linear_history) == getattr(e, name)
    assert e.krylov_iterations >= 2 and all(h["krylov_iterations"] >= 1 for h in e.linear_history)


def test_bad_step_input():
    sim = reference.simulation(1, 0.01)
    with pytest.raises(ValueError, match="time step dt must be > 0 s"):
        sim.step(-1.0)
    with pytest.raises(ValueError, match="target time must be > the current time"):
        sim.advance(0.0)
    with pytest.raises(TypeError, match="max_cutbacks must be an integer >= 0"):
        sim.advance(1.0, max_cutbacks=1.5)
    with pytest.raises(TypeError, match=r"Body\(contact=...\) is now Body\(contact_side=...\)"):
        ngc.Body(sim.body.mesh, ngc.pzt5a(), clamped="left", grounded="top", contact="bottom")
    keepless = reference.simulation(1, 0.01, keep_states=False)
    with pytest.raises(ValueError, match="states were not kept"):
        keepless.state(0)


GAMMA = 1e-4
"""The forcing γ of the test below: small enough that both of ``forcing_term``'s cases stay
under the cap 1e-3 (with γ = 0.9 both were capped after every rise, and the rule after a rise
went untested)."""


def test_eisenstat_walker_forcing_asks_for_no_more_than_the_contraction_can_use():
    """A linear solver with a ``forcing`` γ is asked, after every correction but a step's first,
    for the looser of inexact Newton's margin × target / ‖r_k‖ and ``inexact.forcing_term``: γ
    (‖r_k‖ / ‖r_{k−1}‖)² after a fall (Eisenstat–Walker's choice 2), γ ‖r_{k−1}‖ / ‖r_k‖ after
    a rise; at most 1e-3; at a step's first correction for the margin's accuracy: checked against
    that formula at every correction of the steps into first contact, where the contact set moves
    and Newton contracts slowly (both cases set some tolerances); the states equal the run without
    forcing to Newton's accuracy."""
    # plain corrections (no switch loop): their slow contraction into first contact is the case
    plain = reference.simulation(1, 0.01, switch_loop=False)
    plain.run(DT, (FIRST_CONTACT + 2) * DT)
    sim = reference.simulation(1, 0.01, switch_loop=False)
    newton, solver = sim.newton, sim.newton.solver
    solver.forcing = GAMMA
    asked, targets, residuals = [], [], []
    solve, test = solver.solve, newton.test
    newton.on_iteration = lambda it, value: residuals.append((it, value))

    def recording_solve(*args, tol=None, **kwargs):
        asked.append((len(residuals) - 1, tol))      # the residual it answers, by its index
        return solve(*args, tol=tol, **kwargs)

    def recording_test(x, history, rtol, *args):
        verdict = test(x, history, rtol, *args)
        targets.append(verdict.target)
        return verdict

    solver.solve, newton.test = recording_solve, recording_test
    sim.run(DT, (FIRST_CONTACT + 2) * DT)
    loosened = {False: 0, True: 0}                  # after a fall, after a rise
    for k, tol in asked:
        (it, value), previous = residuals[k], residuals[k - 1][1]
        expected = solver.margin * targets[k] / value
        if it > 0:
            ratio = value / previous
            forcing = GAMMA * (ratio ** 2 if ratio <= 1 else 1 / ratio)
            loosened[ratio > 1] += forcing > expected and forcing > 1e-12
            expected = max(expected, forcing)
        assert tol == pytest.approx(min(1e-3, max(1e-12, expected)), rel=1e-12)
    assert loosened[False] >= 3 and loosened[True] >= 1   # the forcing term, not the margin, set those
    a, b = plain.gfu.vec.FV().NumPy(), sim.gfu.vec.FV().NumPy()
    n_u = sim.body.V.ndof
    for part in (slice(0, n_u), slice(n_u, None)):
        assert np.abs(a[part] - b[part]).max() <= 1e-8 * np.abs(a[part]).max()
