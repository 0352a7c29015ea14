"""Streamed results and resume: a run killed at any moment (SIGKILL or SIGINT) continues from
its files to the states of an uninterrupted run; the files are what ``results`` documents."""
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ElementTree

import meshio
import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact import demo
from ngcontact.output import fingerprint, results
from ngcontact.scenes import reference

DT, T = 2.5e-3, 0.1          # 40 steps of the reference scene: first contact and spreading
EXACT = dict(solver={"ksp_type": "preonly"})
"""A factorisation at every Newton iteration in some runs below: they check the stream and
the resume alone; the kept factorisation resumes bitwise too (``test_an_interrupted_demo_
resumes_bitwise``, ``test_the_demo_resumes``)."""


def same_archives(a, b, last=None):
    """Every stored array of steps 0..``last`` (all) of the run directories ``a`` and ``b``
    (the records: time, dt, states, contact force, Newton's residuals, the linear solver's
    counts, ...; the restart state) bitwise equal, wall times aside; returns how many were
    compared."""
    first, second = (sorted((pathlib.Path(d) / "steps").glob("[0-9]*.npz"))[:None if last is None else last + 1]
                     for d in (a, b))
    assert [p.name for p in first] == [p.name for p in second]
    compared = 0
    for x, y in zip(first, second):
        with np.load(x) as one, np.load(y) as other:
            assert sorted(one.files) == sorted(other.files), x.name
            for key in one.files:
                if key != "wall_s" and not key.startswith("timings/"):
                    assert np.array_equal(one[key], other[key]), (x.name, key)
                    compared += 1
    return compared


def interrupted(out, signum, after):
    """Start the run streaming into ``out`` in another process, send it ``signum`` once
    ``after`` steps are on disk, wait for it to end."""
    code = (f"import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "  # as at a terminal, also when
            f"from ngcontact.scenes import reference; "                                 # started where SIGINT is ignored
            f"reference.simulation(1, solver={{'ksp_type': 'preonly'}}).run({DT}, {T}, out={str(out)!r})")
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


@pytest.mark.parametrize("signum", [pytest.param(signal.SIGKILL, marks=pytest.mark.long), signal.SIGINT])
def test_a_killed_run_resumes_to_the_uninterrupted_states(tmp_path, signum, uninterrupted):
    on_disk = interrupted(tmp_path, signum, after=12)
    assert 12 <= on_disk < len(uninterrupted)                # stopped part-way
    sim = reference.simulation(1, **EXACT).resume(tmp_path)
    assert len(sim.history) == on_disk and sim.t == pytest.approx(uninterrupted[on_disk - 1].time, abs=1e-15)
    sim.run(DT, T, out=tmp_path)
    assert [r.time for r in sim.history] == [r.time for r in uninterrupted]
    for a, b in zip(sim.history, uninterrupted):       # bitwise
        assert np.array_equal(a.state, b.state) and np.array_equal(a.contact.beta, b.contact.beta)
        assert np.array_equal(a.contact.force, b.contact.force) and a.residuals == b.residuals
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
    for name in ("fields", "gamma3"):
        entries = ElementTree.parse(tmp_path / f"{name}.pvd").getroot().findall("Collection/DataSet")
        assert [float(e.get("timestep")) for e in entries] == pytest.approx([r.time for r in sim.history])
        assert all((tmp_path / e.get("file")).exists() for e in entries)
    gamma3 = meshio.read(tmp_path / "vtk" / "gamma3_000005.vtu")        # tests/test_output.py: the rest
    beta = gamma3.cell_data["beta"][0]
    assert len(gamma3.cells_dict["line"]) == len(beta) == len(sim.side.measure)
    assert np.array_equal(beta, sim.history[-1].contact.beta)
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


