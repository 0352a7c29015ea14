"""The certificate's cost: one equilibrated estimate against the step it certifies.

``python -m ngcontact bench-estimate --dim D --order P`` builds the reference scene
(``scenes.reference``; 2D P2 and 3D P1 at the sizes of ``SIZES``), steps by ``dt`` until its
contact zone is not empty (first contact), then ``rounds`` times, interleaved:

* one more step (its record's wall time),
* the estimate of that state by a new ``estimators.EquilibratedEstimator`` built and called
  (``cold``: what ``adapt`` pays on a new level),
* the same state estimated again by that estimator (``warm``: what every later estimate on the
  mesh pays; its patch problems are set up and factorised).

It prints every round, the medians, the ratios estimate ÷ step (and that of round 0 apart: the
first estimate of the process also pays the first use of its memory and of SciPy) and the split
of the cold and the warm estimates by the estimator's NGSolve timers (``ngsolve.Timers()`` named
"ngcontact estimate: ..."; the rest is "other"; the estimator's background thread is not timed
by them, and waiting for it shows as "block solves"). The steps run without a TaskManager; the
estimator uses its background thread and, for its indicator integrals, NGSolve's TaskManager.
Times are wall-clock seconds on the machine that runs it; nothing here asserts a time.
"""
import statistics
import time as wallclock

import ngsolve as ngs

from ngcontact import estimators
from ngcontact.scenes import reference

SIZES = {(2, 2): (0.005, 2), (3, 1): (0.005, 1)}
"""(maxh in m, refinements) of the reference scene per (dim, order): the sizes of the estimate's
cost measurements in docs/speed.md; other cases: maxh 0.005 (2D) or 0.01 (3D), not refined."""
PREFIX = "ngcontact estimate: "
"""The names of the estimator's timers."""


def _timers():
    return {t["name"][len(PREFIX):]: t["time"] for t in ngs.Timers() if t["name"].startswith(PREFIX)}


def _timed(call):
    """(result, wall s, {timer: s}) of ``call()``."""
    before = _timers()
    start = wallclock.perf_counter()
    result = call()
    spent = wallclock.perf_counter() - start
    after = _timers()
    return result, spent, {name: after[name] - before.get(name, 0.0) for name in after
                           if after[name] - before.get(name, 0.0) > 0}


def _built_and_called(sim):
    estimator = estimators.EquilibratedEstimator(sim)
    return estimator, estimator()


def measure(dim=2, order=2, rounds=5, dt=2.5e-3, maxh=None, refine=None, progress=print):
    """The rounds of the module docstring as dicts (round, step_s, newton, cold_s, warm_s,
    total, cold_split, warm_split), after first contact; ``progress`` gets a line per step and
    round."""
    size = SIZES.get((dim, order), (0.005 if dim == 2 else 0.01, 0))
    maxh = size[0] if maxh is None else maxh
    refine = size[1] if refine is None else refine
    sim = reference.simulation(order, maxh, refine, dim, keep_states=False)
    progress(f"reference scene {dim}D P{order}, maxh {maxh:g} m, {refine} refinements: {sim.body.ndof} DOFs, "
             f"{sim.body.mesh.ne} elements")
    for _ in range(int(round(reference.PUSH_END / dt))):
        record = sim.step(dt)
        if record.contact.contact_area > 0:
            break
    else:
        raise RuntimeError("the reference scene did not touch the foundation during the push")
    progress(f"first contact at step {record.step} (t = {record.time:.4g} s, contact {record.contact.contact_area:.3g})")
    rows = []
    for k in range(rounds):
        record = sim.step(dt)
        (estimator, cold), cold_s, cold_split = _timed(lambda: _built_and_called(sim))
        warm, warm_s, warm_split = _timed(estimator)
        rows.append(dict(round=k, step=record.step, step_s=record.wall_s, newton=record.newton_iterations,
                         cold_s=cold_s, warm_s=warm_s, total=cold.total, warm_total=warm.total,
                         cold_split=cold_split, warm_split=warm_split))
        progress(f"round {k}: step {record.step} {record.wall_s:.3f} s ({record.newton_iterations} Newton), estimate "
                 f"cold {cold_s:.3f} s, warm {warm_s:.3f} s, eta {cold.total:.12g}")
    return sim.body.ndof, rows


def summary(ndof, rows):
    """The lines that ``command`` prints after the rounds: medians, ratios, splits."""
    med = lambda key: statistics.median(r[key] for r in rows)
    step = med("step_s")
    ratios = {kind: statistics.median(r[f"{kind}_s"] / r["step_s"] for r in rows) for kind in ("cold", "warm")}
    lines = [f"{ndof} DOFs, {len(rows)} rounds, medians: step {step:.3f} s, estimate cold {med('cold_s'):.3f} s "
             f"(÷ step {ratios['cold']:.2f}), warm {med('warm_s'):.3f} s (÷ step {ratios['warm']:.2f})",
             f"first estimate of the process (round 0): cold {rows[0]['cold_s']:.3f} s (÷ step "
             f"{rows[0]['cold_s'] / rows[0]['step_s']:.2f})"]
    for kind in ("cold", "warm"):
        names = sorted({n for r in rows for n in r[f"{kind}_split"]})
        split = {n: statistics.median(r[f"{kind}_split"].get(n, 0.0) for r in rows) for n in names}
        other = med(f"{kind}_s") - sum(split.values())
        parts = ", ".join(f"{n} {s:.3f}" for n, s in sorted(split.items(), key=lambda item: -item[1]))
        lines.append(f"{kind} split (s, medians): {parts}{', ' if parts else ''}other {other:.3f}")
    return lines


def command(dim, order, rounds=5, dt=2.5e-3, maxh=None, refine=None):
    """``python -m ngcontact bench-estimate``: ``measure`` and print its ``summary``."""
    ndof, rows = measure(dim, order, rounds, dt, maxh, refine, progress=lambda line: print(line, flush=True))
    for line in summary(ndof, rows):
        print(line, flush=True)
    return rows
