"""Streamed results: every computed step on disk as it is computed, and a run resumed from them.

``Simulation.run(dt, T, out=DIR)`` writes into DIR:

* ``run.json``: the run (dt, T, its start time, the global ndof, dimension, ngcontact
  version), the fingerprint of its scene (``ngcontact.output.fingerprint``) with the options of
  ``Simulation.run`` that change the results (``fingerprint.run_options``: dt, T, rtol,
  dt_min, event_dt, max_cutbacks, guess) and ``ranks``, the
  number of MPI ranks that wrote it (1 serially); on a distributed mesh also ``partition``:
  per rank its DOFs, its facets of Γ3 and a hash of its vertices and facets;
* ``steps/NNNNNN.npz``: one NumPy archive per computed step (cut-back steps included),
  numbered from 0 without gaps (a run begun after some steps stores their records first), with
  every field of its StepRecord (``time``, ``newton_iterations``, ``residuals``,
  ``reaction``, ``boundary_reaction/<name>``, ``electrode_charge/<name>``, ``timings/<phase>``,
  ...), of its ContactRecord as ``contact/<field>``, and the state a restart needs as
  ``restart/<part>``: the time scheme's own restart state (``save`` of a scheme in
  ``ngcontact.schemes``; backward Euler: the (u, φ) vector, β before and after clipping, the
  enforcement's own unknowns, the predictor's memory, t, and what Newton's next solve decides
  by, ``solver_restart.restart_state``: the rate c of the step system, Newton's norm scales, the
  values the kept factorisation factorised where they differ from the bulk, left out with
  ``run(restart_data=False)``; with the rule that compiles the Γ3 integrand, how far it has
  counted); run.json names the scheme;
* on a distributed mesh (``mpiexec -n N``) the restart state, and the record's ``state``
  (with ``keep_states``), are each rank's own: they go into ``steps/NNNNNN.rankR.npz``, one
  part per rank R = 0 .. N − 1 (rank 0's holds no DOFs), and ``steps/NNNNNN.npz`` holds the
  record (global on every rank; ``wall_s`` and ``timings`` are rank 0's);
* ``fields.pvd`` with ``vtk/fields_NNNNNN.vtu`` (u with 3 components and φ, NGSolve's
  ``VTKOutput``; on a distributed mesh ``vtk/fields_NNNNNN_procR.vtu``, one per computing rank
  R = 1 .. N − 1, listed as parts of each time step) and ``gamma3.pvd`` with
  ``vtk/gamma3_NNNNNN.vtu`` (the facets of Γ3 as lines in 2D, triangles in 3D, with u at their
  vertices as point data and β, the contact pressure, the multiplier, the charge flux density,
  the potential and the contact set as cell data; distributed: every rank's facets in rank
  order, as the records' arrays): binary ParaView time series that meshio reads too
  (``paraview``, docs/output.md).

The module reads a simulation through a ``Source`` (its mesh, fields, history, the scheme's
``save``, ...), never the Simulation itself; the restart state is whatever the time scheme
saves, and the simulation puts it back (``Simulation.resume``). ``run_directory`` reads the
files back and checks them.

Why one archive per step: a run may be killed at any moment (SIGKILL included), and a step
must then be either wholly on disk or absent. Each archive is written to a temporary name and
renamed (atomic on POSIX), so no kill leaves a half-written step; an HDF5 file that is killed
while its metadata is written can be left unreadable as a whole. On a distributed mesh every
rank renames its part into place, the ranks wait for each other, and rank 0 writes the step's
archive last: a step is on disk when its archive is (parts without an archive, of a run killed
in between, are ignored and overwritten). ``numpy.load`` reads the archives; ``read(DIR)``
stacks the records (of a distributed run too, in a serial process).

A write that fails (a full disk, a directory in the way, NGSolve's VTKOutput leaving a file
unwritten, which it does without a word) stops the run with an OSError on every rank, naming
the step, the rank and the file: no rank waits for ever in a collective operation that a
failed rank never reaches. The steps before it stay on disk, the step computed stays in the
simulation's history, and ``resume(DIR)`` continues from the last step on disk.

``Simulation.resume(DIR)`` puts the last step on disk back into a simulation of the same scene
and scheme (its history, and the scheme's restart state through its ``load``; distributed:
each rank its own parts), and ``run(dt, T, out=DIR)`` with the same options then computes only
the steps not yet reached, to the results of the run never interrupted, bitwise (serially; under
mpiexec MUMPS adds in the order messages arrive; written with ``run(restart_data=False)``, the
first solve factorises anew and the run continues to Newton's tolerance); a run that had reached T is complete, and
``run`` says so (``check_incomplete``). Both check first, on every rank, that DIR was written by
as many MPI ranks (a run is resumed under the ``mpiexec -n N`` that wrote it, a serial one
serially) with the mesh distributed alike, and that it holds this scene (the fingerprints
agree, and at resume the state at t = 0 too; a run of another time scheme is refused), and
``read``, ``resume`` and a continued stream that every step archive is there and readable
(and at resume every part of the last step): a ValueError names each differing field with
both values, or the file that is missing or damaged and what to do. The directory must be
one all ranks see (a shared file system on a cluster).
"""
import hashlib
import json
import numbers
import os
import pathlib
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from typing import Callable

