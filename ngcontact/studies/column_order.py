"""Order in time of backward Euler and BDF2 on the adhesive debonding column, against an
independent stiff-ODE reference: the semi-discrete system (same mesh, same P1 spaces, the forms
of (2.30)-(2.31) and the bonding law (2.9)) integrated by SciPy's Radau IIA
(``semidiscrete_column``).

Scene: the soft column of ``scenes.column`` (clamped and grounded on top, its bottom Γ3 glued to
the foundation), lifted by the upward body force F0 sin²(π t/``PERIOD``) N/m³ over [0, T]; the
glue of ``scenes.reference.CONTACT`` (γ_ν = 1e11 Pa/m, L = 5e-5 m, ε_a = 0, β0 = 1), no
conduction, Nitsche with θ = 0. Γ3 stays open throughout (u_ν < 0 < g, checked at every step:
no contact area, λ_h = 0 at every Gauss point), so that Nitsche's term [P]_- vanishes and, with
θ = 0, nothing of Nitsche is left: the step residual is exactly the semi-discrete system
discretised in time. (With θ = 1 the term −(θ/γ)∫σ̃_ν σ_ν(v) stays; γ and σ_ν(v) both grow
like the scheme's c, so it does not vanish as k → 0 but depends on c: BDF2 with θ = 1 tends to a
u apart from the θ = 0 system's on this mesh by a spatial consistency term, and runs with
different k differ by a part of it; docs/measurements.md, section column_order.) Two histories
(``HISTORIES``):

* "lift" (F0 in N/m³ and T in s: 3e8, 0.05): the glue stretches within L and β falls a little;
* "debond" (1e9, 0.07): every point of Γ3 separates beyond L before T
  (a kink in time of the semi-discrete solution: R_ν' jumps from −1 to 0) and β falls to
  nearly 0 on every facet (ε_a = 0: β decays like exp(−γ_ν L² t), never to 0).

Errors at T of each fully discrete run (``Simulation(scheme=...)``, equal steps, Newton to
1e-12; backward Euler with ``beta_update="implicit"``) against the Radau solution: u relative
in the max norm over the u DOFs, β absolute max over the facets (and relative to max |β_ref|:
β_ref is small at the end of "debond"), φ relative max. Rates
log(e_coarse/e_fine)/log(n_fine/n_coarse) between successive runs (per halving of k). The
reference's own error is estimated by Radau at a looser rtol (``check_rtol``) against it. Rows
``against="replica"`` hold the agreement of ngcontact's runs with the same fully discrete schemes
written on the semi-discrete system (``SemiDiscreteColumn.backward_euler`` / ``bdf2``, with
ngcontact's quadrature of the Γ3 terms): ngcontact steps the system it should, to the Newton
tolerance.
"""
import math

import numpy as np
import ngsolve as ngs
from matplotlib.figure import Figure

import ngcontact as ngc
from ngcontact import checks
from ngcontact.output.progress import bar
from ngcontact.scenes import column, reference

from .common import table, write_csv
from .semidiscrete_column import SemiDiscreteColumn, check_quadrature

PERIOD = 0.2
"""The period of the pull F0 sin²(π t/PERIOD), s."""
HISTORIES = {"lift": (3e8, 0.05), "debond": (1e9, 0.07)}
"""name: (F0 in N/m³, T in s)."""
STEPS = (16, 32, 64, 128, 256, 512)
"""Equal steps over [0, T] of the runs of each scheme."""
LONG_STEPS = 4096
"""The long BDF2 run (the former same-mesh reference of docs/time.md), compared with Radau too."""
SCHEMES = ("backward_euler", "bdf2")
NGCONTACT_QUADRATURE = (2, 3)
"""Gauss points per facet of ngcontact's Γ3 integrals (the residual at order 2p, P_B at 2p + 2)."""
REPLICA_STEPS = 16
COLUMNS = ("history", "scheme", "against", "steps", "dt", "error_u", "rate_u", "error_beta", "rate_beta",
           "error_beta_rel", "rate_beta_rel", "error_phi", "rate_phi", "newton", "min_beta", "max_contact_area",
           "max_multiplier", "max_penetration", "beta_clipped_steps")


