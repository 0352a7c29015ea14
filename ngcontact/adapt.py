"""Adaptive meshes: refine where the error estimate says, for one load step or a whole history.

A scene is given as a function ``scene(mesh) -> Simulation`` (the body, loads and contact on
that mesh, a time Parameter of its own); each level builds its simulation anew on the refined
mesh, so that every object that holds mesh data — the body's spaces, Γ3 and β, the step system,
the solvers, the records — is made for that mesh: nothing is carried from one mesh to the next
but the Newton start of a step (the last level's displacement, interpolated).

* ``mark``: Dörfler's bulk criterion, the fewest elements whose indicators hold ``fraction`` of
  the estimate².
* ``step``: solve one step, estimate, mark, refine (``meshes.refined``: bisection, curved
  boundaries kept), again, until the relative estimate is at most ``tol`` or a limit of DOFs or
  levels is reached; marking by the equilibrated estimate or by the cheap averaging indicator
  with the bound only where it decides (``MARKINGS``).
* ``solve``: one step to a tolerance, certified: ``step`` marking by the averaging indicator,
  Newton stopped at a fraction of the estimate.
* ``history``: run the whole load history on each mesh, mark by each element's largest
  indicator over the estimated steps, refine, and run it again. Why not refine and coarsen as the
  contact zone moves: Netgen bisects but cannot coarsen, so a mesh that followed the contact
  zone would only grow, and the state and β carried from mesh to mesh at every change would add
  an error of their own; the mesh of the swept contact zone's ends, found by the history itself,
  is what a run needs.

The estimate is the equilibrated bound of the step (``estimators.equilibrated``); the relative
estimate divides it by the energy |||x_h||| of the discrete state (the largest over a history).
Bad input is refused before any work (the first solve): a fraction outside (0, 1], a tolerance
that is not positive, limits that are not positive integers or a DOF limit beyond the machine's
memory or below the first mesh's DOFs, a scene that is not a function of the mesh or a mesh
that is not an ngsolve.Mesh, a mesh that cannot be refined (no geometry, distributed), what the
estimator cannot estimate (``estimators.equilibrated.check``: nonlinear laws, weak normal
supports), callbacks that are not functions, streaming a history (``out=``, ``vtk=``: every
level would write into one directory), and a scene whose Simulation has already stepped (or was
resumed): ``step`` and ``solve`` adapt and certify the first step from the initial state, and
``history`` the history from t = 0; the state a stepped scene starts from would be computed on
each level's own mesh, so each level would solve another problem and the certificate would not
be that of the step asked for. A target not reached within the limits stops with every
level kept and the reason; a zero estimate (an exact discrete solution) stops as "target
reached" (its relative estimate is 0), or, without a target, as "nothing to refine"; so does a
first level whose state is stress-free to round-off (its energy and estimate both at most
``ROUNDOFF`` of the state's size, ``_exact_to_roundoff``: a body lifted off the foundation, moved
rigidly; for ``history``, every estimated step of the first level), whose relative estimate would
be a ratio of two round-offs. The goals
"pressure" and "force" stop as "no contact" (not reached, with an ``AccuracyWarning``) on a
level where Γ3 carries no contact pressure (no force): the relative error of a zero goal is
undefined, and refining for it would refine for round-off.
"""
import sys
import time as wallclock
import warnings
from dataclasses import dataclass, field
from contextlib import contextmanager
from functools import partial

import ngsolve as ngs
import numpy as np

from ngcontact import arguments, checks, parallel
from ngcontact.model import forms
from ngcontact.estimators.averaging import AveragingIndicator
from ngcontact.estimators.equilibrated import EquilibratedEstimator, check as estimable
from ngcontact.estimators.goals import GOALS, PressureResidual, edge_points, elements_at_points, force_estimate
from ngcontact.meshes import refined
from ngcontact.output.observables import CONTACT_NOISE
from ngcontact.solve.newton import NewtonError
from ngcontact.time.stepping import AccuracyWarning


def mark(indicators, fraction=0.5):
    """Dörfler marking: a boolean array, True on the fewest elements whose η_K² add up to at
    least ``fraction`` of Σ η_K² (fraction in (0, 1]; 1 marks every element with η_K > 0)."""
    fraction = checks.number("fraction", fraction, 0, 1, low_open=True)
    try:
        eta = np.asarray(indicators, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"mark: the indicators must be an array of numbers (one η_K >= 0 per element), got "
                        f"{type(indicators).__name__}") from None
    if eta.ndim != 1:
        raise ValueError(f"mark: the indicators must be a 1D array (one η_K per element), got shape {eta.shape}")
    if not np.all(np.isfinite(eta)) or np.any(eta < 0):
        bad = eta[~(np.isfinite(eta) & (eta >= 0))]
        raise ValueError(f"mark: the indicators must be finite and >= 0, got {bad[:3].tolist()}")
    eta2 = eta ** 2
    order = np.argsort(-eta2, kind="stable")
    total = eta2.sum()
    marked = np.zeros(len(eta2), dtype=bool)
    if total == 0:
        return marked
    count = int(np.searchsorted(np.cumsum(eta2[order]), fraction * total * (1 - 1e-12)) + 1)
    marked[order[:min(count, len(eta2))]] = True
    return marked


