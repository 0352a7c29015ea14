"""Stability maps (ngcontact.studies.stability): each failure mode detected on a small run, with numbers.

* Nitsche: θ = 1 fails for a tiny γ0, θ = 0 converges to a wrong force, θ = −1 converges for
  every γ0 tried (inaccurate for small γ0); all agree from γ0 = 10 on; the pressure
  oscillates along Γ3 for large γ0; γ0 = 1e4 converges to round-off.
* Penalty: penetration ~ 1/penalty, the condition number grows like it.
* β: the explicit update (4.5) leaves [0, 1] (clipped) once k γ_ν L² > 1, the implicit one
  stays in [0, 1] and decays monotonically.
* ν → 1/2: P1 locks on a Netgen mesh, P2 does not.
* Strong coupling: Newton cycles at k² = 0.9 without cut-backs and recovers with them.
* Complete debonding: β = 0 and the contact force of the glue-free body.
* Load cycles: cut-backs where Newton cycles, force balance at every step.
* The conductive foundation meeting a flat face (a weak spot found by these studies).
* Nonlinear laws: ζ = 0 is the linear plate, the force falls as ζ stiffens the plate; Newton
  fails without cut-backs at κ ≈ 2e5 (projection) and where a sharp power viscosity's yield
  stress meets the load.
* Electrode contact: a narrow conduction ramp on a weak conductance defeats the previous
  solver and law, not the globalised Newton with the pressure-gated ψ.
"""
import math

import numpy as np
import pytest

from types import SimpleNamespace

import ngcontact as ngc
from ngcontact import cli
from ngcontact.scenes import column, reference
from ngcontact.studies import common
from ngcontact.studies import stability as st
from ngcontact.studies.stability import (debonding, electrode_map, incompressibility, load_cycles, nitsche_map,
                                         nonlinear_laws, penalty_sweep, pull_off, shared, strong_coupling,
                                         time_step_sweep)


# ------------------------------------------------------------------------------- helpers

def test_failure_kind():
    assert common.failure_kind([1.0, 3.0, 2.0] + [5.0, 7.0] * 10) == "cycle 2"
    assert common.failure_kind([1.0] + [4.0, 2.0, 3.0] * 8) == "cycle 3"
    assert common.failure_kind([1.0, 1e-3, 1e-8, 2e-9, 3e-9, 2e-9]) == "stagnation"
    assert common.failure_kind(np.random.default_rng(0).uniform(1, 100, 30)) == "no convergence"
    assert common.failure_kind([1.0, float("inf")]) == "diverged"


def test_fitted_slope_needs_three_points():
    assert common.fitted_slope([1, 10, 100], [3, 0.3, 0.03]) == pytest.approx(-1, abs=1e-12)
    assert math.isnan(common.fitted_slope([1, 10], [3, 0.3]))
    assert math.isnan(common.fitted_slope([1, 10, 100], [3, float("nan"), 0.03]))


def test_pressure_oscillation_counts_only_variation_beyond_one_peak():
    class Side:
        midpoints = np.column_stack([np.arange(8.0), np.zeros(8)])
    assert shared.pressure_oscillation(Side, [0, 0, 1, 2, 3, 2, 0, 0]) == 0
    assert shared.pressure_oscillation(Side, [0, 0, 0, 0, 3, 2, 3, 2]) == pytest.approx(2 / 3)
    assert math.isnan(shared.pressure_oscillation(Side, np.zeros(8)))


def test_ok_range_is_the_longest_run_of_ok():
    rows = [dict(theta=1, gamma0=g, status=s) for g, s in
            ((0.1, "ok"), (1, "failed"), (10, "ok"), (100, "ok"), (1e3, "wrong"))]
    assert nitsche_map.ok_range(rows, 1) == (10, 100)
    assert all(math.isnan(v) for v in nitsche_map.ok_range(rows, -1))


# ------------------------------------------------------------------------------- Nitsche

@pytest.fixture(scope="module")
def nitsche():
    return {(r["theta"], r["gamma0"]): r for r in nitsche_map.run(gamma0s=(0.01, 1.0, 100.0), progress=False)}


