"""Stability maps: where the discretisation and the solver fail, measured on small 2D scenes.

Each study returns its rows (a list of flat dicts, one per run or per step; ``write_csv``
writes them) and, given an output directory, draws its charts there as PNG files:

* ``nitsche_map``: γ0 × θ on the reference plate pressed onto the foundation: Newton
  converged or not, iterations, penetration, pressure oscillation along Γ3, contact force
  against a reference, condition number.
* ``penalty_sweep``: the penalty factor over decades against Nitsche's γ0 at the same
  scale: penetration, condition number, Newton iterations.
* ``time_step_sweep``: the explicit β update (4.5) against the implicit one as k γ_ν L²
  crosses 1, on the plate pulled off its glue.
* ``incompressibility``: ν → 1/2 with P1, P2, P3 on one mesh: the tip deflection of the
  cantilever against a fine P3 solution (locking).
* ``strong_coupling``: the piezoelectric coupling factor k² → 1.
* ``debonding``: complete debonding (β → 0) and contact afterwards, against the glue-free body.
* ``load_cycles``: push-pull cycles that open and close the contact: Newton iterations,
  cut-backs, cycling, force balance.

Runs are made without time-step cut-backs (``max_cutbacks=0``) unless stated, so that
failures show. A failed Newton solve (``NewtonError``) is classified by ``failure_kind``
from its residual history. Units are SI, per metre of depth.
"""
import csv
import dataclasses
import math

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from geometries import plate

from . import scene
from .body import Body
from .contact import Contact
from .contact_laws import positive_part
from .loads import Loads
from .materials import EPS0, Material
from .newton import NewtonError
from .nitsche import stiffness
from .timestepping import Simulation

PUSH_END = scene.LOAD_HISTORY[1][0]
"""End of the reference scene's push ramp (s): the full pressure is reached."""
APPLIED = scene.PRESSURE * scene.L1
"""The reference scene's peak load on top, N/m."""
STATUS_COLOURS = {"ok": "#4daf4a", "wrong": "#ff7f00", "failed": "#e41a1c"}


# ------------------------------------------------------------------------------- helpers

