"""Streamed results and resume: a run killed at any moment (SIGKILL or SIGINT) continues from
its files to the states of an uninterrupted run; the files are what ``results`` documents."""
import json
import os
import pathlib
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

from ngcontact import results
from ngcontact.scenes import reference

DT, T = 2.5e-3, 0.1          # 40 steps of the reference scene: first contact and spreading
EXACT = dict(reuse_factorization=False)
"""A factorisation at every Newton iteration in the runs compared bitwise below: the kept
factorisation refactorises when measured wall times say it pays, so two runs of the same
steps may differ at Newton's tolerance (1.2e-8 m of 3.5e3 seen in CI), which is not what
these tests check."""


def interrupted(out, signum, after):
    """Start the run streaming into ``out`` in another process, send it ``signum`` once
    ``after`` steps are on disk, wait for it to end."""
    code = (f"from ngcontact.scenes import reference; "
            f"reference.simulation(1, reuse_factorization=False).run({DT}, {T}, out={str(out)!r})")
    process = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.DEVNULL)
    steps = pathlib.Path(out) / "steps"
    deadline = time.monotonic() + 300
    while process.poll() is None and time.monotonic() < deadline:
        if steps.exists() and len(list(steps.glob("*.npz"))) >= after:
            process.send_signal(signum)
            break
        time.sleep(0.005)
    process.wait(timeout=300)
    return len(list(steps.glob("*.npz")))


@pytest.fixture(scope="module")
def uninterrupted():
    sim = reference.simulation(1, **EXACT)
    sim.run(DT, T)
    return sim.history


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGINT])
def test_a_killed_run_resumes_to_the_uninterrupted_states(tmp_path, signum, uninterrupted):
    on_disk = interrupted(tmp_path, signum, after=12)
    assert 12 <= on_disk < len(uninterrupted)                # stopped part-way
    sim = reference.simulation(1, **EXACT).resume(tmp_path)
    assert len(sim.history) == on_disk and sim.t == pytest.approx(uninterrupted[on_disk - 1].time, abs=1e-15)
    sim.run(DT, T, out=tmp_path)
    assert [r.time for r in sim.history] == pytest.approx([r.time for r in uninterrupted], abs=1e-15)
    scale = np.abs(uninterrupted[-1].state).max()
    for a, b in zip(sim.history, uninterrupted):
        assert np.abs(a.state - b.state).max() <= 1e-12 * scale
        assert np.abs(a.contact.beta - b.contact.beta).max() <= 1e-12
    # the files hold every step once, with the records the simulation kept
    info, history = results.read(tmp_path)
    assert (info["dt"], info["T"], len(history)) == (DT, T, len(uninterrupted))
    for a, b in zip(history, sim.history):
        assert a.step == b.step and a.time == b.time and a.newton_iterations == b.newton_iterations
        assert np.array_equal(a.contact.pressure, b.contact.pressure)
        assert a.electrode_charge == b.electrode_charge
        assert np.array_equal(a.boundary_reaction["left"], b.boundary_reaction["left"])


def test_the_paraview_series_lists_every_step(tmp_path):
    sim = reference.simulation(1)
    sim.run(DT, 5 * DT, out=tmp_path)
    for name, ext in (("fields", "vtu"), ("gamma3", "vtp")):
        entries = ElementTree.parse(tmp_path / f"{name}.pvd").getroot().findall("Collection/DataSet")
        assert [float(e.get("timestep")) for e in entries] == pytest.approx([r.time for r in sim.history])
        assert all((tmp_path / e.get("file")).exists() for e in entries)
    piece = ElementTree.parse(tmp_path / "vtk" / "gamma3_000005.vtp").getroot().find("PolyData/Piece")
    beta = piece.find("CellData/DataArray[@Name='beta']").text.split()
    assert int(piece.get("NumberOfLines")) == len(beta) == len(sim.side.measure)
    assert np.allclose(np.array(beta, dtype=float), sim.history[-1].contact.beta)
    assert json.loads((tmp_path / "run.json").read_text())["model"].startswith("u and φ")


