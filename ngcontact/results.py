"""Streamed results: every computed step on disk as it is computed, and a run resumed from them.

``Simulation.run(dt, T, out=DIR)`` writes into DIR:

* ``run.json``: the run (dt, T, its start time, ndof, dimension, ngcontact version) and the
  fingerprint of its scene (``ngcontact.fingerprint``);
* ``steps/NNNNNN.npz``: one NumPy archive per computed step (cut-back steps included),
  numbered from 0 without gaps (a run begun after some steps stores their records first), with
  every field of its StepRecord (``time``, ``newton_iterations``, ``residuals``,
  ``reaction``, ``boundary_reaction/<name>``, ``electrode_charge/<name>``, ``timings/<phase>``,
  ...), of its ContactRecord as ``contact/<field>``, and the state a restart needs as
  ``restart/<part>``: the time scheme's own restart state (``save`` of a scheme in
  ``ngcontact.schemes``; backward Euler: the (u, φ) vector, β before and after clipping, the
  enforcement's own unknowns, the predictor's memory, t); run.json names the scheme;
* ``fields.pvd`` with ``vtk/fields_NNNNNN.vtu`` (u and φ, NGSolve's ``VTKOutput``) and
  ``gamma3.pvd`` with ``vtk/gamma3_NNNNNN.vtp`` (the facets of Γ3 with β, the contact
  pressure, the multiplier, the charge flux density, the potential and the contact set as
  cell data): ParaView time series.

The module reads a simulation through a ``Source`` (its mesh, fields, history, the scheme's
``save``, ...), never the Simulation itself; the restart state is whatever the time scheme
saves, and the simulation puts it back (``Simulation.resume``).

Why one archive per step: a run may be killed at any moment (SIGKILL included), and a step
must then be either wholly on disk or absent. Each archive is written to a temporary name and
renamed (atomic on POSIX), so no kill leaves a half-written step; an HDF5 file that is killed
while its metadata is written can be left unreadable as a whole. ``numpy.load`` reads the
archives; ``read(DIR)`` stacks them into arrays.

``Simulation.resume(DIR)`` puts the last step on disk back into a simulation of the same scene
and scheme (its history, and the scheme's restart state through its ``load``), and
``run(dt, T, out=DIR)`` with the same dt and T then computes only the nominal steps not yet
reached. Both check first that DIR holds this scene (the fingerprints agree, and at resume
the state at t = 0 too; a run of another time scheme is refused) and ``read``, ``resume`` and a
continued stream that every step
archive is there and readable: a ValueError names each differing field with both values, or
the archive that is missing or damaged and what to do.
"""
import json
import os
import pathlib
import zipfile
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from typing import Callable

import ngsolve as ngs
import numpy as np

from . import parallel
from .fingerprint import mismatch
from .records import ContactRecord, History, StepRecord

DICTS = ("boundary_reaction", "electrode_charge", "timings")
SCHEME_OF_OLD = "backward_euler"
"""The scheme of a run.json written before runs named their time scheme."""