def test_theta_one_fails_for_tiny_gamma0_theta_minus_one_converges(nitsche):
    """γ0 = 0.01: θ = 1 gives no usable force (with full Newton steps it failed; with the
    step-length limit it converges 31 % off), θ = 0 converges to a force 7 % off (47 % before
    the globalisation: another of its many solutions), θ = −1 converges but carries 21 % too
    little; θ = −1 converges for every γ0 tried. At γ0 = 100 all three agree with the reference
    (θ = −1, γ0 = 1000) to 0.1 %."""
    low = nitsche[1, 0.01]
    assert low["status"] == "failed" or (low["status"] == "wrong" and low["force_error"] > 0.2)
    assert nitsche[0, 0.01]["status"] == "wrong" and nitsche[0, 0.01]["force_error"] > 0.05
    assert all(nitsche[-1, g]["status"] != "failed" for g in (0.01, 1.0, 100.0))
    assert nitsche[-1, 0.01]["force_error"] > 0.1
    for theta in (1, 0, -1):
        assert nitsche[theta, 100.0]["status"] == "ok" and nitsche[theta, 100.0]["force_error"] < 1e-3


def test_large_gamma0_penetrates_less_and_oscillates_more(nitsche):
    """The penetration falls like 1/γ0; the facet pressure inherits the zig-zag of the P1
    stress (oscillation 0.44 at γ0 = 100 against 0 at γ0 = 0.01 for θ = −1); cond grows."""
    for theta in (1, 0, -1):
        ratio = nitsche[theta, 100.0]["max_penetration"] / nitsche[theta, 1.0]["max_penetration"]
        slope = math.log10(ratio) / 2
        assert slope == pytest.approx(-1, abs=0.2)
    low, mid, high = (nitsche[-1, g] for g in (0.01, 1.0, 100.0))
    assert low["pressure_oscillation"] < 0.05 < 0.3 < high["pressure_oscillation"]
    assert high["cond"] > 10 * mid["cond"]


def test_huge_gamma0_converges_to_round_off():
    """γ0 = 1e4: the residual stalls at round-off, 1e10 below its start but above rtol; the
    round-off floor grows with the Γ3 stiffness (``stopping.ROUNDOFF``), so the solve counts as
    converged, with the right force and a penetration ~ 1/γ0 (3.5e-12 m)."""
    (row,) = nitsche_map.run(gamma0s=(1e4,), thetas=(1,), progress=False)
    assert row["status"] == "ok" and row["force_error"] < 1e-4
    assert 0 < row["max_penetration"] < 1e-11


# ------------------------------------------------------------------------------- penalty

def test_penalty_penetration_falls_like_one_over_penalty():
    rows = penalty_sweep.run(factors=(0.01, 1.0, 100.0), progress=False)
    assert penalty_sweep.penetration_slope(rows) == pytest.approx(-1, abs=0.1)
    penalty = [r for r in rows if r["method"] == "penalty"]
    assert all(r["converged"] for r in penalty)
    assert penalty[0]["max_penetration"] > 0.3 * reference.CONTACT["gap"]      # 8 µm through a 20 µm gap
    assert penalty[2]["cond"] > 10 * penalty[1]["cond"]


# ------------------------------------------------------------------------------- β update

@pytest.mark.long
def test_explicit_beta_leaves_the_unit_interval_implicit_does_not():
    """dt γ_ν L² = 2 and 8 on the plate pulled off its glue: the explicit update goes below 0
    before clipping (and is clipped on several facets); the implicit one stays in [0, 1] and
    decreases monotonically without clipping."""
    rows = {(r["update"], r["dt_gamma_L2"]): r for r in
            time_step_sweep.run(dt_gamma_L2s=(2.0, 8.0), reference_dt_gamma_L2=1.0, progress=False)}
    for value in (2.0, 8.0):
        explicit, implicit = rows["explicit", value], rows["implicit", value]
        assert explicit["beta_unclipped_min"] < 0 and explicit["clipped"] >= 5
        assert 0 <= implicit["beta_min"] and implicit["beta_max"] <= 1
        assert implicit["clipped"] == 0 and implicit["beta_rise"] == 0
    assert rows["explicit", 8.0]["beta_unclipped_min"] < -0.1
    assert rows["explicit", 8.0]["beta_error"] > 2 * rows["explicit", 2.0]["beta_error"]


