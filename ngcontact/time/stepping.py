"""How a simulation reaches a time: nominal steps with cut-backs, or steps chosen by an error target.

``advance`` reaches a time in one step, or, where Newton fails, in halves (the cut-back
policy). ``nominal_steps`` makes the nominal steps of ``Simulation.run(dt, T)``.
``controlled_steps`` makes ``Simulation.run(dt, T, rtol=...)``: each step's length comes from
the scheme's local error estimate (``schemes.bdf2``: Milne's device) and the tolerance,

  err = max(e_u / rtol, e_β (T − t_0)/(k rtol))    (``error_ratio``; t_0 the run's start),
  accepted when err <= 1; next k = k · min(MAX_GROWTH, max(MIN_SHRINK, SAFETY · err_f^(−1/q_f)))
  of the field f that limits the next step most (q_u = 3, q_β = 2: BDF2's local error is O(k³)),

u's relative local error per step, and β's local error per unit step, normalised by the run's
span (``CONTROLLED``): u is damped by the viscosity (its local errors fade on the relaxation
time), β is not (2.9) — its local errors add up over the run, and the final state (a plate
hanging by its glue, say) follows β. Per unit step, the errors β can add up to over the run
are at most rtol, and the final error falls in proportion to rtol;

a step with err > 1 is rejected (the state put back bitwise) and retried with the smaller k,
a Newton failure halves k, and the events of Γ3 — first contact, lift-off, β reaching 0 on a
facet — are located: a step across which one happens is rejected and halved until it is no
longer than ``event_dt``, then accepted with ``StepRecord.event`` naming it (the estimate
does not hold across a kink), and the scheme restarts from that short step (a backward Euler
step, then BDF2 steps that grow as the estimate allows). The controller's whole state is the
scheme's restart state and the last record's ``dt_next``: a resumed run takes the same steps.
The first step of a run is the dt given: the estimate needs three states. Decisions read the
estimates and records only, never the clock (runs repeat bitwise).
"""
import warnings

import numpy as np

from ngcontact.model.admissible import stiff_contact_terms
from ngcontact.solve.newton import NewtonError

MIN_DT = 1e-20
"""The smallest time step, s: no continuum model steps below it, and 1/dt stays far from
overflow in the viscous term A/dt."""
RESOLUTION = 1e-13
"""A step must be at least this fraction of the time it starts from: below it t + dt is t to
13 digits."""


class TimeStepWarning(UserWarning):
    """``run(dt, T)`` made its nominal steps shorter than the dt asked, so that equal steps
    reach T (equal steps share one rate coefficient, so one factorisation); the message names
    dt asked and dt used."""


def equal_steps(start, T, dt):
    """The number of equal nominal steps from ``start`` to T (s) no longer than dt (s), at
    least one; a TimeStepWarning naming both values when their length differs from dt."""
    count = max(1, int(np.ceil((T - start) / dt - 1e-9)))        # dt > T − t: one step to T
    used = (T - start) / count
    if abs(used - dt) > 1e-9 * dt:
        warnings.warn(f"run: dt = {dt:.6g} s asked, dt = {used:.6g} s used: {count} equal step"
                      f"{'s' if count > 1 else ''} from t = {start:.6g} s reach T = {T:.6g} s "
                      f"(pass a dt that divides T − t to step by it)", TimeStepWarning, stacklevel=3)
    return count


class AccuracyWarning(UserWarning):
    """An error-controlled run accepted a step whose error estimate it could not bring within
    rtol (``FLOOR_SHRINK``); the message is also in ``Simulation.flags``."""


SAFETY, MIN_SHRINK, MAX_GROWTH = 0.9, 0.2, 2.0
"""The controller's safety factor and the bounds of a step's change (MAX_GROWTH < 1 + √2, where
variable-step BDF2 stays zero-stable)."""
CONTROLLED = {"u": "per step", "beta": "per unit step"}
"""The fields whose estimated local error sets the steps, and how (``error_ratio``): the ones
with a time derivative. φ is algebraic (the electric equation has none: φ_n follows from u_n),
as DAE codes leave algebraic variables out of the error test; its estimate is recorded in
``rejections`` and compared with a reference in docs/time.md. With φ in the test, the soft
column (no conduction) rejected most of its tries, every one on φ; without, few. With β per step
as well (as first built), the final error on the reference plate (nodal constraint) fell far
less than rtol: the plate hangs by its glue at T, and the per-step errors of β after lift-off had
added up; per unit step it falls with rtol (docs/measurements.md, section
ngcontact/time/stepping.py)."""
ORDERS = {"per step": 3, "per unit step": 2}
"""The power of k in a controlled quantity: BDF2's local error is O(k³), per unit step O(k²)."""