def failure_kind(residuals):
    """Classify the residual history of a failed Newton solve.

    Returns "stagnation" if the residual fell below 1e-6 of the first one but not to the
    tolerance (it stalls at round-off level), "cycle p" if the last residuals repeat with period p <= 8
    (the semismooth Newton iteration cycles between active sets; p = 1: it is stuck),
    "diverged" if a residual is not finite, "no convergence" otherwise.
    """
    r = np.asarray(residuals, dtype=float)
    if not np.all(np.isfinite(r)):
        return "diverged"
    if r.min() < 1e-6 * r[0]:
        return "stagnation"
    tail = r[len(r) // 2:]
    for p in range(1, 9):
        if len(tail) > 2 * p and np.allclose(tail[p:], tail[:-p], rtol=1e-6, atol=0):
            return f"cycle {p}"
    return "no convergence"


def _failure(err):
    """A NewtonError as a dict: ``failure`` (``failure_kind``), ``failed_step``, ``failed_iterations``."""
    return dict(failure=failure_kind(err.residuals), failed_step=err.step, failed_iterations=err.iteration)


def _run(sim, dt, T, max_cutbacks=0):
    """sim.run without raising: None if it reached T, else ``_failure`` of the error."""
    try:
        sim.run(dt=dt, T=T, max_cutbacks=max_cutbacks)
    except NewtonError as err:
        return _failure(err)
    return None


def _newton(sim, failure):
    """Newton iterations of the run: all computed steps, plus the failed attempt."""
    done = int(sim.history.newton_iterations[1:].sum())
    return done + (failure["failed_iterations"] if failure else 0)


def scaled_condition_number(sim, max_dofs=4000):
    """The 2-norm condition number of the Newton Jacobian at the current state.

    The Jacobian is assembled at ``sim.gfu``, restricted to the free DOFs, and its u and φ
    blocks are scaled by the mean of their diagonal, the scaling with which Newton measures
    residuals (J → S J S, S = diag(s_u^-1/2, s_φ^-1/2)). Dense: small problems only
    (at most ``max_dofs`` free DOFs).
    """
    X = sim.body.X
    free = np.array(list(X.FreeDofs()), dtype=bool)
    if free.sum() > max_dofs:
        raise ValueError(f"scaled_condition_number is dense: {free.sum()} free DOFs > max_dofs = {max_dofs}")
    sim.form.AssembleLinearization(sim.gfu.vec)
    J = sp.csr_matrix(sim.form.mat.CSR()).toarray()
    diagonal = np.abs(J.diagonal())
    scale = np.ones(X.ndof)
    for i in range(2):
        block = np.arange(X.Range(i).start, X.Range(i).stop)
        block = block[free[block]]
        scale[block] = diagonal[block].mean() ** -0.5
    return float(np.linalg.cond((scale[:, None] * J * scale)[np.ix_(free, free)]))


def pressure_oscillation(side, pressure):
    """Oscillation of the facet pressure along Γ3, relative to its maximum.

    (TV(p) − (2 max p − p_first − p_last)) / max p: the total variation beyond that of a
    profile that only rises and then falls; 0 for such a profile, > 0 for a zig-zag or
    for separate contact zones. nan without pressure.
    """
    axis = int(np.ptp(side.midpoints, axis=0).argmax())
    p = np.asarray(pressure)[np.argsort(side.midpoints[:, axis])]
    top = p.max()
    if not top > 0:
        return float("nan")
    return float((np.abs(np.diff(p)).sum() - (2 * top - p[0] - p[-1])) / top)


def _press(contact, *, maxh, order, steps, material=None, max_cutbacks=0):
    """The reference plate pushed onto the foundation over the scene's push ramp (0 to
    0.1 s, full pressure at the end) in ``steps`` steps, without cut-backs by default.

    Returns (sim, failure), failure as in ``_run``. ``material`` replaces PZT-5A.
    """
    t = ngs.Parameter(0.0)
    body = scene.body(order, maxh)
    if material is not None:
        body = Body(body.mesh, material, clamped="left", grounded="top", contact="bottom", order=order)
    sim = Simulation(body, scene.loads(t), contact=contact, time=t, keep_states=False)
    return sim, _run(sim, PUSH_END / steps, PUSH_END, max_cutbacks)


def _reference_force(maxh, order, steps, gamma0=1000.0):
    """Contact force of the pushed plate with θ = −1 and a large γ0 (the reference)."""
    sim, failure = _press(scene.contact(-1, gamma0), maxh=maxh, order=order, steps=steps)
    if failure:
        raise RuntimeError(f"the reference solve (θ = -1, γ0 = {gamma0}) failed: {failure}")
    return float(sim.history[-1].contact.force[1])


def _report(progress, row, keys):
    if progress:
        progress("  ".join(f"{k} {_fmt(row[k])}" for k in keys))


def _fmt(value):
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return "nan" if math.isnan(value) else f"{value:.4g}"
    return str(value)


def write_csv(rows, path):
    """The rows as a CSV file, one column per key of the first row."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.6g}" if isinstance(v, (float, np.floating)) else v)
                             for k, v in row.items()})


def table(rows, columns):
    """A plain-text table of the given columns of the rows."""
    cells = [[_fmt(row[c]) for c in columns] for row in rows]
    widths = [max(len(c), *(len(line[i]) for line in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(columns, widths))]
    lines += ["  ".join(v.rjust(w) for v, w in zip(line, widths)) for line in cells]
    return "\n".join(lines)


def _short(failure):
    """A short label of a ``failure_kind`` for charts: c2 (cycle 2), stag, nc, div."""
    return {"stagnation": "stag", "no convergence": "nc", "diverged": "div"}.get(
        failure, failure.replace("cycle ", "c"))


def _save(fig, out, name):
    fig.savefig(out / name, dpi=100)


# ------------------------------------------------------------------------------- Nitsche γ0 × θ

def nitsche_map(out=None, *, gamma0s=None, thetas=(1, 0, -1), maxh=0.01, order=1, steps=4,
                reference_gamma0=1000.0, force_tol=0.01, quick=False, progress=None):
    """γ0 × θ on the reference plate pushed onto the foundation (scene contact data).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``nitsche_map.png`` (status of every run)
        and ``nitsche_sweep.png`` (the measured quantities against γ0).
    gamma0s : γ0 values; default 15 (quick: 8) log-spaced values in [1e-3, 1e4].
    thetas : Nitsche variants.
    maxh, order : mesh size (m, halved on Γ3) and polynomial order.
    steps : time steps over the push ramp (0 to 0.1 s), no cut-backs.
    reference_gamma0 : the reference force is the θ = −1 solution with this γ0 on the
        same mesh, so that the error measures the method, not the mesh.
    force_tol : relative force error above which a converged run counts as "wrong".
    quick : fewer γ0 values.
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per (θ, γ0): ``status`` ("ok", "wrong" or "failed"), ``failure``
    (``failure_kind``, "" if converged), ``failed_step``, ``newton`` (total iterations,
    with the failed attempt), ``force`` (N/m), ``force_error`` (relative), ``max_penetration``
    (m), ``pressure_oscillation`` (``pressure_oscillation``), ``contact_length`` (m) and
    ``cond`` (``scaled_condition_number`` at the final state).
    """
    if gamma0s is None:
        gamma0s = np.logspace(-3, 4, 8 if quick else 15)
    reference = _reference_force(maxh, order, steps, reference_gamma0)
    rows = []
    for theta in thetas:
        for gamma0 in gamma0s:
            sim, failure = _press(scene.contact(theta, float(gamma0)), maxh=maxh, order=order, steps=steps)
            row = dict(theta=theta, gamma0=float(gamma0), status="failed",
                       failure=failure["failure"] if failure else "",
                       failed_step=failure["failed_step"] if failure else 0,
                       newton=_newton(sim, failure), force=math.nan, force_error=math.nan,
                       max_penetration=math.nan, pressure_oscillation=math.nan,
                       contact_length=math.nan, cond=math.nan)
            if not failure:
                c = sim.history[-1].contact
                error = abs(c.force[1] - reference) / abs(reference)
                row.update(status="ok" if error <= force_tol else "wrong", force=float(c.force[1]),
                           force_error=float(error), max_penetration=c.max_penetration,
                           pressure_oscillation=pressure_oscillation(sim.side, c.pressure),
                           contact_length=c.contact_length, cond=scaled_condition_number(sim))
            rows.append(row)
            _report(progress, row, ("theta", "gamma0", "status", "failure", "newton", "force_error",
                                    "max_penetration", "pressure_oscillation"))
    if out is not None:
        _plot_nitsche(rows, out, force_tol, steps)
    return rows


def ok_range(rows, theta):
    """(smallest, largest) γ0 of the longest run of consecutive γ0 values of a
    ``nitsche_map`` sweep with status "ok" for this θ; (nan, nan) if there is none."""
    runs = sorted((r for r in rows if r["theta"] == theta), key=lambda r: r["gamma0"])
    best, current = [], []
    for r in runs:
        current = current + [r["gamma0"]] if r["status"] == "ok" else []
        best = max(best, current, key=len)
    return (best[0], best[-1]) if best else (math.nan, math.nan)


def _plot_nitsche(rows, out, force_tol, steps):
    thetas = list(dict.fromkeys(r["theta"] for r in rows))
    gamma0s = sorted({r["gamma0"] for r in rows})
    codes = {s: i for i, s in enumerate(STATUS_COLOURS)}
    grid = np.zeros((len(thetas), len(gamma0s)))
    fig = Figure(figsize=(9, 2.8), layout="constrained")
    ax = fig.add_subplot()
    for r in rows:
        i, j = thetas.index(r["theta"]), gamma0s.index(r["gamma0"])
        grid[i, j] = codes[r["status"]]
        label = str(r["newton"]) if r["status"] != "failed" else _short(r["failure"])
        ax.text(j, i, label, ha="center", va="center", fontsize=8)
    ax.imshow(grid, cmap=ListedColormap(list(STATUS_COLOURS.values())), vmin=-0.5,
              vmax=len(STATUS_COLOURS) - 0.5, aspect="auto")
    ax.set_xticks(range(len(gamma0s)), [f"{g:.3g}" for g in gamma0s], fontsize=8)
    ax.set_yticks(range(len(thetas)), [f"θ = {t}" for t in thetas])
    ax.set(xlabel="γ0", title=f"green: converged, force within {100 * force_tol:g} %; orange: "
           "converged, force wrong; red: Newton failed\n(numbers: Newton iterations; c2: cycles "
           "with period 2, nc: no convergence)")
    _save(fig, out, "nitsche_map.png")

    fig = Figure(figsize=(11, 6.5), layout="constrained")
    axes = fig.subplots(2, 3, sharex=True)
    panels = [("newton", "Newton iterations (× = failed)", "linear"),
              ("force_error", "contact force error (relative)", "log"),
              ("max_penetration", "max penetration u_ν − g [m]", "log"),
              ("pressure_oscillation", "pressure oscillation along Γ3", "linear"),
              ("cond", "cond of the scaled Jacobian", "log"),
              ("contact_length", "contact length [m]", "linear")]
    for i, theta in enumerate(thetas):
        runs = [r for r in rows if r["theta"] == theta]
        g = np.array([r["gamma0"] for r in runs])
        ok = np.array([r["status"] != "failed" for r in runs])
        for ax, (key, _, scale) in zip(axes.flat, panels):
            y = np.array([r[key] for r in runs], dtype=float)
            shown = ok & (y > 0) if scale == "log" else ok
            ax.plot(g[shown], y[shown], "o-", color=f"C{i}", ms=4, label=f"θ = {theta}")
            if key == "newton":
                ax.plot(g[~ok], y[~ok], "x", color=f"C{i}", ms=9, mew=2)
    axes[0, 1].axhline(force_tol, color="k", lw=0.6, ls="--")
    for ax, (_, label, scale) in zip(axes.flat, panels):
        ax.set(xscale="log", yscale=scale, ylabel=label)
        ax.grid(True, lw=0.3)
    for ax in axes[1]:
        ax.set_xlabel("γ0")
    axes[0, 0].legend()
    fig.suptitle(f"the reference plate pushed onto the foundation ({steps} steps, no cut-backs)")
    _save(fig, out, "nitsche_sweep.png")


# ------------------------------------------------------------------------------- penalty

def penalty_available():
    """True if ``Contact`` offers ``method="penalty"``."""
    return {"method", "penalty"} <= {f.name for f in dataclasses.fields(Contact)}


def penalty_sweep(out=None, *, factors=None, maxh=0.01, order=1, steps=4, quick=False, progress=None):
    """The penalty factor over decades, against Nitsche (θ = 1) with γ0 equal to the factor
    (ε and γ have the same scaling, factor · p² · stiffness / h).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``penalty_sweep.png``.
    factors : penalty factors = γ0 values; default 1e-3 ... 1e6 (quick: every other decade).
    maxh, order, steps : as in ``nitsche_map``.
    quick : fewer factors.
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per (method, factor): ``converged``, ``failure``, ``newton``,
    ``max_penetration`` (m), ``force`` (N/m), ``force_error`` (against θ = −1, γ0 = 1000),
    ``cond``.
    """
    if not penalty_available():
        raise RuntimeError("Contact has no method='penalty' in this version of ngcontact")
    if factors is None:
        factors = np.logspace(-3, 5, 5) if quick else np.logspace(-3, 6, 10)
    reference = _reference_force(maxh, order, steps)
    rows = []
    for method in ("penalty", "nitsche"):
        for factor in factors:
            extra = dict(method="penalty", penalty=float(factor)) if method == "penalty" else \
                dict(theta=1, gamma0=float(factor))
            sim, failure = _press(Contact(**scene.CONTACT, **extra), maxh=maxh, order=order, steps=steps)
            row = dict(method=method, factor=float(factor), converged=failure is None,
                       failure=failure["failure"] if failure else "", newton=_newton(sim, failure),
                       max_penetration=math.nan, force=math.nan, force_error=math.nan, cond=math.nan)
            if not failure:
                c = sim.history[-1].contact
                row.update(max_penetration=c.max_penetration, force=float(c.force[1]),
                           force_error=float(abs(c.force[1] - reference) / abs(reference)),
                           cond=scaled_condition_number(sim))
            rows.append(row)
            _report(progress, row, ("method", "factor", "converged", "failure", "newton", "max_penetration",
                                    "force_error", "cond"))
    if out is not None:
        _plot_penalty(rows, out)
    return rows


def fitted_slope(rows, x, y, **select):
    """Least-squares slope of log y against log x over the rows matching ``select`` with
    finite, positive y."""
    pts = [(r[x], r[y]) for r in rows if all(r[k] == v for k, v in select.items())
           and np.isfinite(r[y]) and r[y] > 0]
    xs, ys = np.log(np.array(pts)).T
    return float(np.polyfit(xs, ys, 1)[0])


def _plot_penalty(rows, out):
    fig = Figure(figsize=(12, 3.8), layout="constrained")
    axes = fig.subplots(1, 4)
    for i, method in enumerate(("penalty", "nitsche")):
        runs = [r for r in rows if r["method"] == method]
        f = np.array([r["factor"] for r in runs])
        label = "penalty, ε = factor·p²·stiffness/h" if method == "penalty" else \
            "Nitsche θ = 1, γ0 = factor"
        ok = np.array([r["converged"] for r in runs])
        for ax, key in zip(axes, ("max_penetration", "force_error", "cond", "newton")):
            y = np.array([r[key] for r in runs], dtype=float)
            ax.plot(f[ok], np.abs(y[ok]), "o-", color=f"C{i}", ms=4, label=label)
        failed = [r["newton"] for r in runs if not r["converged"]]
        axes[3].plot(f[~ok], failed, "x", color=f"C{i}", ms=9, mew=2)
    f = np.array(sorted({r["factor"] for r in rows}))
    pen = [r for r in rows if r["method"] == "penalty" and r["max_penetration"] > 0]
    if pen:
        ax, r0 = axes[0], pen[0]
        ax.plot(f, r0["max_penetration"] * r0["factor"] / f, "k:", lw=0.8, label="slope −1")
    for ax, label, scale in zip(axes, ("|max penetration| [m]", "contact force error (relative)",
                                       "cond of the scaled Jacobian", "Newton iterations (× = failed)"),
                                ("log", "log", "log", "linear")):
        ax.set(xscale="log", yscale=scale, xlabel="factor", ylabel=label)
        ax.grid(True, lw=0.3)
    axes[0].legend(fontsize=7)
    _save(fig, out, "penalty_sweep.png")


# ------------------------------------------------------------------------------- β update

def _pulled_plate(update, maxh, pull):
    """The reference plate, glued (scene contact data), pulled off from rest: the top load
    ramps to ``pull`` × the scene's pressure (negative: upwards) in 10 ms and is held."""
    t = ngs.Parameter(0.0)
    history = ((0.0, 0.0), (0.01, pull), (1e3, pull))
    loads = Loads(f2={"top": (0, -scene.PRESSURE * scene.load_factor(t, history))})
    return Simulation(scene.body(1, maxh), loads, contact=Contact(**scene.CONTACT, beta_update=update),
                      time=t, keep_states=False)


def _beta_run(update, dt, T, maxh, pull):
    """Step the pulled plate; for the explicit update, record its value before clipping.

    Returns (sim, raw, failure): raw[n] is β_{n−1} − k P_B[β_{n−1} γ_ν R_ν(u_{n−1,ν})² − ε_a]_+,
    the explicit update (4.5) before it is clipped to [0, 1] (raw[0] = β0); for the implicit
    update raw is β itself.
    """
    sim = _pulled_plate(update, maxh, pull)
    c, side = sim.contact, sim.side
    u_normal = sim.u * ngs.specialcf.normal(sim.body.dim)
    rate = side.facet_integrals(positive_part(sim.beta.gf * c.adhesion * c.R(u_normal) ** 2 - c.eps_a))
    raw, failure = [sim.beta.values.copy()], None
    for _ in range(int(round(T / dt))):
        unclipped = sim.beta.values - dt * rate() / side.measure
        try:
            sim.step(dt)
        except NewtonError as err:
            failure = _failure(err)
            break
        if update == "implicit":
            unclipped = sim.beta.values.copy()
        elif not np.allclose(np.clip(unclipped, 0, 1), sim.beta.values, atol=1e-12):
            raise RuntimeError("the recorded explicit update is not the one of adhesion.BondingField")
        raw.append(unclipped)
    return sim, np.array(raw), failure


def _extrapolated_beta(dt, T, maxh, pull):
    """Richardson extrapolation 2 β(k) − β(2k) of the implicit update (first order in k), at
    the times of the 2k grid; returns (times, β, side)."""
    coarse, fine = (_beta_run("implicit", k, T, maxh, pull) for k in (2 * dt, dt))
    for sim, _, failure in (coarse, fine):
        if failure:
            raise RuntimeError(f"the reference β run failed: {failure}")
    beta = 2 * fine[0].history.contact_column("beta")[::2] - coarse[0].history.contact_column("beta")
    return coarse[0].history.times, beta, coarse[0].side


def time_step_sweep(out=None, *, kgl2s=None, reference_kgl2=0.125, T=0.32, pull=-0.2, maxh=0.01,
                    quick=False, progress=None):
    """The explicit β update (4.5) against the implicit one for k γ_ν L² from below to above 1.

    The glued reference plate is pulled off from rest (top load −0.2 × 2 MPa, 10 ms ramp,
    then held): the glue stretches, β decays from the free end and the plate lifts off
    (R_ν = L there, so the explicit decay factor per step is 1 − k γ_ν L²).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``time_step_sweep.png``.
    kgl2s : values of k γ_ν L² (k = value / (γ_ν L²)); default 0.5 ... 8 in factors of 2
        (quick: 0.5, 2, 8).
    reference_kgl2 : the reference is the Richardson extrapolation 2 β(k) − β(2k) of the
        implicit update with k γ_ν L² = ``reference_kgl2`` (quick: twice it); the sweep's k
        must be multiples of 2k.
    T : final time, s (a multiple of every k).
    pull : the held top load as a fraction of the scene's pressure (negative: pull).
    maxh : mesh size, m.
    quick : fewer and coarser steps.
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per (update, k): ``steps``, ``failure``, ``newton``, ``beta_min`` and
    ``beta_max`` (over facets and steps), ``beta_raw_min`` (min of the explicit update
    before clipping; for the implicit update its value itself), ``clipped`` (facet-steps
    clipped) and ``clipped_steps``, ``beta_rise`` (largest increase of β in a step: 0 for a
    monotone decay), ``beta_mean_final``, ``beta_error`` (max over the common times of
    ‖β − β_ref‖_L²(Γ3) / |Γ3|^½).
    """
    if kgl2s is None:
        kgl2s = (0.5, 2.0, 8.0) if quick else (0.5, 1.0, 2.0, 4.0, 8.0)
    if quick:
        reference_kgl2 *= 2
    rate = scene.CONTACT["adhesion"] * scene.CONTACT["bond_length"] ** 2
    ref_times, reference, side = _extrapolated_beta(reference_kgl2 / rate, T, maxh, pull)
    measure = side.measure
    rows, traces = [], {}
    for update in ("explicit", "implicit"):
        for kgl2 in kgl2s:
            dt = kgl2 / rate
            sim, raw, failure = _beta_run(update, dt, T, maxh, pull)
            beta = sim.history.contact_column("beta")
            every = int(round(dt * rate / (2 * reference_kgl2)))
            diff = beta - reference[::every][:len(beta)]
            clipped = sim.history.contact_column("beta_clipped")
            row = dict(update=update, k=dt, kgl2=kgl2, steps=len(beta) - 1,
                       failure=failure["failure"] if failure else "", newton=_newton(sim, failure),
                       beta_min=float(beta.min()), beta_max=float(beta.max()),
                       beta_raw_min=float(raw.min()), clipped=int(clipped.sum()),
                       clipped_steps=int(np.count_nonzero(clipped)),
                       beta_rise=float(max(np.diff(beta, axis=0).max(), 0.0)),
                       beta_mean_final=float(beta[-1].mean()),
                       beta_error=float(np.sqrt((diff ** 2 @ measure) / measure.sum()).max()))
            rows.append(row)
            traces[update, kgl2] = (sim.history.times, beta, raw)
            _report(progress, row, ("update", "kgl2", "steps", "beta_raw_min", "clipped", "beta_rise",
                                    "beta_error", "newton"))
    if out is not None:
        _plot_beta(rows, traces, (ref_times, reference), side, reference_kgl2, out)
    return rows


def _plot_beta(rows, traces, reference, side, reference_kgl2, out):
    tip = int(np.argmax(side.midpoints[:, 0]))
    fig = Figure(figsize=(13, 3.8), layout="constrained")
    axes = fig.subplots(1, 3)
    for i, update in enumerate(("explicit", "implicit")):
        runs = [r for r in rows if r["update"] == update]
        x = [r["kgl2"] for r in runs]
        axes[0].loglog(x, [r["beta_error"] for r in runs], "o-", color=f"C{i}", label=update)
        axes[1].plot(x, [r["beta_raw_min"] for r in runs], "o-", color=f"C{i}", label=update)
    axes[0].set(xlabel="k γ_ν L²", ylabel="max_n ‖β − β_ref‖ / |Γ3|^½",
                title="error against the reference β")
    axes[1].axhline(0, color="k", lw=0.6)
    axes[1].set(xscale="log", xlabel="k γ_ν L²", ylabel="min of β_n before clipping",
                title="explicit (4.5) leaves [0, 1] for k γ_ν L² > 1")
    kgl2s = sorted({r["kgl2"] for r in rows})
    for ax in axes[:2]:
        ax.set_xticks(kgl2s, [f"{k:g}" for k in kgl2s], minor=False)
        ax.set_xticks([], minor=True)
    times, beta = reference
    axes[2].plot(times, beta[:, tip], "k-", lw=2, label="reference")
    shown = sorted({kgl2 for _, kgl2 in traces})
    for j, kgl2 in enumerate(shown[::2] if len(shown) > 3 else shown):
        for update, style in (("explicit", "o--"), ("implicit", "s-")):
            t, b, raw = traces[update, kgl2]
            axes[2].plot(t, b[:, tip], style, color=f"C{j + 2}", ms=3, lw=0.8, label=f"{update} {kgl2:g}")
            if update == "explicit":
                axes[2].plot(t, raw[:, tip], ".", color=f"C{j + 2}", ms=4)
    axes[2].set(xlabel="time t [s]", ylabel="β at the free end",
                title="dots: explicit before clipping")
    for ax in axes:
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7)
    _save(fig, out, "time_step_sweep.png")