import numpy as np

from ngcontact import parallel
from ngcontact.output.fingerprint import run_options
from ngcontact.output.paraview import checked_vtk, fields_writer, gamma3_vtu, own_vtu, vertex_displacement
from ngcontact.output.records import History
from ngcontact.solve.linalg.solver_restart import without_factorization
from ngcontact.time.stepping import MIN_DT, RESOLUTION
from ngcontact.output.run_directory import (check_partition, check_ranks, check_run, check_scene, check_scheme,
                                            check_start, load, load_part, part, read_steps, record_arrays, run_info)


@dataclass(frozen=True)
class Source:
    """What this module reads of a simulation (``Simulation.results_source`` makes it).

    mesh : the ngsolve.Mesh.  fields : (u, φ), GridFunctions written to VTK.
    subdivision : VTK's subdivision of the elements (the highest order − 1).
    side : the ContactSide Γ3, or None.  history : the History of the steps so far.
    description : JSON values of the run that must match at resume: ``ndof`` (global),
        ``dim``, ``model`` and ``scheme`` (the time scheme's name).
    fingerprint : T ↦ the scene's fingerprint for a run to T (``ngcontact.output.fingerprint``).
    save : () ↦ the time scheme's restart state, named numpy arrays (its ``save``).
    start : (the state vector (u, φ) at t = 0 as numpy, the ranges of u and φ in it; the
        rank's DOFs on a distributed mesh).
    """
    mesh: object
    fields: tuple
    subdivision: int
    side: object
    history: History
    description: dict
    fingerprint: Callable
    save: Callable
    start: tuple


def _version():
    try:
        return version("ngcontact")
    except PackageNotFoundError:
        return "unknown"


def _atomic_write(path, write):
    """Write a file through ``write(temporary path)`` and rename it into place."""
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    write(temporary)
    os.replace(temporary, path)