def energy(sim, reference=None):
    """|||x_h||| = ((C_c ε(u_h), ε(u_h)) + (C ∇φ_h, ∇φ_h))^½ of the current state, C_c = F + c A
    with the step's rate coefficient c (J^½; (J/m)^½ in 2D; a body of revolution's weighted by
    2π r, in J^½); with ``reference`` (u_ref, φ_ref:
    GridFunctions, possibly of another mesh, found point by point; φ_ref None without φ) the
    norm of the difference x_h − x_ref, integrated on the simulation's mesh."""
    T, body = sim.body.tensors, sim.body
    rate = sim.system.coefficients.rate.Get() if T.viscous else 0.0
    e, order = forms.strain(sim.u, T), 2 * sim.body.order
    g = ngs.grad(sim.phi) if sim.electric else None
    if reference is not None:
        if not isinstance(reference, (tuple, list)) or len(reference) != 2 \
                or not isinstance(reference[0], ngs.GridFunction) \
                or not (reference[1] is None or isinstance(reference[1], ngs.GridFunction)):
            raise TypeError("energy: reference must be (u_ref, φ_ref), GridFunctions (φ_ref None without φ), got "
                            f"{type(reference).__name__}")
        u_ref, phi_ref = reference
        if sim.electric and phi_ref is None:
            raise ValueError("energy: reference needs φ_ref (the simulation solves for φ), got None")
        e = e - forms.strain(u_ref, T)
        g = g - ngs.grad(phi_ref) if sim.electric else None
        order += 4
    C_c = forms.matrix_cf(T.F + rate * T.A if T.viscous else T.F)
    value = ngs.InnerProduct(C_c * e, e)
    if sim.electric:
        value = value + ngs.InnerProduct(forms.matrix_cf(T.C) * g, g)
    if body.kinematics.weight is not None:       # the whole body's: the weight 2π r
        value, order = body.weighted(value), order + 1
    return float(np.sqrt(max(ngs.Integrate(value.Compile(), sim.body.mesh, order=order), 0.0)))


@dataclass
class Level:
    """One mesh of an adaptation: its ``mesh``, ``ndof``, the ``estimate`` (total, J^½; (J/m)^½ in 2D) and
    ``relative`` estimate, its ``parts`` and element ``indicators``, the wall times of the
    solves (``solve_s``) and of the estimates (``estimate_s``), the Newton iterations, the
    simulation (``sim``, solved), ``marked`` (the elements refined next, None at the last), the
    GMRES iterations (``krylov``) and ``elapsed_s``, the wall time since the adaptation began
    (building, solving and estimating every level so far, refining the meshes; not the time of
    ``on_level``); ``estimate_stops``: the Newton solves that adaptive stopping ended
    (``stop_newton``; the others met the fixed tolerance); ``build_s``: the wall time of
    building the level's simulation (``scene(mesh)``). Marked by the averaging indicator
    (``marking="averaging"``): ``indicators`` are its η_K, ``indicator`` its total, and
    ``certified`` says whether the equilibrated bound was computed on the level (``estimate``
    and ``relative`` are NaN and ``parts`` {} where it was not). Adapted for a ``goal`` other than
    "energy" (``GOALS``): ``goal_value`` (‖λ_h‖_Γ3, Pa m^½ in 2D, or the contact force F_h, N/m in
    2D) and ``goal_estimate``, the relative estimate of its error that the tolerance bounds;
    ``edge_bisections``: how many times the elements at the contact edges were bisected after the
    marked ones (the pressure goal in 2D)."""
    mesh: object
    ndof: int
    estimate: float
    relative: float
    parts: dict
    indicators: np.ndarray
    solve_s: float
    estimate_s: float
    newton: int
    sim: object = field(repr=False, default=None)
    marked: np.ndarray = field(repr=False, default=None)
    krylov: int = 0
    elapsed_s: float = 0.0
    estimate_stops: int = 0
    build_s: float = 0.0
    certified: bool = True
    indicator: float = float("nan")
    goal: str = "energy"
    goal_value: float = float("nan")
    goal_estimate: float = float("nan")
    edge_bisections: int = 0


