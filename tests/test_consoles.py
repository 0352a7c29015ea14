"""Consoles and small surprises: run says when it changes dt, one normal convention for the
obstacles, contact area with a relative threshold, defaults in every --help line, the demo's
console, archives without the solver's restart data, ``adapt --tol --out`` writing its table."""
import warnings

import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.geometries import plate


def column(**options):
    """A short column without contact under a step load (a few DOFs: a run takes milliseconds)."""
    body = ngc.Body(plate(L1=0.01, L2=0.03, maxh=0.01), ngc.pzt5a(relaxation_time=0.1), clamped="bottom",
                    grounded="bottom|top", order=1)
    return ngc.Simulation(body, ngc.Loads(f2={"top": (0, -2e6)}), **options)


def test_run_warns_when_it_shortens_dt():
    """dt = 0.3 s to T = 1 s: 4 equal steps of 0.25 s, and a TimeStepWarning naming both values;
    a dt that divides T − t steps by it without a word."""
    sim = column()
    with pytest.warns(ngc.TimeStepWarning, match=r"dt = 0\.3 s asked, dt = 0\.25 s used: 4 equal steps"):
        history = sim.run(dt=0.3, T=1)
    assert [r.time for r in history] == pytest.approx([0, 0.25, 0.5, 0.75, 1.0], abs=1e-15)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ngc.TimeStepWarning)
        history = sim.run(dt=0.1, T=1.5)
    assert len(history) == 10 and history[-1].time == pytest.approx(1.5)
