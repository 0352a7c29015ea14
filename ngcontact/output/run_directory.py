"""The directory of a streamed run (``results``): its files read back and checked.

``run.json`` is read and compared with a run about to be written or resumed (the options of
``Simulation.run``: dt, T, rtol, dt_min, event_dt, max_cutbacks, guess; the number of MPI
ranks, the time scheme, the partition of a distributed mesh, the scene's fingerprint, the state
at t = 0); the step archives and the ranks' parts are read back, and a missing or damaged one
is a ValueError naming the file, what is wrong and what to do.
"""
import json
import zipfile

import numpy as np

from ngcontact import parallel
from ngcontact.output.fingerprint import RUN_OPTIONS, mismatch
from ngcontact.output.records import ContactRecord, History, StepRecord

DICTS = ("boundary_reaction", "electrode_charge", "timings")
SCHEME_OF_OLD = "backward_euler"
"""The scheme of a run.json written before runs named their time scheme."""


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


def run_info(directory):
    """The run.json of ``directory`` as a dictionary, or None if there is none."""
    path = directory / "run.json"
    if not path.exists():
        return None
    try:
        info = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise ValueError(f"{str(path)!r} cannot be read ({err}); it is not a run of ngcontact.output.results") from None
    if not isinstance(info, dict) or not {"dt", "T", "start"} <= set(info):
        raise ValueError(f"{str(path)!r} lacks dt, T or start: it is not a run of ngcontact.output.results")
    return info


_ABSENT = object()


def run_options(info):
    """{option: value} of the options of ``Simulation.run`` (``fingerprint.RUN_OPTIONS``) of
    the run ``info``: from its fingerprint's ``run.*`` fields; a run.json written before they
    were stored has dt, T and rtol alone (the others absent)."""
    stored = info.get("fingerprint") or {}
    if "run.dt" in stored:
        return {k: stored.get(f"run.{k}", _ABSENT) for k in RUN_OPTIONS}
    return {k: info.get(k, _ABSENT) if k in ("dt", "T", "rtol") else _ABSENT for k in RUN_OPTIONS}


def _option(name, value):
    """An option of ``run`` and its value, for a message."""
    return f"{name} {'none' if value is None else repr(value)}"


def check_run(existing, info, directory):
    """Raise unless a new stream with run.json ``info`` may write into ``directory``, which
    holds the run ``existing``: the same options of ``run`` (``run_options``: dt, T, rtol,
    dt_min, event_dt, max_cutbacks, guess), start, ranks, scheme, partition and scene. A
    differing option is named with both values."""
    if "fingerprint" not in existing:
        check_scene(existing, info["fingerprint"], directory, "out")          # says so
    stored, now = run_options(existing), run_options(info)
    absent = [k for k in RUN_OPTIONS if stored[k] is _ABSENT]
    if absent:
        raise ValueError(f"out: {str(directory)!r} holds a run of an earlier ngcontact, which did not record "
                         f"{', '.join(absent)} (the options of run that change its results): whether this run "
                         "continues it cannot be checked; run again into a new directory")
    differing = [k for k in RUN_OPTIONS if stored[k] != now[k]]
    if differing:
        there, here = (", ".join(_option(k, options[k]) for k in differing) for options in (stored, now))
        raise ValueError(f"out: {str(directory)!r} holds another run ({there}; this run has {here}): resume it with "
                         f"the same {', '.join(RUN_OPTIONS[:-1])} and {RUN_OPTIONS[-1]}, or write to a new directory")
    if existing.get("start") != info["start"]:
        raise ValueError(f"out: {str(directory)!r} holds another run, begun at t = {existing.get('start')} s; this "
                         f"run begins at t = {info['start']} s: resume({str(directory)!r}) continues it, or write "
                         "to a new directory")
    check_ranks(existing, info["ranks"], directory, "out")
    check_scheme(existing, info["scheme"], directory, "out")
    check_partition(existing, info, directory, "out")
    check_scene(existing, info["fingerprint"], directory, "out")


def _written(ranks):
    """How a run on ``ranks`` MPI ranks runs, for a message."""
    return f"on {ranks} MPI ranks (mpiexec -n {ranks})" if ranks > 1 else "serially (1 process)"


def _rerun(ranks):
    """How to start a run on ``ranks`` MPI ranks again, for a message."""
    return f"under mpiexec -n {ranks}" if ranks > 1 else "serially (without mpiexec)"


def _instead(who):
    """The other way out of a refusal to ``who`` ("resume" or "out")."""
    return "run again into a new directory" if who == "resume" else "write to a new directory"


def check_ranks(info, ranks, directory, who):
    """Raise unless the run ``info`` was written by ``ranks`` MPI ranks (1: serially; a
    run.json without ``ranks`` is serial)."""
    stored = info.get("ranks", 1)
    if stored != ranks:
        what = "resume it" if who == "resume" else "continue it (resume, then run)"
        raise ValueError(f"{who}: {str(directory)!r} was written {_written(stored)}, this simulation runs "
                         f"{_written(ranks)}: every rank reads back its own part of each step; {what} "
                         f"{_rerun(stored)}, or {_instead(who)}")