@dataclass
class Adaptation:
    """The levels of an adaptation and why it stopped (``reason``: "target reached", "DOF
    limit", "level limit", "nothing to refine": a zero estimate without a target, or, for the
    goals "pressure" and "force", "no contact": Γ3 carries none of the goal on the last level,
    whose relative error is then undefined); ``reached``: whether the target was met."""
    levels: list
    reason: str
    reached: bool

    @property
    def last(self):
        return self.levels[-1]


def _limits(tol, fraction, max_levels, max_ndof):
    tol = None if tol is None else checks.number("tol", tol, 0, low_open=True)
    fraction = checks.number("fraction", fraction, 0, 1, low_open=True)
    max_levels = checks.integer("max_levels", max_levels, 1, 50)
    max_ndof = checks.fits_in_memory("max_ndof", checks.number("max_ndof", max_ndof, 1))
    return tol, fraction, max_levels, max_ndof


def _inputs(where, scene, mesh, max_levels, polygonal, on_level, stop_newton):
    """The arguments every adaptation has, checked before any work: ``scene`` a function,
    ``mesh`` a serial ngsolve.Mesh that can be refined (if more than one level may be made),
    ``on_level`` a function of one argument or None, ``stop_newton`` in (0, 1] or None."""
    if not callable(scene):
        raise TypeError(f"{where}: scene must be a function mesh -> Simulation (the scene built on each level's "
                        f"mesh), got {type(scene).__name__}")
    if not isinstance(mesh, ngs.Mesh):
        hint = " (wrap a Netgen mesh: ngsolve.Mesh(ngmesh))" if type(mesh).__module__.startswith("netgen") else ""
        raise TypeError(f"{where}: mesh must be an ngsolve.Mesh{hint}, got {type(mesh).__name__}")
    parallel.serial_only(mesh, f"{where}: adaptive refinement", "NGSolve refines serial meshes only")
    polygonal = checks.flag("polygonal", polygonal)
    if max_levels > 1 and not polygonal and type(mesh.ngmesh.GetGeometry()).__name__ == "NetgenGeometry":
        raise ValueError(f"{where}: the mesh cannot be refined: it has no geometry to place new boundary points on "
                         "(made point by point or read from another mesher); mesh a geometry (netgen.occ, geom2d, "
                         "csg), pass polygonal=True if its boundary is polygonal, or max_levels=1")
    checks.callback(f"{where}: on_level", on_level, "the Level")
    return None if stop_newton is None else checks.number("stop_newton", stop_newton, 0, 1, low_open=True)


def _build(scene, mesh):
    """(scene(mesh), checked; the seconds it took)."""
    t0 = wallclock.perf_counter()
    sim = scene(mesh)
    from ngcontact.simulation import Simulation
    if not isinstance(sim, Simulation):
        raise TypeError(f"scene(mesh) must return an ngcontact.Simulation, got {type(sim).__name__}")
    if sim.body.mesh is not mesh:
        raise ValueError("scene(mesh) must build its Simulation on the mesh it is given")
    if len(sim.history) > 1:                     # stepped (or resumed) inside the scene
        raise ValueError(f"scene(mesh) returned a Simulation that has already stepped ({len(sim.history) - 1} "
                         f"step(s), t = {sim.t:g} s): the adaptation solves and certifies the steps from the "
                         "initial state, and a step from a state computed on each level's own mesh is another "
                         "problem on every level; return the Simulation before it steps (its start: u0=), or "
                         "adapt the whole load history with adapt.history")
    estimable(sim)                               # before it is solved
    return sim, wallclock.perf_counter() - t0


def _first(scene, mesh, max_ndof):
    """The first level's simulation (``_build``), refused if its DOFs already pass ``max_ndof``."""
    sim, seconds = _build(scene, mesh)
    if sim.X.ndof > max_ndof:
        raise ValueError(f"max_ndof = {max_ndof:g} is below the {sim.X.ndof} DOFs of the first mesh's simulation: "
                         "no level would fit; raise max_ndof or start from a coarser mesh")
    return sim, seconds


def _relative(estimate, norm):
    """The relative estimate η / |||x_h|||: 0 for a zero estimate (the discrete solution is
    exact, whatever its norm), inf for a nonzero one of a zero state."""
    if estimate == 0:
        return 0.0
    return estimate / norm if norm > 0 else np.inf


ROUNDOFF = 10 * np.finfo(float).eps
"""An estimate and an energy both at most this factor of ‖x_h‖_|K| = (|x_h|ᵀ |K| |x_h|)^½ (the
energy the state's coefficients would carry if none of their contributions cancelled) are at
the round-off of the state: a stress-free state, such as a rigid motion (``_exact_to_roundoff``)."""


