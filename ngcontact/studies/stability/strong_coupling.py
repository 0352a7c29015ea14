"""Strong piezoelectric coupling: PZT-5A's piezoelectric constants scaled until the
coupling factor k² approaches 1, on the reference plate pushed onto the foundation."""
import math

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import add_row, newton_total, table
from .shared import APPLIED, press, save, scaled_condition_number

COLUMNS = ("k2", "e_scale", "stiffening", "converged", "failure", "newton", "recovered", "cutbacks",
           "force_ratio", "cond")
"""The columns of the summary table."""


def coupling_factor(material, dim=2):
    """k² = e33² / (c33^D ε33), c33^D = c33 + e33²/ε33 (the poling axis' entries of the
    model's F, E, C): the electromechanical coupling factor, < 1 for any e."""
    T = material.tensors(dim)
    i = dim - 1
    ratio = T.E[i, i] ** 2 / (T.F[i, i] * T.C[i, i])
    return ratio / (1 + ratio)


def run(out=None, *, k2s=None, maxh=0.01, order=1, steps=4, quick=False, progress=True):
    """The reference plate pushed onto the foundation with PZT-5A's e scaled so that the
    coupling factor k² (``coupling_factor``) approaches 1.

    Each k² is run without cut-backs; a failed run is repeated with cut-backs (6).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``strong_coupling.png``.
    k2s : coupling factors; PZT-5A's own (0.234) is always included; default 0.5 ... 0.9999
        (quick: 0.9, 0.999, 0.9999).
    maxh, order, steps : as in ``nitsche_map.run``.
    quick : fewer k².
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per k²: ``e_scale`` (the factor on e), ``stiffening`` (λ_max(F + Eᵀ
    C⁻¹E) / λ_max(F): the factor by which the elastic part of Nitsche's γ grows),
    ``converged`` (no cut-backs), ``failure``, ``failed_step``, ``newton``, ``recovered``
    (with cut-backs), ``cutbacks``, ``force_ratio`` (contact force / applied load),
    ``max_penetration`` (m), ``cond``.
    """
    base = reference.body(order, maxh).material
    nominal = coupling_factor(base)
    if k2s is None:
        k2s = (0.9, 0.999, 0.9999) if quick else (0.5, 0.7, 0.8, 0.85, 0.88, 0.9, 0.92, 0.95, 0.99, 0.999,
                                                  0.9999)
    k2s = [nominal] + [k for k in k2s if not math.isclose(k, nominal)]
    ratio0 = nominal / (1 - nominal)
    elastic = np.linalg.eigvalsh(base.tensors(2).F).max()
    rows = []
    with bar(len(k2s), "strong_coupling", progress, unit="run") as shown:
        for k2 in k2s:
            scale = math.sqrt(k2 / (1 - k2) / ratio0)
            material = ngc.Material(base.c, scale * base.e, base.eps, base.eta, name=f"PZT-5A, e × {scale:.3g}")
            sim, failure = press(reference.contact(), maxh=maxh, order=order, steps=steps, material=material)
            row = dict(k2=k2, e_scale=scale, stiffening=material.tensors(2).stiffness() / elastic,
                       converged=failure is None, failure=failure["failure"] if failure else "",
                       failed_step=failure["failed_step"] if failure else 0, newton=newton_total(sim, failure),
                       recovered=failure is None, cutbacks=0, force_ratio=math.nan,
                       max_penetration=math.nan, cond=math.nan)
            if failure:
                sim, failure = press(reference.contact(), maxh=maxh, order=order, steps=steps,
                                     material=material, max_cutbacks=6)
                row.update(recovered=failure is None, cutbacks=len(sim.cutbacks))
            if not failure:
                c = sim.history[-1].contact
                row.update(force_ratio=float(c.force[1]) / APPLIED, max_penetration=c.max_penetration,
                           cond=scaled_condition_number(sim))
            add_row(rows, row, shown, COLUMNS)
    if out is not None:
        _plot(rows, out, quick)
    return rows


def summary(rows):
    return table(rows, COLUMNS)


def _plot(rows, out, quick=False):
    x = np.array([1 - r["k2"] for r in rows])
    ok = np.array([r["converged"] for r in rows])
    fig = Figure(figsize=(12, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    newton = np.array([r["newton"] for r in rows], dtype=float)
    axes[0].plot(x[ok], newton[ok], "o", color="C0", label="converged")
    groups = dict.fromkeys((r["failure"], r["recovered"]) for r in rows if not r["converged"])
    for j, (failure, recovered) in enumerate(groups):
        sel = np.array([r["failure"] == failure and r["recovered"] == recovered for r in rows])
        axes[0].plot(x[sel], newton[sel], "xs^v"[j % 4], color=f"C{j + 1}", ms=8, mew=2,
                     label=f"{failure}, {'recovered' if recovered else 'not recovered'} with cut-backs")
    axes[0].set(ylabel="Newton iterations without cut-backs")
    axes[0].legend(fontsize=7)
    # two quantities: the condition number on the left axis, the stiffening on its own right axis
    axes[1].plot(x, [r["cond"] for r in rows], "o-", color="C0")
    axes[1].set(yscale="log")
    axes[1].set_ylabel("cond of the scaled Jacobian (circles)", color="C0")
    axes[1].tick_params(axis="y", colors="C0")
    stiffening = axes[1].twinx()
    stiffening.plot(x, [r["stiffening"] for r in rows], "s--", color="C1")
    stiffening.set(yscale="log")
    stiffening.set_ylabel("λmax(F + EᵀC⁻¹E) / λmax(F) (squares)", color="C1")
    stiffening.tick_params(axis="y", colors="C1")
    axes[2].plot(x, [r["force_ratio"] for r in rows], "o-")
    axes[2].set(ylabel="contact force / applied load")
    for ax in axes:
        ax.set(xscale="log", xlabel="1 − k²")
        ax.invert_xaxis()
        ax.grid(True, lw=0.3)
    save(fig, out / "strong_coupling.png", quick)
