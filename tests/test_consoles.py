"""Consoles and small surprises: run says when it changes dt, one normal convention for the
obstacles, contact area with a relative threshold, defaults in every --help line, the demo's
console, archives without the solver's restart data, ``adapt --tol --out`` writing its table."""
import warnings

import numpy as np
import pytest

import ngcontact as ngc
from support import small_hertz
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


def test_plane_and_signed_distance_take_one_direction():
    """Plane(point, outward) and SignedDistance(distance, outward=...) take the normal pointing
    out of the obstacle towards the body: the plane y = 0 under the plate as both gives the same
    gap and n_o = (0, −1). The old ``normal`` keyword still works with a DeprecationWarning
    (SignedDistance's: pointing into the obstacle); errors name the argument passed."""
    import ngsolve as ngs
    from ngcontact import obstacles
    mesh = plate(L1=1, L2=1, maxh=1)
    point = mesh(0.3, 0.7)
    plane = obstacles.Plane((0.0, 0.0), (0.0, 2.0)).fields(2)
    signed = obstacles.SignedDistance(ngs.y, outward=(0.0, 1.0)).fields(2)
    with pytest.warns(DeprecationWarning, match=r"SignedDistance: normal is deprecated .* pass outward=-normal"):
        old = obstacles.SignedDistance(ngs.y, (0.0, -1.0)).fields(2)
    with pytest.warns(DeprecationWarning, match=r"Plane: normal is deprecated .* pass outward="):
        old_plane = obstacles.Plane((0.0, 0.0), normal=(0.0, 1.0)).fields(2)
    for gap, n_o in (plane, signed, old, old_plane):
        assert gap(point) == pytest.approx(0.7) and n_o(point) == pytest.approx((0.0, -1.0))
    with pytest.raises(ValueError, match=r"Plane: outward \(the normal pointing out of the obstacle towards the "
                                         r"body\) must be a nonzero finite vector, got \[0.0, 0.0\]"):
        obstacles.Plane((0, 0), outward=(0, 0))
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match=r"Plane: normal \(the normal"):
        obstacles.Plane((0, 0), normal=(0, 0))
    with pytest.raises(TypeError, match=r"SignedDistance: give outward, .* \(got both outward and normal\)"):
        obstacles.SignedDistance(ngs.y, (0, -1), outward=(0, 1))
    with pytest.raises(ValueError, match=r"SignedDistance: outward must have 2 components in 2D, got 3"):
        obstacles.SignedDistance(ngs.y, outward=(0.0, 0.0, 1.0)).fields(2)


@pytest.mark.parametrize("make, words", [
    (lambda o, ngs: o.SignedDistance(ngs.y, outward=(0.0, -1.0)),
     r"SignedDistance's outward must point out of the obstacle towards the body \(outward·ν < 0 .* outward·ν "
     r"ranges over \[1, 1\] on Γ3: is outward reversed\?"),
    (lambda o, ngs: o.SignedDistance(ngs.y, outward=(0.0, 2.0)),
     r"SignedDistance's outward must be a unit vector field on Γ3; \|outward\| ranges over \[2, 2\]"),
    (lambda o, ngs: o.SignedDistance(ngs.y, (0.0, 1.0)),
     r"SignedDistance's normal must point from the body into the obstacle \(normal·ν > 0 .* is normal reversed")])
def test_a_reversed_obstacle_direction_is_named_as_passed(make, words):
    """The check of the direction at t = 0 names ``outward`` or ``normal`` as the user passed it."""
    import ngsolve as ngs
    from ngcontact import obstacles
    body = ngc.Body(plate(L1=0.01, L2=0.003, maxh=0.003), ngc.pzt5a(), clamped="left", grounded="top",
                    contact_side="bottom")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        obstacle = make(obstacles, ngs)
    with pytest.raises(ValueError, match=words):
        ngc.Simulation(body, ngc.Loads(), time=ngs.Parameter(0.0), contact=ngc.Contact(obstacle=obstacle))