def _exact_to_roundoff(sim, estimate, norm):
    """Whether the solved ``sim`` is exact to round-off: a zero ``estimate``, or a stress-free
    state, its energy |||x_h||| and the estimate both at most ``ROUNDOFF`` ‖x_h‖_|K| (K the step's
    bulk matrix and loads, ``StepSystem.magnitude``), such as a body lifted off the foundation or
    moved rigidly: the ratio of its two round-offs is no relative error (it is about 1), and
    refining for it would refine for noise."""
    if estimate == 0:
        return True
    x = sim.gfu.vec
    size = float(np.sqrt(max(np.dot(np.abs(x.FV().NumPy()), sim.system.magnitude(x, 0.0)), 0.0)))
    return estimate <= ROUNDOFF * size and norm <= ROUNDOFF * size


def _expect(sim, levels):
    """Before a level's solve: it is expected to take as many Newton iterations as the level
    below, so Γ3's Jacobian is compiled to machine code first where those iterations pay for
    the compile (``machine_code.MachineCode.expect``: the large 3D levels; a level is one step,
    which the simulation's own rule, counting the iterations made, never compiles for)."""
    rule = sim.steps.machine_code
    if rule is not None and levels:
        rule.expect(levels[-1].newton)


def _next(scene, level, tol, levels, max_levels, max_ndof, fraction, polygonal, achieved=None, after=None):
    """(the reason to stop after ``level`` or None, the next simulation, the seconds its build
    took): the mesh marked by ``mark``, refined (then ``after(mesh)``, if given), and the scene
    built on it; one whose DOFs pass ``max_ndof`` is not used (it is built to count them: the
    scene decides its spaces). ``achieved``: the relative estimate the tolerance bounds (default
    the level's ``relative``)."""
    if tol is not None and (level.relative if achieved is None else achieved) <= tol:
        return "target reached", None, 0.0
    if levels >= max_levels:
        return "level limit", None, 0.0
    marked = mark(level.indicators, fraction)
    if not marked.any():                         # every indicator 0: the same mesh again would be
        return "nothing to refine", None, 0.0    # the same level again
    level.marked = marked
    mesh = refined(level.mesh, level.marked, polygonal=polygonal)
    sim, seconds = _build(scene, after(mesh) if after is not None else mesh)
    if sim.X.ndof > max_ndof:
        return "DOF limit", None, seconds
    return None, sim, seconds


def _timed(on_level, level):
    """Call ``on_level(level)`` (if given); the seconds it took, which the levels' ``elapsed_s``
    leave out (a study's own error measurement is not the adaptive loop's work)."""
    if on_level is None:
        return 0.0
    t0 = wallclock.perf_counter()
    on_level(level)
    return wallclock.perf_counter() - t0


MARKINGS = ("equilibrated", "averaging")
"""What ``step`` marks by: the equilibrated estimate on every level (a bound on each), or the
averaging indicator (``estimators.averaging``, about a tenth of a solve) with the equilibrated
bound computed only where it decides: on the first level (to scale the indicator), where the
scaled indicator says the target is met, and on the last level (the certificate)."""


def _certify(sim, level, began):
    """Compute the equilibrated bound of ``level`` (its solved ``sim``) and put it in the level."""
    t0 = wallclock.perf_counter()
    estimate = EquilibratedEstimator(sim)()
    level.estimate, level.parts, level.certified = estimate.total, estimate.parts, True
    level.relative = _relative(estimate.total, energy(sim))
    level.estimate_s += wallclock.perf_counter() - t0
    level.elapsed_s = wallclock.perf_counter() - began
    return estimate


