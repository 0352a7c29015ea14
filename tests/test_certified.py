"""Certified convergence: a state Newton calls converged is one a wrong state cannot imitate at
any scale (``ngcontact.solve.stopping``), a singular Jacobian is named, extreme contact data converge
to the right answer or fail with the reason, and meaningless results are flagged."""
import warnings

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.obstacles import Plane
from ngcontact.scenes import hertz
from ngcontact.scenes import reference as scene
from ngcontact.solve import stopping
from ngcontact.studies.stability import time_step_sweep

DT = 2.5e-3


def reference(steps=8, **contact):
    sim = scene.simulation(1, 0.01, contact=scene.contact(**contact), keep_states=False)
    sim.run(DT, steps * DT)
    return sim


@pytest.fixture(scope="module")
def plain():
    return reference()


def test_a_wrong_state_fails_the_test_at_any_scale(plain):
    """At a converged step the test passes; the same state scaled by 1 ± 1e-6, by 1e3 or by
    1e-3 (an exploded or a collapsed state: the old test's floors 1e-13‖x‖ and ε|K||x| grew
    with the first) does not."""
    sim = plain
    x = sim.gfu.vec
    solution = x.FV().NumPy().copy()
    test = sim.newton.test

    def verdict(factor):
        x.FV().NumPy()[:] = factor * solution
        sim.system.Apply(x, sim.newton.r)
        return test(x, [sim.newton.norm.dual(sim.newton.r)], sim.newton.rtol)
    assert verdict(1.0).converged
    for factor in (1 + 1e-6, 1 - 1e-6, 1e3, 1e-3, 1e8):
        v = verdict(factor)
        assert not v.converged and v.residual > 1e3 * v.target, factor
    x.FV().NumPy()[:] = solution


def test_the_scale_comes_from_loads_and_bulk_forces_not_from_the_contact_terms(plain):
    """S is the same to 1 % whatever the contact stiffness (γ0 1e6 times larger), and it is the size
    of the forces that act: within a factor 10 of the loads' dual norm."""
    stiff = reference(gamma0=1e7)
    for sim in (plain, stiff):
        sim.system.Apply(sim.gfu.vec, sim.newton.r)          # S is that of the last Apply
    s_plain = plain.system.force_scale(plain.newton.norm)
    s_stiff = stiff.system.force_scale(stiff.newton.norm)
    assert s_stiff == pytest.approx(s_plain, rel=0.02)          # the states differ by the penetration
    loads = plain.newton.norm.dual_everywhere(plain.system.f.vec)
    assert loads <= s_plain <= 10 * loads


def test_huge_gamma0_fails_with_the_reason_and_no_cutbacks():
    """γ0 = 1e30 (the old test "converged" in 0 iterations, with a contact force 13x too small):
    the residual stalls at the round-off of the Γ3 terms, far above 1e-6 of the forces; the
    failure says so, names the contact terms and is not retried with smaller steps."""
    sim = scene.simulation(1, 0.01, contact=scene.contact(gamma0=1e30), keep_states=False)
    with pytest.raises(ngc.NewtonError, match=r"cannot be certified.*the terms on Γ3 make up \d+.* % of that "
                                             r"floor.*Try: a smaller Nitsche gamma0") as err:
        sim.run(DT, 8 * DT)
    assert not err.value.recoverable
    failed = err.value.step
    assert [c["step"] for c in sim.cutbacks] == [failed]          # tried once, not halved 6 times
    assert len(sim.history) == failed


def test_huge_adhesion_gives_the_reference_push():
    """γ_ν = 1e30 Pa/m (the old test "converged" in 0 iterations with a plate that did not move):
    in the push the glue is not stretched, so the contact force equals the one with the
    scene's glue (1e11 Pa/m) to the tolerance. (The Γ3 terms no longer set the units of
    Newton's norms: with them, the glue's 1e30 made every correction look singular.)"""
    glued, plain = reference(adhesion=1e30), reference()
    assert glued.history[-1].contact.force[1] == pytest.approx(plain.history[-1].contact.force[1], rel=1e-8)
    assert glued.history[-1].contact.contact_area > 0


def test_a_body_held_only_by_the_contact_is_named_singular():
    """A half-disk held in x only, pulled off a plane by a traction: nothing fixes its vertical
    motion (pushed, the start moves it onto the plane: ``test_starts``). The first correction
    is 1e16 times the residual it answers; Newton says the system is singular and what to give
    (the old test "converged" in 1 iteration at |u| = 5.5e11 m)."""
    body = ngc.Body(hertz.mesh(2, 0.05), hertz.material(), supports={"top": "x"}, contact_side="contact")
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, 0.01 * t)}), time=t,
                         contact=ngc.Contact(obstacle=Plane((0, 0), (0, 1))))
    with pytest.raises(ngc.NewtonError, match=r"singular.*correction is .* times larger than the residual.*"
                                             r"Try: supports that hold the body") as err:
        sim.run(1.0, 1.0)
    assert not err.value.recoverable and len(sim.cutbacks) == 1 and len(sim.history) == 1


