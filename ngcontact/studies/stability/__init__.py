"""Stability maps: where the discretisation and the solver fail, mapped on small 2D scenes.

One module per study; each has ``run(out=None, *, quick=False, progress=True, ...)``
returning its rows (flat dicts, one per run or per step) and drawing its charts into
``out``, and ``summary(rows)``, a short text with the headline numbers:

* ``nitsche_map``: γ0 × θ on the reference plate pressed onto the foundation.
* ``time_step_sweep``: the explicit β update (4.5) against the implicit one as dt γ_ν L²
  crosses 1.
* ``incompressibility``: ν → 1/2 with P1, P2, P3 (locking).
* ``strong_coupling``: the piezoelectric coupling factor k² → 1.
* ``debonding``: complete debonding and contact afterwards, against the glue-free body.
* ``load_cycles``: push-pull cycles that open and close the contact.
* ``penalty_sweep``: the penalty factor over decades against Nitsche's γ0.
* ``nonlinear_laws``: where Newton fails as a law's ζ grows (projection law, power viscosity).
* ``electrode_map``: Newton before and after its globalisation (and ψ gated by the gap or by
  the contact state): the electrode contact's k_e × δ on three meshes, the glue's γ_ν × the
  push's steps on the reference plate, the plate grounded at its clamped end.
* ``pull_off``: Newton iterations per step of the reference history's pull-off against the
  points of Γ3 its release front crosses, over time steps and meshes.

Runs are made without time-step cut-backs unless stated, so that failures show; a failed
Newton solve is classified by ``common.failure_kind``. Units are SI, per metre of depth.
"""
import time as wallclock

from ngcontact import checks, parallel

from ngcontact.studies.common import QUICK, write_csv
from . import (debonding, electrode_map, incompressibility, load_cycles, nitsche_map, nonlinear_laws, penalty_sweep,
               pull_off, strong_coupling, time_step_sweep)

STUDIES = dict(nitsche_map=nitsche_map, time_step_sweep=time_step_sweep, incompressibility=incompressibility,
               strong_coupling=strong_coupling, debonding=debonding, load_cycles=load_cycles,
               penalty_sweep=penalty_sweep, nonlinear_laws=nonlinear_laws, electrode_map=electrode_map,
               pull_off=pull_off)
"""The studies in the order ``python -m ngcontact stability`` runs them."""


def command(out, quick=False, resume=False, studies=None):
    """``python -m ngcontact stability``: run every study (or those named in ``studies``), write
    <study>.csv and the charts into ``out``, print each study's summary; ``resume`` skips the
    studies whose <study>.csv (written when a study ends) is already in ``out``; ``quick``: fewer
    runs, said at the start and the end and on every chart (``common.QUICK``). Serial only
    (refused under mpiexec)."""
    parallel.refuse_under_mpiexec("stability")
    quick, resume = checks.flag("quick", quick), checks.flag("resume", resume)
    unknown = [name for name in studies or () if name not in STUDIES]
    if unknown:
        raise ValueError(f"studies: {', '.join(map(repr, unknown))} is not a stability study; allowed: "
                         f"{', '.join(STUDIES)}")
    out = checks.writable_directory(out)
    start = wallclock.perf_counter()
    mark = f" ({QUICK}: fewer runs per study)" if quick else ""
    if quick:
        print(mark.strip(), flush=True)
    for name, study in STUDIES.items():
        if studies and name not in studies:
            continue
        print(f"\n{name}", flush=True)
        if resume and (out / f"{name}.csv").exists():
            print(f"on disk ({out / f'{name}.csv'}), skipped", flush=True)
            continue
        began = wallclock.perf_counter()
        rows = study.run(out, quick=quick)
        write_csv(rows, out / f"{name}.csv")
        print(f"{study.summary(rows)}\n({wallclock.perf_counter() - began:.1f} s)", flush=True)
    print(f"\nwall {wallclock.perf_counter() - start:.1f} s; results in {out}{mark}")
