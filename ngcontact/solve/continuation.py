"""Path-following for a step Newton cannot solve directly: the laws of Γ3 from smooth to sharp.

The conductance ψ of (2.7) switches on over its ramp δ, and the charge it lets through,
ψ(r) φ_L(φ − φ_Γ), is the product of that switch and a potential drop that reaches 10³ V on an
insulated contact: with δ far below the displacement of the step (δ = 10⁻⁸ m against a push of
10⁻⁴ m) the semismooth Newton steps jump between conducting and insulating sets and do not
settle; where the potentials of the iterates leave the truncation's level L_φ, φ_L is flat
and the Jacobian has no conduction term in φ, and the steps overshoot (docs/stability.md,
sections 8 and 10). With a wide ramp and a high level the same step converges from its start;
each sharper law starts from the solution of the smoother one, where the sets are nearly
right, and takes a few iterations.

``Continuation`` holds the widening w of each such law (an ``ngsolve.Parameter`` the law reads,
1 for the law as given) and the stages of the path: w from the widest (the ramp as wide as Γ3
moved in the failed try, at most ``SMOOTH`` times the body's size; the level ``TRUNCATION``
times higher) down to 1 by factors of at most ``FACTOR``; a stage that fails is bisected.
``Newton.solve`` follows the path as soon as full steps stop making progress, from the
iterate of least residual of its first try; the time scheme does not see it (t, c and û are
those of the step). A stage before the last only starts the next one: it is done once its
residual is ``REDUCTION`` of its first (the next stage's first residual, made by the change of
the laws, is about as large as this stage's). The widest stage takes the line search where full
steps stop making progress; a later stage does so as the first try did: it is given up (and
bisected) at once where the laws of the path flip, and searches otherwise.
"""
import math

import ngsolve as ngs
import numpy as np

SMOOTH = 1e-2
"""The widest ramp of the path, relative to the body's size (the diameter of its bounding box):
wide enough that Newton solves the electrode contact's step from the cold start (docs/measurements.md,
section ngcontact/solve/continuation.py)."""
FACTOR = 100.0
"""The ratio of successive ramps of the path."""
BISECTIONS = 4
"""The stages a path may give up and replace (``Continuation.solve``)."""
TRUNCATION = 1e3
"""The widest truncation of the path, relative to L_φ: a truncation that does not act where the
potentials of a step's iterates go (on the column pressed flat onto the conducting foundation a
high L_φ converges where the given one cycles: docs/stability.md)."""
REDUCTION = 1e-2
"""A stage before the last is done at this fraction of its first residual (``Newton.reduction``):
solved to Newton's tolerance, those stages cost more iterations in all, and one may stall on a kink
of the gated conduction (the electrode contact: docs/stability.md, section 11)."""
MOST = 8
"""The path's widest ramp is at most FACTOR^MOST times the narrowest (a ramp of 10⁻³⁰⁰ m is a step
whatever the path)."""