def step(scene, mesh, dt, *, tol=None, fraction=0.5, max_levels=10, max_ndof=2e5, guess=None, on_level=None,
         stop_newton=None, polygonal=False, marking=None, goal="energy", certify=None):
    """Adapt the mesh to one step of length dt (s) from the initial state (``Simulation.step``):
    solve, estimate, mark (``mark``), refine (``meshes.refined``), until the relative estimate is
    at most ``tol`` (None: until a limit) or ``max_levels`` meshes or ``max_ndof`` DOFs;
    returns the ``Adaptation``. Level ℓ + 1 starts Newton from level ℓ's displacement
    (``guess`` at the first); ``on_level(level)`` is called after each level. ``stop_newton``
    (a fraction, e.g. 0.1; None: Newton's fixed tolerances): from the second level on, Newton
    stops once its last correction's energy is below that fraction of the estimate expected
    on the new mesh (the last one scaled by the DOFs, η (N_ℓ−1/N_ℓ)^(p/d)). ``polygonal``:
    the mesh has no geometry and its boundary is polygonal (``meshes.refined``). ``marking``:
    "equilibrated" (the bound on every level; the energy goal's default) or "averaging"
    (``MARKINGS``: the cheap indicator marks, the bound certifies the first level, the levels
    the scaled indicator says meet ``tol``, and the last; the only marking of the other
    goals). ``goal`` (``GOALS``): what ``tol`` bounds and the marking
    serves — "energy" (the relative energy estimate), "pressure" (the relative L² error of the
    contact pressure λ_h on Γ3) or "force" (the relative error of the contact resultant);
    ``estimators.goals`` says what each estimate rests on. For "pressure" and "force" the
    averaging indicator marks (with the pressure residual for "pressure", and in 2D the elements
    at the contact edges bisected again up to ``EDGE_BISECTIONS`` times), and the equilibrated
    bound is computed on the last level only if ``certify`` (default: only for "energy"; the
    energy goal is certified on its levels whatever ``certify`` says, so False is refused)."""
    tol, fraction, max_levels, max_ndof = _limits(tol, fraction, max_levels, max_ndof)
    stop_newton = _inputs("adapt.step", scene, mesh, max_levels, polygonal, on_level, stop_newton)
    goal = _goal("adapt.step", goal)
    marking = _marking("adapt.step", marking, goal)
    certify = checks.flag("certify", goal == "energy" if certify is None else certify)
    if goal == "energy" and not certify:
        raise ValueError("adapt.step: certify=False with goal='energy': the energy goal's tol bounds the equilibrated "
                         "bound, which certifies its levels; certify= says whether the goals 'pressure' and 'force' "
                         "compute that bound on their last level")
    arguments.time_step(dt, 0.0)                     # dt > 0, finite, before any work
    if goal != "energy":
        return _goal_step(scene, mesh, dt, goal, tol, fraction, max_levels, max_ndof, guess, on_level, stop_newton,
                          polygonal, certify)
    levels, start, began = [], guess, wallclock.perf_counter()
    ratio = None                                     # bound / indicator at the last certified level
    sim, build_s = _first(scene, mesh, max_ndof)
    while True:
        mesh = sim.body.mesh
        if stop_newton is not None and levels:
            last = levels[-1]
            previous = last.estimate if last.certified else ratio * last.indicator
            expected = previous * (last.ndof / sim.X.ndof) ** (sim.body.order / sim.body.dim)
            sim.newton.energy_target = stop_newton * expected
        # a level certified for sure builds its estimator first: the patch system, which does not
        # depend on the state, is numbered and factorised by its background thread during the solve
        t0 = wallclock.perf_counter()
        estimator = EquilibratedEstimator(sim) if marking == "equilibrated" or ratio is None else None
        t1 = wallclock.perf_counter()
        _expect(sim, levels)
        with _levels_kept(levels, sim):
            record = sim.step(dt, guess=start)
        solved = wallclock.perf_counter()
        norm = energy(sim)
        if marking == "equilibrated":
            estimate = estimator()
            indicators, indicator = estimate.indicators, float("nan")
        else:
            cheap = AveragingIndicator(sim)()
            indicators, indicator = cheap.indicators, cheap.total
            predicted = _relative(ratio * cheap.total, norm) if ratio is not None else 0.0
            certify = ratio is None or (tol is not None and predicted <= tol)
            estimate = (estimator or EquilibratedEstimator(sim))() if certify else None
            if estimate is not None and cheap.total > 0:
                ratio = estimate.total / cheap.total
        nan = float("nan")
        level = Level(mesh, sim.X.ndof, estimate.total if estimate else nan,
                      _relative(estimate.total, norm) if estimate else nan, estimate.parts if estimate else {},
                      indicators, solved - t1, wallclock.perf_counter() - solved + t1 - t0,
                      record.newton_iterations, sim, krylov=record.krylov_iterations,
                      elapsed_s=wallclock.perf_counter() - began, estimate_stops=sim.newton.estimate_stops,
                      build_s=build_s, certified=estimate is not None, indicator=indicator)
        levels.append(level)
        if len(levels) == 1 and level.certified and _exact_to_roundoff(sim, level.estimate, norm):
            # (the first level decides: a step that is stress-free is so on every mesh)
            level.relative = 0.0                     # exact to round-off, as a zero estimate
            reason = "target reached" if tol is not None else "nothing to refine"
        else:
            reason, following, build_s = _next(scene, level, tol, len(levels), max_levels, max_ndof, fraction,
                                               polygonal)
        if reason is not None and not level.certified:
            _certify(sim, level, began)              # the last level's certificate
            if tol is not None and level.relative <= tol:
                reason = "target reached"
        began += _timed(on_level, level)
        if reason is not None:
            return Adaptation(levels, reason, reason == "target reached")
        start, sim = sim.u, following                # the start interpolated onto the next mesh (``starts``)