@pytest.mark.slow      # the CLI killed and resumed (the in-process interruptions below check the same bitwise)
def test_the_demo_resumes(tmp_path):
    """``python -m ngcontact demo --resume`` after a SIGKILL gives the run that was never
    interrupted, bitwise (every stored array of every step, and the summary), with the kept
    factorisation of its GMRES; resumed again once complete, it says so and writes the summary
    from its steps."""
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
    # other settings: refused before meshing, naming the setting, and nothing written
    run = tmp_path / "a" / "run"
    written = {p: p.stat().st_mtime_ns for p in run.rglob("*")}
    changes = dict(order=2, maxh=0.02, steps=40, theta=0, gamma0=100.0, dim=3, refine=1)
    for key, value in changes.items():
        settings = {**dict(order=1, maxh=0.01, steps=20), key: value}
        with pytest.raises(ValueError, match=f"with --{key} .*; this one has --{key} {value}: resume with"):
            demo.run(out=tmp_path / "a", resume=True, **settings)
    again = subprocess.run(command + ["--out", str(tmp_path / "a"), "--resume", "--gamma0", "100"],
                           capture_output=True, text=True)
    assert again.returncode == 2 and again.stdout == ""
    assert again.stderr == (f"ngcontact demo: error: resume: {str(run)!r} holds a demo run with --gamma0 10.0; "
                            "this one has --gamma0 100.0: resume with the settings of the interrupted run, or run "
                            "without --resume\n")
    (run / "demo.json").unlink()                 # the settings lost: the scene's own check refuses
    again = subprocess.run(command + ["--out", str(tmp_path / "a"), "--resume", "--gamma0", "100"],
                           capture_output=True, text=True)
    assert again.returncode == 2 and again.stderr.count("\n") == 1
    assert again.stderr.endswith(f"{str(run)!r} was computed with contact.gamma0 = 10.0; this simulation has "
                                 "contact.gamma0 = 100.0: not the same scene\n")
    assert {p: p.stat().st_mtime_ns for p in run.rglob("*")} == {p: t for p, t in written.items()
                                                                 if p.name != "demo.json"}
    subprocess.run(command + ["--out", str(tmp_path / "a"), "--resume"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(command + ["--out", str(tmp_path / "b")], check=True, stdout=subprocess.DEVNULL)
    assert same_archives(tmp_path / "a" / "run", tmp_path / "b" / "run") > 21 * 20
    a, b = (json.loads((tmp_path / d / "summary.json").read_text()) for d in "ab")
    for key in ("times", "contact_length", "tip_deflection", "charge_flux", "beta_min", "newton_iterations"):
        assert a[key] == b[key], key
    (tmp_path / "a" / "summary.json").unlink()
    again = subprocess.run(command + ["--out", str(tmp_path / "a"), "--resume"], capture_output=True, text=True)
    assert again.returncode == 0 and f"the run in {str(run)!r} is already complete: it reached T = 0.5 s at step " \
        "20; nothing is left to compute" in again.stdout
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["tip_deflection"] == b["tip_deflection"]


@pytest.mark.long
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


@pytest.mark.long
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


# ----------------------------------------------------------------------- the scene is checked

COARSE = 0.01                # mesh size of the runs whose directories are checked below (62 vertices)
ELASTIC = ngc.Material.isotropic(1e9, 0.3, 1e-9)     # no piezoelectric coupling


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """Two steps of the reference scene on a coarse mesh, streamed into a directory; and two
    of an elastic plate on an insulating foundation, which solves for u alone."""
    out = tmp_path_factory.mktemp("stored")
    reference.simulation(1, COARSE).run(DT, 2 * DT, out=out / "piezo")
    elastic = reference.simulation(1, COARSE, material=ELASTIC, contact=reference.contact(bare=True))
    assert not elastic.electric
    elastic.run(DT, 2 * DT, out=out / "elastic")
    return out


def pressure(t):
    """The reference pressure at t (s) on the push ramp, Pa, as the messages print it."""
    return f"{reference.PRESSURE * t / reference.PUSH_END:.6g}"


CHANGES = {                  # a change of the scene: (simulation arguments, what the message says)
    "material": (dict(material=ngc.pzt5a(relaxation_time=1e-3)),
                 "material.eta = (36 values in [0, 2.42e+08]); this simulation has material.eta = "
                 "(36 values in [0, 1.21e+08]) (differing by up to 1.21e+08)"),     # A = τ c, c33 = 1.21e11 Pa
    "gap": (dict(contact=reference.contact(gap=3e-5)), "contact.gap = 2e-05; this simulation has contact.gap = 3e-05"),
    "load": (dict(load_history=((0.0, 0.0), (0.1, 2.0))),
             f"loads.f2['top'] = (110 values in [-{pressure(2 * DT)}, 0]); this simulation has loads.f2['top'] "
             f"= (110 values in [-{pressure(4 * DT)}, 0]) (differing by up to {float(pressure(2 * DT)):.3g})"),
    "gamma0": (dict(contact=reference.contact(gamma0=100.0)),
               "contact.gamma0 = 10.0; this simulation has contact.gamma0 = 100.0"),
    "theta": (dict(contact=reference.contact(theta=0)), "contact.theta = 1; this simulation has contact.theta = 0"),
    # 3 fields (u_x, u_y, φ) of 62 vertices at P1, and of the vertices and 62 + 86 - 1 edges at P2
    "order": (dict(order=2), f"space.ndof = {3 * 62}, body.order = 1, body.order_phi = 1; this simulation has "
                             f"space.ndof = {3 * (62 + 62 + 86 - 1)}, body.order = 2, body.order_phi = 2"),
    "mesh": (dict(maxh=0.008), "mesh.vertices = 62, mesh.elements = 86, "),
}


@pytest.mark.parametrize("change", CHANGES)
def test_resume_refuses_another_scene(stored, change):
    """Each kind of change is named with both values, before anything is written."""
    arguments, expected = CHANGES[change]
    arguments = dict(dict(order=1, maxh=COARSE), **arguments)
    written = {p: p.stat().st_mtime_ns for p in (stored / "piezo").rglob("*")}
    prefix = f"resume: {str(stored / 'piezo')!r} was computed with "
    with pytest.raises(ValueError) as error:
        reference.simulation(arguments.pop("order"), arguments.pop("maxh"), **arguments).resume(stored / "piezo")
    message = str(error.value)
    assert message.startswith(prefix + expected) and message.endswith(": not the same scene")
    if change == "mesh":             # the data sampled on the elements of two meshes are not compared
        assert "loads" not in message and "mesh.hash" in message
    else:
        assert message == f"{prefix}{expected}: not the same scene"
    assert {p: p.stat().st_mtime_ns for p in (stored / "piezo").rglob("*")} == written


def test_resume_and_a_new_run_refuse_another_electric_choice_or_start(stored):
    with pytest.raises(ValueError, match="was computed with options.electric = False; this simulation has "
                                         "options.electric = True: not the same scene$"):
        reference.simulation(1, COARSE, material=ELASTIC, contact=reference.contact(bare=True),
                             electric=True).resume(stored / "elastic")
    # u0 = (0, -1e-7 x/L1): zero on Γ1, largest (1e-7 m) at the free end
    u0 = ngs.CF((0, -1e-7 * ngs.x / reference.L1))
    with pytest.raises(ValueError, match=r"starts from another state at t = 0: u differs from this simulation's by "
                                         r"up to 1e-07 m .*another u0\?\): not the same scene"):
        reference.simulation(1, COARSE, u0=u0).resume(stored / "piezo")
    with pytest.raises(ValueError, match="^out: .* was computed with contact.gamma0 = 10.0; this simulation has "
                                         "contact.gamma0 = 100.0: not the same scene"):
        reference.simulation(1, COARSE, contact=reference.contact(gamma0=100.0)).run(DT, 2 * DT, out=stored / "piezo")
    sim = reference.simulation(1, COARSE)
    sim.step(DT)
    with pytest.raises(ValueError, match="computed 1 step.* already; resume .* into a freshly built simulation"):
        sim.resume(stored / "piezo")


def test_the_same_scene_resumes_however_its_data_are_written(stored):
    """A gap given as a CoefficientFunction is the number it equals; the time Parameter is
    left as it was by the fingerprint, whose samples are the load at the sample times."""
    sim = reference.simulation(1, COARSE, contact=reference.contact(gap=ngs.CF(reference.CONTACT["gap"])))
    assert len(sim.resume(stored / "piezo").history) == 3 and sim.t == pytest.approx(2 * DT, abs=1e-15)
    sim.time.Set(0.0123)
    found = sim.fingerprint(0.5)
    assert sim.time.Get() == 0.0123
    times = np.array(found["sample times"])
    assert times.tolist() == [0.0, 0.125, 0.25, 0.375, 0.5]
    f2 = np.array(found["loads.f2['top']"])              # [time][point][component]
    factor = np.interp(times, *zip(*reference.LOAD_HISTORY))
    assert np.all(f2[..., 0] == 0)
    assert np.allclose(f2[..., 1], -reference.PRESSURE * factor[:, None], rtol=1e-14, atol=0)
    assert fingerprint.differences(found, json.loads(json.dumps(found))) == []


def test_a_missing_step_archive_is_named(tmp_path):
    """A deleted middle archive is named; deleting the later ones, as the message says, resumes
    to the states of a run never interrupted."""
    straight = reference.simulation(1, COARSE, **EXACT)
    straight.run(DT, 3 * DT, out=tmp_path)
    (tmp_path / "steps" / "000002.npz").unlink()
    expected = (rf"^'{re.escape(str(tmp_path))}': steps/000002\.npz is missing \(the step archives are numbered "
                r"000000 to 000003 without gaps\); delete the archives after steps/000001\.npz to resume from step 1$")
    with pytest.raises(ValueError, match=expected):
        results.read(tmp_path)
    with pytest.raises(ValueError, match=expected):
        reference.simulation(1, COARSE, **EXACT).resume(tmp_path)
    (tmp_path / "steps" / "000003.npz").unlink()
    sim = reference.simulation(1, COARSE, **EXACT).resume(tmp_path)
    assert len(sim.history) == 2
    sim.run(DT, 3 * DT, out=tmp_path)
    assert np.abs(sim.history[-1].state - straight.history[-1].state).max() <= \
        1e-12 * np.abs(straight.history[-1].state).max()
    assert [r.step for r in results.read(tmp_path)[1]] == [0, 1, 2, 3]


def test_a_step_that_cannot_be_written_stops_the_run_and_keeps_the_steps(tmp_path):
    """A directory where step 2's archive goes: the run stops with an OSError naming the step
    and the file (not a step silently missing from disk); the 3 steps computed stay in
    ``history``, steps 0-1 on disk; resumed from step 1, the run ends on the states of one
    never interrupted."""
    straight = reference.simulation(1, COARSE, **EXACT)
    straight.run(DT, 3 * DT)

    def block(record):
        if record.step == 1:
            (tmp_path / "steps" / "000002.npz").mkdir()
    sim = reference.simulation(1, COARSE, **EXACT)
    expected = (rf"^out: step 2 could not be written into {re.escape(repr(str(tmp_path)))} \(\[Errno 21\] Is a "
                rf"directory: .* -> {re.escape(repr(str(tmp_path / 'steps' / '000002.npz')))}\); the steps before "
                rf"it are on disk: resume\({re.escape(repr(str(tmp_path)))}\) continues from them$")
    with pytest.raises(IsADirectoryError, match=expected):
        sim.run(DT, 3 * DT, out=tmp_path, on_step=block)
    assert len(sim.history) == 3 and sim.history[-1].time == pytest.approx(2 * DT, abs=1e-15)
    (tmp_path / "steps" / "000002.npz").rmdir()
    resumed = reference.simulation(1, COARSE, **EXACT).resume(tmp_path)
    assert len(resumed.history) == 2
    resumed.run(DT, 3 * DT, out=tmp_path)
    assert np.abs(resumed.history[-1].state - straight.history[-1].state).max() <= \
        1e-12 * np.abs(straight.history[-1].state).max()


def test_a_vtk_file_that_was_not_written_stops_the_run(tmp_path, monkeypatch):
    """NGSolve's VTKOutput says nothing when it cannot write its file (checked here: a stem in
    a directory that does not exist); the stream checks the file of every step instead, and
    a writer that writes nothing at step 1 stops the run with an OSError naming the file."""
    mesh = reference.simulation(1, COARSE).body.mesh
    ngs.VTKOutput(mesh, coefs=[ngs.x], names=["x"], filename=str(tmp_path / "absent" / "f")).Do()
    assert not (tmp_path / "absent").exists()                  # ... and no error
    writer = results.fields_writer

    def silent(source, filename, **options):
        if not str(filename).endswith("_000001"):
            return writer(source, filename, **options)
        return type("Silent", (), {"Do": lambda self, time=0.0: None})()
    monkeypatch.setattr(results, "fields_writer", silent)
    sim = reference.simulation(1, COARSE, **EXACT)
    vtu = repr(str(tmp_path / "out" / "vtk" / "fields_000001.vtu"))
    with pytest.raises(OSError, match=rf"^out: step 1 could not be written into .*\(NGSolve's VTKOutput did not "
                                      rf"write {re.escape(vtu)}\); the steps before it are on disk"):
        sim.run(DT, 3 * DT, out=tmp_path / "out")
    assert len(sim.history) == 2 and [r.step for r in results.read(tmp_path / "out")[1]] == [0]


@pytest.mark.parametrize("damage", ["truncated", "garbage"])
def test_a_damaged_step_archive_is_named(tmp_path, damage):
    reference.simulation(1, COARSE).run(DT, 3 * DT, out=tmp_path)
    path = tmp_path / "steps" / "000002.npz"
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2] if damage == "truncated" else b"\x00garbage" * 64)
    expected = (rf"^'{re.escape(str(path))}': the step archive cannot be read \(.+\): it was cut short or "
                r"overwritten; delete it and the later ones \(to 000003\.npz\) to resume from step 1$")
    with pytest.raises(ValueError, match=expected):
        results.read(tmp_path)
    with pytest.raises(ValueError, match=expected):
        reference.simulation(1, COARSE).resume(tmp_path)
    path.unlink()
    (tmp_path / "steps" / "000003.npz").unlink()
    assert len(reference.simulation(1, COARSE).resume(tmp_path).history) == 2


