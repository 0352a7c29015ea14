"""Where Newton fails as a law's nonlinearity grows (``ngcontact.laws``): the reference plate pushed
onto the foundation with the projection law F(ε) = ℰε + ζ(ε − P_K ε) (K a von Mises ball) or
the power viscosity A(ε̇) = τℰε̇ + ζ (δ² + |dev ε̇|²)^((r−2)/2) dev ε̇, over decades of ζ (and
of δ), without and with time-step cut-backs.

The measure of a law's difficulty is its condition κ = L / m (Lipschitz over monotonicity
constant, as ``laws.BoundLaw`` estimates them from samples; for the power viscosity at r = 1
the sampled L misses the peak ζ/δ at ε̇ = 0, so κ is computed as (λ_max(τℰ) + ζ δ^(r−2)) /
λ_min(τℰ) there, its bound).
"""
import math

import numpy as np
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import laws
from ngcontact.output.progress import bar
from ngcontact.scenes import reference

from ngcontact.studies.common import add_row, newton_total, table
from .shared import press, save

COLUMNS = ("law", "zeta", "delta", "kappa", "cutbacks", "converged", "failure", "newton", "newton_max", "force_change")
"""The columns of the summary table."""
RADIUS = 1e-5
"""The von Mises ball's radius (|dev ε|), the strain scale of the pushed plate."""


def _material(law, zeta, delta, exponent):
    material = ngc.pzt5a(relaxation_time=reference.RELAXATION_TIME)
    if law == "linear":
        return material
    if law == "projection":
        return material.with_elasticity(laws.ProjectionLaw(zeta, laws.VonMisesBall(RADIUS)))
    return material.with_viscosity(laws.PowerViscosity(zeta, exponent, delta))


def _kappa(material, law, zeta, delta, exponent):
    tensors = material.tensors(2)
    if law == "projection":
        return tensors.F_law.lipschitz / tensors.F_law.monotonicity
    eigen = np.linalg.eigvalsh(reference.RELAXATION_TIME * np.asarray(tensors.F))   # τℰ, F linear here
    return (eigen[-1] + zeta * delta ** (exponent - 2)) / eigen[0]


def run(out=None, *, zetas=None, power=None, exponent=1.0, maxh=0.01, order=1, steps=4, quick=False, progress=True):
    """Projection law over ``zetas`` and the power viscosity over ``power`` (ζ, δ) pairs, each
    without cut-backs and with up to 6, on the reference plate pushed in ``steps`` steps.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``nonlinear_laws.png``.
    zetas : ζ of the projection law, Pa; default 1e9 ... 1e17 (quick: 1e11, 1e14, 1e16).
    power : (ζ in Pa·s^r, δ in 1/s) of the power viscosity; default ζ 1e5 ... 1e9 × δ 1e-3,
        1e-5, 1e-7 (quick: three pairs).
    exponent : r of the power viscosity (1: the Bingham-like limit, the hardest).
    maxh, order, steps : the plate's mesh size (m), the order, the push's time steps.
    quick : fewer runs.
    progress : show a progress bar and a line per run.

    Returns
    -------
    list of dict, one per (law, ζ, δ, cut-backs): ``kappa`` (L/m), ``converged``,
    ``failure``, ``newton`` (total), ``newton_max`` (per step), ``force`` (N/m, at the end of
    the push), ``force_change`` (against the linear plate, relative).
    """
    if zetas is None:
        zetas = (1e11, 1e14, 1e16) if quick else np.logspace(9, 17, 9)
    if power is None:
        power = ((1e6, 1e-3), (1e6, 1e-6), (1e8, 1e-6)) if quick else \
            [(z, d) for d in (1e-3, 1e-5, 1e-7) for z in np.logspace(5, 9, 5)]
    cases = [("projection", float(z), math.nan) for z in zetas] + [("power", float(z), float(d)) for z, d in power]
    rows = []
    with bar(1 + 2 * len(cases), "nonlinear_laws", progress, unit="run") as shown:
        sim, failure = press(reference.contact(), maxh=maxh, order=order, steps=steps)
        if failure:
            raise RuntimeError(f"the linear plate failed: {failure}")
        linear_force = float(sim.history[-1].contact.force[1])
        shown.update()
        for law, zeta, delta in cases:
            material = _material(law, zeta, delta, exponent)
            kappa = _kappa(material, law, zeta, delta, exponent)
            for cutbacks in (0, 6):
                sim, failure = press(reference.contact(), maxh=maxh, order=order, steps=steps, material=material,
                                     max_cutbacks=cutbacks)
                force = float(sim.history[-1].contact.force[1]) if not failure else math.nan
                row = dict(law=law, zeta=zeta, delta=delta, kappa=float(kappa), cutbacks=cutbacks,
                           converged=failure is None, failure=failure["failure"] if failure else "",
                           newton=newton_total(sim, failure),
                           newton_max=int(max(sim.history.newton_iterations[1:], default=0)),
                           used_cutbacks=len(sim.cutbacks), force=force,
                           force_change=(force - linear_force) / linear_force)
                add_row(rows, row, shown, COLUMNS)
    if out is not None:
        _plot(rows, out, quick)
    return rows


def first_failure(rows, law, cutbacks=0):
    """The smallest κ at which Newton failed for ``law`` (nan if it never did)."""
    failed = [r["kappa"] for r in rows if r["law"] == law and r["cutbacks"] == cutbacks and not r["converged"]]
    return min(failed, default=math.nan)


def summary(rows):
    lines = [table(rows, COLUMNS)]
    for law in ("projection", "power"):
        for cutbacks in (0, 6):
            lines.append(f"{law}, {cutbacks} cut-backs: first failure at κ = {first_failure(rows, law, cutbacks):.3g}")
    return "\n".join(lines)


def _plot(rows, out, quick=False):
    fig = Figure(figsize=(11, 4), layout="constrained")
    axes = fig.subplots(1, 2)
    for cutbacks, marker in ((0, "o"), (6, "s")):
        for law, colour in (("projection", "C0"), ("power", "C1")):
            runs = [r for r in rows if r["law"] == law and r["cutbacks"] == cutbacks]
            kappa = np.array([r["kappa"] for r in runs])
            ok = np.array([r["converged"] for r in runs])
            newton = np.array([r["newton"] for r in runs])
            label = f"{law}, {cutbacks} cut-backs"
            axes[0].scatter(kappa[ok], newton[ok], marker=marker, color=colour, label=label,
                            facecolors="none" if cutbacks else colour)
            axes[0].scatter(kappa[~ok], newton[~ok], marker="x", color=colour, s=60)
            change = np.array([abs(r["force_change"]) for r in runs])
            axes[1].scatter(kappa[ok], np.maximum(change[ok], 1e-16), marker=marker, color=colour, label=label,
                            facecolors="none" if cutbacks else colour)
    axes[0].set(xscale="log", xlabel="κ = L / m of the law", ylabel="Newton iterations (x: failed)",
                title="the pushed plate: Newton against the law's condition")
    axes[1].set(xscale="log", yscale="log", xlabel="κ = L / m of the law",
                ylabel="|contact force − linear| / linear", title="how much the law changes the force")
    for ax in axes:
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7)
    save(fig, out / "nonlinear_laws.png", quick)
