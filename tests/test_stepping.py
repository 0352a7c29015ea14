"""Steps chosen by an error target (issue 24, item 4): ``run(dt, T, rtol=...)`` with BDF2's
local error estimate, rejected tries put back bitwise, events of Γ3 located, records of each
step's k, and a resumed controlled run that continues bitwise."""
import shutil

import ngsolve as ngs
import numpy as np
import pytest
import sympy as sp

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.scenes import reference
from ngcontact.scenes.manufactured import Manufactured, t

from test_manufactured import CUBIC_PHI, CUBIC_U, SCALED

COARSE, DT = 0.02, 2.5e-3


def cubic(rtol, T=0.5):
    """u, φ = e^{2t} × fields P3 holds exactly (no contact): the error is the time error alone."""
    body = ngc.Body(plate(L1=1, L2=1, maxh=0.5), SCALED, clamped="left", grounded="left", contact_side="bottom",
                    order=3)
    g = sp.exp(2 * t)
    mms = Manufactured(body.tensors, g * CUBIC_U, g * CUBIC_PHI)
    time = ngs.Parameter(0)
    sim = ngc.Simulation(body, mms.loads(body, time), time=time, physical_checks=False, scheme="bdf2",
                         u0=mms.cf(CUBIC_U, time), keep_states=False)
    sim.run(0.01, T, rtol=rtol)
    size = np.sqrt(ngs.Integrate(ngs.InnerProduct(ngs.Sym(ngs.Grad(sim.u)), ngs.Sym(ngs.Grad(sim.u))), body.mesh))
    return sim, mms.errors(sim)[0] / size


def test_the_error_follows_the_tolerance():
    """A hundredfold smaller rtol gives a global error ≈ 100^(2/3) ≈ 22× smaller (per-step control
    of a second-order scheme: global error ∝ rtol^(2/3)), in more steps; every accepted step has
    its estimate within the tolerance and the steps add up to T. Observed: 1.8e-3 and 1.0e-4
    (17×), in 10 and 32 steps (a local error per step, max norm: the global error is a few
    rtol); the loose run's steps grow from the first 0.01 to 0.097."""
    loose, e_loose = cubic(1e-3)
    tight, e_tight = cubic(1e-5)
    assert 10 < e_loose / e_tight < 60, (e_loose, e_tight)
    assert e_loose < 6e-3 and e_tight < 4e-4 and len(tight.history) > 2 * len(loose.history)
    for sim in (loose, tight):
        h = sim.history
        assert sum(r.dt for r in h[1:]) == pytest.approx(0.5, rel=1e-12)
        assert all(r.error_estimate is None or r.error_estimate <= 1 for r in h[1:])
        assert {r.scheme for r in h} == {"bdf2"} and h[1].order == 1 and h[-1].order == 2
    assert max(r.dt for r in loose.history[1:]) > 3 * loose.history[1].dt       # the steps grew


def test_events_are_located_and_the_scheme_restarts():
    """First contact on the reference plate: the step at which the contact set appears is at most
    event_dt long, the step before it has no contact, the step after it is backward Euler's, of
    the same length, and the steps grow again."""
    sim = reference.simulation(1, COARSE, scheme="bdf2")
    sim.run(DT, 0.03, rtol=1e-3, event_dt=1e-5)
    h = sim.history
    (n,) = [r.step for r in h if r.event == "first contact"]
    assert h[n].dt <= 1e-5 and h[n - 1].contact.contact_area == 0 < h[n].contact.contact_area
    assert h[n + 1].order == 1 and h[n + 1].dt == pytest.approx(h[n].dt)      # restarted from the short step
    assert max(r.dt for r in h[n + 1:]) > 16 * h[n].dt                         # and grown again
    searched = [x for x in sim.rejections if x["reason"] == "first contact inside the step"]
    assert len(searched) >= 3 and h[n].rejected >= 1             # halvings towards it


