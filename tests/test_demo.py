"""The ``demo`` command: a small run of the reference scene, checked on its numbers and charts."""
import json

import numpy as np
import pytest
from matplotlib.image import imread

from ngcontact.cli import main
from ngcontact.scenes.reference import CONTACT, L1


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """Run ``demo`` on a coarse P1 mesh (k γ_ν L² = 0.625 < 1); return (summary, directory)."""
    out = tmp_path_factory.mktemp("demo")
    main(["demo", "--out", str(out), "--maxh", "0.01", "--steps", "200"])
    return json.loads((out / "summary.json").read_text()), out


def test_force_balance_every_step(demo):
    """Support reaction + foundation force balance the pressure on top: R_y + F_y = p L1."""
    s, _ = demo
    applied = np.array(s["load"]) * L1
    balance = np.array(s["reaction_y"]) + np.array(s["contact_force_y"]) - applied
    assert np.abs(balance).max() < 1e-6 * s["pressure"] * L1


def test_contact_zone_grows_then_opens(demo):
    """Under the push the zone grows from the free end and the tip rests on the foundation
    (u_y = -g); after the pull it is open and the debonded plate has lifted off."""
    s, _ = demo
    length, load = np.array(s["contact_length"]), np.array(s["load"])
    push = np.flatnonzero(np.array(s["times"]) <= 0.1)
    assert np.all(np.diff(length[push]) >= -1e-12)
    assert length.max() > 0.2 * L1 and length[-1] == 0
    at_peak = int(np.argmax(length))
    assert s["tip_deflection"][at_peak] == pytest.approx(-CONTACT["gap"], rel=1e-3)
    assert s["tip_deflection"][-1] > 2 * CONTACT["gap"]
    assert s["max_penetration"] < 3e-2 * CONTACT["gap"]     # observed 1.3 % on this coarse mesh
    assert np.all(np.array(s["max_pressure"])[length == 0] == 0)
    assert load[-1] < 0


def test_glue_debonds_from_the_free_end(demo):
    s, _ = demo
    assert s["beta_min"] < 0.01 and s["beta_max"] > 0.95


def test_charge_flows_only_near_contact(demo):
    """The foundation (φ_Γ = 10 V) conducts while touching: a charge flux through Γ3 at the
    largest zone, none once the plate has lifted off."""
    s, _ = demo
    flux = np.array(s["charge_flux"])
    assert abs(flux[int(np.argmax(s["contact_length"]))]) > 0
    assert abs(flux[-1]) < 1e-12 * np.abs(flux).max()


def test_newton_converges_in_few_iterations(demo):
    s, _ = demo
    its = np.array(s["newton_iterations"])
    assert its.max() <= 12 and its.mean() < 3       # observed: 10 at first contact, mean 2.2


@pytest.mark.parametrize("name", ["history.png", "beta.png", "pressure.png", "potential_at_peak.png"])
def test_charts_are_nontrivial_pngs(demo, name):
    _, out = demo
    path = out / name
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
    image = imread(path)
    assert image.shape[0] >= 300 and image.shape[1] >= 400
    colours = np.unique(np.round(image[..., :3] * 255).astype(int).reshape(-1, 3), axis=0)
    assert len(colours) > 50


class _Record:
    def __init__(self, time, event=None):
        self.time, self.event, self.reaction = time, event, (0.0, 0.0)


class _History(list):
    """What ``demo._plot_overview`` reads of a History: records and β along Γ3."""
    def contact_column(self, name):
        return np.linspace(1.0, 0.0, len(self))[:, None] * np.ones((1, 4))


def _overview(columns, tmp_path, monkeypatch):
    """The figure ``demo._plot_overview`` draws from ``columns``: its axes."""
    from matplotlib.figure import Figure

    import ngcontact.demo
    made = []

    class Kept(Figure):
        def savefig(self, *args, **kwargs):
            made.append(self)
            return super().savefig(*args, **kwargs)
    monkeypatch.setattr(ngcontact.demo, "Figure", Kept)
    history = _History([_Record(0.0)] + [_Record(t) for t in columns["times"]])
    ngcontact.demo._plot_overview(tmp_path / "history.png", columns, history)
    (figure,) = made
    return figure.axes


def test_the_step_panel_only_where_the_steps_vary(demo, tmp_path, monkeypatch):
    """A fixed-step run's k varies by round-off only (t_n − t_{n−1}): no panel of k (its sharp
    dips all read 2.5 × 10⁻³), k named in the title; one quantity per panel, each with its unit.
    Steps cut back: a panel of k whose tick labels differ."""
    from ngcontact.demo import steps_vary
    summary, _ = demo
    columns = {key: summary[key] for key in ("times", "dt", "load", "contact_length", "tip_deflection")}
    assert not steps_vary(columns["dt"])
    axes = _overview(columns, tmp_path, monkeypatch)
    assert len(axes) == 4 and "fixed time step k = 2.5 ms, 200 steps" in axes[0].get_title()
    labels = [ax.get_ylabel() for ax in axes]
    assert all("[" in label for label in labels) and not any("time step" in label for label in labels)
    assert all(len(ax.get_lines()) == 1 for ax in axes[:2])          # one quantity (one line) per panel
    dt = np.array(columns["dt"])
    dt[[20, 21, 60, 61, 62, 63]] /= [2, 2, 4, 4, 4, 4]                # cut-backs
    assert steps_vary(dt)
    axes = _overview(dict(columns, dt=list(dt)), tmp_path, monkeypatch)
    assert len(axes) == 5 and axes[4].get_ylabel() == "time step k [ms]"
    low, high = axes[4].get_ylim()
    shown = [t.get_text() for t in axes[4].get_yticklabels() if low <= t.get_position()[1] <= high]
    assert len(shown) >= 2 and len(set(shown)) == len(shown), shown
