"""Contact on a curved side against Hertz: the half-disk (half-ball) of ``scenes.hertz``
pressed onto a plane, with the obstacle normal n_o and with the body's normal ν (the
paper's form), orders × nested meshes.

Each case is one quasi-static step (the top brought down by d); the errors are those of
``scenes.hertz.errors``: contact half-width a_h/a − 1, peak pressure p0_h/p0 − 1 and the
pressure L2 error on Γ3, with the rate between successive levels (h halves), and the case's
times: ``solve_s`` its step (the coarse levels of the nested start included) and apart
``setup_s``, what it paid once (mesh, forms, step 0; ``common.split_seconds``). Writes
``hertz.csv``, ``hertz.md`` (the tables) and ``hertz_pressure.png`` (λ_h along Γ3 against
Hertz on the finest mesh of each order, both normals).
"""
import json
import math
import time

import ngsolve as ngs
import numpy as np

from ngcontact import checks, parallel

from ngcontact.output.progress import bar
from ngcontact.scenes import hertz
from . import common
from .common import table, write_csv

COLUMNS = ["dim", "order", "normal", "level", "ndof", "newton", "coarse_newton", "force", "a", "width_error",
           "peak_error", "pressure_L2", "rate_L2", "setup_s", "solve_s"]


def case(order, level, normal, dim=2):
    """One solved case as (row, simulation): from level 1 on started by nested iteration
    (``starts``: fewer Newton iterations on the finest level, docs/measurements.md, section
    hertz; ``newton`` counts the finest level's, ``coarse_newton``
    the coarser levels')."""
    t0 = time.perf_counter()
    sim = hertz.simulation(order, refine=level, dim=dim, normal=normal, keep_states=False)
    with ngs.TaskManager():
        sim.run(1.0, 1.0, guess="nested" if level else None)
    setup_s, solve_s = common.split_seconds(time.perf_counter() - t0, sim.history)
    e = hertz.errors(sim)
    row = dict(dim=dim, order=order, normal=normal, level=level, ndof=sim.X.ndof,
               newton=sim.history[-1].newton_iterations,
               coarse_newton=sum(sim.starts.nested.iterations) if level else 0, force=e["force"], a=e["a"],
               width_error=e["a_h"] / e["a"] - 1, peak_error=e["p0_h"] / e["p0"] - 1,
               pressure_L2=e["pressure_L2"], rate_L2=math.nan, setup_s=setup_s, solve_s=solve_s)
    return row, sim


def run(out, orders=(1, 2), levels=4, dim=2, progress=True, resume=False):
    """Every order × level × normal; returns the rows (also written to ``out``). Each case
    is kept in ``out/cases.json`` as it finishes; ``resume`` skips the cases found there.
    Serial only (refused under mpiexec); orders in [1, 10], levels in [1, 10], and the finest
    mesh must fit in the machine's memory, checked before any case."""
    parallel.refuse_under_mpiexec("hertz")
    orders = common.orders("orders", orders)
    levels = checks.integer("levels", levels, 1, checks.MAX_REFINE)
    dim = checks.choice("dim", dim, (2, 3))
    progress, resume = checks.flag("progress", progress), checks.flag("resume", resume)
    checks.fits_in_memory(f"levels = {levels}, order {max(orders)}",     # the coarse mesh is cheap
                          checks.estimated_ndof(hertz.mesh(dim).nv, dim, levels - 1, max(orders)))
    out = checks.writable_directory(out)
    done = json.loads((out / "cases.json").read_text()) if resume and (out / "cases.json").exists() else {}
    rows, finest = [], {}
    cases = [(p, n, k) for p in orders for n in ("obstacle", "body") for k in range(levels)]
    with bar(len(cases), "Hertz cases", progress) as shown:
        for order, normal, level in cases:
            key = f"{dim}D P{order} {normal} L{level}"
            if key in done:
                row, profile = dict(dict(setup_s=math.nan, solve_s=math.nan), **done[key]["row"]), done[key]["profile"]
            else:
                row, sim = case(order, level, normal, dim)
                profile = [list(map(float, a)) for a in _profile(sim)] if level == levels - 1 else None
                done[key] = dict(row=row, profile=profile)
                (out / "cases.json").write_text(json.dumps(done))
            if level > 0:
                previous = rows[-1]
                row["rate_L2"] = math.log2(previous["pressure_L2"] / row["pressure_L2"])
            rows.append(row)
            if level == levels - 1:
                finest[order, normal] = tuple(np.array(a) for a in profile)
            shown.update(1)
    write_csv(rows, out / "hertz.csv", COLUMNS)
    text = table(rows, COLUMNS)
    (out / "hertz.md").write_text("```\n" + text + "\n```\n")
    print(text)
    _plot(finest, out / "hertz_pressure.png")
    return rows


def _profile(sim):
    """(r, λ_h(r), Hertz p(r)) on Γ3 near the contact zone: in 2D r = x at 9 points per facet,
    in 3D r = |(x, y)| at 7 points per triangle (the vertices moved inwards by a fiftieth, the edge midpoints,
    centroid)."""
    e = hertz.errors(sim)
    side, mesh, dim = sim.side, sim.body.mesh, sim.body.dim
    lam = sim.enforcement.multiplier(sim.u, sim.phi, ngs.CF(0.0))
    if dim == 2:
        s = np.linspace(0.02, 0.98, 9)
        weights = np.stack([1 - s, s], axis=1)
    else:
        weights = np.array([[.96, .02, .02], [.02, .96, .02], [.02, .02, .96], [.5, .5, 0], [0, .5, .5],
                            [.5, 0, .5], [1 / 3, 1 / 3, 1 / 3]])
    points = np.einsum("sk,fkd->fsd", weights, side.facet_vertices)
    radius = np.linalg.norm(points[..., :dim - 1], axis=-1)
    points = points[radius.max(axis=1) < 2 * e["a"]].reshape(-1, dim)
    # λ_h needs the volume element's stress and the facet's normal: evaluate on the boundary
    # element with the volume element's fields (BoundaryFromVolumeCF)
    values = ngs.BoundaryFromVolumeCF(lam)(mesh(*points.T, VOL_or_BND=ngs.BND)).ravel()
    r = points[:, 0] if dim == 2 else np.linalg.norm(points[:, :2], axis=1)
    order = np.argsort(r)
    r = r[order]
    exact = e["p0"] * np.sqrt(np.clip(1 - (r / e["a"]) ** 2, 0, None))
    return r, values[order], exact


def _plot(profiles, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    orders = sorted({p for p, _ in profiles})
    fig, axes = plt.subplots(1, len(orders), figsize=(5.5 * len(orders), 4), squeeze=False)
    for ax, order in zip(axes[0], orders):
        for normal, width in (("body", 0.8), ("obstacle", 1.6)):
            x, lam, exact = profiles[order, normal]
            ax.plot(x, lam, lw=width, label=f"λ_h, {normal} normal",
                    **({} if x.min() < 0 else dict(marker=".", ls="none", ms=2)))
        ax.plot(x, exact, "k--", lw=1.5, label="Hertz")
        ax.set_title(f"P{order}, finest mesh")
        ax.set_xlabel("x (m)" if x.min() < 0 else "distance from the axis r (m)")
        ax.set_ylabel("contact pressure (Pa)")
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def command(out, orders, levels, dim, resume=False):
    """``python -m ngcontact hertz``."""
    run(out, orders, levels, dim, resume=resume)