def test_an_absurd_load_is_not_called_singular():
    """2e14 Pa on a clamped plate moves it by kilometres: a regular system with absurd data
    (flagged), not a singular one."""
    body = ngc.Body(plate(maxh=0.01), ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -2e14 * t)}), time=t)
    with pytest.warns(ngc.PhysicsWarning, match="displacement .* exceeds 0.05 of the body's size"):
        sim.run(1.0, 1.0)


def test_the_test_is_scale_free():
    """The clamped plate (no contact) under 2e-3, 2e3 and 2e9 Pa: the same Newton iterations,
    residual histories proportional to the load (a scale-dependent floor would stop one of
    them early or late)."""
    histories = []
    for pressure in (2e-3, 2e3, 2e9):
        body = ngc.Body(plate(maxh=0.01), ngc.pzt5a(2e-3), clamped="left", grounded="top")
        t = ngs.Parameter(0.0)
        sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -pressure * t)}), time=t, physical_checks=False)
        sim.run(0.5, 1.0)
        histories.append([np.array(r.residuals) / pressure for r in sim.history[1:]])
    for other in histories[1:]:
        for a, b in zip(histories[0], other):
            assert len(a) == len(b)
            assert a[0] == pytest.approx(b[0], rel=1e-9)


def test_small_penalty_is_flagged_against_the_displacement():
    """penalty = 1e-9: the plate goes through the foundation by about two gaps (below 0.1 of a
    facet of Γ3, so the facet rule alone did not flag it): flagged against the largest
    displacement."""
    with pytest.warns(ngc.PhysicsWarning, match="penetration .* exceeds 0.1 of the largest displacement"):
        sim = reference(method="penalty", penalty=1e-9)
    penetration = sim.history[-1].contact.max_penetration
    assert scene.CONTACT["gap"] < penetration < 0.1 * sim.side.measure.min()


@pytest.mark.parametrize("theta, gamma0", [(1, 0.1), (0, 0.01), (-1, 0.5)])
def test_a_gamma0_too_small_for_its_theta_is_flagged(theta, gamma0):
    """θ = 1 at γ0 = 0.1 converges to a force 20 % off without any other sign (docs/stability.md):
    flagged when the simulation is built, as for θ = 0 and −1 below their bounds."""
    with pytest.warns(ngc.PhysicsWarning, match=rf"Contact.gamma0 = {gamma0:g} is below .* θ = {theta}"):
        sim = scene.simulation(1, 0.01, contact=scene.contact(theta=theta, gamma0=gamma0))
    assert len(sim.flags) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", ngc.PhysicsWarning)
        scene.simulation(1, 0.01, contact=scene.contact(theta=theta, gamma0=10.0))


def test_a_clipped_explicit_beta_update_is_flagged():
    """dt γ_ν L² = 8 on the pulled plate: the explicit update (4.5) leaves [0, 1] and is clipped;
    the step says so (the implicit update does not need it)."""
    dt = 8 / time_step_sweep.RATE
    for update, flagged in (("explicit", True), ("implicit", False)):
        sim = time_step_sweep.pulled_plate(update, 0.01, -0.2)
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            sim.run(dt, 10 * dt)
        assert any("β update (4.5) left [0, 1]" in m for m in sim.flags) == flagged, update


def test_a_step_on_which_nothing_acts_converges():
    """The top of the coarse 3D Hertz half-ball pushed down by 0.01 R does not bring its flat
    lowest facet onto the plane: the body moves rigidly, no force acts (the force scale is
    round-off itself) and the residual at its round-off floor is certified; the state is the
    rigid motion (u_z = −0.01 R everywhere)."""
    from ngcontact.scenes import hertz
    sim = hertz.simulation(1, dim=3, mesh=hertz.mesh(3, h_contact=0.25), keep_states=False)
    record = sim.step(1.0)
    assert record.contact.contact_area == 0
    uz = np.array([sim.u(sim.body.mesh(*v.point))[2] for v in sim.body.mesh.vertices][:20])
    assert np.allclose(uz, -0.01 * hertz.R, rtol=1e-9)


