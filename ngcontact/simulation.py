"""The simulation of a body under loads in contact on Γ3: time steps, their records, and the
cut-back policy.

``Simulation`` puts the pieces together (the step system of ``forms``, the enforcement
method, Newton, the time scheme of ``schemes``, the recorder), then ``step(dt)`` makes one
transactional step, ``advance(t)`` reaches a time with cut-backs where Newton fails, and
``run(dt, T)`` steps to a final time.
"""
from __future__ import annotations

import os
import time as wallclock
import warnings
from functools import partial
from typing import Callable, NamedTuple

import ngsolve as ngs
import numpy as np
import scipy                     # the package alone (its sparse matrices load where used: the annotation below)

from ngcontact import arguments, parallel
from ngcontact.solve import continuation
from ngcontact.gamma3.build import build as build_gamma3
from ngcontact.output import paraview, results
from ngcontact.time import stepping
from ngcontact.output.fingerprint import fingerprint, options as fingerprint_options
from ngcontact.model.admissible import (PhysicsWarning, check_initial_displacement, check_supports_at_start,
                                        scene_flags)
from ngcontact.checks import integer, number, uses_only
from ngcontact.model.electric_part import electric_parts as electric_parts_of, solves_potential
from ngcontact.gamma3.contact import Contact
from ngcontact.model.body import Body
from ngcontact.model.loads import Loads, as_cf
from ngcontact.model.machine_code import ITERATIONS_PER_STEP, MachineCode
from ngcontact.solve.newton import Newton, NewtonResult, Timings
from ngcontact.output.observables import Recorder
from ngcontact.output.progress import bar
from ngcontact.output.records import History, StepRecord
from ngcontact.time.schemes import DEFAULT, StepCoefficients, TimeScheme, scheme_class
from ngcontact.time.schemes.protocol import check_built
from ngcontact.solve.linalg.solver_choice import as_options, check_simulation, describe, resolve
from ngcontact.solve.nested import COARSE_OPTIONS, coarse_body
from ngcontact.solve.starts import Approach, Starts
from ngcontact.time.step import Step
from ngcontact.solve.step_length import StepLength
from ngcontact.solve.switch_loop import SignoriniPoints, SwitchLoop
from ngcontact.solve.linalg.matrices import free_jacobian
from ngcontact.solve.linalg.protocol import LinearSolver
from ngcontact.solve.system import StepSystem, has_interior_dofs
from ngcontact.solve.weak_form import WeakForm


Guess = str | tuple | ngs.CoefficientFunction | Approach | None
"""Newton's start of a step (``starts``): "nested", "p1", a displacement, or ``Approach(depth)``."""

class Parts(NamedTuple):
    """What a simulation is made of (``assemble``), in the order data flows: the weak form, its
    step system and Γ3, Newton and its linear solver, the time scheme, the starts, the recorder
    and the transactional Step."""
    X: ngs.FESpace
    gfu: ngs.GridFunction
    electric: bool
    electric_parts: list
    condense: bool
    weak_form: WeakForm
    system: StepSystem
    gamma3: object
    gap_check: object
    machine_code: object
    newton: Newton
    potential_solver: object
    scheme: TimeScheme
    starts: Starts
    recorder: Recorder
    steps: Step