STOP_NEWTON = 0.1
"""``solve``'s ``stop_newton`` for the energy goal. The other goals converge Newton to its fixed
tolerances: the stop is an energy criterion, and a correction small in energy may still move
the contact set, which the pressure and force on Γ3 feel (docs/adaptivity.md, "Goals")."""


def solve(scene, mesh, tol, *, dt=1.0, fraction=0.5, max_levels=30, max_ndof=2e5, guess=None, on_level=None,
          stop_newton="default", polygonal=False, marking="averaging", goal="energy", certify=None):
    """Solve the first step, of length dt (s) from the scene's initial state, to a tolerance:
    refine until the equilibrated bound of the energy error, relative to the energy of the
    discrete state, is at most ``tol``
    (certified: the last level's ``estimate`` is that bound), marking by the cheap averaging
    indicator (``MARKINGS``) and stopping Newton and GMRES at ``stop_newton`` times the
    estimate expected on each level (None: the fixed tolerances; "default": ``STOP_NEWTON`` for
    the energy goal, None for the others). ``step`` with these defaults;
    returns its ``Adaptation`` (``reached`` False and the reason if a limit came first). A
    scene whose Simulation has already stepped is refused (ValueError, before its first solve):
    its state at the start of the step would be computed anew on every level's mesh, so the
    levels would solve different steps and none of them the step certified; to adapt a later
    step, build the scene with the displacement it starts from as its initial one (``u0=``).
    ``goal="pressure"`` or ``"force"``: ``tol`` bounds the relative estimate of the contact
    pressure's L² error on Γ3 or of the contact force's error instead (``step``), and the bound
    is computed only with ``certify=True``."""
    if tol is None:
        raise ValueError("adapt.solve: tol must be a finite number > 0 (the relative estimate to certify), got None")
    if isinstance(stop_newton, str):
        if stop_newton != "default":
            raise TypeError(f"adapt.solve: stop_newton must be a number in (0, 1], None (Newton's fixed tolerances) "
                            f"or 'default' ({STOP_NEWTON} for the energy goal, None for the others), got "
                            f"{stop_newton!r}")
        stop_newton = STOP_NEWTON if goal == "energy" else None
    return step(scene, mesh, dt, tol=tol, fraction=fraction, max_levels=max_levels, max_ndof=max_ndof, guess=guess,
                on_level=on_level, stop_newton=stop_newton, polygonal=polygonal, marking=marking, goal=goal,
                certify=certify)


EDGE_BISECTIONS = 2
"""At most how many times, per level of the pressure goal, the elements at the contact edges are
bisected after the marked ones: as many as bring the edges' share of the pressure estimate down
to that of the rest of Γ3 (there the error is O(h) at the edge, whatever the order)."""