class Stream:
    """Writes the steps of a simulation's run into ``directory`` (see the module).

    dt, T, start : the run's nominal time step, final time and start time (s).
    rtol, dt_min, event_dt, max_cutbacks, guess : the other options of ``Simulation.run`` that
        change its results (dt_min and event_dt as used), stored with the fingerprint and
        compared with a run in ``directory`` (``fingerprint.run_options``).
    restart_data : False: the restart states leave out the solver's kept factorisation
        (``solver_restart.without_factorization``; run.json says ``solver_restart: false``).
    resumed : the run info ``restore`` returned if the simulation was resumed, else None.
        Resumed from ``directory``, the stream continues the steps on disk; otherwise it
        starts the directory afresh with the simulation's history so far (the records of
        the earlier steps, the last one with its restart state), replacing a run of the same
        scene, dt, T and number of ranks there. A directory holding another run (dt, T,
        start, number of ranks, distribution of the mesh or scene) is refused on every rank
        before anything is written."""

    def __init__(self, source, directory, dt, T, start, resumed=None, rtol=None, *, dt_min=None, event_dt=None,
                 max_cutbacks=None, guess=None, restart_data=True):
        self.source, self.dir, self.restart_data = source, pathlib.Path(directory), restart_data
        mesh = source.mesh
        self.lead = mesh.comm.rank == 0               # writes the archives and the series (rank 0)
        options = run_options(dt, T, rtol, dt_min, event_dt, max_cutbacks, guess)
        info = dict(dt=dt, T=T, start=start, rtol=rtol, **source.description, solver_restart=restart_data,
                    ngcontact=_version(),
                    format="one numpy archive per step, see ngcontact.output.results",
                    fingerprint=dict(source.fingerprint(T), **options), **_layout(source))
        self.ranks = info["ranks"]
        existing = parallel.together(mesh, run_info, self.dir)
        if existing is not None:
            parallel.together(mesh, check_run, existing, info, self.dir)
        continuing = resumed is not None and pathlib.Path(resumed["directory"]).resolve() == self.dir.resolve()
        self._times = {}                              # step -> time of the steps of this run on disk
        if continuing:
            self._times = {record.step: record.time for record in parallel.together(mesh, read, self.dir)[1]}
        try:
            parallel.together(mesh, self._prepare, continuing, info, errors=(OSError,))
        except OSError as err:
            raise type(err)(f"out: {str(self.dir)!r} could not be prepared for the run ({err})") from None
        # the facets of Γ3 in the order of the records' per-facet arrays (gathered in rank order)
        self._facets = None if source.side is None else parallel.gather(mesh, source.side.facet_vertices)
        if not continuing:
            for record in source.history[:-1]:        # steps computed before this run: records only
                self._save(record, restart=False)
            self(source.history[-1])                  # the state the run starts from

    def _prepare(self, continuing, info):
        """Rank 0: the directories, run.json, and the step archives of another run removed."""
        if not self.lead:
            return
        if not continuing:
            for path in self.dir.glob("steps/[0-9]*.npz"):
                path.unlink()                         # a new run replaces the old one (rank parts included)
        (self.dir / "steps").mkdir(parents=True, exist_ok=True)
        (self.dir / "vtk").mkdir(exist_ok=True)
        _atomic_write(self.dir / "run.json", lambda p: p.write_text(json.dumps(info, indent=1)))

    def __call__(self, record):
        """Write one step: its VTK files, (distributed) every rank's part, its archive last,
        so that a step on disk has all of them."""
        self._save(record, restart=True, vtk=True)

    def _save(self, record, restart, vtk=False):
        """The files of a step: each rank's own (with ``vtk`` the fields' VTK file; on a
        distributed mesh its part: the time scheme's restart state with ``restart``, the record's
        state), then, once every rank has written them, rank 0's: the archive of the record (with
        the restart state when serial; with ``vtk`` after the Γ3 file and the .pvd series). A
        write that fails on any rank raises an OSError on every rank, naming the step, the rank
        and the file, before any rank goes on (the steps before it stay on disk)."""
        arrays = record_arrays(record)
        saved = (self.source.save() if self.restart_data else without_factorization(self.source.save())) \
            if restart else {}
        own = {f"restart/{k}": np.asarray(v) for k, v in saved.items()}
        if self.ranks > 1:
            if "state" in arrays:
                own["state"] = arrays.pop("state")
        else:
            arrays.update(own)
        self._together(record.step, self._own_files, record, own, vtk)
        displacement = None
        if vtk and self._facets is not None:         # u at the vertices of Γ3, gathered as the facets
            mesh = self.source.mesh
            displacement = parallel.gather(mesh, vertex_displacement(mesh, self.source.fields[0],
                                                                     self.source.side.facet_vertices))
        self._together(record.step, self._lead_files, record, arrays, vtk, displacement)

    def _together(self, n, write, *args):
        """``write(*args)`` on every rank; an OSError on any rank raised on all (``parallel.together``)."""
        try:
            parallel.together(self.source.mesh, write, *args, errors=(OSError,))
        except OSError as err:
            raise type(err)(f"out: step {n} could not be written into {str(self.dir)!r} ({err}); the steps "
                            f"before it are on disk: resume({str(self.dir)!r}) continues from them") from None

    def _own_files(self, record, own, vtk):
        """This rank's files of a step: with ``vtk`` its VTK file of the fields (checked: NGSolve's
        VTKOutput does not report a file it could not write), on a distributed mesh its part."""
        n, mesh = record.step, self.source.mesh
        if vtk:
            stem = self.dir / "vtk" / f"fields_{n:06d}"
            checked_vtk(fields_writer(self.source, stem), record.time, own_vtu(mesh, stem))
        if self.ranks > 1:
            _atomic_write(part(self.dir, n, mesh.comm.rank), lambda p: _savez(p, own))

    def _lead_files(self, record, arrays, vtk, displacement):
        """Rank 0's files of a step, once every rank's own are on disk (``displacement``: u at
        the vertices of Γ3, for its file)."""
        if self.lead:
            if vtk:
                self._write_vtk(record, displacement)
            _atomic_write(self.dir / "steps" / f"{record.step:06d}.npz", lambda p: _savez(p, arrays))

    def _write_vtk(self, record, displacement):
        """The Γ3 file of a step (``displacement``: u at its vertices) and both .pvd series
        (after the fields' files of every rank)."""
        n, vtk = record.step, self.dir / "vtk"
        (vtk / f"fields_{n:06d}.pvd").unlink(missing_ok=True)      # VTKOutput's own (distributed)
        if record.contact is not None and self._facets is not None:
            _atomic_write(vtk / f"gamma3_{n:06d}.vtu", lambda p: p.write_bytes(
                gamma3_vtu(self._facets, displacement, record.contact)))
        self._times = {m: t for m, t in self._times.items() if m < n}     # a redone step replaces
        self._times[n] = record.time
        for name in ("fields", "gamma3"):
            entries = "".join(f'<DataSet timestep="{t!r}"{piece} file="vtk/{file}"/>\n'
                              for m, t in sorted(self._times.items()) for piece, file in self._pieces(name, m)
                              if (vtk / file).exists())
            if entries:
                _atomic_write(self.dir / f"{name}.pvd", lambda p, e=entries: p.write_text(
                    '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" byte_order="LittleEndian">\n'
                    f"<Collection>\n{e}</Collection>\n</VTKFile>\n"))

    def _pieces(self, name, m):
        """[(the part attribute, the file in vtk/)] of series ``name`` at step m: one file, or
        for the fields of a distributed mesh one per computing rank (VTKOutput's names)."""
        if name == "fields" and self.ranks > 1:
            return [(f' part="{r}"', f"fields_{m:06d}_proc{r}.vtu") for r in range(1, self.ranks)]
        return [("", f"{name}_{m:06d}.vtu")]