# ------------------------------------------------------------------------------- ν → 1/2

def _tip_deflection(nu, order, mesh):
    """u_y at the free bottom corner of the cantilever under 10 kPa on top, isotropic,
    E = 1 GPa, no piezoelectric coupling, one static step."""
    material = Material.isotropic(1e9, nu, permittivity=1e-9)
    body = Body(mesh, material, clamped="left", grounded="top", order=order)
    sim = Simulation(body, Loads(f2={"top": (0, -1e4)}), keep_states=False)
    sim.step(1.0)
    return float(sim.u(mesh(scene.L1, 0.0))[1]), body.ndof


def incompressibility(out=None, *, nus=None, orders=(1, 2, 3), maxh=0.005, reference_order=3,
                      reference_refine=2, quick=False, progress=None):
    """ν → 1/2: the tip deflection of the clamped plate (no contact) for P1, P2, P3 on one
    Netgen mesh, and P1 on a mesh of about the same size made by ``mesh.Refine()``, relative
    to a P3 solution on the Netgen mesh refined ``reference_refine`` times.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``incompressibility.png``.
    nus : Poisson ratios; default 0.3, 0.45, 0.49, 0.499, 0.4999 (quick: 0.3, 0.49, 0.499).
    orders : orders compared on the Netgen mesh of size ``maxh`` (m).
    reference_order, reference_refine : the fine reference.
    quick : fewer ν.
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per (ν, order, mesh): ``mesh`` ("netgen" or "refined"), ``ndof``,
    ``tip_deflection`` (m), ``ratio`` (to the reference; locking: → 0).
    """
    if nus is None:
        nus = (0.3, 0.49, 0.499) if quick else (0.3, 0.45, 0.49, 0.499, 0.4999)
    meshes = dict(netgen=lambda: plate(scene.L1, scene.L2, maxh=maxh),
                  refined=lambda: plate(scene.L1, scene.L2, maxh=2 * maxh, refine=1))
    rows = []
    for nu in nus:
        reference, _ = _tip_deflection(nu, reference_order, plate(scene.L1, scene.L2, maxh=maxh,
                                                                   refine=reference_refine))
        runs = [(order, "netgen") for order in orders] + [(1, "refined")]
        for order, mesh in runs:
            tip, ndof = _tip_deflection(nu, order, meshes[mesh]())
            row = dict(nu=nu, order=order, mesh=mesh, ndof=ndof, tip_deflection=tip,
                       reference=reference, ratio=tip / reference)
            rows.append(row)
            _report(progress, row, ("nu", "order", "mesh", "ndof", "ratio"))
    if out is not None:
        _plot_incompressibility(rows, out)
    return rows