def released(steps=10):
    """The plate held only by its top, glued to the foundation below (γ_ν = 1e14 Pa/m, L = 10 µm,
    implicit β) and lifted 0.2 mm by its top over 1 s in steps of 0.1 s: the glue lets go by
    t = 0.4 s, then β decays by 1e3 a step and the body moves rigidly with its support."""
    body = ngc.Body(plate(maxh=0.01), ngc.Material.isotropic(6e10, 0.3, 1e-8), supports={"top": "all"},
                    contact_side="bottom")
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": (0, 2e-4 * t)}), time=t,
                         contact=ngc.Contact(gap=0.0, adhesion=1e14, bond_length=1e-5, beta_update="implicit"))
    sim.run(0.1, steps * 0.1)
    return sim


@pytest.fixture(scope="module")
def rigid():
    return released()


def test_a_body_moved_rigidly_after_its_glue_let_go_is_certified(rigid):
    """Once released the residual is at the round-off of the rigid motion's |K||x| (1e-14 J^½),
    above 1e-6 of the glue's last force (S down to 1e-12 J^½): certified as at round-off, to the
    end. The state is the support's motion (u = (0, 2e-4 t) m everywhere), the contact force
    and the support's reaction are those of β (10⁻³ a step) down to round-off of the peak."""
    sim = rigid
    assert sim.history[-1].time == pytest.approx(1.0) and not sim.cutbacks
    peak = max(abs(r.boundary_reaction["top"][1]) for r in sim.history)
    assert peak > 1e6                                            # the glue held at first (7.3 MN/m)
    for record in sim.history[6:]:                               # t >= 0.6 s: β <= 2e-13
        assert record.contact.beta.max() < 1e-12
        assert np.abs(record.contact.force).max() <= 1e-12 * peak
        assert np.abs(record.boundary_reaction["top"]).max() <= 1e-12 * peak
    mesh = sim.body.mesh
    u = np.array([sim.u(mesh(*v.point)) for v in mesh.vertices])
    assert np.allclose(u[:, 1], 2e-4, rtol=1e-12, atol=0) and np.abs(u[:, 0]).max() < 1e-12 * 2e-4
    verdict = _verdict(sim, sim.gfu.vec.FV().NumPy().copy())
    assert verdict.converged and verdict.roundoff and verdict.residual > 1e-6 * verdict.scale


def _verdict(sim, state):
    """The test's verdict on ``state`` put into the simulation's current step, as after an
    iteration that did not reduce the residual (so that the floors are evaluated), with the
    residual vector (so that each field is tested)."""
    x = sim.gfu.vec
    x.FV().NumPy()[:] = state
    sim.system.Apply(x, sim.newton.r)
    value = sim.newton.norm.dual(sim.newton.r)
    return sim.newton.test(x, [value, value], sim.newton.rtol, sim.newton.r)


def test_a_perturbed_rigid_motion_is_refused(rigid):
    """The round-off test certifies the state, not its load: the rigid motion with its free DOFs
    off by 1e-9 of themselves, by 1e3 or 1e-3 times them, or by random noise of 1e-9 of the
    motion, has a residual far above its floor and fails, however small S is."""
    sim = rigid
    x = sim.gfu.vec.FV().NumPy()
    solution = x.copy()
    free = np.array(list(sim.newton.freedofs), dtype=bool)
    noise = np.random.default_rng(0).standard_normal(len(solution)) * 1e-9 * np.abs(solution).max()
    try:
        for wrong in [np.where(free, factor * solution, solution) for factor in (1 + 1e-9, 1 - 1e-9, 1e3, 1e-3)] + \
                     [np.where(free, solution + noise, solution)]:
            v = _verdict(sim, wrong)
            floor = stopping.ROUNDOFF * sim.newton.norm.dual(sim.system.magnitude(sim.gfu.vec))   # Γ3 included
            assert not v.converged and not v.roundoff and v.residual > 1e3 * floor
    finally:
        x[:] = solution
    assert _verdict(sim, solution).converged


def test_an_uncertifiable_residual_names_the_contact_terms_not_the_supports():
    """A residual stuck above the state's round-off is held there by the Γ3 terms: the advice
    names them, never the supports or the data's scale (a rigid motion is certified)."""
    for share in (0.04, 0.9):
        verdict = stopping.Verdict(False, 1e-3, 1e-12, scale=1e-2, floor=2e-3, contact_share=share,
                                   uncertifiable=True)
        reason, hint = verdict.explain()
        assert "round-off floor 2.000e-03" in reason and f"{100 * share:.3g} % of that floor" in reason
        assert "gamma0" in hint and "supports" not in hint and "scale" not in hint