def _outside():
    """The ``stacklevel`` of a warning issued in the caller that names the first frame outside
    ngcontact (the user's call of ``step`` or ``solve``)."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith("ngcontact"):
        frame, level = frame.f_back, level + 1
    return level


@contextmanager
def _levels_kept(levels, sim):
    """A NewtonError of the level being solved (``sim``) names the level and keeps the levels
    solved before it (``error.levels``, a list of ``Level``): an adaptation that fails on its
    fifth mesh still gives its four certified ones."""
    try:
        yield
    except NewtonError as error:
        error.levels = list(levels)
        error.add_note(f"adapt: on level {len(levels) + 1} ({sim.X.ndof} DOFs); the {len(levels)} level(s) solved "
                       "before it are in the error's .levels")
        raise


def _untouched(contact, tensors, goal):
    """Whether Γ3 carries none of the goal at the recorded state ``contact`` (a
    ``ContactRecord``): for "pressure", λ_h at every Gauss point of Γ3, and for "force" that
    and every facet's pressure −σ̃_ν too (the glue's pull, the layer's push), at most the
    round-off of a contact pressure (``observables.CONTACT_NOISE`` times the body's
    stiffness, Pa), so that a pressure or force of round-off is no goal either."""
    noise = CONTACT_NOISE * tensors.stiffness()
    pressed = np.max(np.abs(contact.multiplier_points), initial=0.0) > noise
    if goal == "force":
        pressed = pressed or np.max(np.abs(contact.pressure), initial=0.0) > noise
    return not pressed


def _goal(where, goal):
    if not isinstance(goal, str) or goal not in GOALS:
        raise ValueError(f"{where}: goal must be one of {', '.join(map(repr, GOALS))}, got {goal!r}")
    return goal


def _goal_step(scene, mesh, dt, goal, tol, fraction, max_levels, max_ndof, guess, on_level, stop_newton, polygonal,
               certify):
    """``step`` for the goals "pressure" and "force" (``estimators.goals``): the averaging indicator
    and, for the pressure, its residual mark; the goal's relative estimate meets ``tol``."""
    levels, start, began = [], guess, wallclock.perf_counter()
    sim, build_s = _first(scene, mesh, max_ndof)
    if sim.gamma3 is None:
        raise ValueError(f"adapt: goal={goal!r} needs a scene with a contact side Γ3 (Simulation(contact=...))")
    names = set(sim.body.boundaries["contact_side"])
    while True:
        mesh = sim.body.mesh
        if stop_newton is not None and levels:
            last = levels[-1]
            expected = last.indicator * (last.ndof / sim.X.ndof) ** (sim.body.order / sim.body.dim)
            sim.newton.energy_target = stop_newton * expected
        t0 = wallclock.perf_counter()
        _expect(sim, levels)
        with _levels_kept(levels, sim):
            record = sim.step(dt, guess=start)
        solved = wallclock.perf_counter()
        norm = energy(sim)
        cheap = AveragingIndicator(sim)()
        energy_share = cheap.indicators / norm if norm > 0 else cheap.indicators
        after, bisections = None, 0
        if goal == "pressure":
            estimate = PressureResidual(sim)()
            share = estimate.indicators / estimate.value if estimate.value > 0 else estimate.indicators
            indicators = np.sqrt(share ** 2 + energy_share ** 2)
            edge = float(np.sqrt(np.sum(estimate.indicators[estimate.edges] ** 2)))
            rest = float(np.sqrt(np.sum(estimate.indicators[~estimate.edges] ** 2)))
            points = edge_points(sim.steps)
            if len(points) and edge > 0:
                bisections = EDGE_BISECTIONS if rest == 0 else \
                    int(np.clip(np.ceil(np.log2(edge / rest)), 0, EDGE_BISECTIONS))
            after = partial(_bisect_at, names=names, points=points, times=bisections, polygonal=polygonal)
        else:
            # the bulk's energy (the averaging indicator's Γ3 residual is the pressure's matter)
            bulk = float(np.hypot(cheap.parts["stress"], cheap.parts["flux"]))
            held = sum(record.boundary_reaction.values(), np.zeros(sim.body.dim))
            estimate = force_estimate(record.contact.force, _relative(bulk, norm), held)
            indicators = cheap.indicators
        untouched = _untouched(record.contact, sim.body.tensors, goal)
        level = Level(mesh, sim.X.ndof, float("nan"), float("nan"), {}, indicators, solved - t0,
                      wallclock.perf_counter() - solved, record.newton_iterations, sim,
                      krylov=record.krylov_iterations, elapsed_s=wallclock.perf_counter() - began,
                      estimate_stops=sim.newton.estimate_stops, build_s=build_s, certified=False,
                      indicator=cheap.total, goal=goal, goal_value=estimate.value,
                      goal_estimate=float("nan") if untouched else estimate.relative, edge_bisections=bisections)
        levels.append(level)
        if untouched:                                # a relative error of nothing: no level can meet tol
            reason, following = "no contact", None
            what = "contact pressure" if goal == "pressure" else "force"
            warnings.warn(f"adapt: goal={goal!r}, but Γ3 carries no {what} on level {len(levels)} ({level.ndof} DOFs) "
                          f"at t = {sim.t:g} s: the relative error of a zero goal is undefined, so the adaptation "
                          "stops there (reason 'no contact'). If the body should touch the foundation at this step, "
                          "start from a finer mesh at Γ3; to adapt a step without contact, use goal='energy'",
                          AccuracyWarning, stacklevel=_outside())
        else:
            reason, following, build_s = _next(scene, level, tol, len(levels), max_levels, max_ndof, fraction,
                                               polygonal, achieved=estimate.relative, after=after)
        if reason is not None and certify:
            _certify(sim, level, began)              # the last level's certificate, asked for
        began += _timed(on_level, level)
        if reason is not None:
            return Adaptation(levels, reason, reason == "target reached")
        start, sim = sim.u, following


def _bisect_at(mesh, names, points, times, polygonal):
    """``mesh`` with the elements at the Γ3 facets near ``points`` (the last level's contact
    edges) bisected ``times`` times more (``goals.elements_at_points``)."""
    for _ in range(times):
        near = elements_at_points(mesh, names, points)
        if not near.any():
            break
        mesh = refined(mesh, near, polygonal=polygonal)
    return mesh