def _plot_incompressibility(rows, out):
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
    _save(fig, out, "incompressibility.png")


# ------------------------------------------------------------------------------- coupling k² → 1

def coupling_factor(material, dim=2):
    """k² = e33² / (c33^D ε33), c33^D = c33 + e33²/ε33 (the poling axis' entries of the
    model's F, E, C): the electromechanical coupling factor, < 1 for any e."""
    T = material.tensors(dim)
    i = dim - 1
    ratio = T.E[i, i] ** 2 / (T.F[i, i] * T.C[i, i])
    return ratio / (1 + ratio)


def strong_coupling(out=None, *, k2s=None, maxh=0.01, order=1, steps=4, quick=False, progress=None):
    """The reference plate pushed onto the foundation with PZT-5A's piezoelectric constants
    scaled so that the coupling factor k² (``coupling_factor``) approaches 1.

    Each k² is run without cut-backs; a failed run is repeated with cut-backs (6).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``strong_coupling.png``.
    k2s : coupling factors; PZT-5A's own (0.234) is always included; default 0.5 ... 0.9999
        (quick: 0.9, 0.999, 0.9999).
    maxh, order, steps : as in ``nitsche_map``.
    quick : fewer k².
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per k²: ``e_scale`` (the factor on e), ``stiffening`` (λ_max(F + Eᵀ
    C⁻¹E) / λ_max(F): the factor by which the elastic part of Nitsche's γ grows),
    ``converged`` (no cut-backs), ``failure``, ``failed_step``, ``newton``, ``recovered``
    (with cut-backs), ``cutbacks``, ``force_ratio`` (contact force / applied load),
    ``max_penetration`` (m), ``cond``.
    """
    base = scene.body(order, maxh).material
    nominal = coupling_factor(base)
    if k2s is None:
        k2s = (0.9, 0.999, 0.9999) if quick else (0.5, 0.7, 0.8, 0.85, 0.88, 0.9, 0.92, 0.95, 0.99, 0.999,
                                                  0.9999)
    k2s = [nominal] + [k for k in k2s if not math.isclose(k, nominal)]
    ratio0 = nominal / (1 - nominal)
    elastic = np.linalg.eigvalsh(base.tensors(2).F).max()
    rows = []
    for k2 in k2s:
        scale = math.sqrt(k2 / (1 - k2) / ratio0)
        material = Material(base.c, scale * base.e, base.eps, base.eta, name=f"PZT-5A, e × {scale:.3g}")
        sim, failure = _press(scene.contact(), maxh=maxh, order=order, steps=steps, material=material)
        row = dict(k2=k2, e_scale=scale, stiffening=stiffness(material.tensors(2), 0.0) / elastic,
                   converged=failure is None, failure=failure["failure"] if failure else "",
                   failed_step=failure["failed_step"] if failure else 0, newton=_newton(sim, failure),
                   recovered=failure is None, cutbacks=0, force_ratio=math.nan,
                   max_penetration=math.nan, cond=math.nan)
        if failure:
            sim, again = _press(scene.contact(), maxh=maxh, order=order, steps=steps,
                                material=material, max_cutbacks=6)
            row.update(recovered=again is None, cutbacks=len(sim.cutbacks))
            failure = again
        if not failure:
            c = sim.history[-1].contact
            row.update(force_ratio=float(c.force[1]) / APPLIED, max_penetration=c.max_penetration,
                       cond=scaled_condition_number(sim))
        rows.append(row)
        _report(progress, row, ("k2", "e_scale", "converged", "failure", "newton", "recovered",
                                "cutbacks", "force_ratio", "cond"))
    if out is not None:
        _plot_coupling(rows, out)
    return rows