def error_ratio(estimate, rtol, k, span):
    """(err, growth) of a step of length k (s) whose scheme estimated ``estimate`` (a dict per
    field, ``schemes.bdf2.BDF2.local_error``), in a run of ``span`` seconds: err = max over the
    ``CONTROLLED`` fields of the estimate / rtol, per unit step scaled by span/k; growth is the
    factor for the next step, SAFETY · err_f^(−1/q) of the field f that limits it most, within
    [MIN_SHRINK, MAX_GROWTH]."""
    ratios = {f: estimate[f] / rtol * (span / k if how == "per unit step" else 1.0)
              for f, how in CONTROLLED.items() if f in estimate}
    err = max(ratios.values(), default=0.0)
    factors = [SAFETY * ratio ** (-1 / ORDERS[CONTROLLED[f]]) for f, ratio in ratios.items() if ratio > 0]
    return err, min(MAX_GROWTH, max(MIN_SHRINK, min(factors, default=MAX_GROWTH)))


FLOOR_SHRINK, FLOOR_FALL = 4.0, 2.0
"""A try FLOOR_SHRINK times shorter than the first one rejected for its error whose estimate fell
by less than FLOOR_FALL has met a floor of the estimate that the step size does not reduce (a
time error falls as k³; across a kink in ü as k², in u̇ as k): the step is
accepted, with its estimate above 1 in its record, and flagged (``AccuracyWarning``); for the
rest of the run, a step whose estimate is at most FLOOR_FALL times that floor is accepted alike,
and the next one takes again the step that met the floor (not a shorter one that located an
event); the floor and that step are read back from the records on a resume. With Nitsche the
discrete contact law changes with the step (γ follows c, docs/time.md): on the reference plate
u's estimate stayed at such a floor however short the tries, and a tight rtol took many
rejections (docs/measurements.md, section ngcontact/time/stepping.py)."""
RESTART_BELOW = 0.1
"""A step rejected down to this fraction of the last accepted one restarts the scheme: the
estimate extrapolates from the earlier states, and a kink among them (conduction or contact
switching on at points of Γ3) keeps it large however short the new step is."""


def advance(steps, target, max_cutbacks, on_step, guess, dt=None):
    """``Simulation.advance``: the cut-back policy (its docstring), for the ``step.Step``
    ``steps``. ``dt``: the nominal length of the step to ``target`` (s), which sets the scheme's
    rate coefficient, and the first half of a failed step is half its step; otherwise (a step
    that starts part-way, the second half) the step is target − t."""
    if dt is not None and abs(target - steps.t - dt) > 1e-9 * dt:      # a resumed run may start part-way
        dt = None
    records, pending = [], [(target, dt, 0)]        # (time to reach, nominal step or None, halvings): a stack
    while pending:
        goal, k, halvings = pending.pop()
        k, first, guess = goal - steps.t if k is None else k, guess, None
        try:
            record = steps.take(k, guess=first, target=goal)
        except NewtonError as err:
            n = len(steps.history)
            steps.cutbacks.append(dict(step=n, time=goal, dt=goal - steps.t, iterations=err.iteration,
                                       residuals=err.residuals))
            if halvings == max_cutbacks or not err.recoverable:   # (not recoverable: smaller steps fail too)
                raise _named(steps, err, n, goal)
            pending += [(goal, None, halvings + 1), (steps.t + k / 2, k / 2, halvings + 1)]   # first half on top
            continue
        if on_step is not None:
            on_step(record)
        records.append(record)
    return records


def _named(steps, err, n, goal):
    """The NewtonError of step n with the time steps tried and the stiff Γ3 terms named."""
    err.tried = [c["dt"] for c in steps.cutbacks if c["step"] == n]
    stiff = "" if steps.contact is None else stiff_contact_terms(steps.body, steps.contact, steps.side)
    err.hint += stiff
    tried = ", ".join(f"{dt:.3g}" for dt in err.tried)
    err.args = (f"{err.args[0]}. Time steps tried for step {n} (t -> {goal:.6g} s): dt = {tried} s; "
                f"the state is that of step {n - 1}{stiff}",)
    return err


def nominal_steps(steps, start, T, count, max_cutbacks, after, shown, guess):
    """The ``count`` nominal steps of ``run`` from ``start`` to T (s) not reached yet, the first
    from ``guess``: step i reaches start + i·dt with the nominal dt = (T − start)/count (equal
    steps have one rate coefficient, so one factorisation)."""
    dt = (T - start) / count
    for i in range(count):
        target = T if i == count - 1 else start + (i + 1) * dt
        if target <= steps.t * (1 + 1e-12):          # reached before a resume
            shown.update(1)
            continue
        try:
            records = advance(steps, target, max_cutbacks, after, guess, dt)
            guess = guess if isinstance(guess, str) else None           # "nested", "p1": every step
        except NewtonError as err:
            err.history = steps.history
            raise
        shown.set_postfix_str(f"t = {steps.t:.4g} s, newton {records[-1].newton_iterations}")
        shown.update(1)


def events(before, after):
    """The events of Γ3 between two StepRecords: "first contact", "lift-off", "β reaches 0"
    (on a facet where it was positive), or None."""
    if before.contact is None or after.contact is None:
        return None
    found = []
    if before.contact.contact_area == 0 and after.contact.contact_area > 0:
        found.append("first contact")
    if before.contact.contact_area > 0 and after.contact.contact_area == 0:
        found.append("lift-off")
    if np.any((before.contact.beta > 0) & (after.contact.beta <= 0)):
        found.append("β reaches 0")
    return ", ".join(found) or None