# ------------------------------------------------------------------------------- ν → 1/2

def test_p1_locks_p2_does_not():
    rows = {(r["order"], r["mesh"]): r["ratio"]
            for r in incompressibility.run(nus=(0.499,), orders=(1, 2), progress=False)}
    assert rows[1, "netgen"] < 0.2
    assert rows[2, "netgen"] > 0.95
    assert rows[1, "refined"] > 0.75           # red refinement relieves P1 (measured, not explained)


# ------------------------------------------------------------------------------- coupling

def test_strong_coupling_converges_without_cutbacks():
    """k² = 0.9: with full Newton steps Newton cycled at first contact and needed cut-backs;
    with the step-length limit it converges at the nominal step."""
    nominal, strong = strong_coupling.run(k2s=(0.9,), progress=False)
    assert nominal["k2"] == pytest.approx(0.234, abs=1e-3) and nominal["converged"]
    assert strong["converged"] and strong["cutbacks"] == 0
    assert strong["stiffening"] == pytest.approx(6.19, rel=1e-2)
    assert strong["cond"] > 3 * nominal["cond"]


# ------------------------------------------------------------------------------- debonding

def test_complete_debonding_leaves_the_glue_free_contact_force():
    rows = debonding.run(progress=False)
    s = debonding.headline(rows)
    assert s["beta_max_final"] < 1e-8 and s["debonded_at"] < 0.1
    assert s["force_difference"] < 1e-10
    assert s["contact_force_final"] > 0.1 * 3e8 * 0.02 * 0.02       # pushed onto the foundation
    assert min(r["force_glued"] for r in rows) < -1e4                 # the glue pulled first


# ------------------------------------------------------------------------------- load cycles

def test_load_cycles_complete_with_cutbacks_and_force_balance():
    """k = 25 ms, two push-pull cycles: the full Newton steps cycled at the reversals and
    needed cut-backs; the globalised Newton needs none."""
    (row,) = load_cycles.run(dts=(0.025,), cycles=2, progress=False)
    assert row["failure"] == "" and row["cutbacks"] == 0 and row["cycling"] == 0
    assert row["records"] >= 0.2 / 0.025 and row["openings"] == 2
    assert row["balance"] < 1e-10


# ------------------------------------------------------------------------------- pull-off

def test_the_pull_off_takes_about_an_iteration_per_point_the_release_front_crosses():
    """The reference history at 10 ms (P2, 5 mm) with plain corrections: its worst step after the
    first contact is in the pull-off, where the release front crosses 17 Gauss points of Γ3 in 19
    iterations. With the Signorini switch's inner loop no step takes more than 6 (measured 6)
    and the whole history fewer than two thirds of the iterations (67 against 128). The force
    balance holds at every step of both."""
    plain, looped = pull_off.run(quick=True, progress=False)
    assert not plain["switch_loop"] and looped["switch_loop"]
    for row in (plain, looped):
        assert row["failure"] == "" and row["steps"] == 20 and row["balance"] < 1e-10
    assert plain["worst_time"] > reference.LOAD_HISTORY[2][0]          # after the load reverses
    assert plain["worst_crossed"] >= 8 and plain["crossed_max"] == plain["worst_crossed"]
    assert 0.7 <= plain["per_point"] <= 3 and plain["worst_newton"] >= 0.7 * plain["worst_crossed"]
    assert looped["worst_newton"] <= 6 and looped["newton_total"] < 2 / 3 * plain["newton_total"]
    assert looped["crossed_max"] >= 8                                 # the same front, crossed in fewer iterations


# ------------------------------------------------------------------------------- nonlinear laws

