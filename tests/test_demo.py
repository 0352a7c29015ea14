"""The ``demo`` command: a small run of the reference scene, checked on its numbers and charts."""
import json

import numpy as np
import pytest
from matplotlib.image import imread

from ngcontact.cli import main


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """Run ``demo`` on a coarse P1 mesh, one step per ms; return (summary, output directory)."""
    out = tmp_path_factory.mktemp("demo")
    main(["demo", "--out", str(out), "--order", "1", "--maxh", "0.01", "--steps", "24"])
    return json.loads((out / "summary.json").read_text()), out


def full_load(summary):
    """Indices of the steps at full pressure: the hold, from right after the ramp to its end."""
    return np.flatnonzero(np.isclose(summary["load"], summary["pressure"], rtol=1e-9))


def test_global_force_balance(demo):
    s, _ = demo
    total = s["pressure"] * s["L1"]                      # N/m, downward on "top"
    end_of_hold = full_load(s)[-1]
    assert s["reaction_y"][end_of_hold] == pytest.approx(total, rel=1e-8)
    # quasi-static: the support carries the load at every step, viscous or not
    assert np.allclose(s["reaction_y"], np.array(s["load"]) * s["L1"], rtol=0, atol=1e-8 * total)


def test_linear_without_contact(demo):
    s, _ = demo
    assert s["time_steps"] == len(s["times"]) == len(s["newton_iterations"]) == 24
    assert s["newton_iterations"] == [1] * 24


def test_creep_and_recovery(demo):
    s, _ = demo
    tip = np.array(s["tip_deflection"])
    after_ramp, end_of_hold = full_load(s)[[0, -1]]
    assert end_of_hold - after_ramp == 10                # a 10 ms hold
    assert tip[after_ramp] < 0                           # pushed down
    assert abs(tip[end_of_hold]) > 1.5 * abs(tip[after_ramp])  # creep: τ = 2 ms = the ramp time
    assert abs(tip[-1]) < 0.02 * abs(tip[end_of_hold])   # recovery after 11 ms unloaded
    assert s["max_potential"] > 0


@pytest.mark.parametrize("name", ["tip_deflection.png", "potential_at_peak.png"])
def test_charts(demo, name):
    _, out = demo
    path = out / name
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 10_000
    image = imread(path)
    assert image.shape[0] >= 200 and image.shape[1] >= 400
    assert np.ptp(image[..., :3]) > 0.5                  # not a single flat colour
    assert len(np.unique(image[..., :3].reshape(-1, 3), axis=0)) > 50