def contact():
    """The Contact of the study: the reference glue, no conduction, Nitsche θ = 0, the
    implicit β update for backward Euler (BDF2 has its own and ignores it)."""
    return ngc.Contact(**dict(reference.CONTACT, conductance=0.0, theta=0, beta_update="implicit"))


def pull(F0):
    """t ↦ F0 sin²(π t/PERIOD) (N/m³), for a time Parameter (a CoefficientFunction) or a float."""
    def force(t):
        return F0 * (ngs.sin(ngs.pi * t / PERIOD) ** 2 if isinstance(t, ngs.CoefficientFunction)
                     else math.sin(math.pi * t / PERIOD) ** 2)
    return force


def semidiscrete(F0, quadrature="exact"):
    """The column's ``SemiDiscreteColumn`` under the pull of F0 (N/m³)."""
    return SemiDiscreteColumn(column.body(), contact(), pull(F0), quadrature)


def run(F0, T, scheme, steps, beta_tolerance=None):
    """The column's Simulation of ``scheme`` run to T (s) in ``steps`` equal steps; returns it
    and {newton, max_contact_area (m), max_multiplier (λ_h, Pa), max_penetration (max u_ν − g, m),
    beta_clipped_steps (steps whose β update left [0, 1] and was clipped: BDF2's β̂ < 0)} over
    all its steps (without the physical checks' warnings: the clipping is counted here).
    ``beta_tolerance``: BDF2's ``beta_tolerance`` (β_n consistent with u_n to it), if given."""
    sim = column.simulation(pull(F0), contact(), scheme=scheme, rtol=1e-12, keep_states=False,
                            physical_checks=False)
    if beta_tolerance is not None and hasattr(sim.scheme, "beta_tolerance"):
        sim.scheme.beta_tolerance = beta_tolerance
    h = sim.run(T / steps, T)
    records = [r.contact for r in h[1:]]
    return sim, dict(newton=int(sum(h.newton_iterations)),
                     max_contact_area=max(r.contact_area for r in records),
                     max_multiplier=max(float(np.abs(r.multiplier_points).max()) for r in records),
                     max_penetration=max(r.max_penetration for r in records),
                     beta_clipped_steps=sum(r.beta_clipped > 0 for r in records))


def _fields(sim, sd):
    """ngcontact's (u, β, φ) at the end, β in the semi-discrete system's facet order."""
    x, X = sim.gfu.vec.FV().NumPy(), sim.X
    order = [int(np.argmin(np.linalg.norm(sim.side.midpoints - m, axis=1))) for m in sd.midpoints]
    return (x[X.Range(0).start:X.Range(0).stop].copy(), sim.beta.values[order].copy(),
            x[X.Range(1).start:X.Range(1).stop].copy())


def errors(fields, ref):
    """{error_u, error_beta, error_beta_rel, error_phi} of (u, β, φ) against ``ref``."""
    (u, beta, phi), (u_r, beta_r, phi_r) = fields, ref
    with np.errstate(invalid="ignore", divide="ignore"):         # β_ref = 0: nan, said so
        return dict(error_u=float(np.abs(u - u_r).max() / np.abs(u_r).max()),
                    error_beta=float(np.abs(beta - beta_r).max()),
                    error_beta_rel=float(np.abs(beta - beta_r).max() / np.abs(beta_r).max()),
                    error_phi=float(np.abs(phi - phi_r).max() / np.abs(phi_r).max()))


def add_rates(rows):
    """rate_* of each row from the row before it of the same history, scheme and reference."""
    last = {}
    for row in rows:
        key = (row["history"], row["scheme"], row["against"])
        before = last.get(key)
        for field in ("u", "beta", "beta_rel", "phi"):
            row[f"rate_{field}"] = math.nan if before is None else \
                math.log(before[f"error_{field}"] / row[f"error_{field}"]) / math.log(row["steps"] / before["steps"])
        last[key] = row
    return rows