def assemble(body, loads, contact, time, Scheme, solver, choice, options, coarse) -> Parts:
    """The parts of a simulation of ``body`` under ``loads`` with ``contact`` (checked data;
    ``Simulation``'s arguments): the weak form (``solve.weak_form``) and its step system, Γ3
    (``gamma3.build``), the linear solver (``solver_choice``) and Newton, the time scheme
    ``Scheme`` (a class), the starts (``coarse(mesh, order)``: the Step of a coarser level) and the
    Step that records into a History."""
    X = body.space()
    electric_parts = electric_parts_of(body, loads, contact)
    electric = solves_potential(options["electric"], electric_parts, body)
    gfu = ngs.GridFunction(X, name="state")
    distributed = parallel.is_distributed(body.mesh)     # see solver_choice.check_simulation, parallel_notes
    automatic = has_interior_dofs(X) and body.tensors.linear and choice.iterative in (None, False)  # no GMRES
    condense = automatic if options["condense"] is None else bool(options["condense"])
    coefficients = StepCoefficients(time, body.V)        # t_n, c, û: written by the scheme only
    weak_form = WeakForm(body, loads, coefficients, contact)
    condense &= contact is None or contact.enforcement_method.condensable
    kept = body.region("contact_side") if contact is not None else None
    system = StepSystem(weak_form, X, condense=condense, kept=kept)
    if not electric:
        # φ = 0: its DOFs leave the free sets in place (after the step system's last
        # FinalizeUpdate, which would reset them; UNUSED coupling types would break
        # static condensation); condensed interior φ DOFs stay 0 (no coupling, no charge)
        for free in (X.FreeDofs(), X.FreeDofs(coupling=True)):
            free[X.Range(1)] = False
    realcompile = options["realcompile"]
    gamma3, gap_check, machine_code = None, None, None
    if contact is not None:
        gamma3, gap_check = build_gamma3(body, contact, system, realcompile is True)
        if realcompile is None:              # by what the run will do (``machine_code``)
            machine_code = MachineCode(system, gamma3.side.B.ndof, body.dim, electric)
    solver, potential_solver = resolve(solver, body, contact, system, X, choice, electric=electric,
                                       condense=condense, realcompile=realcompile, distributed=distributed)
    hook = gamma3.enforcement.newton_hook if contact is not None else None
    limit = None
    if contact is not None and hook is None and options["limit_steps"]:
        limit = StepLength(gamma3.side, gfu, gamma3.gap, normal=gamma3.sampled_normal)
    newton = Newton(system, gfu, solver=solver, rtol=options["rtol"], maxit=options["maxit"], hook=hook,
                    step_length=limit)
    if options["switch_loop"] and SwitchLoop.applies(contact, gamma3, system, solver, distributed):
        newton.switch_loop = SwitchLoop(SignoriniPoints(gamma3, contact, gfu), gamma3.enforcement.theta)
    continuation.build(newton, gamma3, gfu, body.size, options["globalise"])
    scheme = Scheme(coefficients, system, newton, gfu, gamma3.beta if contact is not None else None,
                    options["predictor"], gamma3.normal if contact is not None else None)
    check_built(scheme)
    # checks that the supports and the contact hold the body; the levels of nested iteration
    starts = Starts(body, gamma3, system, coefficients.at, coarse)
    recorder = Recorder(body, gfu, system, gamma3)
    physical_checks = bool(options["physical_checks"])
    steps = Step(body, loads, contact, gamma3, scheme, starts, recorder, History(), electric=electric,
                 keep_states=options["keep_states"], physical_checks=physical_checks, gap_check=gap_check,
                 machine_code=machine_code,
                 flags=scene_flags(contact) if physical_checks else [])     # what makes no physical sense
    return Parts(X, gfu, electric, electric_parts, condense, weak_form, system, gamma3, gap_check, machine_code,
                 newton, potential_solver, scheme, starts, recorder, steps)