def controlled_steps(steps, start, T, dt, rtol, after, shown, dt_min, event_dt):
    """Steps from steps.t to T (s) chosen by the error target ``rtol`` (module docstring) in the
    run that began at ``start`` (s), the first proposed of length dt (or the last accepted
    step's ``dt_next`` after a resume); steps shorter than ``dt_min`` fail: a NewtonError or a
    ValueError naming the time and why, with every step computed so far kept."""
    last = steps.history[-1]
    k = last.dt_next if last.dt_next is not None else dt
    span = T - start
    steps.scheme.control(rtol)                  # its inner tolerances (BDF2's β passes) to the error test's
    rejected, streak = [], []           # streak: (k, err) of the tries rejected for their error at this step
    # the floor of the estimate met in this run (the first step accepted above rtol), from the records: a resume sees it
    # and the step that met it: the next steps at the floor take it again, not a shorter one an event made
    met = next((r for r in steps.history if r.time > start and r.error_estimate is not None and r.error_estimate > 1),
               None)
    floor_level, floor_k = (None, None) if met is None else (met.error_estimate, met.dt)
    while steps.t < T * (1 - 1e-12) and T - steps.t > 1e-9 * min(dt, span):
        k = min(k, T - steps.t)
        if T - steps.t - k < 0.01 * k:                  # no sliver of a step before T
            k = T - steps.t
        saved, before = steps.scheme.checkpoint(), steps.history[-1]
        try:
            record = steps.take(k)
        except NewtonError as err:
            rejected.append(dict(time=steps.t + k, dt=k, reason=f"Newton failed at iteration {err.iteration}"))
            steps.rejections.append(rejected[-1])
            if k / 2 < dt_min:
                err.history = steps.history
                raise _named(steps, err, len(steps.history), steps.t + k)
            k /= 2
            continue
        estimate = steps.scheme.estimate
        err, growth = (None, MAX_GROWTH) if estimate is None else error_ratio(estimate, rtol, k, span)
        event = events(before, record)
        if event:                       # a kink in time: the estimate does not hold across it
            err = None
        reason = (f"{event} inside the step" if event and k > event_dt else
                  f"error estimate {err:.3g} × rtol" if err is not None and err > 1 else None)
        floor = not event and err is not None and err > 1 and (
            bool(streak) and k <= streak[0][0] / FLOOR_SHRINK and err >= streak[0][1] / FLOOR_FALL
            or floor_level is not None and err <= FLOOR_FALL * floor_level)
        if floor and floor_level is None:              # the step size does not reduce the estimate: say so once
            floor_level, floor_k = err, k
            _flag(steps, f"step {len(steps.history) - 1} (t = {steps.t:.6g} s): the local error estimate stayed at "
                       f"{err:.3g} × rtol on tries from {streak[0][0]:.3g} s to {k:.3g} s (a time error falls as "
                       f"k³): it measures what the step does not reduce (with Nitsche: the contact law changes with "
                       f"the step, γ follows c; docs/time.md); the step is accepted; rtol = {rtol:g} is below what "
                       f"this discretisation can tell apart (from here on, steps with an estimate up to "
                       f"{FLOOR_FALL * err:.3g} × rtol are accepted; their records have error_estimate > 1)")
        if floor:
            reason = None
        if reason is not None and k > dt_min:
            steps.scheme.restore(saved)                 # the state, β and the scheme's memory, bitwise
            del steps.history[-1]
            rejected.append(dict(time=steps.t + k, dt=k, reason=reason, estimate=estimate))
            steps.rejections.append(rejected[-1])
            if err is None or err <= 1:               # an event inside: halve towards it
                k /= 2
            else:
                streak.append((k, err))
                k *= growth
                if before.dt is not None and k < RESTART_BELOW * before.dt:
                    steps.scheme.restart()              # the estimate sees a kink among the earlier states
            continue
        if reason is not None:
            hint = ("; an estimate that stays near rtol on ever shorter steps measures Newton's inexactness: a "
                    "larger rtol, or a smaller Simulation(rtol=...)" if err is not None else "")
            raise ValueError(f"run(rtol={rtol:g}): the step from t = {steps.t - k:.6g} s reached dt_min = {dt_min:.3g} s "
                             f"({reason}); every step so far is kept in the history{hint}")
        record.error_estimate, record.rejected, record.event = err, len(rejected), event
        record.dt_next = max(k, floor_k) if floor else k * (growth if err is not None else 1.0)
        if event:                                      # located: restart from the short step
            steps.scheme.restart()
            record.dt_next = k
        rejected, streak = [], []
        k = record.dt_next
        after(record)
        shown.update(record.dt)
        shown.set_postfix_str(f"t = {steps.t:.4g} s, dt {record.dt:.3g} s, newton {record.newton_iterations}")


def _flag(steps, message):
    """Say ``message`` (an ``AccuracyWarning``) and keep it in ``steps.flags``."""
    steps.flags.append(message)
    warnings.warn(message, AccuracyWarning, stacklevel=3)
