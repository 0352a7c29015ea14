"""The same scripts on several MPI processes (mpiexec from the mpich wheel of the test
extra): the 3D demo distributed equals the serial run, and what does not run distributed
says so. NGSolve distributes from rank 0, which keeps no elements: ``-n 2`` computes on one
rank (the distributed code paths without shared DOFs), ``-n 3`` on two (shared DOFs)."""
import contextlib
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import meshio
import numpy as np
import pytest

from ngcontact import demo
from test_output import check_warp

HERE = pathlib.Path(__file__).parent
MPI_SLOW = pytest.mark.slow
"""The runs of whole scenes on 2 and 3 ranks against the serial run (minutes in all): ``-m slow``,
and every one of them in CI's PETSc leg, which runs this module whole. The default run keeps the
distributed smoke checks below that are not so marked (a failed write stops every rank, the
serial commands refused under mpiexec)."""
DEMO = ["-m", "ngcontact", "demo", "--dim", "3", "--maxh", "0.02", "--steps", "20"]


def mpiexec():
    """The mpiexec next to this Python (the mpich wheel puts it in the environment's bin/)."""
    found = pathlib.Path(sys.executable).parent / "mpiexec"
    found = str(found) if found.exists() else shutil.which("mpiexec")
    assert found, "mpiexec not found: install the test extra (pip install '.[test]' brings mpich and mpi4py)"
    return found


def launch(ranks, *args, timeout=600):
    """``mpiexec -n ranks python *args``: its stdout, after a clean exit. A run that has not
    ended after ``timeout`` s (a rank waiting for ever in a collective operation the others
    left) is stopped, every rank with it (its process group), and fails the test."""
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    process = subprocess.Popen([mpiexec(), "-n", str(ranks), sys.executable, *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env, cwd=HERE.parent, start_new_session=True)
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        stdout = stderr = ""
        for stop in (signal.SIGTERM, signal.SIGKILL):       # mpiexec passes SIGTERM on to the ranks
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, stop)
            try:
                stdout, stderr = process.communicate(timeout=10)
                break
            except subprocess.TimeoutExpired:
                continue
        pytest.fail(f"mpiexec -n {ranks} {' '.join(map(str, args))} did not end within {timeout} s (a rank waits "
                    f"in a collective operation the others left?): {(stdout or '')[-1000:]}{(stderr or '')[-1000:]}")
    assert process.returncode == 0, stdout[-3000:] + stderr[-3000:]
    return stdout


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    demo.run(dim=3, maxh=0.02, steps=20, out=out, switch_loop=False)   # (distributed: plain corrections)
    return json.loads((out / "summary.json").read_text())


@MPI_SLOW
@pytest.mark.parametrize("ranks", [2, 3])
def test_distributed_demo_equals_the_serial_run(serial, tmp_path, ranks):
    """``mpiexec -n N python -m ngcontact demo --dim 3``: per step the contact force, the tip
    displacement (a probe point), the charge flux, the peak pressure, the contact area and
    min β (push, hold, pull: β falls to ~0.007; Newton iterations ±1) equal the serial run to 1e-8 relative; rank
    0 alone writes the summary and charts, every computing rank its part of each step in the stream (run/)."""
    launch(ranks, *DEMO, "--out", str(tmp_path))
    distributed = json.loads((tmp_path / "summary.json").read_text())
    assert distributed["ranks"] == ranks and serial["ranks"] == 1
    for key in ("contact_force_y", "tip_deflection", "charge_flux", "max_pressure", "contact_length"):
        a, b = np.array(serial[key], float), np.array(distributed[key], float)
        assert a.shape == b.shape and np.abs(a).max() > 0, key
        assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max(), key
    # Newton: the serial run's kept factorisation with GMRES may stop one iteration apart
    assert np.abs(np.subtract(serial["newton_iterations"], distributed["newton_iterations"])).max() <= 1
    assert min(serial["beta_min"], distributed["beta_min"]) < 0.05
    assert abs(serial["beta_min"] - distributed["beta_min"]) <= 1e-8
    assert (tmp_path / "history.png").exists() and (tmp_path / "run" / "fields.pvd").exists()
    assert len(list(tmp_path.glob("run/vtk/fields_000001_proc*.vtu"))) == ranks - 1
    assert len(list(tmp_path.glob("run/steps/000001.rank*.npz"))) == ranks


