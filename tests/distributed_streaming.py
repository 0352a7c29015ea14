"""Run by tests/test_parallel.py, serially or under mpiexec: streamed results (``run(out=)``) and
``resume`` of the 2D reference plate (P1, maxh 10 mm, ``STEPS`` steps of ``DT`` from first
contact on). Rank 0 writes JSON to the last argument.

* ``serial DIR OUT``: the uninterrupted run streamed into DIR; per step the contact force, and
  the facets of Γ3 (midpoints) with the pressure, β and potential of the last step.
* ``run DIR SERIAL OUT`` (under mpiexec): the run streamed into DIR, interrupted after step
  ``STOP`` (an ``on_step`` that raises, once the step is on disk), a new Simulation resumed
  from DIR and run to the end; an uninterrupted run without ``out``; the contact forces of
  both; then the messages of what is refused: a stream into SERIAL (a serial run's directory)
  and a resume from it, a resume from a copy of DIR without rank 2's part of the last step, and with
  another partition in its run.json, and resumes from DIR with another γ0, another time scheme
  and another u0.
* ``fail DIR OUT`` (under mpiexec): runs streamed into DIR/part and DIR/archive, with a
  directory put (by an ``on_step``) where rank 1's part, or rank 0's archive, of step ``FAIL``
  goes; the OSError's message on every rank, the steps computed and the archives on disk; then
  DIR/part resumed (the obstacle removed) and run to the end, and an uninterrupted run.
* ``resume DIR OUT``: a resume from DIR; the message of every rank.
"""
import json
import pathlib
import shutil
import sys

import ngsolve as ngs

from ngcontact import parallel
from ngcontact.scenes import reference

DT, STEPS, STOP, FAIL = 2.5e-3, 10, 6, 4
T = STEPS * DT


class Interrupted(Exception):
    """Raised by an on_step after step STOP: the run stops as if killed there."""


def simulation(**options):
    return reference.simulation(1, 0.01, **dict(dict(switch_loop=False), **options))   # (as a distributed run)


def refusal(attempt):
    """The message of the ValueError ``attempt()`` raises on every rank, in rank order."""
    try:
        attempt()
        message = "no error"
    except ValueError as err:
        message = str(err)
    return parallel.every(sim.body.mesh, message)


def forces(history):
    return [record.contact.force.tolist() for record in history]


mode, directory, out = sys.argv[1], pathlib.Path(sys.argv[2]), sys.argv[-1]
sim = simulation()
found = dict(ranks=parallel.size(sim.body.mesh))
if mode == "serial":
    sim.run(DT, T, out=directory)
    last = sim.history[-1].contact
    found.update(force=forces(sim.history), midpoints=sim.side.midpoints.tolist(), pressure=last.pressure.tolist(),
                 beta=last.beta.tolist(), potential=last.potential.tolist())
elif mode == "run":
    def stop(record):
        if record.step == STOP:
            raise Interrupted
    try:
        sim.run(DT, T, out=directory, on_step=stop)
    except Interrupted:
        pass
    resumed = simulation().resume(directory)
    found["resumed_at"] = len(resumed.history) - 1
    resumed.run(DT, T, out=directory)
    sim = simulation()
    sim.run(DT, T)
    found.update(force=forces(resumed.history), uninterrupted=forces(sim.history))
    serial = pathlib.Path(sys.argv[3])
    found["out_serial"] = refusal(lambda: simulation().run(DT, T, out=serial))
    found["resume_serial"] = refusal(lambda: simulation().resume(serial))
    copy = directory.parent / "incomplete"
    if parallel.rank() == 0:
        shutil.copytree(directory, copy)
        (copy / "steps" / f"{STEPS:06d}.rank2.npz").unlink()
    parallel.barrier(sim.body.mesh)
    found["missing_part"] = refusal(lambda: simulation().resume(copy))
    info = json.loads((copy / "run.json").read_text())
    info["partition"][1]["ndof"] += 1                  # as if rank 1 had held another part of the mesh
    parallel.barrier(sim.body.mesh)
    if parallel.rank() == 0:
        (copy / "run.json").write_text(json.dumps(info))
    parallel.barrier(sim.body.mesh)
    found["partition"] = refusal(lambda: simulation().resume(copy))
    found["scene"] = refusal(lambda: simulation(contact=reference.contact(gamma0=100.0)).resume(directory))
    found["scheme"] = refusal(lambda: simulation(scheme="bdf2").resume(directory))
    found["start"] = refusal(lambda: simulation(u0=ngs.CF((0, -1e-7 * ngs.x / reference.L1))).resume(directory))
elif mode == "fail":
    def blocked(name):
        """An on_step that, after step FAIL − 1 is on disk, puts a directory where the file
        ``name`` of step FAIL goes (rank 0 does it; the step's collectives follow)."""
        def block(record):
            if record.step == FAIL - 1 and parallel.rank() == 0:
                (record_dir / "steps" / name.format(n=FAIL)).mkdir()
        return block
    for case, name in (("part", "{n:06d}.rank1.npz"), ("archive", "{n:06d}.npz")):
        record_dir = directory / case
        sim = simulation()
        try:
            sim.run(DT, T, out=record_dir, on_step=blocked(name))
            message = "no error"
        except OSError as err:
            message = f"{type(err).__name__}: {err}"
        found[case] = dict(messages=parallel.every(sim.body.mesh, message), computed=len(sim.history),
                           archives=sorted(p.name for p in (record_dir / "steps").glob("[0-9]*.npz") if p.is_file()))
    resumed = simulation().resume(directory / "part")
    found["resumed_at"] = len(resumed.history) - 1
    if parallel.rank() == 0:
        (directory / "part" / "steps" / f"{FAIL:06d}.rank1.npz").rmdir()
    parallel.barrier(resumed.body.mesh)
    resumed.run(DT, T, out=directory / "part")
    sim = simulation()
    sim.run(DT, T)
    found.update(force=forces(resumed.history), uninterrupted=forces(sim.history))
else:
    found["resume"] = refusal(lambda: simulation().resume(directory))
if parallel.rank() == 0:
    pathlib.Path(out).write_text(json.dumps(found))