def _steps(name, values):
    """A list of step counts: integers >= 2 in increasing order."""
    if isinstance(values, (str, bytes)) or not isinstance(values, (list, tuple, range)) or not values:
        raise TypeError(f"{name} must be a nonempty list of step counts, got {values!r}")
    values = [checks.integer(name, n, 2, checks.MAX_STEPS) for n in values]
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"{name} must increase, got {values}")
    return values


def _histories(values):
    if isinstance(values, str) or not isinstance(values, (list, tuple)) or not values:
        raise TypeError(f"histories must be a nonempty list of names of {sorted(HISTORIES)}, got {values!r}")
    for name in values:
        checks.choice("histories", name, tuple(HISTORIES))
    return list(values)


def _arguments(histories, steps, long_steps, progress):
    """The arguments shared by ``study`` and ``main``, checked (errors name them)."""
    if long_steps is not None:
        long_steps = checks.integer("long_steps", long_steps, 2, checks.MAX_STEPS)
    return _histories(histories), _steps("steps", steps), long_steps, checks.flag("progress", progress)


def study(histories=tuple(HISTORIES), steps=STEPS, long_steps=LONG_STEPS, rtol=1e-12, check_rtol=1e-10,
          quadrature="exact", progress=True):
    """Rows (dict, ``COLUMNS``) of every run against the Radau reference at ``rtol`` (its own
    error: ``scheme="radau"``, Radau at ``check_rtol``, its ``steps`` the reference's accepted
    steps; the reference with ngcontact's quadrature of the Γ3 terms:
    ``scheme="radau, ngcontact quadrature"``), and ngcontact's agreement with the
    fully discrete replicas (``against="replica"``, REPLICA_STEPS steps). ``histories``: names of
    ``HISTORIES``; ``steps``: increasing step counts of both schemes; ``long_steps``: a BDF2 run
    (None: none); ``quadrature``: the reference's Γ3 quadrature (``SemiDiscreteColumn``)."""
    histories, steps, long_steps, progress = _arguments(histories, steps, long_steps, progress)
    check_quadrature(quadrature)
    rtol = checks.number("rtol", rtol, 0, 1e-6, low_open=True)
    check_rtol = checks.number("check_rtol", check_rtol, rtol, 1e-3, low_open=True)
    cases = [(scheme, n) for scheme in SCHEMES for n in steps] + ([("bdf2", long_steps)] if long_steps else [])
    rows = []
    with bar(len(histories) * (len(cases) + 5), "column order", progress, unit="run") as shown:
        for name in histories:
            F0, T = HISTORIES[name]
            sd = semidiscrete(F0, quadrature)
            u, beta, result = sd.radau(T, rtol=rtol)
            U, P = sd.full(u)
            ref = (U, beta, P)
            base = dict(history=name, min_beta=float(beta.min()))
            shown.update()
            u2, beta2, _ = sd.radau(T, rtol=check_rtol)
            U2, P2 = sd.full(u2)
            rows.append(dict(base, scheme="radau", against="radau", steps=len(result.t) - 1, dt=math.nan,
                             **errors((U2, beta2, P2), ref), min_beta=float(beta2.min())))
            shown.update()
            other = semidiscrete(F0, NGCONTACT_QUADRATURE if quadrature == "exact" else "exact")
            u3, beta3, _ = other.radau(T, rtol=rtol)
            U3, P3 = other.full(u3)
            rows.append(dict(base, scheme="radau, " + ("ngcontact quadrature" if quadrature == "exact" else "exact"),
                             against="radau", steps=math.nan, dt=math.nan, **errors((U3, beta3, P3), ref)))
            shown.update()
            replica = semidiscrete(F0, NGCONTACT_QUADRATURE)
            for scheme in SCHEMES:
                sim, info = run(F0, T, scheme, REPLICA_STEPS, beta_tolerance=1e-10)
                u4, beta4 = getattr(replica, scheme)(REPLICA_STEPS, T)
                U4, P4 = replica.full(u4)
                fields = _fields(sim, sd)
                rows.append(dict(base, scheme=scheme, against="replica", steps=REPLICA_STEPS, dt=T / REPLICA_STEPS,
                                 **errors(fields, (U4, beta4, P4)), **info, min_beta=float(fields[1].min())))
                shown.update()
            for scheme, n in cases:
                sim, info = run(F0, T, scheme, n)
                fields = _fields(sim, sd)
                rows.append(dict(base, scheme=scheme, against="radau", steps=n, dt=T / n, **errors(fields, ref),
                                 **info, min_beta=float(fields[1].min())))
                shown.write(f"{name} {scheme} {n}: u {rows[-1]['error_u']:.3e}, β {rows[-1]['error_beta']:.3e}, "
                            f"φ {rows[-1]['error_phi']:.3e}")
                shown.update()
    rows = add_rates(rows)
    for row in rows:
        for c in COLUMNS:
            row.setdefault(c, math.nan)
    for row in rows:
        if row.get("max_contact_area", 0) > 0 or row.get("max_multiplier", 0) > 0:
            raise RuntimeError(f"Γ3 closed in the {row['history']} {row['scheme']} run with {row['steps']} steps "
                               f"(contact area {row['max_contact_area']:.3g} m, λ_h {row['max_multiplier']:.3g} Pa): "
                               "the semi-discrete system without contact is not its reference")
    return rows


