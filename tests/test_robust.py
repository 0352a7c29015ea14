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
    """k = 20 ms with full Newton steps only (no step-length limit, no globalisation): Newton
    cycles at the load reversal (t = 0.2 s) without cut-back; with it the run reaches T, the
    failed steps are halved, and every record is in equilibrium. With the defaults (the
    step-length limit and the globalisation), or with the globalisation alone (the line search
    engages on the cycle), no cut-back is needed, and their records are in equilibrium too.
    (Plain Newton corrections: the Signorini switch's inner loop, ``switch_loop``, solves
    the reversal without a cycle.)
    (The step-length limit alone no longer suffices: where Γ3 touches at a solve's start its
    deeper cut leaves this reversal to the globalisation.)"""
    sim, _ = reference(limit_steps=False, globalise=False, switch_loop=False)
    with pytest.raises(ngc.NewtonError, match="cycles: the iterates repeat"):
        sim.run(dt=0.02, T=0.3, max_cutbacks=0)
    limited, _ = reference()
    limited.run(dt=0.02, T=0.3, max_cutbacks=0)
    searched, _ = reference(limit_steps=False)
    searched.run(dt=0.02, T=0.3, max_cutbacks=0)
    sim, t = reference(limit_steps=False, globalise=False, switch_loop=False)
    h = sim.run(dt=0.02, T=0.3)
    assert h.times[-1] == pytest.approx(0.3, abs=1e-12) and len(sim.cutbacks) >= 1
    assert len(h) - 1 > 15                                     # more records than nominal steps
    dts = np.diff(h.times)
    assert dts.min() < 0.02 - 1e-12 and np.all(dts > 0)
    assert np.isclose(dts, 0.02).sum() >= 10                   # recovery: back to k after the cut-back
    for rec in list(h[1:]) + list(limited.history[1:]) + list(searched.history[1:]):
        t.Set(rec.time)
        applied = scene.pressure(t)(sim.body.mesh(0.05, 0.02)) * scene.L1
        assert rec.reaction[1] + rec.contact.force[1] == pytest.approx(applied, abs=1e-6 * scene.PRESSURE * scene.L1)
    assert len(searched.history) - 1 == 15 and max(r.newton_iterations for r in searched.history) <= 30


def test_unrecoverable_step_reports_the_attempts_and_keeps_the_steps():
    """Newton limited to two iterations cannot pass the first contact (the active set
    changes) at any step size: the error names the step and the time steps tried; every step
    before it is kept, and the state is the last kept step's."""
    sim = scene.simulation(1, maxit=2)
    with pytest.raises(ngc.NewtonError, match=r"Time steps tried for step \d+ \(t -> [0-9.]+ s\): "
                                             r"dt = 0.00125, 0.000625 s") as err:
        sim.run(dt=2.5e-3, T=0.05, max_cutbacks=2)
    assert len(err.value.history) == len(sim.history) >= 3
    assert np.allclose(sim.u.vec.FV().NumPy(), sim.history[-1].state[:sim.body.V.ndof])


def test_cutback_argument_checked():
    sim, _ = reference()
    with pytest.raises(ValueError, match="max_cutbacks must be an integer >= 0"):
        sim.run(dt=0.1, T=0.2, max_cutbacks=-1)