@MPI_SLOW
def test_the_demo_resumes_distributed(tmp_path):
    """``mpiexec -n 3 python -m ngcontact demo --resume`` (2D, 10 steps) continues a run whose
    steps 6 to 10 were lost (their archives deleted, their rank parts
    left, as by a kill between the parts and the archive) to the summary of the whole run,
    the tip deflection of the steps on disk from each rank's kept states; under ``-n 2`` it
    is refused before meshing, naming both numbers of ranks, and nothing is written."""
    command = ["-m", "ngcontact", "demo", "--steps", "10", "--maxh", "0.01", "--out", str(tmp_path)]
    launch(3, *command)
    whole = json.loads((tmp_path / "summary.json").read_text())
    assert len(whole["times"]) == 10 and min(whole["tip_deflection"]) < -1e-6
    (tmp_path / "summary.json").unlink()
    for n in range(6, 11):
        (tmp_path / "run" / "steps" / f"{n:06d}.npz").unlink()
    written = {p: p.stat().st_mtime_ns for p in (tmp_path / "run").rglob("*")}
    done = subprocess.run([mpiexec(), "-n", "2", sys.executable, *command, "--resume"], capture_output=True,
                          text=True, timeout=600, env=dict(os.environ, PYTHONWARNINGS="ignore"), cwd=HERE.parent)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (f"ngcontact demo: error: resume: {str(tmp_path / 'run')!r} was written on 3 MPI ranks "
                           "(mpiexec -n 3), this simulation runs on 2 MPI ranks (mpiexec -n 2): every rank reads back "
                           "its own part of each step; resume it under mpiexec -n 3, or run again into a new "
                           "directory\n")
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "run").rglob("*")} == written
    assert "resumed at step 5, t = 0.2500 s" in launch(3, *command, "--resume")
    resumed = json.loads((tmp_path / "summary.json").read_text())
    for key in ("times", "newton_iterations", "contact_length", "tip_deflection", "charge_flux", "contact_force_y",
                "beta_min"):
        assert np.allclose(resumed[key], whole[key], rtol=1e-12, atol=1e-20), key