def punch(point_y):
    """A PZT-5A cylinder (radius 5 mm, 3 mm high, on its meridian section) on the plane
    y = ``point_y``, pressed by 1 MPa × t on its top."""
    import netgen.occ as occ
    import ngsolve as ngs
    from ngcontact.obstacles import Plane
    face = occ.Rectangle(0.005, 0.003).Face()
    face.edges.Min(occ.X).name, face.edges.Max(occ.X).name = "axis", "right"
    face.edges.Min(occ.Y).name, face.edges.Max(occ.Y).name = "bottom", "top"
    body = ngc.Body(ngs.Mesh(occ.OCCGeometry(face, dim=2).GenerateMesh(maxh=0.001)), ngc.pzt5a(),
                    supports={"axis": "normal"}, grounded="top", contact_side="bottom", axisymmetric=True)
    t = ngs.Parameter(0.0)
    return ngc.Simulation(body, ngc.Loads(f2={"top": (0, -1e6 * t)}), time=t,
                          contact=ngc.Contact(obstacle=Plane((0.0, point_y), (0.0, 1.0))))


def test_a_round_off_pressure_is_no_contact():
    """The plane at y = 0.1 + 0.2 − 0.3 = 5.6e-17 m: unloaded, the punch's pressure is 0.15 Pa
    of round-off (1e-12 of PZT's stiffness), and its contact area and set are 0; loaded, the
    whole base π r² is in contact at t = 0.5 and 1, as on the plane y = 0."""
    sim = punch(0.1 + 0.2 - 0.3)
    sim.run(0.5, 1.0)
    first = sim.history[0].contact
    assert 0 < first.pressure.max() < 1.0 and first.contact_area == 0 and not first.contact_set.any()
    for record in sim.history[1:]:
        assert record.contact.contact_area == pytest.approx(np.pi * 0.005 ** 2, rel=1e-12)
        assert record.contact.contact_set == pytest.approx(1.0, rel=1e-12)


def _states_default(text, default):
    """Whether an option's help ``text`` names its ``default`` (each item of a list; numbers by
    value: "10" states 10.0, "1e6" states 1000000.0)."""
    import re
    numbers = {float(n) for n in re.findall(r"(?<![\w.])-?\d+(?:\.\d*)?(?:e[+-]?\d+)?", text.replace("^", "**"))}
    items = default if isinstance(default, (list, tuple)) else [default]
    return "default" in text and all(
        float(item) in numbers if isinstance(item, (int, float)) else str(item) in text for item in items)


def test_every_help_line_shows_its_default():
    """``python -m ngcontact <command> --help``: every option has a meaning, and every option
    with a default (not a flag, not None) names that default in its help as printed."""
    import argparse
    import re
    import textwrap
    from ngcontact import cli
    main = cli.parser()
    (commands,) = [a for a in main._actions if isinstance(a, argparse._SubParsersAction)]
    assert set(commands.choices) >= {"demo", "convergence", "stability", "hertz", "bench", "cluster", "timesteps",
                                     "timeorder", "adapt", "axisymmetric"}
    missing = []
    for name, sub in commands.choices.items():
        printed = sub.format_help()
        options = printed[printed.index("options:"):]
        for action in sub._actions:
            if not action.option_strings or action.help == argparse.SUPPRESS or action.dest == "help":
                continue
            flag = action.option_strings[-1]
            block = re.search(rf"^  {re.escape(', '.join(action.option_strings))}\b.*?(?=^  -|\Z)", options,
                              re.M | re.S)
            assert block, (name, flag)
            text = " ".join(block.group(0).split())
            if not action.help:
                missing.append(f"{name} {flag}: no meaning")
            elif action.default not in (None, False) and not _states_default(text, action.default):
                missing.append(f"{name} {flag}: default {action.default!r} not shown in {textwrap.shorten(text, 200)}")
    assert not missing, "\n".join(missing)


def test_the_demo_prints_twenty_lines_and_a_bar(tmp_path, capsys):
    """40 steps: a line each 0.025 s (20 lines, every 2nd step), the last at t = 0.5 s; after
    lift-off (contact 0) the charge flux, ±1e-23 C/m of round-off, prints as 0, in contact as
    a number; the progress bar counts the 40 steps on stderr."""
    from ngcontact import demo
    summary = demo.run(out=tmp_path, maxh=0.02, steps=40, progress=True)
    printed = capsys.readouterr()
    lines = [line.split() for line in printed.out.splitlines() if line[:5].strip().isdigit()]
    assert [int(line[0]) for line in lines] == list(range(2, 41, 2))
    opened = [line for line in lines if float(line[3]) == 0]
    assert opened and all(line[-1] == "0" for line in opened)
    assert all(abs(float(line[-1])) > 1e-7 for line in lines if float(line[3]) > 0)
    assert 0 < max(abs(q) for q, a in zip(summary["charge_flux"], summary["contact_length"]) if a == 0) < 1e-18
    assert "charge flux [C/m]" in printed.out and "40/40" in printed.err