def _savez(path, arrays):
    with open(path, "wb") as f:
        np.savez(f, **arrays)
        f.flush()
        os.fsync(f.fileno())


def read(directory):
    """The steps on disk as (run info, History): the run.json dictionary and the StepRecords
    of every step, in order. Raises a ValueError naming the file if run.json is missing, a
    step archive is missing (they are numbered 0..N without gaps) or cannot be read."""
    info, history, _ = read_steps(pathlib.Path(directory))
    return info, history


def restore(source, directory):
    """The last step of ``directory`` for ``source`` (a freshly built simulation of the same
    scene and time scheme): (the run info with ``directory``, the History on disk, the
    scheme's restart state as named arrays, for its ``load``).

    The scene is checked first: the run must have been written by as many MPI ranks as this
    simulation runs on (1 serially), the time scheme named in run.json must be the source's,
    a distributed mesh distributed alike, the fingerprint stored there (``fingerprint``)
    must be this simulation's, and the state at t = 0 (u0 and the potential it gives) the
    one of step 0 on disk; a difference is a ValueError naming each differing field with
    both values (on every rank). A run.json without a fingerprint (written before
    ngcontact stored one) is refused: its scene cannot be checked, and continuing it with
    another scene is the silent wrong result this check exists to prevent; such a run is
    computed again into a new directory. On a distributed mesh each rank reads its own part
    of every step (its state) and the restart state of the last one."""
    if not isinstance(directory, (str, os.PathLike)):
        raise TypeError(f"resume: directory must be a path (str or pathlib.Path), got {directory!r}")
    directory = pathlib.Path(directory)
    if len(source.history) != 1:
        raise ValueError(f"resume: the simulation has computed {len(source.history) - 1} step(s) already; resume "
                         f"{str(directory)!r} into a freshly built simulation of its scene")
    mesh = source.mesh
    layout = dict(_layout(source), ndof=source.description["ndof"])
    info = parallel.together(mesh, _stored_run, directory, source.description["scheme"], layout)
    parallel.together(mesh, check_scene, info, source.fingerprint(info["T"]), directory, "resume")
    history, first, restart = parallel.together(mesh, _steps_to_resume, directory, info.get("ranks", 1),
                                                mesh.comm.rank)
    check_start(mesh, source.start, first.get("restart/state", first.get("state")), directory)
    return dict(info, directory=str(directory)), history, restart