def test_a_run_from_before_the_fingerprint_is_refused(tmp_path):
    reference.simulation(1, COARSE).run(DT, 2 * DT, out=tmp_path)
    info = json.loads((tmp_path / "run.json").read_text())
    del info["fingerprint"]
    (tmp_path / "run.json").write_text(json.dumps(info))
    for attempt in (lambda: reference.simulation(1, COARSE).resume(tmp_path),
                    lambda: reference.simulation(1, COARSE).run(DT, 2 * DT, out=tmp_path)):
        with pytest.raises(ValueError, match="no fingerprint in run.json.*cannot be checked; run again into a new "
                                             "directory$"):
            attempt()


def test_a_run_from_before_the_options_were_recorded_is_refused(tmp_path):
    """A fingerprint without the options added since (the linear solver's, those of run) is
    refused, naming what was not recorded."""
    reference.simulation(1, COARSE).run(DT, 2 * DT, out=tmp_path)
    info = json.loads((tmp_path / "run.json").read_text())
    for key in ("options.inverse", "run.dt", "run.T", "run.rtol", "run.dt_min", "run.event_dt", "run.max_cutbacks",
                "run.guess"):
        del info["fingerprint"][key]
    (tmp_path / "run.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match=r"computed with options.inverse = not recorded \(a run of an earlier "
                                         r"ngcontact\); this simulation has options.inverse = 'sparsecholesky'"):
        reference.simulation(1, COARSE).resume(tmp_path)
    with pytest.raises(ValueError, match="holds a run of an earlier ngcontact, which did not record dt_min, event_dt, "
                                         "max_cutbacks, guess .*; run again into a new directory$"):
        reference.simulation(1, COARSE).run(DT, 2 * DT, out=tmp_path)


def test_a_run_begun_after_some_steps_stores_them(tmp_path):
    """Streaming from step 2 on writes the records of steps 0 and 1 first: the archives are
    numbered from 0 and a resume gives the whole history and the state of the last step."""
    sim = reference.simulation(1, COARSE, **EXACT)
    sim.run(DT, 2 * DT)
    sim.run(DT, 3 * DT, out=tmp_path)
    _, history = results.read(tmp_path)
    assert [(r.step, r.time) for r in history] == [(r.step, r.time) for r in sim.history]
    resumed = reference.simulation(1, COARSE, **EXACT).resume(tmp_path)
    assert resumed.t == sim.t and np.array_equal(resumed.gfu.vec.FV().NumPy(), sim.gfu.vec.FV().NumPy())
    assert np.array_equal(resumed.history[1].state, sim.history[1].state)


# ----------------------------------------------------------------------------- a resume is exact

class Stop(Exception):
    """Raised by an on_step callback: the run stops as a killed one does, its steps on disk."""


def demo_run(directory, scheme, run, stop, resume=False):
    """The demo's run (``demo.run``: ``reference.simulation`` of its contact, then ``run(0.5 s /
    steps, 0.5 s, out=..., rtol=...)``) on its coarsest mesh (maxh 0.02), stopped after step
    ``stop`` by an on_step that raises; with ``resume`` resumed from ``directory`` first."""
    sim = reference.simulation(1, 0.02, contact=reference.contact(1, 10.0), scheme=scheme)
    if resume:
        sim.resume(directory)

    def halt(record):
        if record.step == stop:
            raise Stop
    end = reference.LOAD_HISTORY[-1][0]
    with pytest.raises(Stop):
        sim.run(end / run["steps"], end, out=directory, rtol=run.get("rtol"), on_step=halt)


DEMOS = {   # scheme, demo options, the steps after which it is interrupted, the last step compared
    "backward_euler": ("backward_euler", dict(steps=40), (8, 23), 30),
    "bdf2 rtol": ("bdf2", dict(steps=4, rtol=0.1), (6, 24), 30),
}


@pytest.mark.parametrize("name", [n if n == "backward_euler" else pytest.param(n, marks=pytest.mark.long) for n in DEMOS])
def test_an_interrupted_demo_resumes_bitwise(tmp_path, name):
    """The demo's run (its default scheme, and BDF2 with error-controlled steps: the demo with
    ``--scheme bdf2 --rtol 0.1``) interrupted after step K and resumed equals the run never
    interrupted bitwise: every stored array of every step (time, dt, states, β, contact force,
    Newton's residuals, the Krylov iterations, dt_next, the restart state). The interruptions
    are where a kept factorisation is alive (made again at the resume from the values saved)
    and, for BDF2, where the rate c is not that of the first step (Newton's norm scales, set at
    the first step, are saved too); before these were saved, the default demo resumed at step 100
    differed by up to 2.2e-11 of the state (relative) and the BDF2 demo with rtol 1e-3 resumed
    at step 60 by 2.6e-8 of the state and 2.7e-7 of its steps."""
    scheme, run, cuts, last = DEMOS[name]
    demo_run(tmp_path / "whole", scheme, run, last)
    for cut in cuts:
        directory = tmp_path / f"cut{cut}"
        shutil.copytree(tmp_path / "whole", directory)
        for path in (directory / "steps").glob("*.npz"):
            if int(path.stem) > cut:
                path.unlink()
        with np.load(directory / "steps" / f"{cut:06d}.npz") as archive:
            assert "restart/kept_values" in archive.files       # the factorisation is made again
            if scheme == "bdf2":
                with np.load(directory / "steps" / "000001.npz") as first:
                    assert archive["restart/solver_rate"] != first["restart/solver_rate"]
        demo_run(directory, scheme, run, last, resume=True)
        assert same_archives(tmp_path / "whole", directory, last) > (last + 1) * 20


@pytest.fixture(scope="module")
def unfinished(tmp_path_factory):
    """Runs stopped part-way (their last archive deleted): the coarse reference scene with
    fixed steps (``nominal``), with BDF2's error-controlled steps (``controlled``), and at P2
    with the P1 start of every step (``p1``)."""
    out = tmp_path_factory.mktemp("unfinished")
    reference.simulation(1, COARSE).run(DT, 3 * DT, out=out / "nominal")
    reference.simulation(1, COARSE, scheme="bdf2").run(DT, 0.01, rtol=1e-3, out=out / "controlled")
    reference.simulation(2, COARSE).run(DT, 3 * DT, guess="p1", out=out / "p1")
    for name in ("nominal", "controlled", "p1"):
        archives = sorted((out / name / "steps").glob("*.npz"))
        archives[-1].unlink()
    return out


SIMULATION_OPTIONS = {      # Simulation(**changed): the fingerprint's field, stored, this simulation's
    "rtol": (dict(rtol=1e-8), "options.rtol", "1e-10", "1e-08"),
    "maxit": (dict(maxit=20), "options.maxit", "50", "20"),
    "predictor": (dict(predictor=True), "options.predictor", "False", "True"),
    "limit_steps": (dict(limit_steps=False), "options.limit_steps", "True", "False"),
    "condense": (dict(condense=True), "options.condense", "False", "True"),
    "inverse": (dict(solver="umfpack"), "options.inverse", "'sparsecholesky'", "'umfpack'"),
    "reuse_factorization": (dict(solver={"ksp_type": "preonly"}), "options.reuse_factorization", "True", "False"),
    "iterative": (dict(solver="iterative"), "options.iterative", "False", "'multigrid'"),
    "realcompile": (dict(realcompile=False), "options.realcompile", "none", "False"),
}


@pytest.mark.parametrize("option", SIMULATION_OPTIONS)
def test_resume_refuses_other_simulation_options(unfinished, option):
    """An option of Simulation that changes the results, changed, is refused at resume, naming
    the option with both values, before anything is written."""
    changed, field, stored, now = SIMULATION_OPTIONS[option]
    directory = unfinished / "nominal"
    written = {p: p.stat().st_mtime_ns for p in directory.rglob("*")}
    with pytest.raises(ValueError) as error:
        reference.simulation(1, COARSE, **changed).resume(directory)
    message = str(error.value)
    assert message.startswith(f"resume: {str(directory)!r} was computed with ") and \
        message.endswith(": not the same scene")
    there, here = message.split("; this simulation has ")
    assert f"{field} = {stored}" in there and f"{field} = {now}" in here
    assert {p: p.stat().st_mtime_ns for p in directory.rglob("*")} == written
    with pytest.raises(ValueError, match="holds a run of the time scheme 'backward_euler', this simulation's scheme "
                                         "is 'bdf2'"):
        reference.simulation(1, COARSE, scheme="bdf2").resume(directory)


RUN_OPTIONS = {     # base run, run(...) as it was, as it is now, the option named, stored, now
    "dt": ("nominal", dict(dt=DT, T=3 * DT), dict(dt=DT / 2), "dt", "0.0025", "0.00125"),
    "T": ("nominal", dict(dt=DT, T=3 * DT), dict(T=4 * DT), "T", "0.0075", "0.01"),
    "max_cutbacks": ("nominal", dict(dt=DT, T=3 * DT), dict(max_cutbacks=3), "max_cutbacks", "6", "3"),
    "guess": ("p1", dict(dt=DT, T=3 * DT, guess="p1"), dict(guess=None), "guess", "'p1'", "none"),
    "rtol": ("controlled", dict(dt=DT, T=0.01, rtol=1e-3), dict(rtol=1e-4), "rtol", "0.001", "0.0001"),
    "dt_min": ("controlled", dict(dt=DT, T=0.01, rtol=1e-3), dict(dt_min=1e-8), "dt_min", "2.5e-09", "1e-08"),
    "event_dt": ("controlled", dict(dt=DT, T=0.01, rtol=1e-3), dict(event_dt=5e-3 * DT), "event_dt", "2.5e-06",
                 "1.25e-05"),
}


@pytest.mark.parametrize("option", RUN_OPTIONS)
def test_a_resumed_run_refuses_other_run_options(unfinished, option):
    """An option of run that changes the results (event_dt: where first contact is located,
    say), changed after a resume, is refused before a step is taken, naming it with both values
    (dt_min and event_dt as used, their defaults 1e-6 dt and 1e-3 dt resolved); the same
    options continue the run."""
    base, before, changed, name, stored, now = RUN_OPTIONS[option]
    order = 2 if base == "p1" else 1
    scheme = "bdf2" if base == "controlled" else "backward_euler"
    directory = unfinished / base
    written = {p: p.stat().st_mtime_ns for p in directory.rglob("*")}
    sim = reference.simulation(order, COARSE, scheme=scheme).resume(directory)
    steps = len(sim.history)
    arguments = {**before, **changed}
    with pytest.raises(ValueError) as error:
        sim.run(arguments.pop("dt"), arguments.pop("T"), out=directory, **arguments)
    assert str(error.value) == (f"out: {str(directory)!r} holds another run ({name} {stored}; this run has {name} "
                                f"{now}): resume it with the same dt, T, rtol, dt_min, event_dt, max_cutbacks and "
                                "guess, or write to a new directory")
    assert len(sim.history) == steps and {p: p.stat().st_mtime_ns for p in directory.rglob("*")} == written


def test_a_complete_run_says_so(stored, tmp_path):
    """Resumed, a run that reached its T says so when run again (not that T must be later),
    with how to extend it; run into another directory, it continues from its last state as the
    simulation that computed it does, bitwise."""
    directory = stored / "piezo"
    for T_asked in (2 * DT, DT):
        sim = reference.simulation(1, COARSE).resume(directory)
        with pytest.raises(ValueError) as error:
            sim.run(DT, T_asked, out=directory)
        assert str(error.value) == (
            f"run: the run in {str(directory)!r} is already complete: it reached its T = 0.005 s at step 2 (t = 0.005 "
            f"s), nothing is left to compute (ngcontact.results.read({str(directory)!r}) reads it). To extend it, "
            "run(dt, T_later, out=<another directory>) continues from its last state (T_later > 0.005 s; the "
            "directory of a run keeps its T)")
    sim.run(DT, 3 * DT, out=tmp_path / "extended")
    straight = reference.simulation(1, COARSE)
    straight.run(DT, 2 * DT)
    straight.run(DT, 3 * DT)
    assert [r.time for r in sim.history] == [r.time for r in straight.history]
    assert np.array_equal(sim.history[-1].state, straight.history[-1].state)
    assert [r.step for r in results.read(tmp_path / "extended")[1]] == [0, 1, 2, 3]


def test_the_compile_rule_resumes_where_it_stood(tmp_path):
    """The rule that compiles the Γ3 integrand when the iterations pay for it (``machine_code``)
    counts on after a resume from what it had counted (it counts rejected tries too, which the
    records do not hold): it compiles at the step the run never interrupted does."""
    sim = reference.simulation(1, COARSE, scheme="bdf2")
    sim.run(DT, 0.01, rtol=1e-3, out=tmp_path)
    assert sim.rejections and sim._machine_code.spent > 0
    resumed = reference.simulation(1, COARSE, scheme="bdf2").resume(tmp_path)
    assert resumed._machine_code.spent == sim._machine_code.spent and not resumed.realcompile