class Continuation:
    """The widening of the regularised laws of Γ3 and the path of a failed solve.

    ``laws``: [(name, Parameter w the law reads (w = 1: the law as given), unit, size)]: a ramp
    (unit "m", its width δ: widened up to ``SMOOTH`` times the body's size) or a truncation
    (unit "V", its level L_φ: widened up to ``TRUNCATION`` times); ``size``: the body's size (m).
    ``stages``: the widenings of the path, widest first, 1 last (empty where the laws are
    already smooth on the body's scale); each law is widened by the stage's w or by its own
    widest, the smaller."""

    def __init__(self, laws, size, normal_motion=None):
        self.laws = [tuple(law) for law in laws]
        self.size, self.normal_motion = size, normal_motion
        self.stages = self.path(SMOOTH * size)

    def _widest(self, unit, width, span):
        if unit == "V":
            return TRUNCATION
        return min(FACTOR ** MOST, max(1.0, span / width))

    @property
    def widest(self):
        """The largest widening of the path (``FACTOR`` ** ``MOST`` at most)."""
        return max(self._widest(unit, width, SMOOTH * self.size) for _, _, unit, width in self.laws)

    def path(self, span):
        """The widenings from ramps of ``span`` (m) to 1."""
        if not self.laws:
            return []
        widest = max(self._widest(unit, width, min(span, SMOOTH * self.size)) for _, _, unit, width in self.laws)
        count = math.ceil(math.log(widest) / math.log(FACTOR) - 1e-9) if widest > 1 else 0
        return [widest ** (1 - i / count) for i in range(count + 1)] if count else []

    def __bool__(self):
        return bool(self.stages)

    def set(self, w):
        for _, parameter, unit, width in self.laws:
            parameter.Set(min(w, self._widest(unit, width, SMOOTH * self.size)))

    SWITCHES = {"m": "the conduction ψ", "V": "the potential truncation φ_L"}
    """The switch (``switches.Switches``) of each kind of law the path widens, by its unit."""

    def widens(self, flips):
        """The switches among ``flips`` (``switches.Switches.flipping``) of the laws this path
        widens (an empty list where none flips)."""
        widened = {self.SWITCHES[unit] for _, _, unit, _ in self.laws}
        return [name for name, *_ in flips if name in widened]

    @property
    def names(self):
        return " and ".join(name for name, *_ in self.laws)

    def solve(self, newton, first, start, best, step, time, timer):
        """Follow the path from the state ``best`` (a vector: the failed try's iterate of least
        residual; ``start``, the step's start, gives how far that try moved Γ3) after the
        NewtonError ``first``: each stage starts from the last converged one and gives up where
        the first try did (no progress with full steps); a stage given up is replaced by one
        halfway (geometrically) from the last converged width, or, before any, by one ``FACTOR``
        wider (up to ``widest``), at most ``BISECTIONS`` times. Returns the NewtonResult of the last stage, with
        ``iterations`` those of the converged stages, ``discarded`` those of the first try and of
        the stages given up, ``path`` [(w, iterations)]. A failure raises the NewtonError of the
        last stage tried (its own linear counts, ``spent`` the iterations of the whole path), which
        names the path and ``first``."""
        from ngcontact.solve.newton import LINEAR_COUNTS, NewtonError      # (newton takes a Continuation)
        stages = list(self.stages)
        if self.normal_motion is not None:       # the ramps from how far the failed try moved Γ3
            stages = self.path(min(SMOOTH * self.size, max(self.normal_motion(newton.gfu.vec, start), 0.0)))
        stages = stages or [1.0]
        x, kept = newton.gfu.vec, start.CreateVector()
        kept.data = x.data = best
        path, total = [], {name: getattr(first, name) for name in LINEAR_COUNTS}
        iterations, discarded, bisections, converged = 0, first.iteration, 0, None
        try:
            while stages:
                w = stages[0]
                self.set(w)
                newton.reduction = None if w == 1.0 else REDUCTION
                if newton.line_search is not None:      # (the widest stage searches; a later one as the first try)
                    newton.line_search.remedy = "search" if converged is None else None
                try:
                    result = newton.tries(step, time, timer)
                except NewtonError as err:
                    discarded += err.iteration
                    for name in LINEAR_COUNTS:
                        total[name] += getattr(err, name)
                    wider = min(w * FACTOR, self.widest)             # (before any stage converged)
                    if not err.recoverable or bisections == BISECTIONS or converged is None and wider <= w:
                        done = ", ".join(f"{v:.3g}: {n}" for v, n in path) or "none"
                        err.spent = discarded + iterations
                        err.args = (f"{err.args[0]} (following {self.names} from {path[0][0] if path else w:.3g} "
                                    f"times its width to 1, at {w:.3g} times; stages done (width: iterations): "
                                    f"{done}; the direct solve: {first.reason})",)
                        raise
                    bisections += 1
                    stages.insert(0, wider if converged is None else math.sqrt(w * converged))
                    x.data = kept
                    continue
                stages.pop(0)
                converged, kept.data = w, x
                path.append((w, result.iterations))
                iterations += result.iterations
                for name in LINEAR_COUNTS:
                    total[name] += getattr(result, name)
        finally:
            self.set(1.0)
            newton.reduction = None
            if newton.line_search is not None:
                newton.line_search.remedy = None
        result.iterations, result.discarded, result.path = iterations, discarded, path
        for name in LINEAR_COUNTS:
            setattr(result, name, total[name])
        return result


def build(newton, gamma3, state, size, globalise=True):
    """Set up ``newton`` (a ``Newton`` on the state (u, φ)) for the simulation's Γ3 (``gamma3``,
    None without contact) of a body of ``size`` m (``Body.size``): ``switches``, what it names
    in a cycle; ``continuation``, the path it follows after a failed solve (None where no law
    is regularised); without ``globalise``, full steps only (no line search, no path)."""
    from ngcontact.gamma3.switches import Switches
    newton.switches = Switches(gamma3, state) if gamma3 is not None else None
    laws = gamma3.contact.regularised() if gamma3 is not None and globalise else []
    newton.continuation = Continuation(laws, size, NormalMotion(gamma3, state)) if laws else None
    if not globalise:
        newton.line_search = None


class NormalMotion:
    """max |u_ν(x) − u_ν(y)| over the sample points of Γ3 (m), over every rank: how far a
    failed Newton try moved Γ3 (x its last iterate, y its start)."""

    def __init__(self, gamma3, state):
        self.side, self.normal = gamma3.side, gamma3.sampled_normal
        self.difference = ngs.GridFunction(state.space)

    def __call__(self, x, y):
        from ngcontact import parallel
        self.difference.vec.data = x - y
        moved = self.side.normal_displacement(self.difference.components[0], self.normal)
        return float(parallel.maximum(self.side.mesh, np.abs(moved).ravel(), initial=0.0))