def complete(info, t):
    """Whether the run of run.json ``info`` had reached its T when its last step on disk ended at
    ``t`` (s): to round-off of T and of its nominal dt (where ``Simulation.run``'s steps stop)."""
    T, dt = info.get("T"), info.get("dt")
    if not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in (T, dt, t)):
        return False
    return T - t <= max(MIN_DT, RESOLUTION * abs(t), 1e-12 * abs(T), 1e-9 * abs(dt))


def check_incomplete(resumed, history, T):
    """Raise if the run ``resumed`` (the run info of ``restore``; None: nothing to check) had
    reached its T (``complete``) and ``T``, the final time now asked for, is no later: the run is
    already complete. The message says where it ended and how to extend it (from its last state,
    into another directory: a run's directory keeps its T)."""
    if resumed is None or not history or not isinstance(T, numbers.Real) or isinstance(T, bool):
        return
    t, last, stored = history[-1].time, len(history) - 1, resumed["T"]
    if not (complete(resumed, t) and (T <= stored or T - t < max(MIN_DT, RESOLUTION * abs(t)))):
        return
    directory = resumed["directory"]
    raise ValueError(f"run: the run in {directory!r} is already complete: it reached its T = {stored:g} s at step "
                     f"{last} (t = {t:.9g} s), nothing is left to compute (ngcontact.results.read({directory!r}) "
                     f"reads it). To extend it, run(dt, T_later, out=<another directory>) continues from its last "
                     f"state (T_later > {t:.9g} s; the directory of a run keeps its T)")


def _stored_run(directory, scheme, layout):
    """The run.json of ``directory`` for a resume with the time scheme ``scheme`` and the
    ranks and partition ``layout`` (``_layout``), checked."""
    info = run_info(directory)
    if info is None:
        raise ValueError(f"resume: {str(directory)!r} holds no streamed run (no run.json)")
    check_ranks(info, layout["ranks"], directory, "resume")
    check_scheme(info, scheme, directory, "resume")
    check_partition(info, layout, directory, "resume")
    return info


def _steps_to_resume(directory, ranks, rank):
    """(History, the arrays of step 0, the restart state of the last step) of ``directory``
    for ``rank`` of ``ranks``: distributed, the records' states and the restart state from
    the rank's parts, every part of the last step on disk."""
    _, history, paths = read_steps(directory)
    if not history:
        raise ValueError(f"resume: {str(directory)!r} holds no computed step to resume from")
    last = len(paths) - 1
    if ranks > 1:
        for r in range(ranks):
            load_part(directory, last, r, last, load=False)
        own = [load_part(directory, n, rank, last) for n in range(last + 1)]
        for record, arrays in zip(history, own):
            record.state = arrays.get("state")
        first, final, named = own[0], own[-1], part(directory, last, rank)
    else:
        first, final, named = load(paths[0], 0, last)[1], load(paths[-1], last, last)[1], paths[-1]
    restart = {k[len("restart/"):]: v for k, v in final.items() if k.startswith("restart/")}
    if not {"t", "state"} <= set(restart):
        raise ValueError(f"resume: {str(named)!r} holds no restart state (the run was stopped while the "
                         "steps before it were written); run again into a new directory")
    return history, first, restart


def _layout(source):
    """How the run is split over MPI ranks, as stored in run.json: ``ranks`` (1 serially)
    and, on a distributed mesh, ``partition``: per rank its DOFs, its facets of Γ3 and a
    hash of its vertices and facets (the same mesh on the same ranks is distributed alike)."""
    mesh = source.mesh
    layout = dict(ranks=parallel.size(mesh))
    if parallel.is_distributed(mesh):
        facets = np.zeros((0,)) if source.side is None else source.side.facet_vertices
        digest = hashlib.sha256(np.round(mesh.ngmesh.Coordinates(), 12) + 0.0)       # + 0.0: no -0.0
        digest.update(np.round(facets, 12) + 0.0)
        layout["partition"] = parallel.every(mesh, dict(ndof=len(source.start[0]), facets=len(facets),
                                                        hash=digest.hexdigest()[:16]))
    return layout