def check_partition(info, layout, directory, who):
    """Raise unless the run ``info`` split its mesh over the ranks as ``layout`` does."""
    stored, now = info.get("partition"), layout.get("partition")
    if stored == now:
        return
    r = next(r for r in range(len(now)) if stored[r] != now[r])
    raise ValueError(f"{who}: {str(directory)!r} was written with its mesh distributed otherwise: rank {r} held "
                     f"{stored[r]['ndof']} DOFs and {stored[r]['facets']} facets of Γ3 (hash {stored[r]['hash']}) of "
                     f"{info.get('ndof')} DOFs, this simulation's rank {r} holds {now[r]['ndof']} and "
                     f"{now[r]['facets']} (hash {now[r]['hash']}) of {layout['ndof']}: another "
                     f"mesh or order, or another partition of it (METIS); use the mesh of the run {_rerun(len(now))}, "
                     f"or {_instead(who)}")


def check_scheme(info, scheme, directory, who):
    """Raise unless the run ``info`` was computed with the time scheme ``scheme``."""
    stored = info.get("scheme", SCHEME_OF_OLD)
    if stored != scheme:
        raise ValueError(f"{who}: {str(directory)!r} holds a run of the time scheme {stored!r}, this simulation's "
                         f"scheme is {scheme!r}: build it with Simulation(scheme={stored!r}), or write to a new "
                         "directory")


def check_scene(info, current, directory, who):
    """Raise unless the fingerprint ``current`` is the one stored in the run ``info``."""
    if "fingerprint" not in info:
        raise ValueError(f"{who}: {str(directory)!r} holds a run written before ngcontact stored the scene of a "
                         "run (no fingerprint in run.json): whether this simulation is its scene cannot be "
                         "checked; run again into a new directory")
    def scene(found):                     # the options of ``run`` are compared by ``check_run``
        return {k: v for k, v in found.items() if not k.startswith("run.")}
    found = mismatch(scene(info["fingerprint"]), scene(current))
    if found:
        raise ValueError(f"{who}: {str(directory)!r} was computed with {found}: not the same scene")


def check_start(mesh, start, saved, directory):
    """Raise unless ``saved``, the state of step 0 on disk (or None), is the state at t = 0 of
    ``start`` (``Source.start``) to 1e-8 of its size, for u and φ apart (u0, and φ0 from the
    data at t = 0); on a distributed mesh the rank's parts, the largest values over the ranks."""
    now, ranges = start
    if parallel.any_rank(mesh, saved is None or len(saved) != len(now)):
        return
    for (name, unit), r in zip((("u", "m"), ("φ", "V")), ranges):
        part = slice(r.start, r.stop)
        difference = parallel.maximum(mesh, np.abs(saved[part] - now[part]), initial=0.0)
        size = max(parallel.maximum(mesh, np.abs(saved[part]), initial=0.0),
                   parallel.maximum(mesh, np.abs(now[part]), initial=0.0))
        if difference > 1e-8 * size:
            raise ValueError(f"resume: {str(directory)!r} starts from another state at t = 0: {name} differs from "
                             f"this simulation's by up to {difference:.3g} {unit} (of {size:.3g} {unit}; another "
                             "u0?): not the same scene")


def read_steps(directory):
    """(run info, History, archive paths) of ``directory``, every archive checked."""
    info = run_info(directory)
    if info is None:
        raise ValueError(f"{str(directory)!r} holds no streamed run (no run.json)")
    paths = _archives(directory)
    history = History()
    for n, path in enumerate(paths):
        history.append(load(path, n, len(paths) - 1)[0])
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


def load(path, n, last):
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
    raise ValueError(f"{str(path)!r}: the step archive {problem}; {_remedy(n, last, 'it')}")


def _remedy(n, last, archive):
    """What to do when step n (of 0..last) is damaged: ``archive`` names its step archive."""
    later = f" and the later ones (to {last:06d}.npz)" if last > n else ""
    return "run again into a new directory" if n == 0 else f"delete {archive}{later} to resume from step {n - 1}"


def part(directory, n, rank):
    """The path of the part of ``rank`` of step n (a distributed run)."""
    return directory / "steps" / f"{n:06d}.rank{rank}.npz"


def load_part(directory, n, rank, last, load=True):
    """The arrays of the part of ``rank`` of step n (of 0..last), or with ``load`` False only
    checked to be on disk; else a ValueError naming the file, what is wrong and what to do
    (the step is incomplete: its archive is on disk, so it was deleted or damaged since)."""
    path = part(directory, n, rank)
    what = _remedy(n, last, f"steps/{n:06d}.npz")
    if not path.exists():
        raise ValueError(f"{str(path)!r} is missing: step {n} is incomplete (its archive steps/{n:06d}.npz is on disk, "
                         f"the part of rank {rank} is not); {what}")
    if not load:
        return None
    try:
        with np.load(path) as data:
            return {key: data[key] for key in data}
    except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as err:
        raise ValueError(f"{str(path)!r}: the part of rank {rank} of step {n} cannot be read ({type(err).__name__}: "
                         f"{err}): it was cut short or overwritten; {what}") from None