def test_bad_directories_are_named(tmp_path):
    sim = reference.simulation(1)
    sim.run(DT, 2 * DT, out=tmp_path)
    with pytest.raises(ValueError, match="holds another run"):
        reference.simulation(1).run(2 * DT, 4 * DT, out=tmp_path)
    with pytest.raises(ValueError, match="not the same scene"):
        reference.simulation(2).resume(tmp_path)
    with pytest.raises(ValueError, match="holds no streamed run"):
        reference.simulation(1).resume(tmp_path / "nothing")


def test_the_demo_resumes(tmp_path):
    """``python -m ngcontact demo --resume`` after a SIGKILL gives the summary of a run that
    was never interrupted."""
    command = [sys.executable, "-m", "ngcontact", "demo", "--steps", "20", "--maxh", "0.01"]
    process = subprocess.Popen(command + ["--out", str(tmp_path / "a")], stdout=subprocess.DEVNULL)
    steps = tmp_path / "a" / "run" / "steps"
    while process.poll() is None:
        if steps.exists() and len(list(steps.glob("*.npz"))) >= 8:
            os.kill(process.pid, signal.SIGKILL)
            break
        time.sleep(0.005)
    process.wait()
    assert not (tmp_path / "a" / "summary.json").exists()
    subprocess.run(command + ["--out", str(tmp_path / "a"), "--resume"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(command + ["--out", str(tmp_path / "b")], check=True, stdout=subprocess.DEVNULL)
    a, b = (json.loads((tmp_path / d / "summary.json").read_text()) for d in "ab")
    for key in ("times", "contact_length", "tip_deflection", "charge_flux", "beta_min"):
        assert np.allclose(a[key], b[key], rtol=1e-9, atol=1e-15), key


def test_studies_skip_the_cases_on_disk(tmp_path):
    """``hertz --resume`` and ``bench --resume`` keep the cases already measured (a marked
    value in the file survives) and compute only the missing ones."""
    from ngcontact.studies import bench, hertz
    hertz.run(tmp_path / "h", orders=(1,), levels=1, progress=False)
    cases = json.loads((tmp_path / "h" / "cases.json").read_text())
    cases["2D P1 obstacle L0"]["row"]["newton"] = -7                 # a mark: not recomputed
    (tmp_path / "h" / "cases.json").write_text(json.dumps(cases))
    rows = hertz.run(tmp_path / "h", orders=(1,), levels=2, progress=False, resume=True)
    assert [r["newton"] for r in rows if r["level"] == 0 and r["normal"] == "obstacle"] == [-7]
    assert len(json.loads((tmp_path / "h" / "cases.json").read_text())) == 4
    bench.run(tmp_path / "b", orders=(1,), max_ndof=600, steps=2, progress=False)
    data = json.loads((tmp_path / "b" / "bench.json").read_text())
    data["rows"][0]["step_s"] = 123.0
    (tmp_path / "b" / "bench.json").write_text(json.dumps(data))
    rows, _ = bench.run(tmp_path / "b", orders=(1,), max_ndof=600, steps=2, progress=False, resume=True)
    assert [r["step_s"] for r in rows] == [123.0]
    with pytest.raises(ValueError, match="holds a bench with dim 2, steps 2"):
        bench.run(tmp_path / "b", orders=(1,), max_ndof=600, steps=3, progress=False, resume=True)


def test_the_reference_convergence_study_resumes(tmp_path):
    """The fine run of the reference-scene study streams into the study's directory and a
    resumed study reuses it and the finished cases (same errors, no new fine steps)."""
    from ngcontact.studies import convergence
    from ngcontact.studies.common import CaseStore
    settings = dict(orders=(1,), levels=1, steps=4, T=0.01, maxh=0.02, reference_level=1, progress=False)
    first = convergence.reference_study(**settings, store=CaseStore(tmp_path))
    fine = next((tmp_path / "cases").glob("fine*"))
    written = {p: p.stat().st_mtime_ns for p in (fine / "steps").glob("*.npz")}
    again = convergence.reference_study(**settings, store=CaseStore(tmp_path, resume=True))
    assert again[0].error_max == first[0].error_max and len(written) == 5
    assert {p: p.stat().st_mtime_ns for p in (fine / "steps").glob("*.npz")} == written