def _plot_coupling(rows, out):
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
    axes[1].plot(x, [r["cond"] for r in rows], "o-", label="cond of the scaled Jacobian")
    axes[1].plot(x, [r["stiffening"] for r in rows], "s--", label="λmax(F + EᵀC⁻¹E) / λmax(F)")
    axes[1].set(yscale="log")
    axes[1].legend(fontsize=7)
    axes[2].plot(x, [r["force_ratio"] for r in rows], "o-")
    axes[2].set(ylabel="contact force / applied load")
    for ax in axes:
        ax.set(xscale="log", xlabel="1 − k²")
        ax.invert_xaxis()
        ax.grid(True, lw=0.3)
    _save(fig, out, "strong_coupling.png")


# ------------------------------------------------------------------------------- debonding

COLUMN = dict(W=0.02, H=0.02, maxh=0.005)
"""The debonding scene: a square column (m), clamped and grounded on top, glued at the bottom."""


def _column(adhesion, force, update):
    """The column of a soft piezoelectric polymer-like material (E = 1 GPa, ν = 0.3,
    e33 = 0.05, e31 = −0.02 C/m², ε = 10 ε0, A = τ F with the scene's τ; not a data-sheet
    material), lifted by a body force ``force`` (N/m³, upwards) held to 0.1 s, then pushed
    down by the same force from 0.12 s. Scene contact data, without conduction."""
    material = Material.isotropic(1e9, 0.3, permittivity=10 * EPS0, e31=-0.02, e33=0.05,
                                  name="soft piezo polymer").with_viscosity(scene.RELAXATION_TIME)
    mesh = plate(COLUMN["W"], COLUMN["H"], maxh=COLUMN["maxh"])
    body = Body(mesh, material, clamped="top", grounded="top", contact="bottom")
    t = ngs.Parameter(0.0)
    history = ((0.0, 0.0), (0.01, 1.0), (0.1, 1.0), (0.12, -1.0), (1e3, -1.0))
    contact = Contact(**{**scene.CONTACT, "adhesion": adhesion, "conductance": 0.0}, beta_update=update)
    return Simulation(body, Loads(f0=(0, force * scene.load_factor(t, history))), contact=contact,
                      time=t, keep_states=False), history


