"""Laws steeper at the run's strains than at their samples ((2.16)-(2.17) allow any constants):
the run goes on with the contact stiffness scale raised to the slope measured there (the step
redone), checked against closed forms of a uniaxial column; laws without a bound on their slope
are refused by what was measured."""
import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from conftest import C33, E33, EPS33
from support import viscous_slab_column
from ngcontact import laws
from ngcontact.geometries import plate
from ngcontact.model import forms

W, H = 0.01, 0.03                  # m


def clip_hardening(E, zeta, r, name="clip hardening", **options):
    """σ_ij = E ε_ij + ζ (ε_ij − clip(ε_ij, −r, r)) entrywise (Pa): strongly monotone with m = E,
    Lipschitz with L = E + ζ (Frobenius norms), slope E within |ε_ij| ≤ r, E + ζ beyond."""
    def hardening(eps):
        dim = eps.dims[0]

        def entry(e):
            return E * e + zeta * ngs.IfPos(e - r, e - r, ngs.IfPos(-r - e, e + r, 0))
        return ngs.CF(tuple(entry(eps[i, j]) for i in range(dim) for j in range(dim)), dims=(dim, dim))
    return laws.StrainLaw(hardening, name, **options)


def inverse(E, zeta, r, stress, stiffening=0.0):
    """ε of f(ε) + k ε = σ (f of ``clip_hardening``, k = ``stiffening``), in closed form."""
    eps = stress / (E + stiffening)
    if abs(eps) > r:
        eps = (stress + np.sign(stress) * zeta * r) / (E + zeta + stiffening)
    return eps


def _strains(sim, body):
    """ε_yy at points of the column (P1: uniform where the state is uniaxial), and u_y on top."""
    points = [(W / 2, H), (0.2 * W, 0.7 * H), (0.8 * W, 0.2 * H)]
    return np.array([sim.u(body.mesh(x, y))[1] / y for x, y in points])


def test_a_law_steeper_beyond_its_samples_runs_and_meets_the_closed_form():
    """The hardening law with E = 1 Pa, ζ = 3 Pa, r = 0.01 (m = 1, L = 4; the samples reach 10 ×
    strain_scale = 0.01 = r, where the slope is 1) on a column clamped at its bottom and pulled
    by a traction to ε = 0.0125 beyond the kink: was refused as steeper than 2 × L = 2 Pa;
    now u_y/y = ε of the closed form E ε + ζ (ε − r) = P to 1e-9 at points of the column, the
    stiffness scale raised at step 1 from 1 Pa to the slope 4 Pa. Below the kink (ε = 0.008)
    nothing is raised and ε = P/E."""
    E, zeta, r = 1.0, 3.0, 0.01
    for target, raised in ((0.0125, True), (0.008, False), (-0.0125, True)):
        P = E * target + zeta * (np.sign(target) * max(abs(target) - r, 0.0))
        material = ngc.Material.isotropic(1.0, 0.0, 1e-8).with_elasticity(clip_hardening(E, zeta, r))
        body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), material, clamped="bottom", grounded="bottom|top")
        sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, P)}))
        sim.run(dt=0.25, T=1.0)
        expected = inverse(E, zeta, r, P)
        assert expected == pytest.approx(target, rel=1e-12)
        assert np.allclose(_strains(sim, body), expected, rtol=1e-9, atol=0), (_strains(sim, body), expected)
        rescaled = sim.rescaled_laws
        assert len(sim.history) == 5
        if raised:
            assert [entry[0] for entry in rescaled] == [1], rescaled
            assert rescaled[0][2] == pytest.approx(1.0, rel=1e-3) and rescaled[0][3] == pytest.approx(4.0, rel=1e-6)
            assert body.tensors.F_law.scale.Get() == pytest.approx(4.0, rel=1e-6)
        else:
            assert rescaled == () and body.tensors.F_law.scale.Get() == body.tensors.F_law.lipschitz