class Simulation:
    """Time stepping of a Body under Loads, with a contact law on Γ3 (backward Euler, the
    paper's scheme, by default).

    Parameters
    ----------
    body : Body.
    loads : Loads (CoefficientFunctions may depend on ``time``).
    contact : Contact or None; None leaves Γ3 traction-free and charge-free.
    time : ngsolve.Parameter used in the loads and the contact data (created if not given);
        the time scheme sets it to t_n at step n.
    scheme : the time scheme, a name of ``schemes.SCHEMES``: "backward_euler" (default, the
        paper's (4.3)–(4.5)) or "bdf2"; or a class of the user's that follows
        ``schemes.TimeScheme``, built here with the simulation's step system (the class, not an
        instance; checked before any work: a TypeError naming what it lacks).
    u0 : initial displacement (number tuple or CoefficientFunction), zero on Γ1 and admissible;
        default 0. Newton's start of a step may differ from it (``step(dt, guess=...)``).
    solver : the linear solver of the Newton corrections (``solver_choice``; ``solver`` says what
        is used):
        None (default): by the system. Serially a factorisation kept as GMRES's preconditioner
        between Newton iterations and made again only when that pays
        (``linear_solver.KeptFactorization``): "sparsecholesky" of a symmetric Jacobian (no
        contact, or ``Contact.symmetric``), else of its symmetric part; for Nitsche's θ = −1
        "umfpack" at every iteration (its skew Γ3 part does not suit GMRES); in 3D from 10⁵ DOFs
        without condensation, on nested meshes (``Body.hierarchy``), GMRES around multigrid.
        Distributed: MUMPS where PETSc is installed, else "masterinverse".
        A name (``solver_choice.names()``): every direct solver of NGSolve's
        ``la.GetAvailableSolvers()`` and "mumps" (PETSc's; LDLᵀ or LU by the Jacobian's
        symmetry), kept as by default; "multigrid" (GMRES with Γ3 solves around block multigrid,
        P1 on nested meshes, or BDDC, P2+), "gamg" (around PETSc's GAMG); "direct" or
        "iterative" (the kind, the rest by the system).
        A dict of options as a PETSc user writes them, without the dash
        (``petsc_options.check``): ``{"ksp_type": "preonly"}`` factorises at every iteration,
        ``{"pc_type": "lu", "pc_factor_mat_solver_type": "umfpack"}`` names the factorisation,
        ``{"pc_type": "gamg", "pc_gamg_threshold": 0.02}`` tunes GAMG.
        An object with the protocol ``solve.linalg.protocol.LinearSolver`` (a ``solve`` method
        and a ``name``), used as it is.
        The nodal constraint (``method="active_set"``) solves its saddle point systems itself.
    inverse, reuse_factorization, iterative : the earlier options of the solver, replaced by
        ``solver`` (a DeprecationWarning names the ``solver=`` that does the same).
    rtol, maxit : Newton tolerance (relative) and iteration limit per step.
    keep_states : keep a copy of (u, φ) of every step in the history.
    predictor : start Newton from the linear extrapolation of the last two states instead of
        the last state. It saves a few of the iterations of the reference run on fine steps,
        but on coarse steps the extrapolated state penetrates deep and Newton may fail where
        the warm start converges (docs/speed.md).
    condense : static condensation of the element-interior DOFs (those of the elements at Γ3
        are kept); default: when the space has such DOFs (order >= 3 in 2D, >= 4 in 3D).
    realcompile : compile the Γ3 Jacobian's integrand to machine code (needs a C++ compiler,
        a compile once, for cheaper assemblies of the Γ3 Jacobian after it;
        docs/measurements.md): True at once, False never, None (default) when the Newton
        iterations a run expects pay for it (``machine_code``); ``realcompile`` says whether it
        is. With ``solver="gamg"`` the same choice for the preconditioner forms' integrand
        (None: from ``machine_code.BULK_COMPILED_FROM`` elements).
    limit_steps : shorten Newton corrections that would carry open points of Γ3 deep into
        the foundation (``step_length``): Newton's iterations at first contact then no longer
        grow with the mesh. Nitsche and penalty (the nodal constraint makes its own
        corrections).
    switch_loop : with Nitsche's method on a contact with glue or conduction, settle the contact
        set of Γ3's Gauss points inside each Newton correction (``switch_loop``): where the
        contact zone shrinks (a pull-off) a step takes a few iterations instead of about one per
        point released. On one process, with a linear bulk and the built-in direct or
        kept-factorisation solvers; the converged state is the same.
    electric : solve for φ: None (default) when the scene has an electric part (piezoelectric
        coupling, conduction on Γ3, charges or electrode potentials), else u alone (φ = 0 is
        not an unknown: its DOFs are left out of every solve); True keeps φ; False with an
        electric part raises. ``model`` says which.
    physical_checks : warn (``PhysicsWarning``, listed in ``flags``) of data and steps that
        make no physical sense: a Nitsche γ0 too small for its θ, penetration beyond 0.1 of a
        facet of Γ3 or of the largest displacement, displacements beyond 0.05 of the body's
        size, a clipped β update (``admissible``); False for scale-free tests (manufactured
        solutions of unit size).
    globalise : where Newton's full steps stop making progress, a line search on the residual
        norm and then a path through smoother laws of Γ3 (``line_search``, ``continuation``);
        False: full steps only.

    The arguments are checked before any work (``arguments``): the options True or False
    (None where it means automatic), else a TypeError naming the option.

    The state after the last step: ``t`` (s), ``u``, ``phi`` (components of ``gfu``), the
    bonding field ``beta`` (``beta.values``), and ``history``, one StepRecord per step.
    """

    def __init__(self, body: Body, loads: Loads | None = None, *, contact: Contact | None = None,
                 time: ngs.Parameter | None = None, u0: tuple | ngs.CoefficientFunction | None = None,
                 solver: str | dict | LinearSolver | None = None, inverse: str | None = None, rtol: float = 1e-10,
                 maxit: int = 50, keep_states: bool = True, predictor: bool = False, condense: bool | None = None,
                 realcompile: bool | None = None, limit_steps: bool = True, reuse_factorization: bool = True,
                 iterative: bool | str | None = None, electric: bool | None = None, physical_checks: bool = True,
                 scheme: str | type[TimeScheme] = DEFAULT, globalise: bool = True, switch_loop: bool = True) -> None:
        options = arguments.simulation(body, loads, contact, time, inverse, dict(
            keep_states=keep_states, predictor=predictor, condense=condense, realcompile=realcompile,
            limit_steps=limit_steps, reuse_factorization=reuse_factorization, iterative=iterative,
            electric=electric, physical_checks=physical_checks, globalise=globalise, switch_loop=switch_loop))
        keep_states, predictor, condense, realcompile, limit_steps, reuse_factorization, iterative, electric, \
            physical_checks, globalise, switch_loop = options.values()
        Scheme = scheme_class(scheme)
        choice = as_options(solver, inverse, iterative, reuse_factorization)
        self.parallel_notes = check_simulation(body.mesh, contact, choice.inverse, condense, choice.reuse,
                                               choice.iterative)
        loads = loads or Loads()
        loads.check(body)
        time = time if time is not None else ngs.Parameter(0.0)
        number("rtol", rtol, 0, 1, low_open=True, high_open=True)
        integer("maxit", maxit, 1)
        uses_only(time, loads.coefficients() + (contact.coefficients() if contact is not None else []))
        self.body, self.loads, self.contact, self.time = body, loads, contact, time
        parts = assemble(body, loads, contact, time, Scheme, solver, choice, dict(
            electric=electric, condense=condense, realcompile=realcompile, rtol=rtol, maxit=maxit,
            limit_steps=limit_steps, globalise=globalise, predictor=predictor, keep_states=keep_states,
            physical_checks=physical_checks, switch_loop=switch_loop), partial(self._coarse, dict(
                u0=u0, scheme=scheme, rtol=rtol, maxit=maxit, limit_steps=limit_steps, switch_loop=switch_loop)))
        self.X, self.gfu, self.weak_form, self.system = parts.X, parts.gfu, parts.weak_form, parts.system
        self.u, self.phi = self.gfu.components
        self.electric, self._electric_parts, self.condense = parts.electric, parts.electric_parts, parts.condense
        self.gamma3, self._gap_check, self._machine_code = parts.gamma3, parts.gap_check, parts.machine_code
        self.newton, self._potential_solver, self.scheme = parts.newton, parts.potential_solver, parts.scheme
        self.starts, self.recorder, self.steps = parts.starts, parts.recorder, parts.steps
        for message in self.flags:
            warnings.warn(message, PhysicsWarning, stacklevel=2)
        self._resumed, self.u0 = None, u0         # the run info of resume(); u0 as given
        self._start(u0)

    def _coarse(self, options, mesh, order):
        """The Step of this scene on ``mesh`` at ``order`` (None: the body's), with Simulation's
        ``options`` and ``nested.COARSE_OPTIONS``: a level of nested iteration."""
        coarse = coarse_body(self.body, mesh, order)
        return Simulation(coarse, self.loads, contact=self.contact, time=self.time, electric=self.electric,
                          **options, **COARSE_OPTIONS).steps

    @property
    def realcompile(self):
        """Whether the Γ3 Jacobian is assembled with its integrand compiled to machine code."""
        return self.system.machine_code

    @property
    def model(self):
        """Which unknowns this simulation solves, and why."""
        if self.electric:
            return f"u and φ ({', '.join(self._electric_parts) or 'electric=True'})"
        return "u alone (no piezoelectric coupling, no conduction on Γ3, no electric loads: φ = 0)"

    def __repr__(self):
        contact = "none" if self.contact is None else self.contact.enforcement_method.name
        return (f"Simulation(t = {self.t:g} s, {len(self.history)} records; solves {self.model}; "
                f"contact: {contact}; linear solver: {self.solver})")

    # the parts of Γ3 users read
    side = property(lambda self: self.gamma3.side, doc="The ContactSide Γ3.")
    beta = property(lambda self: self.gamma3.beta, doc="The BondingField β (``beta.values``).")
    gap = property(lambda self: self.gamma3.gap, doc="The gap g, a CoefficientFunction (m).")
    enforcement = property(lambda self: self.gamma3.enforcement, doc="The enforcement method on Γ3.")

    @property
    def contact_pressure(self) -> ngs.CoefficientFunction:
        """λ_h (Pa, >= 0), the pointwise contact pressure of the rigid foundation on Γ3 for the
        current state, as the enforcement method imposes it (Nitsche: λ_h = −[P_γ(u_h)]₋; 0 where
        the body is free): a CoefficientFunction of the state with volume gradients, read on Γ3
        (``sim.side.integrate(cf)``, ``sim.side.at_gauss_points(cf)``; at points of Γ3:
        ``ngsolve.BoundaryFromVolumeCF(cf)(mesh(x, y, VOL_or_BND=ngsolve.BND))``). The body's normal stress adds the layer and the glue:
        ``sim.gamma3.contact_pressure(u, φ)`` is −σ_ν = λ_h + p(u_ν) − γ_ν β² R_ν(u_ν). Records keep
        its facet averages (``StepRecord.contact.multiplier``)."""
        if self.gamma3 is None:
            raise ValueError("contact_pressure: the simulation has no contact side Γ3 (Simulation(contact=None))")
        return self.gamma3.multiplier(self.u, self.phi)

    t = property(lambda self: self.scheme.t, doc="The time of the last step, s.")
    history = property(lambda self: self.steps.history, doc="The History: one StepRecord per step, step 0 first.")
    cutbacks = property(lambda self: self.steps.cutbacks, doc="The failed tries of ``advance`` (dicts).")
    rejections = property(lambda self: self.steps.rejections,
                          doc="The tries an error-controlled ``run`` rejected (dicts).")
    flags = property(lambda self: self.steps.flags, doc="The messages of what makes no physical sense.")
    physical_checks = property(lambda self: self.steps.physical_checks, doc="Whether steps are checked.")
    keep_states = property(lambda self: self.steps.keep_states, doc="Whether records keep (u, φ).")
    solver = property(lambda self: self.newton.solver_name,
                      doc="The linear solver of the Newton corrections, as it is actually used.")

    # what ran, read-only: for tests, studies and users who check which solver and laws acted
    @property
    def solver_detail(self) -> str:
        """The linear solver object of the Newton corrections as built, as its repr (its kind,
        factorisation and symmetry, e.g. ``"DirectSolver('mumps', symmetric=True)"``)."""
        return repr(self.newton.solver)

    @property
    def solver_options(self) -> dict:
        """The linear solver as used, in the fields a run's fingerprint records
        (``options.inverse``, ``options.reuse_factorization``, ``options.iterative``, and
        ``options.petsc`` for tuned PETSc options); a copy."""
        return dict(describe(self.newton.solver))

    @property
    def rescaled_laws(self) -> tuple:
        """The laws the law watch rescaled so far, in order: (step, the law's name, its new
        scale, the slope that made it) for each rescaling (``solve.law_watch``); empty where
        none was."""
        return tuple(self.system.laws.rescaled)

    @property
    def matrix_changes(self) -> int:
        """How many times the bulk matrix K (with the rate coefficient c) changed: after each
        change a kept factorisation is made anew."""
        return self.system.generation

    def pieces(self) -> dict | None:
        """The pieces of the laws of Γ3 at the current state, a fresh dict: for each law (e.g.
        ``"the contact set"``) the integer piece at the Gauss points of each facet of Γ3
        (``gamma3.switches``); None without contact."""
        switches = self.newton.switches
        return None if switches is None else switches()

    def _start(self, u0):
        """Step 0: u0 (checked), φ0 from the electric equation at t = 0, and its record."""
        if u0 is not None:
            u0 = as_cf(u0, self.body.dim, "u0")
            check_initial_displacement(self.body, u0, self.gamma3)
            self.u.Set(u0)
            clamped = ~np.array(list(self.body.V.FreeDofs()), dtype=bool)
            given = self.u.vec.FV().NumPy()[clamped].copy()
            self.u.vec.FV().NumPy()[clamped] = 0.0
        else:
            given = np.zeros(self.body.V.ndof - self.body.V.FreeDofs().NumSet())
        start, timings = wallclock.perf_counter(), Timings()
        # φ0 with u = u0 held: the potential's free DOFs only, with the terms of a step of 1 s
        self.scheme.start()
        check_supports_at_start(self.body, self.u, given)
        phi_only = ngs.BitArray(self.X.FreeDofs())
        phi_only[self.X.Range(0)] = False
        if self.electric:
            newton = Newton(self.system.uncondensed, self.gfu, solver=self._potential_solver,
                            freedofs=phi_only, rtol=self.newton.rtol, maxit=self.newton.maxit)
            result = newton.solve(step=0, time=0.0, timer=timings)
            self._potential_solver = None        # used once: its factorisation or hierarchy is freed
        else:                                    # nothing to solve: φ0 = 0
            residual = self.gfu.vec.CreateVector()
            self.system.Apply(self.gfu.vec, residual)
            result = NewtonResult(0, [0.0], residual)
        self.history.append(self.steps.record(0, result, start, timings))

    # ----------------------------------------------------------------------- stepping
    def step(self, dt: float, guess: Guess = None) -> StepRecord:
        """One step of the time scheme, of length dt (s); returns its StepRecord. ``guess``:
        Newton's start instead of the last state (``starts``: a displacement, which may
        penetrate, ``starts.Approach(depth)``, "nested" or "p1"). Transactional: either t, u,
        φ, β and the history all advance, or they are left bitwise as they were and the error
        (``NewtonError`` if Newton fails) is raised. dt, the guess and the data of Γ3 at t + dt
        are checked first (``arguments.time_step``, ``gamma3.build.gamma3_data``)."""
        return self.steps.take(arguments.time_step(dt, self.t), guess)

    def advance(self, target: float, max_cutbacks: int = 6, on_step: Callable | None = None,
                guess: Guess = None) -> list[StepRecord]:
        """Reach the time ``target`` (s) in one step, or, where Newton fails, in two half
        steps, each halved again on failure, down to 1/2^max_cutbacks of the step
        (max_cutbacks in [0, ``arguments.MAX_CUTBACKS``]); returns the new StepRecords and
        calls ``on_step(record)`` after each step, while the state is that step's; ``guess``
        starts the first try (``step``), the warm start the cut-back steps. Each
        cut-back is listed in ``cutbacks``. If even the smallest step fails, the NewtonError
        names the time steps tried; the state is that of the last computed step."""
        max_cutbacks, on_step = arguments.cutbacks(max_cutbacks), arguments.callback(on_step)
        return self.steps.advance(arguments.later("target time", target, self.t), max_cutbacks, on_step, guess)

    def run(self, dt: float, T: float, *, max_cutbacks: int = 6, progress: bool = False, vtk: str | None = None,
            on_step: Callable | None = None, out: str | os.PathLike | None = None, guess: Guess = None,
            rtol: float | None = None, dt_min: float | None = None, event_dt: float | None = None,
            restart_data: bool = True) -> History:
        """Step from the current time to T (s) with nominal steps dt (s); returns the History.
        The nominal steps are equal and reach T exactly: when dt does not divide T − t, they
        are (T − t)/⌈(T − t)/dt⌉, shorter than dt, and a ``TimeStepWarning`` names dt asked
        and dt used.
        With ``rtol`` (a relative local error per step, for a scheme with an error estimate:
        "bdf2") the steps are chosen by it instead, dt the first (``stepping``): rejected tries
        in ``rejections``, events located to ``event_dt`` (default 1e-3 dt), no step below
        ``dt_min`` (default 1e-6 dt); ``max_cutbacks`` and ``guess`` are for nominal steps.

        max_cutbacks : the cut-back policy of ``advance`` for each nominal step (the next
            nominal step uses dt again).
        progress : show a progress bar (True or False).
        vtk : file name stem for NGSolve's VTKOutput of u and φ (one file per step; under
            mpiexec one per computing rank and step, collected by ``<vtk>.pvd``), or None; not
            a directory (``out`` writes u, φ and Γ3 into one: docs/output.md).
        on_step : called with each new StepRecord, right after its step (cut-back steps
            included).
        out : a directory to stream every step into as it is computed (``results``: records,
            restart state, ParaView series of the body and of Γ3, docs/output.md; under
            mpiexec every rank writes its own part of each step into it, a directory all ranks
            see); after ``resume(out)``, the same dt and T continue the interrupted run on its
            own nominal steps.
        guess : Newton's start (``step``): "nested" or "p1" for every step, another guess for the first.
        restart_data : with ``out``, False leaves the solver's kept factorisation out of the step
            archives (its values are most of an archive: records, states and the scheme's restart
            state stay); ``resume`` then factorises anew from the state and continues the run to
            Newton's tolerance, not bitwise. True (the default) keeps it: a resume is bitwise.
        If a step fails even at the smallest cut-back, the NewtonError is raised with
        ``error.history`` holding every step computed so far (also in ``history``).
        The arguments are checked before the first step (``arguments.run``: the directories
        of ``vtk`` and ``out`` must be writable, at most ``checks.MAX_STEPS`` steps).
        """
        results.check_incomplete(self._resumed, self.history, T)      # resumed, complete: say so
        dt, T, max_cutbacks, progress = arguments.run(self.t, self.body.mesh, dt, T, max_cutbacks, progress, vtk,
                                                      on_step, out)
        control = arguments.controlled(self.newton.rtol, self.scheme, dt, rtol, dt_min, event_dt, T)
        if not arguments.flag("restart_data", restart_data) and out is None:
            raise ValueError("run: restart_data=False is for the step archives of out=DIR: give out too")
        self.starts.resolve(guess)
        resumed = self._resumed
        start = resumed["start"] if resumed and (resumed["dt"], resumed["T"], resumed.get("rtol")) == (dt, T, rtol) \
            else self.t
        steps = stepping.equal_steps(start, T, dt) if control is None else max(1, int(np.ceil((T - start) / dt - 1e-9)))
        if self._machine_code is not None:
            self._machine_code.expect(steps * ITERATIONS_PER_STEP)
        callbacks = [on_step] if on_step else []
        if out is not None:                      # checks the directory, writes the history so far
            dt_min, event_dt = control or (None, None)
            callbacks.insert(0, results.Stream(self.results_source(), out, dt, T, start, resumed, rtol, dt_min=dt_min,
                                               event_dt=event_dt, max_cutbacks=max_cutbacks, guess=guess,
                                               restart_data=restart_data))
        if vtk is not None:                      # distributed: one .vtu per computing rank and step, one .pvd
            series = paraview.FieldsSeries(self.results_source(), vtk)
            series(self.t)
            callbacks.insert(0, lambda record: series(record.time))

        def after(record):
            for callback in callbacks:
                callback(record)
        with bar(T - self.t if control else steps, "time steps", progress, unit="s" if control else "step") as shown:
            if progress:                        # a long step shows its Newton iterations
                self.newton.on_iteration = lambda it, r: shown.set_postfix_str(
                    f"t -> {self.time.Get():.4g} s, Newton {it}, residual {r:.1e}")
            try:
                if control:
                    stepping.controlled_steps(self.steps, start, T, dt, rtol, after, shown, *control)
                else:
                    stepping.nominal_steps(self.steps, start, T, steps, max_cutbacks, after, shown, guess)
            finally:
                self.newton.on_iteration = None
        return self.history

    def resume(self, directory: str | os.PathLike) -> Simulation:
        """Continue a run streamed into ``directory`` (``run(..., out=directory)``) that was
        interrupted: its last step on disk becomes this simulation's state and history (the
        simulation must be freshly built, of the same scene and time scheme: ``results.restore``
        checks it and the step archives; the scheme puts back its own restart state). Under
        mpiexec, on as many ranks as the run was written by, each rank reads its own part. Then
        ``run(dt, T, out=directory)`` with the run's dt and T computes the rest. Returns self."""
        info, history, restart = results.restore(self.results_source(), directory)
        self.scheme.load(restart)
        if self._machine_code is not None and "machine_code_spent" in restart:    # its rule counts on
            self._machine_code.spent = float(restart["machine_code_spent"])
            if restart["machine_code"]:
                self.system.use_machine_code()
        self.history[:] = history
        self._resumed = info
        return self

    def _restart_state(self):
        """The restart state of a step archive (``results``): the time scheme's (its ``save``)
        and, where a rule decides whether the Γ3 integrand is compiled, how far it has counted
        and whether it compiled (a resumed run compiles at the same step)."""
        arrays = self.scheme.save()
        if self._machine_code is not None:
            arrays.update(machine_code_spent=np.asarray(self._machine_code.spent),
                          machine_code=np.asarray(self.system.machine_code))
        return arrays

    def results_source(self):
        """What ``results`` reads of this simulation (``results.Source``)."""
        body, X, side = self.body, self.X, self.gamma3.side if self.gamma3 is not None else None
        return results.Source(body.mesh, (self.u, self.phi), max(body.order, body.order_phi) - 1, side, self.history,
                              dict(ndof=X.ndofglobal, dim=body.dim, model=self.model, scheme=self.scheme.name),
                              self.fingerprint, self._restart_state, (self.gfu.vec.FV().NumPy(), [X.Range(0), X.Range(1)]))

    def fingerprint(self, T: float) -> dict:
        """The fingerprint of this simulation's scene and options for a run to T (s): what
        ``results`` stores and compares (``output.fingerprint``)."""
        options = fingerprint_options(self.newton, self.scheme, self.electric, self.condense,
                                      self._machine_code is not None)
        return fingerprint(self.body, self.loads, self.contact, self.X.ndofglobal, options,
                           self.scheme.coefficients.at, T)

    # ----------------------------------------------------------------------- reading the state
    def state(self, n: int) -> ngs.GridFunction:
        """GridFunction of (u, φ) at step n (needs ``keep_states``): n an integer in [0, len(history) − 1],
        or from the end in [−len(history), −1]; a TypeError or IndexError naming n and that range otherwise."""
        arguments.history_index(n, len(self.history))
        if self.history[n].state is None:
            raise ValueError("the states were not kept: pass keep_states=True to Simulation")
        gf = ngs.GridFunction(self.body.X)
        gf.vec.FV().NumPy()[:] = self.history[n].state
        return gf

    def jacobian(self, scaled: bool = True) -> "scipy.sparse.csr_matrix":
        """The step Jacobian R'(x) at the current state (with the last step's t and dt) on the
        free DOFs, as a scipy CSR matrix; ``scaled``: S J S with S = diag(s_u^-½, s_φ^-½), s_b
        the mean of |diagonal| over block b (the scaling of Newton's norms)."""
        return free_jacobian(self.system.uncondensed, self.gfu.vec, self.X, scaled)