@pytest.mark.slow      # a study of six runs (python -m ngcontact stability)
def test_newton_fails_where_a_law_becomes_a_constraint_and_cutbacks_recover_the_projection():
    """ζ = 0 gives the linear force (1e-9); the force falls monotonically as ζ grows (a
    stiffer plate presses less); the projection law at ζ = 1e16 Pa (κ ≈ 2.4e5) fails without
    cut-backs and converges with them; the power viscosity at r = 1 with ζ = 1e6 Pa (the
    order of the 2 MPa load) converges with δ = 1e-3 1/s and, with the globalised Newton (full
    steps failed either way), with δ = 1e-6, the sharper law carrying a little less force."""
    rows = nonlinear_laws.run(zetas=(0.0, 1e11, 1e12, 1e16), power=((1e6, 1e-3), (1e6, 1e-6)), progress=False)
    projection = {(r["zeta"], r["cutbacks"]): r for r in rows if r["law"] == "projection"}
    assert abs(projection[0.0, 0]["force_change"]) < 1e-9
    changes = [projection[z, 0]["force_change"] for z in (0.0, 1e11, 1e12)]
    assert changes[0] > changes[1] > changes[2] > -1, changes
    assert not projection[1e16, 0]["converged"] and projection[1e16, 6]["converged"]
    assert projection[1e16, 0]["kappa"] > 1e5
    power = {(r["delta"], r["cutbacks"]): r for r in rows if r["law"] == "power"}
    assert power[1e-3, 0]["converged"] and power[1e-6, 0]["converged"]
    assert power[1e-6, 0]["force_change"] < power[1e-3, 0]["force_change"] < 0 < power[1e-6, 0]["force_change"] + 0.05
    assert nonlinear_laws.first_failure(rows, "projection") == projection[1e16, 0]["kappa"]


# ------------------------------------------------------------------------------- conduction

@pytest.mark.parametrize("conductance, truncation", [(1e-4, 1e3), (0.0, 1e3), (1e-4, 1e6)])
def test_conductive_foundation_meeting_a_flat_face(conductance, truncation):
    """A weak spot found by these studies. A square column of a soft piezoelectric material
    is pushed flat onto the conductive foundation (k_e = 1e-4 F/m², φ_Γ = 10 V) in one step.
    Without conduction its bottom face floats at about −1.1e4 V, beyond the truncation
    L_φ = 1e3 V of the scene: where φ_L is saturated, the Newton Jacobian has no conduction
    term in φ, each step overshoots, and full Newton steps cycle even with cut-backs. The
    globalised Newton follows a path through wider levels L_φ (and ramps) and converges to
    φ ≈ φ_Γ on Γ3, as with L_φ = 1e6 V directly."""
    contact = reference.contact(adhesion=0.0, conductance=conductance, potential_truncation=truncation)
    if conductance and truncation < 1e4:
        full = column.simulation(lambda t: -1e9 * t, contact, viscous=False, keep_states=False, globalise=False)
        with pytest.raises(ngc.NewtonError) as err:
            full.run(dt=1.0, T=1.0, max_cutbacks=2)
        assert "cycles: the iterates repeat" in str(err.value)
    sim = column.simulation(lambda t: -1e9 * t, contact, viscous=False, keep_states=False)
    record = sim.run(dt=1.0, T=1.0, max_cutbacks=0)[-1]
    c = record.contact
    assert c.contact_area == pytest.approx(0.02)
    if conductance:
        assert record.newton_iterations + record.discarded_iterations <= 20
    if conductance:
        assert np.all(np.abs(c.potential - 10.0) < 1.0)
    else:
        assert np.all(c.potential < -1e4)


# ------------------------------------------------------------------------------- electrode