@pytest.fixture(scope="module")
def serial_scenes(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial_scenes")
    runs = {}
    for scene in SCENES:
        command = [sys.executable, str(HERE / "distributed_scenes.py"), scene, "default", str(out / f"{scene}.json")]
        done = subprocess.run(command, capture_output=True, text=True, cwd=HERE.parent, timeout=900)
        assert done.returncode == 0, done.stderr[-3000:]
        runs[scene] = json.loads((out / f"{scene}.json").read_text())
    return runs


SCENES = ("reference-law", "reference-p3", "reference-p1start", "hertz-force", "indenter3d", "axisymmetric")


LONG = {("reference-p3", 3), ("indenter3d", 3), ("axisymmetric", 3)}
"""The cases on 3 ranks whose 2-rank runs check the same code (20–26 s each): ``-m slow``."""


@MPI_SLOW
@pytest.mark.parametrize("scene, ranks", [pytest.param(scene, ranks, marks=pytest.mark.slow) if (scene, ranks) in LONG
                                          else (scene, ranks) for scene in SCENES for ranks in (2, 3)])
def test_distributed_scenes_equal_the_serial_run(serial_scenes, tmp_path, scene, ranks):
    """``mpiexec -n 2|3`` with the default distributed solver (MUMPS where PETSc is installed,
    else "masterinverse"): the 2D reference plate with a nonlinear elasticity (the projection
    law, issue 26), the plate at P3 with static condensation, at P2 started from P1 at every
    step (``guess="p1"``), the Hertz half-disk under force control (held by the contact alone:
    the "touch" start), and a 3D block on rollers and two symmetry planes indented by a
    moving rigid sphere, and a piezoelectric body of revolution on a conducting plane
    (``tests/distributed_scenes.py``): per step the contact force (every component),
    the charge flux (the plate; the block has no conduction: u and φ at a probe under the
    indenter instead) and the supports' reactions equal the serial run to 1e-8 of their largest
    values, Newton's iterations to ±1; the indenter's force balances the reactions (1e-8)."""
    launch(ranks, str(HERE / "distributed_scenes.py"), scene, "default", str(tmp_path / "run.json"), timeout=900)
    distributed, serial = json.loads((tmp_path / "run.json").read_text()), serial_scenes[scene]
    assert distributed["ranks"] == ranks
    conducts = scene.startswith("reference") or scene == "axisymmetric"   # else u, φ at a probe, not the charge
    keys = ("force", "charge") if conducts else ("force", "probe_u") + (("probe_phi",) if scene == "indenter3d" else ())
    pairs = [(key, serial[key], distributed[key]) for key in keys]
    pairs += [(name, serial["reactions"][name], distributed["reactions"][name]) for name in serial["reactions"]]
    force = np.abs(serial["force"]).max()
    for key, a, b in pairs:                       # a reaction is measured against the contact force too
        a, b = np.array(a), np.array(b)
        size = np.abs(a).max() if key in keys else max(np.abs(a).max(), force)
        assert a.shape == b.shape and size > 0, key
        assert np.abs(a - b).max() <= 1e-8 * size, (key, np.abs(a - b).max() / size)
    assert np.abs(np.subtract(serial["newton"], distributed["newton"])).max() <= 1
    if scene == "indenter3d":
        for run in (serial, distributed):
            force, reactions = np.array(run["force"])[1:], sum(np.array(r) for r in run["reactions"].values())
            assert np.abs(force + reactions).max() <= 1e-8 * np.abs(force).max()
    if scene == "axisymmetric":                   # the axial force balances the top's (N, whole body)
        for run in (serial, distributed):
            force, top = np.array(run["force"])[1:, 1], np.array(run["reactions"]["top"])[:, 1]
            assert np.abs(force + top).max() <= 1e-8 * np.abs(force).max()


LOOPS = ("bdf2", "bdf2-rtol", "penalty", "law", "active_set")
"""The cases of ``tests/distributed_loops.py``: loops that stop on data, and the refused nodal constraint."""


@pytest.fixture(scope="module")
def serial_loops(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial_loops") / "loops.json"
    done = subprocess.run([sys.executable, str(HERE / "distributed_loops.py"), ",".join(LOOPS), str(out)],
                          capture_output=True, text=True, cwd=HERE.parent, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(out.read_text())


@MPI_SLOW
@pytest.mark.parametrize("ranks", [2, 3])
def test_loops_that_stop_on_data_stop_alike_on_every_rank(serial_loops, tmp_path, ranks):
    """``mpiexec -n 2|3 tests/distributed_loops.py`` (the 2D reference plate, P1, maxh 20 mm): BDF2
    with fixed steps over the push, hold and pull (β's passes from u_n: each rank took its own
    facets' change, and rank 0, which has none, left them at once and hung), BDF2 with
    error-controlled steps across the lift-off (the local error estimate and the events over all
    ranks: rejected tries, the lift-off located), the penalty method, and a nonlinear elasticity
    (the projection law) with BDF2 end on every rank with the serial run's steps (times to 1e-10,
    the same rejections and events), contact force and β (gathered, by facet midpoint) to 1e-10
    of their largest values, the charge flux to 1e-9. Newton's iterations may differ: with
    PETSc, the kept MUMPS factorisation's GMRES stops at other iterates (a step 9 iterations
    apart over its β passes was seen), and the penalty run's charges, a small φ-part that
    Newton's stopping test bounds less tightly than the forces, differed by 5.8e-11 and 1.7e-10
    of their largest between runs whose steps stopped one iteration apart. The nodal constraint
    (``method="active_set"``) is refused on every rank with the same ValueError, before any step."""
    launch(ranks, str(HERE / "distributed_loops.py"), ",".join(LOOPS), str(tmp_path / "loops.json"), timeout=300)
    found = json.loads((tmp_path / "loops.json").read_text())
    assert found["ranks"] == ranks
    controlled = serial_loops["bdf2-rtol"]
    assert controlled["rejections"] > 0 and "lift-off" in controlled["events"]
    assert min(serial_loops["bdf2"]["beta"][-1]) < 0.5                   # the glue debonds: β's passes ran
    for case in LOOPS[:-1]:
        serial, distributed = serial_loops[case], found[case]
        assert distributed["finished"] == [True] * ranks, case
        assert len(distributed["times"]) == len(serial["times"]), case
        assert np.abs(np.subtract(distributed["times"], serial["times"])).max() <= 1e-10 * serial["times"][-1], case
        assert (distributed["rejections"], distributed["events"]) == (serial["rejections"], serial["events"]), case
        for key, tol in (("force", 1e-10), ("charge", 1e-9), ("beta", 1e-10)):
            a, b = np.array(serial[key]), np.array(distributed[key])
            assert a.shape == b.shape and np.abs(a).max() > 0, (case, key)
            assert np.abs(a - b).max() <= tol * np.abs(a).max(), (case, key, np.abs(a - b).max() / np.abs(a).max())
    messages = found["active_set"]["messages"]
    assert serial_loops["active_set"]["messages"] == ["no error"]
    assert len(messages) == ranks and len(set(messages)) == 1
    assert messages[0] == (f"Contact.method 'active_set' (the nodal constraint) does not run on a distributed mesh "
                           f"(mpiexec with {ranks} ranks): its saddle point systems are scipy matrices of one rank; "
                           "use 'nitsche' or 'penalty'")


@MPI_SLOW
def test_the_bdf2_demo_ends_distributed(serial_loops, tmp_path):
    """``mpiexec -n 2 python -m ngcontact demo --steps 4 --scheme bdf2`` (maxh 20 mm) ends within
    120 s with the serial run's steps, contact force, charge flux and final β (the same scene as
    ``distributed_loops.py bdf2``; 1e-10 relative): before, rank 0 (no facets of Γ3) left BDF2's
    passes of β at once and recorded the step while rank 1 waited in the next Newton solve, for
    ever."""
    command = ["-m", "ngcontact", "demo", "--steps", "4", "--scheme", "bdf2", "--maxh", "0.02"]
    launch(2, *command, "--out", str(tmp_path), timeout=600)
    distributed, serial = json.loads((tmp_path / "summary.json").read_text()), serial_loops["bdf2"]
    assert distributed["ranks"] == 2 and distributed["times"] == serial["times"][1:]
    for key, expected in (("contact_force_y", np.array(serial["force"])[1:, -1]),
                          ("charge_flux", np.array(serial["charge"])[1:])):
        found = np.array(distributed[key])
        assert np.abs(expected).max() > 0 and np.abs(found - expected).max() <= 1e-10 * np.abs(expected).max(), key
    assert abs(distributed["beta_min"] - min(serial["beta"][-1])) <= 1e-10 and distributed["beta_min"] < 0.1


def run_script(*args):
    """tests/distributed_streaming.py serially."""
    done = subprocess.run([sys.executable, str(HERE / "distributed_streaming.py"), *map(str, args)],
                          capture_output=True, text=True, cwd=HERE.parent, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]


def cells(path):
    """The cells of a Γ3 .vtu (2D: lines) as (midpoints, {name: cell values}), read by meshio."""
    mesh = meshio.read(path)
    lines = mesh.cells_dict["line"]
    values = {name: arrays[0] for name, arrays in mesh.cell_data.items()}
    assert list(mesh.cells_dict) == ["line"] and all(len(v) == len(lines) for v in values.values())
    return mesh.points[lines].mean(axis=1)[:, :2], values


@MPI_SLOW
def test_streamed_results_resume_distributed(tmp_path):
    """``run(dt, T, out=DIR)`` and ``resume(DIR)`` under ``mpiexec -n 3`` (2D reference plate,
    P1, 10 steps, ``tests/distributed_streaming.py``): interrupted after step 6 (on disk) and
    resumed by a new Simulation, the contact force of every step equals an uninterrupted
    distributed run (1e-12) and the serial run (1e-8 relative); every step has its archive and
    one part per rank, ``read`` gives the records serially; fields.pvd lists both computing
    ranks' .vtu of every step; the Γ3 .vtu of the last step has the gathered facets with the
    serial run's values in the cells at the same midpoints (the potential differs from facet
    to facet, and the gathered order is not the serial one) and warps onto the ranks' files of
    the body. Refused with a message naming
    both numbers of ranks, on every rank: a resume on 2 ranks, a serial resume, a stream or
    resume on 3 ranks from a serial run's directory; a missing rank part of the last step
    names the file, another partition in run.json names the rank; another γ0, time scheme or
    u0 is named as serially, on every rank."""
    from ngcontact.output import results
    from ngcontact.scenes import reference
    script = str(HERE / "distributed_streaming.py")
    serial_dir, run_dir = tmp_path / "serial", tmp_path / "run"
    run_script("serial", serial_dir, tmp_path / "serial.json")
    launch(3, script, "run", run_dir, serial_dir, tmp_path / "run.json", timeout=300)
    serial, run = (json.loads((tmp_path / f"{name}.json").read_text()) for name in ("serial", "run"))
    assert (serial["ranks"], run["ranks"], run["resumed_at"]) == (1, 3, 6)
    expected = np.array(serial["force"])
    assert expected.shape == (11, 2) and np.abs(expected).max() > 1e4
    scale = np.abs(expected).max()
    assert np.abs(np.array(run["force"]) - run["uninterrupted"]).max() <= 1e-12 * scale
    assert np.abs(np.array(run["force"]) - expected).max() <= 1e-8 * scale
    steps = sorted(p.name for p in (run_dir / "steps").iterdir())
    assert steps == [f"{n:06d}{part}.npz" for n in range(11) for part in ("", ".rank0", ".rank1", ".rank2")]
    info, history = results.read(run_dir)                   # records only, in this serial process
    assert (info["ranks"], len(info["partition"]), info["ndof"]) == (3, 3, 186)
    assert all(record.state is None for record in history)
    assert np.abs(np.array([r.contact.force for r in history]) - expected).max() <= 1e-8 * scale
    # ParaView: both computing ranks' files of every step
    entries = ElementTree.parse(run_dir / "fields.pvd").getroot().findall("Collection/DataSet")
    assert [e.get("part") for e in entries] == ["1", "2"] * len(history)
    assert [float(e.get("timestep")) for e in entries] == pytest.approx([r.time for r in history for _ in "12"])
    for entry in entries:
        text = (run_dir / entry.get("file")).read_text(errors="replace")
        assert entry.get("file").endswith(f"_proc{entry.get('part')}.vtu")
        assert 'Name="displacement"' in text and 'Name="potential"' in text
    # Γ3: the gathered facets, each cell with the serial run's values at its midpoint
    midpoints, values = cells(run_dir / "vtk" / "gamma3_000010.vtu")
    serial_midpoints = np.array(serial["midpoints"])
    distance = np.linalg.norm(midpoints[:, None] - serial_midpoints[None], axis=-1)
    match = distance.argmin(axis=1)
    assert len(midpoints) == len(serial_midpoints) == 20 and distance.min(axis=1).max() < 1e-12
    assert sorted(match) == list(range(20)) and list(match) != list(range(20))
    potential = history[-1].contact.potential
    assert len(np.unique(np.round(potential, 6))) == 20 and np.abs(potential).max() > 10
    for name in ("pressure", "beta", "potential"):
        field = np.array(serial[name])
        assert np.abs(values[name] - field[match]).max() <= 1e-8 * max(np.abs(field).max(), 1.0), name
    assert np.abs(values["pressure"]).max() > 1e6
    # ... and warps onto the computing ranks' files of the body (test_output.check_warp)
    parts = [meshio.read(run_dir / "vtk" / f"fields_000010_proc{r}.vtu") for r in (1, 2)]
    body = meshio.Mesh(np.vstack([p.points for p in parts]), [],
                       point_data={"displacement": np.vstack([p.point_data["displacement"] for p in parts])})
    assert check_warp(body, meshio.read(run_dir / "vtk" / "gamma3_000010.vtu")) > 1e-6
    # refused: another number of ranks, on every rank, naming both; a missing part
    launch(2, script, "resume", run_dir, tmp_path / "resume.json", timeout=300)
    refused = json.loads((tmp_path / "resume.json").read_text())["resume"]
    assert refused == 2 * [f"resume: {str(run_dir)!r} was written on 3 MPI ranks (mpiexec -n 3), this simulation "
                           "runs on 2 MPI ranks (mpiexec -n 2): every rank reads back its own part of each step; "
                           "resume it under mpiexec -n 3, or run again into a new directory"]
    with pytest.raises(ValueError, match=re.escape(
            f"resume: {str(run_dir)!r} was written on 3 MPI ranks (mpiexec -n 3), this simulation runs serially "
            "(1 process): every rank reads back its own part of each step; resume it under mpiexec -n 3, or run "
            "again into a new directory")):
        reference.simulation(1, 0.01).resume(run_dir)
    assert run["out_serial"] == 3 * [
        f"out: {str(serial_dir)!r} was written serially (1 process), this simulation runs on 3 MPI ranks (mpiexec "
        "-n 3): every rank reads back its own part of each step; continue it (resume, then run) serially (without "
        "mpiexec), or write to a new directory"]
    assert run["resume_serial"] == 3 * [run["out_serial"][0].replace("out: ", "resume: ").replace(
        "continue it (resume, then run)", "resume it").replace("write to a new", "run again into a new")]
    part = tmp_path / "incomplete" / "steps" / "000010.rank2.npz"
    assert run["missing_part"] == 3 * [f"{str(part)!r} is missing: step 10 is incomplete (its archive "
                                       "steps/000010.npz is on disk, the part of rank 2 is not); delete "
                                       "steps/000010.npz to resume from step 9"]
    assert len(set(run["partition"])) == 1 and re.fullmatch(
        rf"resume: {re.escape(repr(str(tmp_path / 'incomplete')))} was written with its mesh distributed otherwise: "
        r"rank 1 held (\d+) DOFs and (\d+) facets of Γ3 \(hash \w+\) of 186 DOFs, this simulation's rank 1 holds "
        r"(\d+) and \2 \(hash \w+\) of 186: another mesh or order, or another partition of it \(METIS\); use the "
        r"mesh of the run under mpiexec -n 3, or run again into a new directory", run["partition"][0])
    held, holds = (int(g) for g in re.fullmatch(r".*held (\d+) DOFs.*holds (\d+) and.*", run["partition"][0]).groups())
    assert held == holds + 1
    # the checks of the scene, the scheme and the start, on every rank
    assert run["scene"] == 3 * [f"resume: {str(run_dir)!r} was computed with contact.gamma0 = 10.0; this "
                                "simulation has contact.gamma0 = 100.0: not the same scene"]
    assert run["scheme"] == 3 * [f"resume: {str(run_dir)!r} holds a run of the time scheme 'backward_euler', this "
                                 "simulation's scheme is 'bdf2': build it with Simulation(scheme='backward_euler'), "
                                 "or write to a new directory"]
    assert len(set(run["start"])) == 1 and re.fullmatch(
        rf"resume: {re.escape(repr(str(run_dir)))} starts from another state at t = 0: u differs from this "
        r"simulation's by up to 1e-07 m \(of .* m; another u0\?\): not the same scene", run["start"][0])


@pytest.mark.long
def test_a_failed_write_on_one_rank_stops_every_rank(tmp_path):
    """``run(dt, T, out=DIR)`` under ``mpiexec -n 3`` (``tests/distributed_streaming.py fail``):
    when rank 1 cannot write its part of step 4, or rank 0 the step's archive (a directory in
    the way), every rank raises the same OSError naming the step, the rank and the file, instead
    of waiting for ever in the next collective operation (the code before hung there); the
    steps 0-3 are on disk with all their parts, step 4 (computed: 5 records in memory) has no
    archive, and the run resumed from step 3 (the obstacle removed) ends with the contact
    forces of an uninterrupted run."""
    launch(3, str(HERE / "distributed_streaming.py"), "fail", tmp_path, tmp_path / "fail.json", timeout=300)
    found = json.loads((tmp_path / "fail.json").read_text())
    for case, rank, name in (("part", 1, "000004.rank1.npz"), ("archive", 0, "000004.npz")):
        directory = tmp_path / case
        messages = found[case]["messages"]
        assert len(messages) == 3 and len(set(messages)) == 1, messages
        assert messages[0].startswith(f"IsADirectoryError: out: step 4 could not be written into "
                                      f"{str(directory)!r} (rank {rank}: [Errno 21] Is a directory: ")
        assert messages[0].endswith(f"-> {str(directory / 'steps' / name)!r}); the steps before it are on disk: "
                                    f"resume({str(directory)!r}) continues from them")
        assert found[case]["computed"] == 5
        on_disk = [f"{n:06d}{part}.npz" for n in range(4) for part in ("", ".rank0", ".rank1", ".rank2")]
        parts = [f"000004.rank{r}.npz" for r in (0, 2)] if case == "part" else [f"000004.rank{r}.npz" for r in range(3)]
        assert found[case]["archives"] == sorted(on_disk + parts)
    assert found["resumed_at"] == 3
    force, uninterrupted = np.array(found["force"]), np.array(found["uninterrupted"])
    assert force.shape == (11, 2) and np.abs(force - uninterrupted).max() <= 1e-12 * np.abs(uninterrupted).max()


@MPI_SLOW
def test_what_does_not_run_distributed_says_so(tmp_path):
    """A serial mesh given to Body, more computing ranks than elements, the nodal active set,
    GMRES with NGSolve's multigrid, a serial factorisation, the Jacobian as a scipy matrix, the
    guesses that need the whole mesh, the error estimator, adaptive
    refinement and refining a mesh raise a ValueError naming the feature under mpiexec; ``run(vtk=)``
    writes one ParaView file per computing rank and step (the initial state and 2 steps),
    with u and φ, collected by one .pvd."""
    lines = dict(line.split(": ", 1) for line in launch(3, str(HERE / "distributed_errors.py"), str(tmp_path))
                 .splitlines() if ": " in line)
    assert lines["serial mesh"].startswith("mesh: a serial mesh under mpiexec with 3 ranks (every rank would "
                                          "solve the whole problem); distribute it")
    assert "'active_set'" in lines["active_set"] and "distributed mesh" in lines["active_set"]
    assert "solver='multigrid'" in lines["multigrid"] and "nested meshes" in lines["multigrid"]
    assert "solver='umfpack'" in lines["umfpack"] and "distributed mesh" in lines["umfpack"]
    assert lines["jacobian"].startswith("the Jacobian as a scipy matrix (Simulation.jacobian) does not run on a "
                                        "distributed mesh (mpiexec with 3 ranks)")
    assert lines["nested"].startswith("guess='nested'") and lines["approach"].startswith(
        "guess=Approach(depth) without a direction does not run on a distributed mesh")
    assert lines["ranks"] == ("mpiexec -n 3: the mesh has 1 elements for 2 computing ranks (rank 0 keeps none); "
                              "run on at most 2 ranks or refine the mesh")
    assert lines["estimator"].startswith("the equilibrated error estimator does not run on a distributed mesh")
    assert lines["adapt"].startswith("adapt.step: adaptive refinement does not run on a distributed mesh")
    assert lines["refined"] == "refined: a distributed mesh cannot be refined (NGSolve refines serial meshes only)"
    assert lines["vtk"] == "2 steps"
    parts = sorted(path.name for path in tmp_path.glob("fields_proc*.vtu"))
    assert len(parts) == 2 * 3, parts                # 2 computing ranks × (initial state + 2 steps)
    collection = (tmp_path / "fields.pvd").read_text()
    assert all(part in collection for part in parts)
    for part in parts:
        text = (tmp_path / part).read_text(errors="replace")
        assert 'Name="displacement"' in text and 'Name="potential"' in text


@pytest.mark.parametrize("command", ["hertz", *(pytest.param(c, marks=pytest.mark.long)
                                              for c in ("convergence", "stability", "adapt", "timesteps", "timeorder"))])
def test_serial_commands_are_refused_under_mpiexec(command, tmp_path):
    """``mpiexec -n 2 python -m ngcontact hertz|convergence|stability``: one line, printed by
    rank 0 only, exit status 2 on every rank, nothing written (each rank ran the whole serial
    study; convergence hung)."""
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    done = subprocess.run([mpiexec(), "-n", "2", sys.executable, "-m", "ngcontact", command, "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=600, env=env,
                          cwd=HERE.parent)
    assert done.returncode == 2
    assert done.stderr.strip() == (f"ngcontact {command}: error: {command} runs serially only: under mpiexec with 2 "
                                   "ranks every rank would run the whole serial problem; run it without mpiexec")
    assert not (tmp_path / "out").exists()


def test_mpich_waits_yield_when_there_are_more_ranks_than_cores(monkeypatch):
    """With more ranks than cores (``mpi_launch.size`` from mpiexec's environment), MPICH's
    waits sleep instead of spinning (``mpi_launch.YIELDING``), unless the user set them; with as
    many ranks as cores nothing is set."""
    from ngcontact import mpi_launch
    for name in mpi_launch.YIELDING:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(mpi_launch.os, "cpu_count", lambda: 2)
    monkeypatch.setenv("PMI_SIZE", "2")
    mpi_launch.yield_when_oversubscribed()
    assert not any(name in os.environ for name in mpi_launch.YIELDING)
    monkeypatch.setenv("PMI_SIZE", "3")
    monkeypatch.setenv("MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT", "64")
    mpi_launch.yield_when_oversubscribed()
    assert os.environ["MPIR_CVAR_CH4_PROGRESS_THROTTLE"] == "1"
    assert os.environ["MPIR_CVAR_CH4_PROGRESS_THROTTLE_NO_PROGRESS_COUNT"] == "64"
