"""The reference of the 2D Hertz race problem (``studies.hertz_reference``): the measure on samples
with a known answer, the stored reference against equilibrium and Hertz, and the errors of a
small ngcontact run against it."""
import math

import numpy as np
import pytest
from scipy import integrate

from ngcontact.scenes import hertz
from ngcontact.studies import hertz_reference as hr


def arc_samples(b, amplitude, facets=40, half_angle=0.3):
    """Samples (x, y, q) on ``facets`` uneven arcs of the unit circle about (0, 1), θ in
    [−half_angle, half_angle], s linear in θ on each: q = amplitude (b² − x²)."""
    rng = np.random.default_rng(3)
    cuts = np.sort(np.concatenate([[-half_angle, half_angle], rng.uniform(-half_angle, half_angle, facets - 1)]))
    s = hr.gauss_parameters()
    theta = cuts[:-1, None] + (cuts[1:] - cuts[:-1])[:, None] * s[None, :]
    x, y = np.sin(theta), 1 - np.cos(theta)
    return x, y, amplitude * (b * b - x * x)


def test_the_measure_integrates_on_the_arc_and_finds_the_edge_between_points():
    """λ = [A(b² − x²)]_+ on the circle: F = A ∫(b² − sin²θ) dθ over |θ| < asin b (arc length, not
    x: 0.2 % apart here), a_h = b to round-off (the largest sample with λ > 0 is up to a facet
    short), and ‖λ − p‖² against p = c sqrt(b² − x²) as scipy's quad with the singular points
    given finds it."""
    b, amplitude, c = 0.1, 2.0, 0.15
    x, y, q = arc_samples(b, amplitude)
    edge = math.asin(b)
    force = amplitude * (2 * b * b * edge - (edge - math.sin(2 * edge) / 2))
    reference = hr.Reference(dict(force=force, a=b, s_chebyshev_even=[c], pressure_norm=1.0))
    m = hr.measure(x, y, q, reference)
    assert m["force"] == pytest.approx(force, rel=1e-12)
    assert abs(m["force"] - amplitude * integrate.quad(lambda t: b * b - t * t, -b, b)[0]) > 1e-3 * force
    assert m["a"] == pytest.approx(b, abs=1e-13)
    assert b - np.max(np.abs(x[q > 0])) > 1e-5
    exact, _ = integrate.quad(lambda t: (amplitude * (b * b - math.sin(t) ** 2)
                                         - c * math.sqrt(max(b * b - math.sin(t) ** 2, 0))) ** 2,
                              -edge, edge, points=[-edge, edge], epsabs=0, epsrel=1e-13, limit=200)
    assert m["squared"] == pytest.approx(exact, rel=1e-9)


def test_the_stored_reference_meets_equilibrium_and_lies_about_one_percent_from_hertz():
    """The profile integrates on Γ3 to the stored F (∫ p ds = F, to the families' agreement);
    Hertz's half-plane formula for that F gives a 0.2–2 % wider zone and a 0–1 % lower peak (the
    finite half-disk, docs/race_reference.md); the stored agreement meets its targets."""
    ref = hr.Reference.load()
    force, _ = hr.profile_force_and_norm(ref.a, ref.coefficients)
    assert force == pytest.approx(ref.force, rel=1e-6)
    a_hertz, p0_hertz = hertz.closed_form(ref.force, 2)
    assert 0.002 < 1 - ref.a / a_hertz < 0.02
    assert 0 < ref.pressure(0.0) / p0_hertz - 1 < 0.01
    assert ref.pressure(ref.a) == 0 and ref.pressure(-1.01 * ref.a) == 0
    table = ref.data["table"]
    assert np.allclose(ref.pressure(np.array(table["x"])), table["p"], rtol=1e-12, atol=0)
    agreed = ref.data["agreement_max"]
    assert agreed["force"] <= 1e-7 and agreed["a_abs"] <= 1e-6 and agreed["pressure_L2"] <= 1e-4


def test_the_reference_measured_against_itself_and_against_hertz():
    """The stored profile sampled on arcs graded toward ±a (``reference_samples``) and measured
    against itself: errors at round-off (the measure adds ≪ 1e-4 to any error), ∫ p ds to the
    profile's own integral; against Hertz's formula for the same F instead: a 0.5 % and the
    pressure 1 % apart, what a measure against Hertz would report for the exact solution."""
    ref = hr.Reference.load()
    samples = hr.reference_samples(ref)
    e = hr.errors(*samples, ref)
    assert e["pressure_L2"] < 1e-12 and e["a"] < 1e-12
    assert e["force_integrated"] == pytest.approx(ref.data["profile_force"], rel=1e-12)
    a_hertz, p0_hertz = hertz.closed_form(ref.force, 2)
    norm = hr.profile_force_and_norm(a_hertz, [p0_hertz / a_hertz])[1]
    against_hertz = hr.errors(*samples, hr.Reference(dict(force=ref.force, a=a_hertz, pressure_norm=norm,
                                                          s_chebyshev_even=[p0_hertz / a_hertz])))
    assert 0.003 < against_hertz["a"] < 0.01 and 0.005 < against_hertz["pressure_L2"] < 0.02


def test_race_errors_of_a_p2_run_lie_in_their_band():
    """P2 on the scene's mesh at h_contact = 0.01 m: F_h is the recorded force, the errors lie in
    the bands of such a run (F within 1e-3, a within 3 %, pressure 0.5–5 %, docs/race_reference.md)
    and the measure does not move when its quadrature is doubled."""
    sim = hertz.simulation(2, dim=2, depth=hr.DEPTH, h_contact=0.01, keep_states=False)
    sim.step(1.0)
    e = hr.race_errors(sim)
    assert e["force"] < 1e-3 and e["a"] < 3e-2 and 5e-3 < e["pressure_L2"] < 5e-2
    assert e["force_h"] == float(sim.history[-1].contact.force[-1])
    again = hr.errors(*hr.facet_samples(sim), force=e["force_h"], piece_points=2 * hr.PIECE_POINTS)
    assert again["pressure_L2"] == pytest.approx(e["pressure_L2"], rel=1e-6)
    assert again["a_h"] == pytest.approx(e["a_h"], abs=1e-12)


def test_bad_inputs_are_refused_with_the_parameter_named():
    x, y, q = arc_samples(0.1, 1.0)
    with pytest.raises(ValueError, match="x, y, q"):
        hr.measure(x[:, :10], y[:, :10], q[:, :10])
    sim = hertz.simulation(1, dim=2, depth=hr.DEPTH, h_contact=0.1)
    with pytest.raises(ValueError, match="sim: solve"):
        hr.race_errors(sim)


@pytest.mark.parametrize("argv, words", [(["--out", "/nonexistent/folder/reference.json"], "out: the folder"),
                                         (["--out", "reference.json", "--levels", "0"], "levels")])
def test_the_command_refuses_before_any_solve(argv, words, capsys, monkeypatch, tmp_path):
    """``python -m ngcontact hertz-reference``: an output it cannot write or no levels end in one
    line naming the parameter, exit status 2, before any solve."""
    from ngcontact import cli
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(hr, "solve", lambda *a, **k: pytest.fail("solved before refusing"))
    with pytest.raises(SystemExit) as stop:
        cli.main(["hertz-reference", *argv])
    assert stop.value.code == 2
    assert words in capsys.readouterr().err
