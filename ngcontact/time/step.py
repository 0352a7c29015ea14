"""The parts that make a time step, handed down by ``Simulation`` to what steps, starts, checks
and estimates (``stepping``, ``solve.nested``, ``estimators``) in its place.

``Step.take(dt)`` is one transactional step of the time scheme: either t, (u, φ), β and the
history all advance, or they are left bitwise as they were and the error is raised.
``Step.advance(target)`` reaches a time with cut-backs (``stepping.advance``).
"""
from __future__ import annotations

import time as wallclock
import warnings
from dataclasses import dataclass, field
from functools import partial

import ngsolve as ngs

from ngcontact.gamma3.build import gamma3_data
from ngcontact.model.admissible import PhysicsWarning, flags
from ngcontact.solve.newton import Timings
from ngcontact.time import stepping


@dataclass(eq=False)
class Step:
    """What makes a step of a Body under Loads with a contact law on Γ3, and what steps fill.

    body, loads : the Body and its Loads.
    contact, gamma3 : the Contact and its built Γ3 parts (``gamma3.build.Gamma3``), or None.
    scheme : the time scheme (``schemes.TimeScheme``; its ``system``: the StepSystem;
        ``newton``: Newton; ``state``: the GridFunction of (u, φ)).
    starts : Newton's starts (``solve.starts.Starts``).
    recorder : makes a step's record from the state (``output.observables.Recorder``).
    history : the StepRecords, step 0 first; ``cutbacks``, ``rejections``, ``flags``: the
        failed tries of ``advance``, the rejected tries of error-controlled runs, and the
        messages of what makes no physical sense.
    electric : whether φ is an unknown. keep_states : copy (u, φ) into each record.
    physical_checks : flag steps that make no physical sense (``model.admissible.flags``).
    gap_check : checks the gap at a time (a gap given as a CoefficientFunction), or None.
    machine_code : the rule that decides whether Γ3's integrand is compiled, or None.
    """

    body: object
    loads: object
    contact: object
    gamma3: object
    scheme: object
    starts: object
    recorder: object
    history: list
    electric: bool = True
    keep_states: bool = True
    physical_checks: bool = True
    gap_check: object = None
    machine_code: object = None
    cutbacks: list = field(default_factory=list)
    rejections: list = field(default_factory=list)
    flags: list = field(default_factory=list)

    system = property(lambda self: self.scheme.system, doc="The StepSystem.")
    newton = property(lambda self: self.scheme.newton, doc="Newton.")
    gfu = property(lambda self: self.scheme.state, doc="The GridFunction of (u, φ).")
    u = property(lambda self: self.scheme.state.components[0], doc="The displacement u (m).")
    phi = property(lambda self: self.scheme.state.components[1], doc="The potential φ (V).")
    X = property(lambda self: self.scheme.state.space, doc="The product space of (u, φ).")
    t = property(lambda self: self.scheme.t, doc="The time of the last step, s.")
    side = property(lambda self: self.gamma3.side if self.gamma3 is not None else None, doc="Γ3, or None.")

    def take(self, dt, guess=None, target=None):
        """One step of length dt (s, the step's nominal length: the scheme's rate coefficient
        comes from it) to ``target`` (s; default t + dt), Newton started from ``guess``
        (``starts.Starts.resolve``); returns its StepRecord. Transactional (module docstring);
        dt and the guess are the caller's to check (``arguments.time_step``)."""
        guessed = self.starts.resolve(guess)
        target = self.t + dt if target is None else target
        n, start = len(self.history), wallclock.perf_counter()
        saved, timings = self.scheme.checkpoint(), Timings()
        try:
            attempt = 0
            while True:
                if self.contact is not None:                    # the data at t_n, before the solve
                    at = self.scheme.coefficients.at
                    gamma3_data(self.contact, self.gamma3, self.body.mesh, at, target)
                    if self.contact.obstacle is None and isinstance(self.contact.gap, ngs.CoefficientFunction):
                        with at(target):
                            self.gap_check(target)
                result = self.scheme.advance(dt, step=n, timer=timings, start=partial(self.starts.apply, guessed),
                                             target=target)
                # (2.16)-(2.17) at the step's strains; a law's stiffness scale grew: the step again
                if self.system.laws is None or not self.system.laws.check_step(self.gfu.vec, n, self.t, attempt):
                    break
                self.scheme.restore(saved)
                attempt += 1
            record = self.record(n, result, start, timings)
        except BaseException:
            self.scheme.restore(saved)
            raise
        self.history.append(record)
        if self.machine_code is not None:
            self.machine_code.account(record.newton_iterations)
        found = flags(self.body, record, self.u, self.side) if self.physical_checks else []
        for message in found:
            self.flags.append(message)
            warnings.warn(message, PhysicsWarning, stacklevel=3)
        return record

    def record(self, n, result, start, timings):
        """The StepRecord of step n, with its wall time since ``start`` split into ``timings``."""
        record = self.recorder.record(n, self.t, result, keep_state=self.keep_states)
        record.scheme = self.scheme.name
        if n:
            record.dt, record.order = self.t - self.history[-1].time, self.scheme.last_order
        record.wall_s = wallclock.perf_counter() - start
        record.timings = dict(timings, other=record.wall_s - sum(timings.values()))
        return record

    def advance(self, target, max_cutbacks=6, on_step=None, guess=None, dt=None):
        """Reach ``target`` (s) in one step of nominal length ``dt`` (default target − t), halved
        where Newton fails (``stepping.advance``); returns the new StepRecords."""
        return stepping.advance(self, target, max_cutbacks, on_step, guess, dt)
