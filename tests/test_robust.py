"""Robust time stepping: a failed step is retried with halved steps, and what cannot be
recovered is reported with the attempts, keeping every step computed."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.scenes import reference as scene


def reference(maxh=0.01, **options):
    sim = scene.simulation(1, maxh, **options)
    return sim, sim.time


def test_cutback_recovers_the_load_reversal():
    """k = 20 ms with full Newton steps: Newton cycles at the load reversal (t = 0.2 s)
    without cut-back; with it the run reaches T, the failed steps are halved, and every
    record is in equilibrium. With the step-length limit (the default) no cut-back is needed,
    and its records are in equilibrium too."""
    sim, _ = reference(limit_steps=False)
    with pytest.raises(ngc.NewtonError, match="did not converge"):
        sim.run(dt=0.02, T=0.3, max_cutbacks=0)
    limited, _ = reference()
    limited.run(dt=0.02, T=0.3, max_cutbacks=0)
    sim, t = reference(limit_steps=False)
    h = sim.run(dt=0.02, T=0.3)
    assert h.times[-1] == pytest.approx(0.3, abs=1e-12) and len(sim.cutbacks) >= 1
    assert len(h) - 1 > 15                                     # more records than nominal steps
    dts = np.diff(h.times)
    assert dts.min() < 0.02 - 1e-12 and np.all(dts > 0)
    assert np.isclose(dts, 0.02).sum() >= 10                   # recovery: back to k after the cut-back
    for rec in list(h[1:]) + list(limited.history[1:]):
        t.Set(rec.time)
        applied = scene.pressure(t)(sim.body.mesh(0.05, 0.02)) * scene.L1
        assert rec.reaction[1] + rec.contact.force[1] == pytest.approx(applied, abs=1e-6 * scene.PRESSURE * scene.L1)


def test_unrecoverable_step_reports_the_attempts_and_keeps_the_steps():
    """A load that turns non-finite after t = 0.25 s cannot be stepped over: the error names
    the step and the time steps tried; every step up to 0.25 s is kept."""
    t = ngs.Parameter(0)
    body = ngc.Body(scene.body().mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    bad = ngs.IfPos(t - 0.25, 1e300 * 1e300, 1e6)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -bad)}), time=t)
    with pytest.raises(ngc.NewtonError, match=r"Time steps tried for step \d+ .*dt = 0.05, 0.025") as err:
        sim.run(dt=0.1, T=1, max_cutbacks=2)
    times = err.value.history.times
    assert times[-1] == pytest.approx(0.25) and len(err.value.history) == len(sim.history)
    assert np.allclose(sim.u.vec.FV().NumPy(), sim.history[-1].state[:body.V.ndof])


def test_cutback_argument_checked():
    sim, _ = reference()
    with pytest.raises(ValueError, match="max_cutbacks must be an integer >= 0"):
        sim.run(dt=0.1, T=0.2, max_cutbacks=-1)