def test_electrode_narrow_ramp_fails_before_and_converges_after():
    """k_e = 1e-3 F/m², δ = 1e-8 m, h_contact = 2e-4 m, P2: full Newton steps with ψ(u_ν − g)
    (before) cycle with period 2 (Newton's detector; ``failure_kind`` sees no convergence);
    the globalised Newton with the pressure-gated ψ (after) converges, to the force of the
    wide ramp δ = 1e-6 m (6.108e6 N/m, within 1e-4) and its potential on the fully pressed
    facets (about 1.06 kV: a weak conductance does not ground the contact; k_e = 1 gives 1 V)."""
    cell = dict(conductances=(1e-3,), discretisations=((2e-4, 2),), adhesions=(), grounded_steps=0, progress=False)
    rows = electrode_map.run(ramp_widths=(1e-8,), variants=("before",), **cell) + \
        electrode_map.run(ramp_widths=(1e-6, 1e-8), variants=("after",), **cell)
    runs = {(r["variant"], r["ramp_width"]): r for r in rows}
    assert len(rows) == 3 and all(r["scene"] == "electrode" for r in rows)
    before, after, wide = runs["before", 1e-8], runs["after", 1e-8], runs["after", 1e-6]
    assert before["status"] == "failed" and before["reason"] == "cycle 2"
    assert after["status"] == "ok" and wide["status"] == "ok"
    assert abs(after["force_change"]) < 0.01
    assert after["force"] == pytest.approx(wide["force"], rel=1e-3)
    assert after["phi_pressed_inner"] == pytest.approx(wide["phi_pressed_inner"], rel=0.05)
    assert 500 < after["phi_pressed_inner"] < after["phi_pressed"] + 1e-9
    assert after["pressed"] >= 5
    assert "c2" in electrode_map.summary(rows)         # the before cell: nc/c2 (or c2)


def test_pressed_potentials_leave_out_the_edges_of_the_contact_zone():
    class Side:
        midpoints = np.column_stack([np.array([3.0, 0.0, 1.0, 2.0, 4.0, 5.0]), np.zeros(6)])
    pressure = [1.0, 0.0, 1.0, 1.0, 1.0, 0.0]          # pressed: x = 1, 2, 3, 4; fully: x = 2, 3
    potential = [-3.0, 100.0, 50.0, 2.0, -40.0, 7.0]
    assert electrode_map.pressed_potentials(Side, pressure, potential) == (3.0, 50.0, 4)
    assert electrode_map.pressed_potentials(Side, pressure, potential, foundation=2.0)[:2] == (5.0, 48.0)
    inner, pressed, count = electrode_map.pressed_potentials(Side, np.zeros(6), potential)
    assert math.isnan(inner) and math.isnan(pressed) and count == 0


# ------------------------------------------------------------------------------- CLI

def test_cli_writes_csv_and_prints_a_table(tmp_path, monkeypatch, capsys):
    def run(out, quick=False):
        (out / "tiny.png").write_bytes(b"png")
        return [dict(a=1, b=0.5), dict(a=2, b=0.25)]
    tiny = SimpleNamespace(run=run, summary=lambda rows: common.table(rows, ("a", "b")))
    monkeypatch.setattr(st, "STUDIES", dict(tiny=tiny))
    cli.main(["stability", "--out", str(tmp_path), "--quick"])
    assert (tmp_path / "tiny.csv").read_text().splitlines() == ["a,b", "1,0.5", "2,0.25"]
    out = capsys.readouterr().out
    assert "0.25" in out and (tmp_path / "tiny.png").exists()
    assert out.count(common.QUICK) == 2          # --quick: said at the start and at the end


def test_the_stability_command_runs_only_the_studies_named(tmp_path, monkeypatch, capsys):
    """``--study NAME``: only the named studies run (each writes its CSV); an unknown name is
    refused with the allowed ones before anything runs."""
    from ngcontact.studies import stability
    ran = []

    class Study:
        def __init__(self, name):
            self.name = name

        def run(self, out, quick=False):
            ran.append(self.name)
            return [dict(value=1.0)]

        def summary(self, rows):
            return f"{self.name}: {len(rows)} row"
    monkeypatch.setattr(stability, "STUDIES", {name: Study(name) for name in ("first", "second", "third")})
    stability.command(tmp_path, studies=["third", "first"])
    assert ran == ["first", "third"]
    assert sorted(p.name for p in tmp_path.glob("*.csv")) == ["first.csv", "third.csv"]
    with pytest.raises(ValueError, match="'fourth' is not a stability study; allowed: first, second, third"):
        stability.command(tmp_path, studies=["fourth"])
    assert ran == ["first", "third"]