@dataclass(frozen=True)
class Source:
    """What this module reads of a simulation (``Simulation.results_source`` makes it).

    mesh : the ngsolve.Mesh.  fields : (u, φ), GridFunctions written to VTK.
    subdivision : VTK's subdivision of the elements (the highest order − 1).
    side : the ContactSide Γ3, or None.  history : the History of the steps so far.
    description : JSON values of the run that must match at resume: ``ndof``, ``dim``,
        ``model`` and ``scheme`` (the time scheme's name).
    fingerprint : T ↦ the scene's fingerprint for a run to T (``ngcontact.fingerprint``).
    save : () ↦ the time scheme's restart state, named numpy arrays (its ``save``).
    start : (the state vector (u, φ) at t = 0 as numpy, the ranges of u and φ in it).
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
    resumed : the run info ``restore`` returned if the simulation was resumed, else None.
        Resumed from ``directory``, the stream continues the steps on disk; otherwise it
        starts the directory afresh with the simulation's history so far (the records of
        the earlier steps, the last one with its restart state), replacing a run of the same
        scene, dt and T there. A directory holding another run (dt, T, start or scene) is
        refused before anything is written."""

    def __init__(self, source, directory, dt, T, start, resumed=None, rtol=None):
        parallel.serial_only(source.mesh, "run(out=...): streaming the results", "each rank holds part of the state")
        self.source, self.dir = source, pathlib.Path(directory)
        info = dict(dt=dt, T=T, start=start, rtol=rtol, **source.description, ngcontact=_version(),
                    format="one numpy archive per step, see ngcontact.results", fingerprint=source.fingerprint(T))
        existing = _run_info(self.dir)
        if existing is not None:
            if any(existing.get(k) != info[k] for k in ("dt", "T", "start", "rtol")):
                raise ValueError(f"out: {str(self.dir)!r} holds another run (dt {existing.get('dt')}, T "
                                 f"{existing.get('T')}, start {existing.get('start')}, rtol {existing.get('rtol')}); "
                                 "resume it with the same dt, T and rtol, or write to a new directory")
            _check_scheme(existing, info["scheme"], self.dir, "out")
            _check_scene(existing, info["fingerprint"], self.dir, "out")
        continuing = resumed is not None and pathlib.Path(resumed["directory"]).resolve() == self.dir.resolve()
        self._times = {}                              # step -> time of the steps of this run on disk
        if continuing:
            self._times = {record.step: record.time for record in read(self.dir)[1]}
        else:
            for path in self.dir.glob("steps/[0-9]*.npz"):
                path.unlink()                         # a new run replaces the old one
        (self.dir / "steps").mkdir(parents=True, exist_ok=True)
        (self.dir / "vtk").mkdir(exist_ok=True)
        _atomic_write(self.dir / "run.json", lambda p: p.write_text(json.dumps(info, indent=1)))
        if not continuing:
            for record in source.history[:-1]:        # steps computed before this run: records only
                self._save(record, restart=False)
            self(source.history[-1])                  # the state the run starts from

    def __call__(self, record):
        """Write one step: its archive last, so that a step on disk has its VTK files too."""
        self._write_vtk(record.step, record)
        self._save(record, restart=True)

    def _save(self, record, restart):
        """The archive of a step: its record, and with ``restart`` the time scheme's restart state."""
        arrays = record_arrays(record)
        if restart:
            arrays.update({f"restart/{k}": np.asarray(v) for k, v in self.source.save().items()})
        _atomic_write(self.dir / "steps" / f"{record.step:06d}.npz", lambda p: _savez(p, arrays))

    def _write_vtk(self, n, record):
        source = self.source
        fields_writer(source, self.dir / "vtk" / f"fields_{n:06d}").Do(time=record.time)
        (self.dir / "vtk" / f"fields_{n:06d}.pvd").unlink(missing_ok=True)
        if record.contact is not None:
            _atomic_write(self.dir / "vtk" / f"gamma3_{n:06d}.vtp",
                          lambda p: p.write_text(_gamma3_vtp(source.side, record.contact)))
        self._times = {m: t for m, t in self._times.items() if m < n}     # a redone step replaces
        self._times[n] = record.time
        for name, ext in (("fields", "vtu"), ("gamma3", "vtp")):
            entries = "".join(f'<DataSet timestep="{t!r}" file="vtk/{name}_{m:06d}.{ext}"/>\n'
                              for m, t in sorted(self._times.items())
                              if (self.dir / "vtk" / f"{name}_{m:06d}.{ext}").exists())
            if entries:
                _atomic_write(self.dir / f"{name}.pvd", lambda p, e=entries: p.write_text(
                    '<?xml version="1.0"?>\n<VTKFile type="Collection" version="1.0" byte_order="LittleEndian">\n'
                    f"<Collection>\n{e}</Collection>\n</VTKFile>\n"))


def fields_writer(source, filename, **options):
    """NGSolve's VTKOutput of u and φ ("displacement", "potential") of ``source`` into
    ``filename`` (a stem; ``options`` such as ``legacy=False`` go to VTKOutput)."""
    return ngs.VTKOutput(source.mesh, coefs=list(source.fields), names=["displacement", "potential"],
                         filename=str(filename), subdivision=source.subdivision, **options)


def _savez(path, arrays):
    with open(path, "wb") as f:
        np.savez(f, **arrays)
        f.flush()
        os.fsync(f.fileno())