def test_the_penalty_follows_the_law_slope_at_the_run_strains():
    """The column on the foundation (Γ3 = bottom, a roller on the left, the penalty method with
    factor 10) pressed by P: the penalty ε_p = p² S/h with the law's scale S, so the bottom
    sinks by P/ε_p and the top by P/ε_p + |ε| H. S = 4 Pa (the slope at ε = −0.0125) gives
    both to 1e-9; the scale of the samples (1 Pa) would sink the bottom 4 times as far."""
    E, zeta, r, factor = 1.0, 3.0, 0.01, 10.0
    P = E * 0.0125 + zeta * 0.0025
    material = ngc.Material.isotropic(1.0, 0.0, 1e-8).with_elasticity(clip_hardening(E, zeta, r))
    body = ngc.Body(plate(L1=W, L2=H, maxh=W), material, supports={"left": "x"}, grounded="top",
                    contact_side="bottom")
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -P)}),
                         contact=ngc.Contact(gap=0.0, method=ngc.Penalty(factor)))
    start = ngs.GridFunction(body.V)
    start.Set(ngs.CF((0, -1e-4)))                  # touching: the penalty is active at Newton's start
    sim.step(1.0, guess=start.vec.FV().NumPy().copy())
    bottom = body.mesh.Boundaries("bottom")
    stiffness = ngs.Integrate(forms.boundary_stiffness(body, 0.0), body.mesh, definedon=bottom) / W
    h = ngs.Integrate(ngs.specialcf.mesh_size, body.mesh, definedon=bottom) / W
    assert body.tensors.F_law.scale.Get() == pytest.approx(4.0, rel=1e-6)
    assert stiffness == pytest.approx(4.0 / h, rel=1e-6)           # p² S / h, p = 1
    sink = P / (factor * stiffness)
    eps = inverse(E, zeta, r, -P)
    top, foot = (sim.u(body.mesh(W / 2, y))[1] for y in (H, 0.0))
    assert foot == pytest.approx(-sink, rel=1e-9)
    assert top == pytest.approx(-sink + eps * H, rel=1e-9)


def test_a_piezoelectric_column_with_a_hardening_law_meets_its_closed_form(uniaxial):
    """The uniaxial PZT-like material (c13 = e31 = 0) with F the hardening law (E = c33,
    ζ = 3 c33, kink at r = 1e-4, samples to 1e-5), open circuit (grounded at the bottom only):
    D_y = 0 stiffens the column by k = e33²/κ33, so σ = f(ε) + k ε = P and φ(top) = e33 ε H/κ33.
    P takes ε to 1.25 r: ε and φ to 1e-9, the elasticity law's scale raised to 4 c33."""
    E, zeta, r = C33, 3 * C33, 1e-4
    k = E33 ** 2 / EPS33
    target = 1.25 * r
    P = E * target + zeta * (target - r) + k * target
    material = uniaxial().with_elasticity(clip_hardening(E, zeta, r, strain_scale=1e-6))
    body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), material, clamped="bottom", grounded="bottom")
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, P)}))
    sim.run(dt=0.5, T=1.0)
    eps = inverse(E, zeta, r, P, stiffening=k)
    assert eps == pytest.approx(target, rel=1e-12)
    assert np.allclose(_strains(sim, body), eps, rtol=1e-9, atol=0)
    assert sim.phi(body.mesh(W / 2, H)) == pytest.approx(E33 * eps * H / EPS33, rel=1e-9)
    assert body.tensors.F_law.scale.Get() == pytest.approx(4 * C33, rel=1e-6)
    assert [entry[0] for entry in sim.rescaled_laws] == [1]


