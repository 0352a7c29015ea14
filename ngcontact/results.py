"""Streamed results: every computed step on disk as it is computed, and a run resumed from them.

``Simulation.run(dt, T, out=DIR)`` writes into DIR:

* ``run.json``: the run (dt, T, its start time, ndof, dimension, ngcontact version);
* ``steps/NNNNNN.npz``: one NumPy archive per computed step (cut-back steps included), with
  every field of its StepRecord (``time``, ``newton_iterations``, ``residuals``,
  ``reaction``, ``boundary_reaction/<name>``, ``electrode_charge/<name>``, ``timings/<phase>``,
  ...), of its ContactRecord as ``contact/<field>``, and the state a restart needs as
  ``restart/<part>`` (the (u, φ) vector, β before and after clipping, the enforcement's own
  unknowns, the predictor's memory, t);
* ``fields.pvd`` with ``vtk/fields_NNNNNN.vtu`` (u and φ, NGSolve's ``VTKOutput``) and
  ``gamma3.pvd`` with ``vtk/gamma3_NNNNNN.vtp`` (the facets of Γ3 with β, the contact
  pressure, the multiplier, the charge flux density, the potential and the contact set as
  cell data): ParaView time series.

Why one archive per step: a run may be killed at any moment (SIGKILL included), and a step
must then be either wholly on disk or absent. Each archive is written to a temporary name and
renamed (atomic on POSIX), so no kill leaves a half-written step; an HDF5 file that is killed
while its metadata is written can be left unreadable as a whole. ``numpy.load`` reads the
archives; ``read(DIR)`` stacks them into arrays.

``Simulation.resume(DIR)`` puts the last step on disk back into a simulation of the same scene
(history, time, state, β, the enforcement's unknowns, the predictor's memory), and
``run(dt, T, out=DIR)`` with the same dt and T then computes only the nominal steps not yet
reached.
"""
import json
import os
import pathlib
from importlib.metadata import PackageNotFoundError, version

import ngsolve as ngs
import numpy as np

from . import parallel
from .records import ContactRecord, History, StepRecord

DICTS = ("boundary_reaction", "electrode_charge", "timings")


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
    """Writes the steps of a simulation's run into ``directory`` (see the module)."""

    def __init__(self, sim, directory, dt, T, start):
        parallel.serial_only(sim.body.mesh, "run(out=...): streaming the results", "each rank holds part of the state")
        self.sim, self.dir = sim, pathlib.Path(directory)
        (self.dir / "steps").mkdir(parents=True, exist_ok=True)
        (self.dir / "vtk").mkdir(exist_ok=True)
        info = dict(dt=dt, T=T, start=start, ndof=sim.X.ndof, dim=sim.body.dim, ngcontact=_version(),
                    model=sim.model, format="one numpy archive per step, see ngcontact.results")
        existing = self._info()
        if existing is not None and any(existing[k] != info[k] for k in ("dt", "T", "start", "ndof", "dim")):
            raise ValueError(f"out: {str(self.dir)!r} holds another run (dt {existing['dt']}, T {existing['T']}, "
                             f"start {existing['start']}, ndof {existing['ndof']}); resume it with the same dt "
                             "and T, or write to a new directory")
        _atomic_write(self.dir / "run.json", lambda p: p.write_text(json.dumps(info, indent=1)))
        self._times = {}                              # step -> time of the steps on disk
        for path in (self.dir / "steps").glob("[0-9]*.npz"):
            with np.load(path) as data:
                self._times[int(path.stem)] = float(data["time"])

    def _info(self):
        path = self.dir / "run.json"
        return json.loads(path.read_text()) if path.exists() else None

    def __call__(self, record):
        """Write one step: its archive last, so that a step on disk has its VTK files too."""
        n = record.step
        self._write_vtk(n, record)
        arrays = record_arrays(record)
        arrays.update({f"restart/{k}": v for k, v in restart_arrays(self.sim).items()})
        _atomic_write(self.dir / "steps" / f"{n:06d}.npz", lambda p: _savez(p, arrays))

    def _write_vtk(self, n, record):
        sim = self.sim
        order = max(sim.body.order, sim.body.order_phi)
        writer = ngs.VTKOutput(sim.body.mesh, coefs=[sim.u, sim.phi], names=["displacement", "potential"],
                               filename=str(self.dir / "vtk" / f"fields_{n:06d}"), subdivision=order - 1)
        writer.Do(time=record.time)
        (self.dir / "vtk" / f"fields_{n:06d}.pvd").unlink(missing_ok=True)
        if record.contact is not None:
            _atomic_write(self.dir / "vtk" / f"gamma3_{n:06d}.vtp",
                          lambda p: p.write_text(_gamma3_vtp(sim.side, record.contact)))
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


def restart_arrays(sim):
    """What a restart needs beyond the record: the scheme's checkpoint as arrays."""
    saved = sim.scheme.checkpoint()
    arrays = dict(t=np.asarray(saved.t), state=saved.state)
    if saved.beta is not None:
        arrays.update(beta=saved.beta, beta_unclipped=saved.beta_unclipped)
    if saved.hook is not None:
        arrays["hook"] = np.asarray(saved.hook)
    if saved.last is not None:
        arrays.update(last_state=saved.last[0], last_dt=np.asarray(saved.last[1]))
    return arrays


def read(directory):
    """The steps on disk as (run info, History): the run.json dictionary and the StepRecords
    of every complete step, in order."""
    directory = pathlib.Path(directory)
    if not (directory / "run.json").exists():
        raise ValueError(f"{str(directory)!r} holds no streamed run (no run.json)")
    info = json.loads((directory / "run.json").read_text())
    history = History()
    for path in sorted((directory / "steps").glob("[0-9]*.npz")):
        with np.load(path) as data:
            history.append(record_from_arrays(data))
    return info, history


def restore(sim, directory):
    """Put the last step of ``directory`` back into ``sim`` (a new simulation of the same
    scene): its history, time, state, β, the enforcement's unknowns, the predictor's memory.
    Returns the run info."""
    from .backward_euler import Checkpoint
    parallel.serial_only(sim.body.mesh, "resume()", "streaming the results is serial only")
    info, history = read(directory)
    if not history:
        raise ValueError(f"{str(directory)!r} holds no computed step to resume from")
    if info["ndof"] != sim.X.ndof or info["dim"] != sim.body.dim:
        raise ValueError(f"{str(directory)!r} holds a run with {info['ndof']} DOFs in {info['dim']}D; this "
                         f"simulation has {sim.X.ndof} in {sim.body.dim}D: not the same scene")
    last = sorted(pathlib.Path(directory, "steps").glob("[0-9]*.npz"))[-1]
    with np.load(last) as data:
        r = {k[len("restart/"):]: data[k] for k in data if k.startswith("restart/")}
    saved = Checkpoint(float(r["t"]), r["state"], r.get("beta"), r.get("beta_unclipped"),
                       r.get("hook"), (r["last_state"], float(r["last_dt"])) if "last_state" in r else None)
    sim.scheme.restore(saved)
    sim.history[:] = history
    return info
