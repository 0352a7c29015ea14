"""Newton's globalisation (line search, path through smoother laws) and what ψ reads (gating)."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.solve import continuation, line_search
from ngcontact.geometries import plate
from ngcontact.scenes import electrode, reference


def _balanced(record, applied=0.0):
    """Reactions of Γ1 and the supports + contact force = the applied load (N/m), to 1e-6 of
    the force."""
    total = sum(r[1] for r in record.boundary_reaction.values()) + record.contact.force[1]
    return abs(total - applied) <= 1e-6 * max(abs(record.contact.force[1]), abs(applied))


def _fully_pressed(sim, record):
    """Facets of Γ3 pressed, with both neighbours along Γ3 pressed too (not the contact zone's edges)."""
    order = np.argsort(sim.side.midpoints[:, 0])
    pressed = record.contact.pressure[order] > 0
    inner = pressed & np.roll(pressed, 1) & np.roll(pressed, -1)
    inner[[0, -1]] = False
    chosen = np.zeros_like(pressed)
    chosen[order] = inner
    return chosen


def test_the_plate_grounded_at_its_clamped_end_converges():
    """Grounded where it is clamped, the reference plate's potential on Γ3 leaves φ_L's level
    L_φ = 1e3 V at first contact: full Newton steps cycle (contact set, glue, ψ and φ_L flip).
    Globalised, the line search gives up and the path through wider ramps and levels solves
    the step; the forces balance."""
    def simulation(**options):
        t = ngs.Parameter(0.0)
        body = ngc.Body(plate(maxh=0.01, maxh_contact=0.005), ngc.pzt5a(2e-3), clamped="left", grounded="left",
                        contact_side="bottom")
        return ngc.Simulation(body, reference.loads(t), contact=reference.contact(), time=t, **options), t
    stuck, _ = simulation(globalise=False)
    stuck.step(0.00625)
    with pytest.raises(ngc.NewtonError):
        stuck.step(0.00625)
    sim, t = simulation()
    sim.step(0.00625)
    record = sim.step(0.00625)
    assert record.newton_iterations + record.discarded_iterations <= 30
    assert record.contact.force[1] > 0
    t.Set(record.time)
    assert _balanced(record, reference.pressure(t)(sim.body.mesh(0.05, 0.02)) * reference.L1)


@pytest.mark.parametrize("conductance, ramp_width", [(1e-3, 1e-8), (1e-3, 1e-6), (1.0, 1e-8)])
def test_the_electrode_contact_converges_where_full_steps_fail(conductance, ramp_width):
    """The PZT-5A half-disk pressed 0.16 mm onto a grounded conducting plane in one step (P2,
    facets of R/50): with ψ of the gap and full steps, Newton cycles or wanders (the first two
    cases); with the defaults each converges, in equilibrium, in at most 30 iterations with
    those of the tries given up (measured: 13, 24, 11)."""
    full = electrode.simulation(conductance, ramp_width, h_contact=2e-4, gating="gap", globalise=False)
    if conductance < 1:
        with pytest.raises(ngc.NewtonError):
            full.step(1.0)
    sim = electrode.simulation(conductance, ramp_width, h_contact=2e-4)
    record = sim.step(1.0)
    assert record.newton_iterations + record.discarded_iterations <= 30
    assert record.contact.force[1] == pytest.approx(6.10e6, rel=0.01) and _balanced(record)   # N/m


def test_pressure_gating_makes_the_pressed_zone_equipotential():
    """k_e = 1 F/m², δ = 1e-8 m: Nitsche's u_ν − g on pressed points is ±7e-8 m on facets of
    R/50, so with ψ of the gap parts of the pressed zone do not conduct (tens of volts against
    the foundation's 0 V); with ψ of the contact state every facet inside the zone sits at the
    drop D·ν/k_e of the law (2.7) (about 1 V)."""
    potentials = {}
    for gating in ("gap", "pressure"):
        sim = electrode.simulation(1.0, 1e-8, h_contact=2e-4, gating=gating)
        record = sim.step(1.0)
        inside = _fully_pressed(sim, record)
        c = record.contact
        potentials[gating] = np.abs(c.potential[inside]).max()
        if gating == "pressure":
            drop = c.charge_flux_density[inside] / 1.0          # D·ν / k_e, V
            assert np.allclose(c.potential[inside], drop, rtol=0.05, atol=0.05)
    assert potentials["pressure"] < 2.0 < 20.0 < potentials["gap"]


def test_the_line_search_engages_on_cycles_and_stalls_only():
    """Full steps stay full while the residual halves within ``PATIENCE`` steps (a rise at a
    change of the contact set included); a repeated pattern or a stall engages the search."""
    search = line_search.LineSearch()
    converging = [1e-2, 1e3, 1e2, 5.0, 1e4, 0.1, 1e-3, 1e-8]
    for i in range(1, len(converging) + 1):
        search.observe(converging[:i])
    assert not search.engaged
    search.start()
    cycle = [1.0, 2.071, 0.256, 2.071, 0.256, 2.071]
    for i in range(1, len(cycle) + 1):
        search.observe(cycle[:i])
    assert search.engaged and "cycle of period 2" in search.why
    search.start()
    stall = [1.0] + [10.0 + 0.1 * k for k in range(line_search.PATIENCE + 1)]
    for i in range(1, len(stall) + 1):
        search.observe(stall[:i])
    assert search.engaged and "without progress" in search.why


def test_the_path_runs_from_smooth_to_the_law_in_geometric_stages():
    """A ramp of 1e-8 m on a body of 1 m: from 1e-2 m (``SMOOTH``) to δ by factors of at most
    ``FACTOR``; a ramp of 5e-324 m is widened no more than FACTOR^MOST; φ_L's level alone by
    ``TRUNCATION``."""
    w = ngs.Parameter(1.0)
    path = continuation.Continuation([("ψ", w, "m", 1e-8)], 1.0)
    assert path.stages[0] == pytest.approx(1e6) and path.stages[-1] == 1.0
    ratios = np.array(path.stages[:-1]) / np.array(path.stages[1:])
    assert np.all(ratios <= continuation.FACTOR * (1 + 1e-12)) and np.all(ratios > 1)
    tiny = continuation.Continuation([("ψ", w, "m", 5e-324)], 1.0)
    assert tiny.stages[0] == pytest.approx(continuation.FACTOR ** continuation.MOST)
    level = continuation.Continuation([("φ_L", w, "V", 1e3)], 1.0)
    assert level.stages[0] == pytest.approx(continuation.TRUNCATION)
    level.set(1e9)
    assert w.Get() == pytest.approx(continuation.TRUNCATION)
    assert ngc.Contact(conductance=0.0).regularised() == []
    names = [name for name, *_ in ngc.Contact(conductance=1e-3).regularised()]
    assert names == ["the conduction ramp δ", "the potential truncation L_φ"]


def test_a_search_given_up_names_the_laws_that_changed():
    """Without the path (and with its last resort failing too: maxit 20), the electrode
    contact at k_e = 1e-3, δ = 1e-6 stops with what engaged the search and which laws of Γ3
    changed piece since it began, with their remedies."""
    sim = electrode.simulation(1e-3, 1e-6, h_contact=2e-4, maxit=20)
    sim.newton.continuation = None
    with pytest.raises(ngc.NewtonError) as caught:
        sim.step(1.0)
    message = str(caught.value)
    assert "nor with a line search" in message and "the conduction ψ changes on" in message, message
    assert "ramp_width" in caught.value.hint
    assert len(sim.history) == 1                                     # the start is kept


class _Flipping:
    """A stand-in for ``switches.Switches`` whose ``names`` change piece between any two states."""

    def __init__(self, names):
        self.names = names

    def __call__(self):
        return {}

    def flipping(self, states):
        return [(name, 1, [0.0], [1.0]) for name in self.names] if len(states) > 1 else []


def test_the_remedy_follows_what_flips():
    """Full steps that stall while ψ changes piece go to the path at once (budget 0); while
    only the contact set flips, to the line search (``BUDGET``); the path's widest stage
    searches whatever flips."""
    path = continuation.Continuation([("δ", ngs.Parameter(1.0), "m", 1e-8), ("L_φ", ngs.Parameter(1.0), "V", 1e3)], 1.0)
    stall = [1.0] + [10.0 + 0.1 * k for k in range(line_search.PATIENCE + 1)]

    def engage(names, remedy=None):
        search = line_search.LineSearch()
        search.remedy = remedy
        for i in range(1, len(stall) + 1):
            search.observe(stall[:i], _Flipping(names), path)
        assert search.engaged
        return search
    searched = engage(["the contact set"])
    assert searched.budget == line_search.BUDGET and not searched.exhausted
    handed = engage(["the contact set", "the conduction ψ"])
    assert handed.budget == 0 and handed.exhausted and "the conduction ψ changing piece" in handed.why
    assert engage(["the conduction ψ"], remedy="search").budget == line_search.BUDGET
    assert path.widens([("the potential truncation φ_L", 2, [0.0], [1.0]), ("the glue R_ν", 1, [0.0], [1.0])]) \
        == ["the potential truncation φ_L"]


def test_the_path_stops_its_stages_at_their_reduction_and_the_last_at_the_tolerance():
    """The electrode contact at k_e = 1e-3 F/m², δ = 1e-6 m (P2, R/50) follows the path: every
    stage before the last stops once its residual is ``REDUCTION`` of its first (or at the
    tolerance), the last (the law as given) at the tolerance; 30 iterations at most in all
    (measured: 24), the forces in balance."""
    sim = electrode.simulation(1e-3, 1e-6, h_contact=2e-4)
    seen, tries = [], sim.newton.tries

    def watched(*args):
        result = tries(*args)
        seen.append((sim.newton.reduction, result))
        return result
    sim.newton.tries = watched
    record = sim.step(1.0)
    stages = [(reduction, result) for reduction, result in seen if reduction is not None]
    assert stages and all(reduction == continuation.REDUCTION for reduction, _ in stages)
    for reduction, result in stages:
        r = result.residuals
        assert result.stopped == "tolerance" or (result.stopped == "reduction" and r[-1] <= reduction * r[0] < r[-2])
    assert seen[-1][0] is None and seen[-1][1].stopped == "tolerance"
    assert record.newton_iterations + record.discarded_iterations <= 30 and _balanced(record)