def _gamma3_vtp(side, contact):
    """The facets of Γ3 as VTK PolyData (lines in 2D, triangles in 3D), fields as cell data."""
    facets, dim = side.facet_vertices, side.dim
    points = np.zeros((facets.shape[0] * dim, 3))
    points[:, :dim] = facets.reshape(-1, dim)
    cells = np.arange(len(points)).reshape(-1, dim)
    offsets = np.arange(1, len(facets) + 1) * dim
    kind = "Lines" if dim == 2 else "Polys"

    def array(name, values, typ="Float64", components=1):
        text = " ".join(repr(float(v)) if typ == "Float64" else str(int(v)) for v in np.ravel(values))
        return (f'<DataArray type="{typ}" Name="{name}" NumberOfComponents="{components}" format="ascii">'
                f"{text}</DataArray>\n")
    fields = dict(beta=contact.beta, pressure=contact.pressure, multiplier=contact.multiplier,
                  charge_flux_density=contact.charge_flux_density, potential=contact.potential,
                  contact_set=contact.contact_set)
    counts = f'NumberOfLines="{len(facets) if dim == 2 else 0}" NumberOfPolys="{len(facets) if dim == 3 else 0}"'
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">\n'
            f'<PolyData>\n<Piece NumberOfPoints="{len(points)}" NumberOfVerts="0" {counts} NumberOfStrips="0">\n'
            "<Points>\n" + array("points", points, components=3) + "</Points>\n"
            f"<{kind}>\n" + array("connectivity", cells, "Int64") + array("offsets", offsets, "Int64")
            + f"</{kind}>\n<CellData>\n" + "".join(array(k, v) for k, v in fields.items())
            + "</CellData>\n</Piece>\n</PolyData>\n</VTKFile>\n")


# ----------------------------------------------------------------------- records <-> arrays

def record_arrays(record):
    """A StepRecord as flat named arrays (dictionaries and the ContactRecord with prefixes)."""
    arrays = {}
    for key, value in vars(record).items():
        if key == "contact":
            if value is not None:
                arrays.update({f"contact/{k}": np.asarray(v) for k, v in vars(value).items() if v is not None})
        elif key in DICTS:
            arrays.update({f"{key}/{k}": np.asarray(v) for k, v in value.items()})
        elif value is not None:
            arrays[key] = np.asarray(value)
    return arrays


def record_from_arrays(data):
    """The StepRecord of ``record_arrays``."""
    plain, dicts, contact = {}, {k: {} for k in DICTS}, {}
    for key in data:
        if key.startswith("restart/"):
            continue
        head, _, tail = key.partition("/")
        value = data[key]
        if head == "contact":
            contact[tail] = value if value.ndim else value.item()
        elif head in DICTS:
            dicts[head][tail] = value if value.ndim else value.item()
        else:
            plain[head] = value if value.ndim else value.item()
    plain["residuals"] = list(np.atleast_1d(plain["residuals"]))
    return StepRecord(**plain, **dicts, contact=ContactRecord(**contact) if contact else None)


def read(directory):
    """The steps on disk as (run info, History): the run.json dictionary and the StepRecords
    of every step, in order. Raises a ValueError naming the file if run.json is missing, a
    step archive is missing (they are numbered 0..N without gaps) or cannot be read."""
    info, history, _ = _read(pathlib.Path(directory))
    return info, history


def restore(source, directory):
    """The last step of ``directory`` for ``source`` (a freshly built simulation of the same
    scene and time scheme): (the run info with ``directory``, the History on disk, the
    scheme's restart state as named arrays, for its ``load``).

    The scene is checked first: the time scheme named in run.json must be the source's, the
    fingerprint stored there (``fingerprint``) must be this simulation's, and the state at
    t = 0 (u0 and the potential it gives) the one of step 0 on disk; a difference is a
    ValueError naming each differing field with both values. A run.json without a
    fingerprint (written before ngcontact stored one) is refused: its scene cannot be
    checked, and continuing it with another scene is the silent wrong result this check
    exists to prevent; such a run is computed again into a new directory."""
    parallel.serial_only(source.mesh, "resume()", "streaming the results is serial only")
    if not isinstance(directory, (str, os.PathLike)):
        raise TypeError(f"resume: directory must be a path (str or pathlib.Path), got {directory!r}")
    directory = pathlib.Path(directory)
    if len(source.history) != 1:
        raise ValueError(f"resume: the simulation has computed {len(source.history) - 1} step(s) already; resume "
                         f"{str(directory)!r} into a freshly built simulation of its scene")
    info = _run_info(directory)
    if info is None:
        raise ValueError(f"resume: {str(directory)!r} holds no streamed run (no run.json)")
    _check_scheme(info, source.description["scheme"], directory, "resume")
    _check_scene(info, source.fingerprint(info["T"]), directory, "resume")
    info, history, paths = _read(directory)
    if not history:
        raise ValueError(f"resume: {str(directory)!r} holds no computed step to resume from")
    first = _load(paths[0], 0, len(paths) - 1)[1]
    _check_start(source.start, first.get("restart/state", first.get("state")), directory)
    restart = {k[len("restart/"):]: v for k, v in _load(paths[-1], len(paths) - 1, len(paths) - 1)[1].items()
               if k.startswith("restart/")}
    if not {"t", "state"} <= set(restart):
        raise ValueError(f"resume: {str(paths[-1])!r} holds no restart state (the run was stopped while the "
                         "steps before it were written); run again into a new directory")
    return dict(info, directory=str(directory)), history, restart