def _pressed(factor=10.0):
    """The column of the penalty test pressed by P(t) = t × 0.02 Pa (ε = −0.0125 at t = 1 s):
    the law's kink is crossed between t = 0.5 and 0.75 s."""
    material = ngc.Material.isotropic(1.0, 0.0, 1e-8).with_elasticity(clip_hardening(1.0, 3.0, 0.01))
    body = ngc.Body(plate(L1=W, L2=H, maxh=W), material, supports={"left": "x"}, grounded="top",
                    contact_side="bottom")
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": ngs.CF((0, -0.02 * t))}), time=t,
                         contact=ngc.Contact(gap=0.0, method=ngc.Penalty(factor)))
    start = ngs.GridFunction(body.V)
    start.Set(ngs.CF((0, -1e-4)))
    return sim, start.vec.FV().NumPy().copy()


def test_the_raised_scale_is_kept_by_a_resumed_run_and_a_new_simulation_starts_afresh(tmp_path):
    """The scale raised at the step that crosses the kink is part of a step's restart state: a
    run resumed after that step repeats the uninterrupted one bitwise (its penalty follows the
    raised scale, not the samples' L). A second Simulation of the same Body starts from L again
    and repeats the first run bitwise."""
    sim, guess = _pressed()
    sim.step(0.25, guess=guess)                             # touching: then each step starts from the last
    sim.run(0.25, 1.0, out=tmp_path / "a")
    assert [entry[0] for entry in sim.rescaled_laws] == [3], sim.rescaled_laws
    whole = [r.state.copy() for r in sim.history]
    again = ngc.Simulation(sim.body, sim.loads, time=sim.time, contact=sim.contact)
    again.step(0.25, guess=guess)
    again.run(0.25, 1.0)
    assert all(np.array_equal(a.state, b) for a, b in zip(again.history, whole))
    steps = sorted((tmp_path / "a" / "steps").glob("*.npz"))
    assert len(steps) == 5
    steps[-1].unlink()                                      # interrupted after step 3
    resumed, _ = _pressed()
    resumed.resume(tmp_path / "a")
    assert resumed.body.tensors.F_law.scale.Get() == pytest.approx(4.0, rel=1e-6)
    resumed.run(0.25, 1.0, out=tmp_path / "a")
    assert resumed.rescaled_laws == ()
    assert len(resumed.history) == 5 and all(np.array_equal(a.state, b) for a, b in zip(resumed.history, whole))


def test_a_viscosity_steeper_beyond_its_samples_follows_backward_euler(uniaxial):
    """A(ε̇) = τℰε̇ + ζ(ε̇ − P_K ε̇), K = {ε̇_yy ≥ −q}, ζ = 3τc33 (the creep of test_laws, 4 times
    as steep past the kink) with its samples 100 times below q (strain_scale q/1000): the
    column creeps faster than q at first, where A is steeper than 2 × its samples' slope;
    backward Euler's recursion holds to 1e-9, and the viscosity's scale was raised at step 1,
    to 4τc33 (the yy slope)."""
    from test_laws import P, TAU, T
    s_lin = -P / C33
    q = -0.5 * s_lin / TAU
    zeta = 3 * TAU * C33
    material = uniaxial(TAU).with_viscosity(laws.ProjectionLaw(zeta, laws.Slab(1, lower=-q), strain_scale=q / 1000))
    body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), material, clamped="bottom", grounded="bottom|top")
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -P)}))
    n = 20
    k = T / n
    sim.run(dt=k, T=T)
    strains = [sim.state(i).components[0](body.mesh(W / 2, H))[1] / H for i in range(n + 1)]
    expected = viscous_slab_column(P, TAU, C33, zeta, q, k, n)
    assert sum((b - a) / k < -q for a, b in zip(expected, expected[1:])) >= 2
    assert np.allclose(strains, expected, rtol=1e-9, atol=1e-9 * P / C33)
    assert [entry[0] for entry in sim.rescaled_laws] == [1], sim.rescaled_laws
    assert body.tensors.A_law.scale.Get() == pytest.approx(4 * TAU * C33, rel=1e-6)