def _marking(where, marking, goal="energy"):
    """``marking`` checked (None: "equilibrated" for the energy goal, "averaging" for the others,
    which mark by the averaging indicator only)."""
    if marking is None:
        return "equilibrated" if goal == "energy" else "averaging"
    if not isinstance(marking, str) or marking not in MARKINGS:
        raise ValueError(f"{where}: marking must be one of {', '.join(map(repr, MARKINGS))}, got {marking!r}")
    if goal != "energy" and marking != "averaging":
        raise ValueError(f"{where}: marking={marking!r} with goal={goal!r}: the equilibrated marking marks by the "
                         "energy bound; the goal marks by its own estimate and the averaging indicator (marking="
                         "'averaging', its default): drop marking= or use goal='energy'")
    return marking


def history(scene, mesh, dt, T, *, tol=None, fraction=0.5, max_levels=10, max_ndof=2e5, every=1, on_level=None,
            stop_newton=None, polygonal=False, **run_options):
    """Adapt the mesh to a whole load history: run ``Simulation.run(dt, T, **run_options)`` on
    each mesh, estimate every ``every``-th step (and the last), mark each element by its largest
    indicator over them, refine, and run again, until the largest relative estimate over the
    steps is at most ``tol`` or a limit; returns the ``Adaptation`` (``Level.estimate`` the
    largest over the steps, ``relative`` that over the largest |||x_h|||). ``stop_newton`` (a
    fraction; None: Newton's fixed tolerances): after a step's estimate, Newton stops once its
    last correction's energy is below that fraction of it. ``run_options`` go to every run
    but ``out`` and ``vtk`` (refused: each level's run would stream into the same directory;
    keep a level's simulation with ``on_level``)."""
    tol, fraction, max_levels, max_ndof = _limits(tol, fraction, max_levels, max_ndof)
    stop_newton = _inputs("adapt.history", scene, mesh, max_levels, polygonal, on_level, stop_newton)
    every = checks.integer("every", every, 1, 10 ** 6)
    for name in ("out", "vtk"):
        if run_options.get(name) is not None:
            raise ValueError(f"adapt.history runs the history once per level, each on a new mesh: {name}= "
                             f"({run_options[name]!r}) would stream every level into one directory; keep a level's "
                             "simulation with on_level (level.sim) and write it yourself")
    arguments.callback(run_options.get("on_step"))
    arguments.time_step(dt, 0.0)                     # dt > 0 and T > 0, finite, before any work
    checks.number("T", T, 0, low_open=True, unit="s")
    levels, began = [], wallclock.perf_counter()
    sim, build_s = _first(scene, mesh, max_ndof)
    while True:
        mesh = sim.body.mesh
        estimator, spent = None, [0.0]
        state = dict(estimate=0.0, norm=0.0, parts={}, indicators=np.zeros(mesh.ne), exact=not levels)

        def on_step(record, sim=sim):
            nonlocal estimator
            if record.step % every and record.time < T * (1 - 1e-12):
                return
            t0 = wallclock.perf_counter()
            estimator = estimator or EquilibratedEstimator(sim)
            estimate = estimator()
            state["indicators"] = np.maximum(state["indicators"], estimate.indicators)
            if estimate.total > state["estimate"]:
                state["estimate"], state["parts"] = estimate.total, estimate.parts
            norm = energy(sim)
            state["norm"] = max(state["norm"], norm)
            if state["exact"]:                        # (the first level's steps: see ``step``)
                state["exact"] = _exact_to_roundoff(sim, estimate.total, norm)
            if stop_newton is not None:
                sim.newton.energy_target = stop_newton * estimate.total
            spent[0] += wallclock.perf_counter() - t0
        t0 = wallclock.perf_counter()
        user = run_options.pop("on_step", None)
        with _levels_kept(levels, sim):
            sim.run(dt, T, on_step=(lambda r: (on_step(r), user(r))) if user else on_step, **run_options)
        wall = wallclock.perf_counter() - t0
        norm = state["norm"]
        level = Level(mesh, sim.X.ndof, state["estimate"], _relative(state["estimate"], norm),
                      state["parts"], state["indicators"], wall - spent[0], spent[0],
                      int(sum(sim.history.newton_iterations)), sim,
                      krylov=int(sum(r.krylov_iterations for r in sim.history[1:])),
                      elapsed_s=wallclock.perf_counter() - began, estimate_stops=sim.newton.estimate_stops,
                      build_s=build_s)
        levels.append(level)
        if user:
            run_options["on_step"] = user
        if state["exact"]:                            # every estimated step exact to round-off
            level.relative = 0.0
            reason, sim = ("target reached" if tol is not None else "nothing to refine"), None
        else:
            reason, sim, build_s = _next(scene, level, tol, len(levels), max_levels, max_ndof, fraction, polygonal)
        began += _timed(on_level, level)
        if reason is not None:
            return Adaptation(levels, reason, reason == "target reached")