def debonding(out=None, *, force=3e8, dt=2e-3, T=0.2, beta_update="explicit", quick=False, progress=None):
    """Complete debonding, then contact: the glued column against the same column without glue.

    The body force lifts the column (force × H = 6 MPa against the glue's strength γ_ν L = 5 MPa:
    the glue stretches beyond L), β decays to 0 everywhere, the force reverses at 0.1-0.12 s
    and pushes the column onto the foundation. Cut-backs are allowed (6).

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``debonding.png``.
    force : body force, N/m³.
    dt, T : time step and final time, s (k γ_ν L² = 0.5 at 2 ms).
    beta_update : "explicit" or "implicit".
    quick : twice the time step.
    progress : callable for a summary line, or None.

    Returns
    -------
    list of dict, one per step: ``time``, ``body_force`` (N/m³, upwards), ``beta_max``,
    ``beta_mean``, ``force_glued`` and ``force_free`` (the foundation's force on the
    column, N/m, y), ``newton_glued``, ``newton_free``, ``cutbacks`` (both runs, over the
    whole run).
    """
    if quick:
        dt *= 2
    runs = {}
    for name, adhesion in (("glued", scene.CONTACT["adhesion"]), ("free", 0.0)):
        sim, history = _column(adhesion, force, beta_update)
        failure = _run(sim, dt, T, max_cutbacks=6)
        if failure:
            raise RuntimeError(f"the {name} column failed: {failure}")
        runs[name] = sim
    glued, free = (runs[k].history for k in ("glued", "free"))
    if len(glued) != len(free) or not np.allclose(glued.times, free.times):
        raise RuntimeError("the glued and glue-free runs took different time steps (cut-backs)")
    times = np.array(history)
    beta = glued.contact_column("beta")
    rows = [dict(time=float(g.time), body_force=float(force * np.interp(g.time, *times.T)),
                 beta_max=float(b.max()), beta_mean=float(b.mean()),
                 force_glued=float(g.contact.force[1]), force_free=float(f.contact.force[1]),
                 newton_glued=int(g.newton_iterations), newton_free=int(f.newton_iterations),
                 cutbacks=len(runs["glued"].cutbacks) + len(runs["free"].cutbacks))
            for g, f, b in zip(glued[1:], free[1:], beta[1:])]
    if progress:
        s = debonding_summary(rows)
        progress(f"beta_max final {s['beta_max_final']:.3g}; after complete debonding "
                 f"|F_glued − F_free| / |F| <= {s['force_difference']:.3g}")
    if out is not None:
        _plot_debonding(rows, out)
    return rows