def test_a_controlled_run_resumes_bitwise(tmp_path):
    """Killed after some steps (the later archives deleted), a controlled run resumed from disk
    takes the same steps to the same final state, bitwise: the scheme's memory and the next
    step (``dt_next``) are in the restart state and the records."""
    whole = reference.simulation(1, COARSE, scheme="bdf2", solver={"ksp_type": "preonly"})
    whole.run(DT, 0.02, rtol=1e-3, out=tmp_path / "a")
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    archives = sorted((tmp_path / "b" / "steps").glob("*.npz"))
    for path in archives[len(archives) // 2:]:
        path.unlink()
    resumed = reference.simulation(1, COARSE, scheme="bdf2", solver={"ksp_type": "preonly"}).resume(tmp_path / "b")
    resumed.run(DT, 0.02, rtol=1e-3, out=tmp_path / "b")
    assert [r.time for r in resumed.history] == [r.time for r in whole.history]
    assert np.array_equal(resumed.gfu.vec.FV().NumPy(), whole.gfu.vec.FV().NumPy())
    with pytest.raises(ValueError, match="holds another run .*rtol 0.001"):
        reference.simulation(1, COARSE, scheme="bdf2").run(DT, 0.02, rtol=1e-4, out=tmp_path / "a")


@pytest.mark.parametrize("kwargs, message", [
    (dict(rtol=0), "rtol must be"), (dict(rtol=0.5), "rtol must be"), (dict(rtol="1e-3"), "rtol must be"),
    (dict(rtol=1e-3, dt_min=0.0), "dt_min must be"), (dict(rtol=1e-3, dt_min=1.0), "dt_min must be"),
    (dict(rtol=1e-3, event_dt=1e-9, dt_min=1e-8), "event_dt must be"),
    (dict(dt_min=1e-6), "dt_min = 1e-06 is for error-controlled steps: give rtol too"),
    (dict(rtol=1e-9), r"rtol = 1e-09 is below 100 × Newton's tolerance \(1e-10\)"),
])
def test_bad_controls_are_named_before_any_step(kwargs, message):
    sim = reference.simulation(1, COARSE, scheme="bdf2")
    with pytest.raises((ValueError, TypeError), match=message):
        sim.run(DT, 0.01, **kwargs)
    assert len(sim.history) == 1


def test_backward_euler_has_no_estimate_to_control_steps():
    with pytest.raises(ValueError, match="the scheme 'backward_euler' has no local error estimate .*Simulation\\(scheme='bdf2'\\)"):
        reference.simulation(1, COARSE).run(DT, 0.01, rtol=1e-3)


@pytest.mark.long
def test_the_demo_chooses_its_steps(tmp_path):
    """``demo --scheme bdf2 --rtol 1e-3``: the steps add up to the load history's 0.5 s, vary by
    orders of magnitude (short at the located events), and the chart of them is written."""
    from ngcontact import demo
    summary = demo.run(maxh=0.02, steps=50, out=tmp_path, scheme="bdf2", rtol=1e-3)
    dts = np.array(summary["dt"])
    assert dts.sum() == pytest.approx(0.5, rel=1e-12) and dts.max() > 100 * dts.min()
    assert (tmp_path / "history.png").stat().st_size > 10_000


def test_the_error_ratio_is_per_step_for_u_and_per_unit_step_for_beta():
    """``stepping.error_ratio``: u's estimate against rtol, β's scaled by span/k (so that the
    errors β adds up over the run stay within rtol); φ (algebraic) is left out; the next step
    grows by SAFETY · ratio^(−1/3) for u and ^(−1/2) for β, the most limiting of the two."""
    from ngcontact.time import stepping
    estimate = dict(u=1e-4, beta=1e-6, phi=5.0)
    err, growth = stepping.error_ratio(estimate, rtol=1e-3, k=0.01, span=1.0)
    assert err == pytest.approx(0.1) and growth == pytest.approx(0.9 * 0.1 ** (-1 / 3))
    err, growth = stepping.error_ratio(estimate, rtol=1e-3, k=0.005, span=1.0)     # β per unit step: doubles
    assert err == pytest.approx(0.2) and growth == pytest.approx(0.9 * 0.1 ** (-1 / 3))     # u limits the growth
    err, growth = stepping.error_ratio(dict(u=1e-5, beta=2.5e-6), rtol=1e-3, k=0.005, span=1.0)
    assert err == pytest.approx(0.5) and growth == pytest.approx(0.9 * 0.5 ** (-1 / 2))     # β does
    err, growth = stepping.error_ratio(dict(u=1e-6, beta=1e-3), rtol=1e-4, k=0.01, span=0.1)
    assert err == pytest.approx(100.0) and growth == stepping.MIN_SHRINK
    assert stepping.error_ratio(dict(phi=1.0), 1e-3, 0.01, 1.0) == (0.0, stepping.MAX_GROWTH)


def _glued_column(rtol=None, steps=None):
    """The soft column glued and lifted off over 0.05 s (β falls to 0.90; docs/time.md)."""
    from ngcontact.scenes import column
    contact = ngc.Contact(**dict(reference.CONTACT, conductance=0.0))
    sim = column.simulation(lambda t: 3e8 * ngs.sin(np.pi * t / 0.2) ** 2, contact, scheme="bdf2", keep_states=False)
    sim.run(0.05 / (steps or 16), 0.05, rtol=rtol)
    return sim


@pytest.mark.long
def test_the_glue_s_final_error_falls_with_rtol():
    """β is not damped: per step, its local errors add up over the run (the final error fell
    only as rtol^(2/3) or less); per unit step, the final error falls in proportion to rtol.
    Against BDF2 with 1024 fixed steps (itself ~1e-6 from a 4096-step run): observed β errors
    1.3e-4 and 1.5e-5 at rtol 1e-4 and 1e-5 (8.4×)."""
    ref = _glued_column(steps=1024)
    errors = [np.abs(_glued_column(rtol).beta.values - ref.beta.values).max() for rtol in (1e-4, 1e-5)]
    assert errors[0] < 3e-4 and errors[1] < 3e-5, errors
    assert 6 < errors[0] / errors[1] < 14, errors


def test_an_estimate_that_the_step_does_not_reduce_is_accepted_and_flagged(monkeypatch):
    """A floor of the estimate (here: a stand-in estimate of 3 × rtol whatever the step; on the
    reference plate, Nitsche's γ following c holds u's at ~1e-6) would shrink the steps to dt_min
    and stop the run; instead, a try 4× shorter than the first rejected one whose estimate fell less
    than 2× is accepted, its record keeps the estimate (> 1), and the run says so once."""
    sim = reference.simulation(1, COARSE, scheme="bdf2")
    monkeypatch.setattr(sim.scheme, "local_error", lambda dt, before, before_beta: dict(u=3e-3, phi=0.0))
    with pytest.warns(ngc.AccuracyWarning, match=r"stayed at 3 × rtol on tries from .* it measures what the step "
                                                  r"does not reduce"):
        sim.run(DT, 3 * DT, rtol=1e-3)
    h = sim.history
    assert h[-1].time == pytest.approx(3 * DT, rel=1e-12)
    floored = [r for r in h[1:] if r.error_estimate is not None and r.error_estimate > 1]
    assert floored and all(r.error_estimate == pytest.approx(3.0) for r in floored)
    assert all(r.rejected <= 4 for r in h[1:])                       # 0.9 · 3^(−1/3) = 0.62 a rejection
    assert sum("stayed at" in f for f in sim.flags) == 1


def test_steps_at_a_floor_of_the_estimate_take_the_step_that_met_it_again(monkeypatch):
    """The same stand-in floor over 0.03 s, across the first contact (events located by halving):
    after a step shortened to locate an event, the next steps at the floor take again the step
    that met the floor (6.1e-4 s), instead of keeping the 2 µs of the located event: 51 steps
    (8 735 when a floored step kept its own length)."""
    sim = reference.simulation(1, COARSE, scheme="bdf2", keep_states=False)
    monkeypatch.setattr(sim.scheme, "local_error", lambda dt, before, before_beta: dict(u=3e-3, phi=0.0))
    with pytest.warns(ngc.AccuracyWarning, match="stayed at 3 × rtol"):
        sim.run(DT, 0.03, rtol=1e-3)
    h = sim.history
    assert h[-1].time == pytest.approx(0.03, rel=1e-12) and len(h) - 1 <= 60
    floored = [r for r in h[1:] if r.error_estimate is not None and r.error_estimate > 1]
    met = floored[0].dt
    assert DT / 8 < met < DT and max(r.dt for r in h[h.index(floored[0]):] if r.time < 0.03 - met) \
        == pytest.approx(met, rel=1e-9)
    assert min(r.dt for r in h[1:]) < met / 100                          # an event was located in between


def test_equal_nominal_steps_are_one_step_size():
    """``run(0.005, 0.1)``: step n reaches n·dt and its rate coefficient is 1/dt (the nominal
    step, not t_n − t_{n−1}, whose round-off made 1/k differ in the last bits), so the system
    changes its bulk matrix once (the start's c = 1/s, then 200/s: generation 2; from the
    differences of target times, 14) and the kept factorisation is made 2 times instead of 13;
    the times are the targets n·dt."""
    from ngcontact.scenes import reference
    sim = reference.simulation(1, 0.01, keep_states=False)
    sim.run(0.005, 0.1)
    assert sim.matrix_changes == 2 and sim.scheme.coefficients.rate.Get() == 200.0
    assert sum(r.factorizations for r in sim.history[1:]) <= 3
    assert [r.time for r in sim.history] == [n * 0.005 for n in range(20)] + [0.1]