def test_archives_without_the_solver_restart_data(tmp_path):
    """``run(out=, restart_data=False)``: the step archives lose the kept factorisation (half the
    size on this coarse plate), keep the records and the scheme's state; resumed after its later
    archives are deleted, the run factorises anew and ends where the uninterrupted one does, to Newton's
    tolerance; ``restart_data=False`` without ``out`` is refused by name."""
    import shutil
    from ngcontact.output.results import read
    from ngcontact.scenes import reference
    sizes = {}
    for kept in (True, False):
        sim = reference.simulation(1, 0.02)
        sim.run(2.5e-3, 0.02, out=tmp_path / str(kept), restart_data=kept)
        archives = sorted((tmp_path / str(kept) / "steps").glob("*.npz"))
        sizes[kept] = archives[-1].stat().st_size
        with np.load(archives[-1]) as last:
            assert ("restart/kept_values" in last) is kept and "restart/state" in last and "contact/beta" in last
            factorization = last["restart/kept_values"].nbytes if kept else 0
        whole = sim.gfu.vec.FV().NumPy().copy()
        if kept:
            dropped = factorization
    assert sizes[True] - sizes[False] >= dropped and sizes[False] < 0.6 * sizes[True], sizes
    shutil.copytree(tmp_path / "False", tmp_path / "cut")
    for path in sorted((tmp_path / "cut" / "steps").glob("*.npz"))[5:]:
        path.unlink()
    resumed = reference.simulation(1, 0.02).resume(tmp_path / "cut")
    resumed.run(2.5e-3, 0.02, out=tmp_path / "cut", restart_data=False)
    final = resumed.gfu.vec.FV().NumPy()
    assert np.abs(final - whole).max() <= 1e-7 * np.abs(whole).max()
    assert len(read(tmp_path / "cut")[1]) == len(read(tmp_path / "False")[1]) == 9
    with pytest.raises(ValueError, match=r"restart_data=False is for the step archives of out=DIR"):
        reference.simulation(1, 0.02).run(2.5e-3, 0.01, restart_data=False)
    with pytest.raises(TypeError, match=r"restart_data must be True or False, got 'no'"):
        reference.simulation(1, 0.02).run(2.5e-3, 0.01, out=tmp_path / "x", restart_data="no")


def test_adapt_to_tolerance_writes_its_table_and_levels(tmp_path, monkeypatch):
    """``python -m ngcontact adapt --tol 0.5 --out DIR`` on the coarse Hertz disk: DIR holds
    tolerance.csv and tolerance.json with the levels printed (the last one certified within
    0.5) and each level's mesh, which Netgen reads back."""
    import csv
    import json
    import ngsolve as ngs
    from ngcontact import cli
    from ngcontact.studies import adaptivity
    monkeypatch.setitem(adaptivity.SCENES, "hertz", small_hertz)
    cli.main(["adapt", "--tol", "0.5", "--scene", "hertz", "--orders", "1", "--out", str(tmp_path)])
    (run,) = json.loads((tmp_path / "tolerance.json").read_text())
    assert (run["scene"], run["order"], run["tol"], run["reached"]) == ("hertz", 1, 0.5, True)
    assert 0 < run["relative"] <= 0.5 and run["levels"][-1]["ndof"] == run["ndof"]
    with open(tmp_path / "tolerance.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["level"]) for r in rows] == list(range(len(run["levels"])))
    assert [int(r["ndof"]) for r in rows] == [level["ndof"] for level in run["levels"]]
    assert float(rows[-1]["relative"]) == pytest.approx(run["relative"], rel=1e-11)
    for k, level in enumerate(run["levels"]):
        mesh = ngs.Mesh(str(tmp_path / f"hertz_P1_level{k}.vol"))
        assert mesh.ne > 0