def chart(rows, path):
    """Error at T against the number of steps, log-log, one panel per history, one line per
    scheme and field; slope-1 and slope-2 guides; Radau's own error written in the corner."""
    histories = list(dict.fromkeys(r["history"] for r in rows))
    fig = Figure(figsize=(6.2 * len(histories), 4.8))
    for i, name in enumerate(histories):
        ax = fig.add_subplot(1, len(histories), i + 1)
        mine = [r for r in rows if r["history"] == name and r["against"] == "radau"]
        for scheme, color in (("backward_euler", "C0"), ("bdf2", "C3")):
            runs = sorted((r for r in mine if r["scheme"] == scheme), key=lambda r: r["steps"])
            for field, style, marker in (("u", "-", "o"), ("beta", "--", "s"), ("phi", ":", "^")):
                ax.loglog([r["steps"] for r in runs], [r[f"error_{field}"] for r in runs], style, marker=marker,
                          color=color, markersize=4, label=f"{scheme.replace('_', ' ')} {field}")
        runs = [r for r in mine if r["scheme"] in SCHEMES]
        if runs:
            n = np.array(sorted({r["steps"] for r in runs}), dtype=float)
            top = max(r["error_u"] for r in runs)
            ax.loglog(n, top * (n[0] / n), color="grey", linewidth=0.8, label="slope −1")
            ax.loglog(n, top * (n[0] / n) ** 2 / 3, color="black", linewidth=0.8, label="slope −2")
        radau = [r for r in mine if r["scheme"] == "radau"]
        if radau:
            ax.text(0.02, 0.02, f"Radau at the looser rtol: u {radau[0]['error_u']:.1e}, β {radau[0]['error_beta']:.1e}, "
                    f"φ {radau[0]['error_phi']:.1e}", transform=ax.transAxes, fontsize=7, color="grey")
        F0, T = HISTORIES.get(name, (math.nan, math.nan))
        ax.set_title(f"{name}: F0 = {F0:.0e} N/m³, T = {T:g} s")
        ax.set_xlabel("steps over [0, T]")
        ax.set_ylabel("error at T against Radau (u, φ relative; β absolute)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(out, histories=tuple(HISTORIES), steps=STEPS, long_steps=LONG_STEPS, progress=True):
    """Run the study into the directory ``out``: column_order.csv, column_order.png, and a table
    on stdout. Returns the rows."""
    from ngcontact import parallel
    parallel.refuse_under_mpiexec("timeorder")
    histories, steps, long_steps, progress = _arguments(histories, steps, long_steps, progress)
    out = checks.writable_directory(out)
    rows = study(histories, steps, long_steps, progress=progress)
    write_csv(rows, out / "column_order.csv", COLUMNS)
    chart(rows, out / "column_order.png")
    print(table(rows, ("history", "scheme", "against", "steps", "error_u", "rate_u", "error_beta", "rate_beta",
                       "error_beta_rel", "error_phi", "rate_phi", "newton")))
    return rows