# ----------------------------------------------------------------------- checks of a directory

def _run_info(directory):
    """The run.json of ``directory`` as a dictionary, or None if there is none."""
    path = directory / "run.json"
    if not path.exists():
        return None
    try:
        info = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise ValueError(f"{str(path)!r} cannot be read ({err}); it is not a run of ngcontact.results") from None
    if not isinstance(info, dict) or not {"dt", "T", "start"} <= set(info):
        raise ValueError(f"{str(path)!r} lacks dt, T or start: it is not a run of ngcontact.results")
    return info


def _check_scheme(info, scheme, directory, who):
    """Raise unless the run ``info`` was computed with the time scheme ``scheme``."""
    stored = info.get("scheme", SCHEME_OF_OLD)
    if stored != scheme:
        raise ValueError(f"{who}: {str(directory)!r} holds a run of the time scheme {stored!r}, this simulation's "
                         f"scheme is {scheme!r}: build it with Simulation(scheme={stored!r}), or write to a new "
                         "directory")


def _check_scene(info, current, directory, who):
    """Raise unless the fingerprint ``current`` is the one stored in the run ``info``."""
    if "fingerprint" not in info:
        raise ValueError(f"{who}: {str(directory)!r} holds a run written before ngcontact stored the scene of a "
                         "run (no fingerprint in run.json): whether this simulation is its scene cannot be "
                         "checked; run again into a new directory")
    found = mismatch(info["fingerprint"], current)
    if found:
        raise ValueError(f"{who}: {str(directory)!r} was computed with {found}: not the same scene")


def _check_start(start, saved, directory):
    """Raise unless ``saved``, the state of step 0 on disk (or None), is the state at t = 0 of
    ``start`` (``Source.start``) to 1e-8 of its size, for u and φ apart (u0, and φ0 from the
    data at t = 0)."""
    now, ranges = start
    if saved is None or len(saved) != len(now):
        return
    for (name, unit), r in zip((("u", "m"), ("φ", "V")), ranges):
        part = slice(r.start, r.stop)
        difference = np.abs(saved[part] - now[part]).max(initial=0.0)
        size = max(np.abs(saved[part]).max(initial=0.0), np.abs(now[part]).max(initial=0.0))
        if difference > 1e-8 * size:
            raise ValueError(f"resume: {str(directory)!r} starts from another state at t = 0: {name} differs from "
                             f"this simulation's by up to {difference:.3g} {unit} (of {size:.3g} {unit}; another "
                             "u0?): not the same scene")


def _read(directory):
    """(run info, History, archive paths) of ``directory``, every archive checked."""
    info = _run_info(directory)
    if info is None:
        raise ValueError(f"{str(directory)!r} holds no streamed run (no run.json)")
    paths = _archives(directory)
    history = History()
    for n, path in enumerate(paths):
        history.append(_load(path, n, len(paths) - 1)[0])
    return info, history, paths


def _archives(directory):
    """The step archives of ``directory`` in order, numbered 0..N without gaps."""
    found = {int(p.stem): p for p in directory.glob("steps/*.npz") if p.stem.isdigit()}
    last = max(found, default=-1)
    missing = [n for n in range(last + 1) if n not in found]
    if missing:
        names = ", ".join(f"steps/{n:06d}.npz" for n in missing[:5]) + (", ..." if len(missing) > 5 else "")
        verb = "are" if len(missing) > 1 else "is"
        first = missing[0]
        what = ("run again into a new directory" if first == 0 else
                f"delete the archives after steps/{first - 1:06d}.npz to resume from step {first - 1}")
        raise ValueError(f"{str(directory)!r}: {names} {verb} missing (the step archives are numbered "
                         f"000000 to {last:06d} without gaps); {what}")
    return [found[n] for n in range(last + 1)]


def _load(path, n, last):
    """(StepRecord, arrays) of the archive ``path`` of step n (of 0..last), or a ValueError
    naming the file, what is wrong and what to do."""
    try:
        with np.load(path) as data:
            arrays = {key: data[key] for key in data}
        record = record_from_arrays(arrays)
    except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
        problem = f"cannot be read ({type(err).__name__}: {err}): it was cut short or overwritten"
    else:
        if record.step == n:
            return record, arrays
        problem = f"holds step {record.step}, not {n}"
    later = f" and the later ones (to {last:06d}.npz)" if last > n else ""
    what = "run again into a new directory" if n == 0 else f"delete it{later} to resume from step {n - 1}"
    raise ValueError(f"{str(path)!r}: the step archive {problem}; {what}")
