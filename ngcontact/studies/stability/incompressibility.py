"""ν → 1/2: locking of P1, P2, P3 in the plate bent by a pressure (no contact), against a
fine P3 solution."""
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.geometries import plate
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import add_row, table
from .shared import save

COLUMNS = ("nu", "order", "mesh", "ndof", "ratio")
"""The columns of the summary table."""


def tip_deflection(nu, order, mesh):
    """u_y (m) at the free bottom corner of the cantilever under 10 kPa on top, isotropic,
    E = 1 GPa, no piezoelectric coupling, one static step; and the ndof."""
    material = ngc.Material.isotropic(1e9, nu, permittivity=1e-9)
    body = ngc.Body(mesh, material, clamped="left", grounded="top", order=order)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -1e4)}), keep_states=False)
    sim.step(1.0)
    return float(sim.u(mesh(reference.L1, 0.0))[1]), body.ndof


def run(out=None, *, nus=None, orders=(1, 2, 3), maxh=0.005, reference_order=3, reference_refine=2,
        quick=False, progress=True):
    """The tip deflection of the clamped plate (no contact) for P1, P2, P3 on one Netgen mesh,
    and P1 on a mesh of about the same size made by ``mesh.Refine()``, relative to a P3
    solution on the Netgen mesh refined ``reference_refine`` times.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``incompressibility.png``.
    nus : Poisson ratios; default 0.3, 0.45, 0.49, 0.499, 0.4999 (quick: 0.3, 0.49, 0.499).
    orders : orders compared on the Netgen mesh of size ``maxh`` (m).
    reference_order, reference_refine : the fine reference.
    quick : fewer ν.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per (ν, order, mesh): ``mesh`` ("netgen" or "refined"), ``ndof``,
    ``tip_deflection`` (m), ``ratio`` (to the reference; locking: → 0).
    """
    if nus is None:
        nus = (0.3, 0.49, 0.499) if quick else (0.3, 0.45, 0.49, 0.499, 0.4999)
    meshes = dict(netgen=lambda: plate(reference.L1, reference.L2, maxh=maxh),
                  refined=lambda: plate(reference.L1, reference.L2, maxh=2 * maxh, refine=1))
    cases = [(order, "netgen") for order in orders] + [(1, "refined")]
    rows = []
    with bar(len(nus) * (len(cases) + 1), "incompressibility", progress, unit="run") as shown:
        for nu in nus:
            fine, _ = tip_deflection(nu, reference_order, plate(reference.L1, reference.L2, maxh=maxh,
                                                                refine=reference_refine))
            shown.update()
            for order, mesh in cases:
                tip, ndof = tip_deflection(nu, order, meshes[mesh]())
                row = dict(nu=nu, order=order, mesh=mesh, ndof=ndof, tip_deflection=tip,
                           reference=fine, ratio=tip / fine)
                add_row(rows, row, shown, COLUMNS)
    if out is not None:
        _plot(rows, out, quick)
    return rows


def summary(rows):
    return table(rows, COLUMNS)


def _plot(rows, out, quick=False):
    fig = Figure(figsize=(6.5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for i, (order, mesh) in enumerate(dict.fromkeys((r["order"], r["mesh"]) for r in rows)):
        runs = [r for r in rows if r["order"] == order and r["mesh"] == mesh]
        style = "o-" if mesh == "netgen" else "s--"
        ax.plot([0.5 - r["nu"] for r in runs], [r["ratio"] for r in runs], style, color=f"C{i}",
                label=f"P{order}, {mesh} mesh ({runs[0]['ndof']} DOFs)")
    ax.set(xscale="log", xlabel="1/2 − ν", ylabel="tip deflection / fine P3",
           title="locking: plate bent by a pressure, plane strain", ylim=(0, 1.05))
    ax.invert_xaxis()
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    save(fig, out / "incompressibility.png", quick)