def debonding_summary(rows, beta_tol=1e-8):
    """Final β_max, the time from which β_max < ``beta_tol``, and the largest difference of
    the glued and glue-free contact forces from then on, relative to the largest force."""
    debonded = [r for r in rows if r["beta_max"] < beta_tol]
    scale = max(abs(r["force_free"]) for r in rows)
    return dict(beta_max_final=rows[-1]["beta_max"],
                debonded_at=debonded[0]["time"] if debonded else math.nan,
                force_difference=max((abs(r["force_glued"] - r["force_free"]) for r in debonded),
                                     default=math.nan) / scale,
                contact_force_final=rows[-1]["force_glued"])


def _plot_debonding(rows, out):
    t = np.array([r["time"] for r in rows])
    fig = Figure(figsize=(7.5, 5.5), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    axes[0].plot(t, [1e-3 * r["force_glued"] for r in rows], "-", lw=2, label="glued")
    axes[0].plot(t, [1e-3 * r["force_free"] for r in rows], "--", label="no glue")
    axes[0].set(ylabel="foundation force on Γ3 [kN/m]",
                title="column lifted (glue in tension, then debonded), then pushed down")
    axes[0].legend()
    axes[1].semilogy(t, np.maximum([r["beta_max"] for r in rows], 1e-300), "C1", label="max β")
    axes[1].semilogy(t, np.maximum([r["beta_mean"] for r in rows], 1e-300), "C1:", label="mean β")
    axes[1].set(xlabel="time t [s]", ylabel="bonding field β", ylim=(1e-18, 2))
    axes[1].legend()
    for ax in axes:
        ax.grid(True, lw=0.3)
    _save(fig, out, "debonding.png")


# ------------------------------------------------------------------------------- load cycles

def _cycle_history(cycles, period, low):
    """Load factors (time, fraction of the scene's pressure): push to 1, reverse to ``low``."""
    history = [(0.0, 0.0)]
    for i in range(cycles):
        history += [(i * period + period / 2, 1.0), ((i + 1) * period, low)]
    return tuple(history)


def load_cycles(out=None, *, dts=None, cycles=4, period=0.1, low=-0.2, maxh=0.01, quick=False,
                progress=None):
    """Push-pull cycles on the reference scene (glue, conduction) that open and close the
    contact repeatedly: the top load goes 0 → 1 → ``low`` (× 2 MPa) every ``period`` s.

    Cut-backs are allowed (6); each cut-back's failed attempt is classified by
    ``failure_kind``.

    Parameters
    ----------
    out : pathlib.Path or None, where to draw ``load_cycles.png``.
    dts : nominal time steps, s; default 5, 10, 20, 25, 50 ms (quick: 10, 25 ms).
    cycles, period, low : the load history.
    maxh : mesh size, m.
    quick : fewer time steps, two cycles.
    progress : callable for a line per run, or None.

    Returns
    -------
    list of dict, one per nominal time step ``dt``: ``records`` (steps computed), ``newton``
    (total), ``newton_max`` (per step), ``cutbacks``, ``cycling`` (cut-backs whose failed
    attempt cycled), ``switches`` (facets entering or leaving the contact zone, summed over steps),
    ``openings`` (steps after which the contact zone is empty while it was not before),
    ``balance`` (max over steps of |reaction + contact force − load| / peak load),
    ``beta_min_final``.
    """
    if dts is None:
        dts = (0.01, 0.025) if quick else (0.005, 0.01, 0.02, 0.025, 0.05)
    if quick:
        cycles = 2
    history = _cycle_history(cycles, period, low)
    rows, traces = [], {}
    for dt in dts:
        t = ngs.Parameter(0.0)
        loads = Loads(f2={"top": (0, -scene.PRESSURE * scene.load_factor(t, history))})
        sim = Simulation(scene.body(1, maxh), loads, contact=scene.contact(), time=t, keep_states=False)
        failure = _run(sim, dt, cycles * period, max_cutbacks=6)
        h = sim.history
        in_contact = h.contact_column("contact_set")[1:] > 0.5
        length = h.contact_column("contact_length")[1:]
        load = APPLIED * np.interp(h.times[1:], *np.array(history).T)
        balance = h.reactions[1:, 1] + h.contact_column("force")[1:, 1] - load
        row = dict(dt=dt, failure=failure["failure"] if failure else "", records=len(h) - 1,
                   newton=_newton(sim, failure), newton_max=int(h.newton_iterations[1:].max()),
                   cutbacks=len(sim.cutbacks),
                   cycling=sum(failure_kind(c["residuals"]).startswith("cycle") for c in sim.cutbacks),
                   switches=int(np.count_nonzero(np.diff(in_contact, axis=0))),
                   openings=int(np.count_nonzero((length[1:] == 0) & (length[:-1] > 0))),
                   balance=float(np.abs(balance).max() / APPLIED),
                   beta_min_final=float(h[-1].contact.beta.min()))
        rows.append(row)
        traces[dt] = (h.times[1:], length, h.newton_iterations[1:], [c["time"] for c in sim.cutbacks])
        _report(progress, row, ("dt", "records", "newton", "newton_max", "cutbacks", "cycling",
                                "switches", "openings", "balance"))
    if out is not None:
        _plot_cycles(traces, history, out)
    return rows


def _plot_cycles(traces, history, out):
    fig = Figure(figsize=(9, 7), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    times, factors = np.array(history).T
    axes[0].plot(times, 1e-6 * scene.PRESSURE * factors, "k")
    axes[0].set(ylabel="pressure on top [MPa]", title="push-pull cycles on the reference scene")
    for i, (dt, (t, length, newton, cut)) in enumerate(traces.items()):
        axes[1].plot(t, 1e3 * length, "o-", color=f"C{i}", ms=3, lw=0.7, label=f"k = {1e3 * dt:g} ms")
        axes[2].plot(t, newton, "o-", color=f"C{i}", ms=3, lw=0.7)
        for c in cut:
            axes[2].axvline(c, color=f"C{i}", lw=0.8, ls=":")
    axes[1].set(ylabel="contact length [mm]")
    axes[1].legend(fontsize=7, ncol=len(traces))
    axes[2].set(xlabel="time t [s]", ylabel="Newton iterations per step\n(dotted: cut-back)")
    for ax in axes:
        ax.grid(True, lw=0.3)
    _save(fig, out, "load_cycles.png")


# ------------------------------------------------------------------------------- all studies

STUDIES = dict(nitsche_map=nitsche_map, time_step_sweep=time_step_sweep,
               incompressibility=incompressibility, strong_coupling=strong_coupling,
               debonding=debonding, load_cycles=load_cycles, penalty_sweep=penalty_sweep)
"""The studies in the order ``python -m ngcontact stability`` runs them (penalty last)."""

TABLES = dict(
    nitsche_map=("theta", "gamma0", "status", "failure", "newton", "force_error", "max_penetration",
                 "pressure_oscillation", "cond"),
    penalty_sweep=("method", "factor", "converged", "failure", "newton", "max_penetration", "force_error",
                   "cond"),
    time_step_sweep=("update", "kgl2", "steps", "beta_raw_min", "beta_min", "clipped", "beta_rise",
                     "beta_error"),
    incompressibility=("nu", "order", "mesh", "ndof", "ratio"),
    strong_coupling=("k2", "e_scale", "stiffening", "converged", "failure", "newton", "recovered",
                     "cutbacks", "force_ratio", "cond"),
    load_cycles=("dt", "records", "newton", "newton_max", "cutbacks", "cycling", "switches",
                 "openings", "balance"),
)
"""The columns ``summary`` prints for each study."""


def summary(name, rows):
    """A short text summary of a study's rows: a table and the headline numbers."""
    if name == "debonding":
        s = debonding_summary(rows)
        return "\n".join(f"{k}: {_fmt(v)}" for k, v in s.items())
    text = table(rows, TABLES[name])
    if name == "nitsche_map":
        ranges = {theta: ok_range(rows, theta) for theta in dict.fromkeys(r["theta"] for r in rows)}
        text += "\nconverged with the force within tolerance for γ0 in: " + ", ".join(
            f"θ = {theta}: [{_fmt(a)}, {_fmt(b)}]" for theta, (a, b) in ranges.items())
    if name == "penalty_sweep":
        text += f"\nfitted slope of the penetration against the penalty factor: " \
                f"{fitted_slope(rows, 'factor', 'max_penetration', method='penalty'):.3f}"
    return text
