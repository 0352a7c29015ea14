"""Nonlinear laws (``laws``, the paper's (2.16)-(2.17)) held to their hypotheses at the run's strains.

A law is checked at sampled strains before the run (``laws.BoundLaw``), and the run's strains
may lie beyond them. After each step Newton solved (``law_terms.LawTerms.check_step``, called
by ``Simulation.step`` before the step is kept), each law is evaluated at the step's own
strains, at the quadrature points of N (``LawWatch``): its tangent there (forward differences:
dim(dim+1)/2 + 1 evaluations of the law at every point), the chord from the point's strain at
the step before (at the first step, from 0), and, when the strains grow beyond the sampled
ones, samples up to twice the largest. A tangent that is not positive in some direction, or
steeper than the law's bound, is confirmed by an exact chord of the checked law (a point
within the difference step of a kink mixes the sides' columns).

(2.16)-(2.17) allow any constants m > 0 and L, so a law steeper at the run's strains than at
its samples is not wrong: where its L was estimated and a confirmed slope exceeds
``LIPSCHITZ_MARGIN`` times its stiffness ``scale`` (``laws.BoundLaw``), the scale is raised to
that slope and the step is redone with the Nitsche γ and penalty that follow it
(``MaterialTensors.contact_stiffness``; ``LawTerms.check_step`` returns True, ``Step.take``
solves the step again, at most ``REDOS`` times; the γ of weak normal supports keeps the scale
of the Simulation's build, their matrix being assembled once). Deterministic: the decision reads the law and
the state only. Refused, by ``LawViolation`` (a ``NewtonError``, not recoverable: the cut-back
policy does not retry it), naming the law, what was found, the strain, the point and the
step, is evidence against the hypotheses only: a slope ≤ 0 (or below a given monotonicity), a
slope above a given ``lipschitz``, a non-finite stress or tangent, a slope that grows without
bound (``unbounded``: along the ray of strains through the steep point, from 1e-``DECADES`` to
1e``DECADES`` times it, by ``GROWTH`` or more per decade over the last two decades at either
end), and a law changed since its check (a Parameter it reads). The step is not kept, the steps
before are (``NewtonError.history``). Before each step's first residual, each law is verified
to be the one checked (``LawTerms.apply``).

Cost: runs without laws pay nothing. With a projection law on the reference plate the check
takes a small share of the run's CPU time (docs/measurements.md, section ngcontact/solve/law_watch.py).

When Newton fails in a run with laws, ``LawTerms.explain`` (``LawWatch.diagnose``) names a law
that is the likely cause in the error's reason and hint: a non-finite stress or tangent at the
last iterate, a violation of (2.16)-(2.17) there, a tangent ``FAR_BEYOND`` its Lipschitz bound,
or a stiffness ratio L/m above ``STIFFNESS_RATIO``.
"""
import math

import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.model.laws import coordinates
from ngcontact.solve.newton import NewtonError
from ngcontact.model.voigt import matrix_cf

LIPSCHITZ_MARGIN = 2.0
"""A law whose Lipschitz constant was estimated from samples may be steeper at the run's strains
than its stiffness ``scale`` (or ``BoundLaw.tangent_bound``, the steepest tangent at the
samples) by up to this factor, which the margins of γ0 and the penalty absorb; beyond it the
scale is raised to the sampled slope and the step redone. A given ``lipschitz`` is held to
exactly."""
REDOS = 6
"""Times a step is solved again because a law's stiffness scale grew (each time by more than
``LIPSCHITZ_MARGIN``); a scale still growing after them is refused as not Lipschitz."""
DECADES = 6
"""The ray of strains probed for an unbounded slope: 1e-DECADES to 1e+DECADES times the strain."""
GROWTH = 2.0
"""A slope growing by this factor or more per decade over the last two decades at an end of the
probed ray (a power |ε|^q of the strain, q ≥ 0.3) is evidence that it has no bound."""
FAR_BEYOND = 10.0
"""A tangent this many times the Lipschitz bound at Newton's last iterate names the law as the
cause of a failure (``LawTerms.explain``)."""
CHANGED_HINT = "the law as a fixed function of the strain; build the Body again with the law as it is to be run"
"""What to do about a law changed since its check."""
STIFFNESS_RATIO = 1e8
"""A law whose Lipschitz constant exceeds its monotonicity by this factor (PZT-5A's tensor: 4.6;
the laws of the tests: up to 60) is named as the likely cause of a failure: Newton's linear
systems lose as many digits."""


class LawViolation(NewtonError):
    """A nonlinear law (``laws``) broke the hypotheses (2.16)-(2.17) at the strains of a step
    (or changed since it was checked): the step is not kept (``history``: the steps before, set
    by ``Simulation.run``); ``law`` names it, ``strain`` is the strain (numpy) where it broke,
    or None. Not ``recoverable``: smaller time steps reach the same strains."""

    def __init__(self, law, reason, *, step, time, hint, strain=None):
        super().__init__(reason, iteration=0, residuals=[], step=step, time=time, hint=hint, recoverable=False)
        self.law, self.strain = law, strain
        where = f"step {step} (t = {time:.6g} s)" if step is not None else f"the step to t = {time:.6g} s"
        self.args = (f"{reason}; at {where}, which is not kept. Try: {hint}",)


class LawWatch:
    """One law (``laws.BoundLaw``) at the strains of the run: its ``argument`` (the strain, or
    strain rate, matrix CF of the GridFunction ``state``) at the points of the quadrature rule of
    ``order`` on every element (module docstring)."""

    def __init__(self, bound, state, argument, order):
        self.bound, self.state, self.dim = bound, state, bound.dim
        mesh = state.space.mesh
        types = {el.type for el in mesh.Elements(ngs.VOL)}
        self.points = mesh.MapToAllElements({t: ngs.IntegrationRule(t, order) for t in types}, ngs.VOL) \
            if types else None
        self.mesh, self.coordinates = mesh, ngs.CF((ngs.x, ngs.y, ngs.z)[:mesh.dim])
        self.shifts = [ngs.Parameter(0.0) for _ in bound.basis]         # ε + h t_b B_b: the differences
        shifted = argument
        for t, B in zip(self.shifts, bound.basis):
            shifted = shifted + t * matrix_cf(B)
        stress = bound.matrix_stress(shifted)
        self.values, self.stress = ngs.CF((shifted, stress)).Compile(), stress.Compile()
        zero = bound.evaluate(np.zeros((self.dim, self.dim)))
        count = 0 if self.points is None else len(self.points)
        self.previous = (np.zeros((count, self.dim, self.dim)), np.broadcast_to(zero, (count, self.dim, self.dim)))
        self.rng_seed = 20261126

    def name(self):
        return self.bound.describe()

    def evaluate(self):
        """(ε, σ, J) at the points (numpy: N × dim × dim twice, N × n × n: the tangent in the
        law's orthonormal strain basis, forward differences)."""
        d2 = self.dim ** 2
        if self.points is None:
            n = len(self.shifts)
            return np.zeros((0, self.dim, self.dim)), np.zeros((0, self.dim, self.dim)), np.zeros((0, n, n))
        for t in self.shifts:
            t.Set(0.0)
        base = np.asarray(self.values(self.points))
        eps, sigma = (base[:, :d2].reshape(-1, self.dim, self.dim), base[:, d2:].reshape(-1, self.dim, self.dim))
        largest = float(np.max(np.linalg.norm(eps, axis=(1, 2)), initial=0.0)) if np.all(np.isfinite(eps)) else 0.0
        h = 1e-6 * max(largest, self.bound.law.strain_scale)
        columns = []
        for t in self.shifts:
            t.Set(h)
            shifted = np.asarray(self.stress(self.points)).reshape(-1, self.dim, self.dim)
            t.Set(0.0)
            columns.append(coordinates(shifted - sigma, self.bound.basis) / h)
        return eps, sigma, np.stack(columns, axis=-1)

    def _where(self, p):
        """The coordinates of point p (m), for messages."""
        at = np.ravel(self.coordinates(self.points[p:p + 1]))
        return "(" + ", ".join(f"{c:.4g}" for c in at) + ") m"

    def bounds(self):
        """(the smallest slope, the largest) the law must keep, or beyond which its stiffness
        scale is raised: its given monotonicity (0 for an estimated one: strong monotonicity,
        m > 0) and its given Lipschitz constant (or ``LIPSCHITZ_MARGIN`` times its stiffness
        ``scale``, or the steepest tangent at the samples)."""
        law, bound = self.bound.law, self.bound
        low = 0.0 if law.monotonicity is None else law.monotonicity * (1 - 1e-6)
        high = law.lipschitz * (1 + 1e-6) if law.lipschitz is not None else \
            LIPSCHITZ_MARGIN * max(bound.scale.Get(), bound.tangent_bound)
        return low, high

    def check(self, step, time, attempt=0):
        """Raise ``LawViolation`` where the law breaks (2.16)-(2.17) at the state's strains;
        True if its stiffness scale grew (the step is to be solved again: ``attempt`` times
        already), else False: ``keep`` then remembers the strains if the state is kept
        (module docstring)."""
        bound, name = self.bound, self.name()
        where = f" (the run's strain at step {step})"
        hint = (f"a law that is strongly monotone and Lipschitz at every strain ((2.16)-(2.17)); the check "
                f"before the run samples strains up to 10 × strain_scale ({10 * bound.law.strain_scale:.3g} here): "
                "a strain_scale near the run's strains samples them before the run")
        try:
            bound.verify(fresh=False)
        except ValueError as error:
            raise LawViolation(name, str(error), step=step, time=time, hint=CHANGED_HINT) from None
        eps, sigma, J = self.evaluate()
        steeper = []
        found = _first(self.mesh, self._violation(eps, sigma, J, steeper))
        if found is None and parallel.maximum(self.mesh, np.linalg.norm(eps, axis=(1, 2)), 0.0) > bound.checked_range:
            found = _first(self.mesh, self._resample(eps, where, steeper))
        grown = parallel.any_rank(self.mesh, bool(steeper))
        if found is None and grown:
            found = _first(self.mesh, self._unbounded(eps, steeper))
        slope = parallel.maximum(self.mesh, [entry[0] for entry in steeper], 0.0) if grown else 0.0
        if found is None and grown and attempt >= REDOS:
            found = (f"not Lipschitz: its slope at the run's strains grew past {LIPSCHITZ_MARGIN:g} × its stiffness "
                     f"scale {bound.scale.Get():.4g} Pa again (to {slope:.4g} Pa) after the step was solved "
                     f"{attempt + 1} times, each with the scale raised to the slope measured", None)
        if found is not None:
            message, strain = found
            if message.startswith("not Lipschitz"):
                hint = ("a law whose slope has one bound L at every strain ((2.16)-(2.17): |F(a) − F(b)| ≤ "
                        "L |a − b|), a stiffening that levels off (the slope may be any constant, it is followed)")
            raise LawViolation(name, f"{name} breaks (2.16)-(2.17) at the run's strains: {message}", step=step,
                               time=time, hint=hint, strain=strain)
        self._pending = (eps, sigma)
        if grown:
            self.rescaled = (bound.scale.Get(), slope)
            bound.scale.Set(slope)
            return True
        return False

    def keep(self):
        """The strains of the step just checked become the step before (once every law passed)."""
        self.previous = self._pending

    def _violation(self, eps, sigma, J, steeper=None):
        """(message, strain) of the first violation at the points, or None. With ``steeper`` (a
        list) and an estimated Lipschitz constant, a confirmed slope above the bound is no
        violation: (slope, strain, unit direction, where) of the steepest chord and tangent are
        appended to it."""
        name = self.name()
        estimated = steeper is not None and self.bound.law.lipschitz is None
        finite = np.all(np.isfinite(sigma), axis=(1, 2)) & np.all(np.isfinite(J), axis=(1, 2))
        if not finite.all():
            p = int(np.argmin(finite))
            return (f"a non-finite stress {_fmt(sigma[p])} Pa (or tangent) at the strain {_fmt(eps[p])} at "
                    f"{self._where(p)}", eps[p])
        low, high = self.bounds()
        # the chords from the strains of the step before, exact
        d_eps = coordinates(eps - self.previous[0], self.bound.basis)
        d_sigma = coordinates(sigma - self.previous[1], self.bound.basis)
        size = np.linalg.norm(d_eps, axis=1)
        scale = np.linalg.norm(eps, axis=(1, 2)) + np.linalg.norm(self.previous[0], axis=(1, 2))
        moved = size > 1e-6 * scale
        if moved.any():
            slack = 1e-9 * (np.linalg.norm(sigma, axis=(1, 2)) + np.linalg.norm(self.previous[1], axis=(1, 2)))
            slope = np.where(moved, np.sum(d_sigma * d_eps, axis=1) / np.where(moved, size, 1) ** 2, np.inf)
            steep = np.where(moved, np.linalg.norm(d_sigma, axis=1) / np.where(moved, size, 1), 0.0)
            below = moved & (slope < low - slack / np.where(moved, size, 1))
            above = moved & (steep > high + slack / np.where(moved, size, 1))
            if below.any():
                p = int(np.argmax(below))
                return (f"not strongly monotone between the strain {_fmt(self.previous[0][p])} of the step before and "
                        f"{_fmt(eps[p])} at {self._where(p)}: (σ(a) − σ(b)):(a − b)/|a − b|² = {slope[p]:.4g} Pa"
                        + (f" < the given monotonicity {self.bound.law.monotonicity:.4g}" if low > 0 else " ≤ 0"),
                        eps[p])
            if above.any() and estimated:
                p = int(np.argmax(np.where(above, steep, -np.inf)))
                unit = np.einsum("b,bij->ij", d_eps[p] / size[p], np.array(self.bound.basis))
                steeper.append((float(steep[p]), eps[p], unit, f" at {self._where(p)}"))
            elif above.any():
                p = int(np.argmax(above))
                return (f"not Lipschitz with its bound between the strain {_fmt(self.previous[0][p])} of the step "
                        f"before and {_fmt(eps[p])} at {self._where(p)}: |σ(a) − σ(b)|/|a − b| = {steep[p]:.4g} Pa "
                        f"> {high:.4g} Pa ({self._bound_words()})", eps[p])
        # the tangents: candidates, confirmed by exact chords of the checked law
        S = 0.5 * (J + np.swapaxes(J, 1, 2))
        diagonal = np.diagonal(S, axis1=1, axis2=2)
        gershgorin = np.min(2 * diagonal - np.sum(np.abs(S), axis=2), axis=1)       # <= λ_min(S)
        doubtful = np.flatnonzero(gershgorin <= low)
        if doubtful.size:
            values, vectors = np.linalg.eigh(S[doubtful])
            order = np.argsort(values[:, 0])
            for k in order[:4]:
                if values[k, 0] > low:
                    break
                p = doubtful[k]
                direction = np.einsum("b,bij->ij", vectors[k][:, 0], np.array(self.bound.basis))
                found = self._confirm(eps[p], direction, lambda s, g: s <= low)
                if found is not None:
                    slope, _ = found
                    return (f"not strongly monotone at the strain {_fmt(eps[p])} at {self._where(p)}: along the "
                            f"direction {_fmt(direction)}, the slope (σ(ε + h d) − σ(ε)):d/h = {slope:.4g} Pa"
                            + (f" < the given monotonicity {self.bound.law.monotonicity:.4g}" if low > 0 else " ≤ 0"),
                            eps[p])
        frobenius = np.linalg.norm(J, axis=(1, 2))                                # >= |J|_2
        steep = np.flatnonzero(frobenius > high)
        if steep.size:
            _, singular, right = np.linalg.svd(J[steep])
            order = np.argsort(-singular[:, 0])
            for k in order[:4]:
                if singular[k, 0] <= high:
                    break
                p = steep[k]
                direction = np.einsum("b,bij->ij", right[k][0], np.array(self.bound.basis))
                found = self._confirm(eps[p], direction, lambda s, g: g > high)
                if found is not None and estimated:
                    steeper.append((found[1], eps[p], direction, f" at {self._where(p)}"))
                    break
                if found is not None:
                    _, slope = found
                    return (f"steeper than its Lipschitz bound at the strain {_fmt(eps[p])} at {self._where(p)}: "
                            f"along the direction {_fmt(direction)}, |σ(ε + h d) − σ(ε)|/h = {slope:.4g} Pa > "
                            f"{high:.4g} Pa ({self._bound_words()})", eps[p])
        return None

    def _bound_words(self):
        law = self.bound.law
        if law.lipschitz is not None:
            return "the given Lipschitz constant"
        return (f"{LIPSCHITZ_MARGIN:g} × the stiffness scale {self.bound.scale.Get():.4g} Pa (the Lipschitz constant "
                f"{self.bound.lipschitz:.4g} Pa estimated from the samples, or the slope measured since), which "
                "sets the run's Nitsche γ and penalty")

    def _confirm(self, strain, direction, broken):
        """(slope, steepness) of an exact chord of the checked law at ``strain`` along the unit
        ``direction`` (steps ±h, h = 1e-6 of the strain's size) where ``broken(slope,
        steepness)``, or None."""
        h = 1e-6 * max(float(np.linalg.norm(strain)), self.bound.law.strain_scale)
        for start in (strain, strain - h * direction):
            slope, steepness = self.bound.chord(start, direction, h)
            if broken(slope, steepness) or not math.isfinite(slope):
                return slope, steepness
        return None

    def _resample(self, eps, where, steeper=None):
        """Samples of the hypotheses up to twice the run's largest strain (``BoundLaw.hypotheses``):
        (message, strain) of a violation, or None; the sampled range grows. Slopes above the
        bound of an estimated L go to ``steeper`` as in ``_violation``, at the largest strain."""
        bound = self.bound
        largest = 2 * parallel.maximum(self.mesh, np.linalg.norm(eps, axis=(1, 2)), 0.0)
        rng = np.random.default_rng([self.rng_seed, int(largest / bound.law.strain_scale * 1e6) % (2 ** 32)])
        try:
            m, L, _ = bound.hypotheses(rng, bound.law.strain_scale, largest, where=" (sampled up to twice the "
                                       f"run's largest strain, {largest / 2:.4g})")
        except ValueError as error:
            return str(error).replace(f"{self.name()} ", "", 1), None
        low, high = self.bounds()
        if m < low:
            return (f"its monotonicity at samples up to twice the run's largest strain ({largest / 2:.4g}) is {m:.4g} "
                    f"Pa, below the given {bound.law.monotonicity:.4g}", None)
        if L > high and steeper is not None and bound.law.lipschitz is None:
            norms = np.linalg.norm(eps, axis=(1, 2))
            if norms.size:
                p = int(np.argmax(norms))
                steeper.append((L, eps[p], eps[p] / norms[p], f" (the run's largest, at {self._where(p)})"))
        elif L > high:
            return (f"its slopes at samples up to twice the run's largest strain ({largest / 2:.4g}) reach {L:.4g} Pa "
                    f"> {high:.4g} Pa ({self._bound_words()})", None)
        bound.checked_range = largest
        return None

    def _unbounded(self, eps, steeper):
        """(message, strain) if the slope of the law grows without bound along the ray of
        strains s ε through the steepest point of ``steeper`` (s = 10^k, |k| ≤ ``DECADES``;
        slopes |σ(s ε + h d) − σ(s ε)|/h along its direction d, h = s |ε| · 1e-6): by ``GROWTH``
        or more per decade over the last two decades at either end, or non-finite; else None."""
        if not steeper:
            return None
        slope, strain, direction, where = max(steeper, key=lambda entry: entry[0])
        size = float(np.linalg.norm(strain))
        if not size > 0:                                   # at ε = 0: the ray of the direction
            strain, size = direction * self.bound.law.strain_scale, self.bound.law.strain_scale
        factors = 10.0 ** np.arange(-DECADES, DECADES + 1)
        slopes = []
        for s in factors:
            try:
                _, steepness = self.bound.chord(s * strain, direction, 1e-6 * s * size)
            except (ValueError, FloatingPointError, OverflowError):
                steepness = math.nan
            slopes.append(steepness)
        slopes = np.array(slopes)
        estimated = f"{slope:.4g} Pa at the run's strain, {slope / self.bound.lipschitz:.3g} × the Lipschitz " \
                    f"constant {self.bound.lipschitz:.4g} Pa estimated from the samples"
        if not np.all(np.isfinite(slopes)):
            k = int(np.argmin(np.isfinite(slopes)))
            return (f"not Lipschitz: its slope along the direction {_fmt(direction)} is {slopes[k]} at "
                    f"{factors[k]:g} × the strain {_fmt(strain)}{where} (the tangent was {estimated})", strain)
        for end, (a, b, c), (sa, sb, sc) in (("large", slopes[-3:], factors[-3:]),
                                             ("small", slopes[2::-1], factors[2::-1])):
            if b >= GROWTH * a and c >= GROWTH * b:
                return (f"not Lipschitz: its slope grows without bound towards {end} strains along the direction "
                        f"{_fmt(direction)} through the strain {_fmt(strain)}{where}: |σ(sε + h d) − σ(sε)|/h = "
                        f"{a:.4g}, {b:.4g}, {c:.4g} Pa at s = {sa:g}, {sb:g}, {sc:g} ({(c / a) ** 0.5:.3g} × per decade, "
                        f"≥ {GROWTH:g} is taken as unbounded; the tangent was {estimated})", strain)
        return None

    def diagnose(self, matrix):
        """(reason, hint) if this law is the likely cause of a Newton failure at the state (the
        last iterate; ``matrix``: the laws' last Jacobian, or None), else None."""
        bound, name = self.bound, self.name()
        try:
            bound.verify(fresh=False)
        except ValueError as error:
            return str(error), CHANGED_HINT
        eps, sigma, J = self.evaluate()
        reach = f"(the check before the run sampled strains up to {bound.checked_range:.3g})"
        bad = ~(np.all(np.isfinite(sigma), axis=(1, 2)) & np.all(np.isfinite(J), axis=(1, 2)))
        if parallel.any_rank(self.mesh, bad.any()):
            detail = ""
            if bad.any():
                p = int(np.argmax(bad))
                detail = f" {_fmt(sigma[p])} Pa at the strain {_fmt(eps[p])} at {self._where(p)}"
            return (f"the {name} gives a non-finite stress or tangent{detail} at the last iterate {reach}",
                    f"the {name}: a law that is finite at every strain, or a strain_scale that covers the run's "
                    "strains so that the check sees them")
        if matrix is not None and parallel.any_rank(
                self.mesh, not np.all(np.isfinite(matrix.AsVector().FV().NumPy()))):
            return (f"the {name} gives a non-finite Jacobian at the last iterate {reach}",
                    f"the {name}: a law differentiable to finite values at every strain")
        hint = (f"the {name}: a law strongly monotone and Lipschitz at every strain ((2.16)-(2.17)), or a "
                "strain_scale near the run's strains so that the check sees them")
        found = _first(self.mesh, self._violation(eps, sigma, J))
        if found is None and parallel.maximum(self.mesh, np.linalg.norm(eps, axis=(1, 2)), 0.0) > bound.checked_range:
            found = _first(self.mesh, self._resample(eps, " (at the last iterate)"))
        if found is not None:
            return f"the {name} breaks (2.16)-(2.17) at the last iterate's strains {reach}: {found[0]}", hint
        _, high = self.bounds()
        steepest = np.linalg.norm(J, axis=(1, 2)) / math.sqrt(len(bound.basis))     # <= |J|_2
        if parallel.maximum(self.mesh, steepest, 0.0) > FAR_BEYOND * high:
            p = int(np.argmax(steepest)) if steepest.size else None
            at = f" at the strain {_fmt(eps[p])} at {self._where(p)}" if p is not None else ""
            return (f"the {name}'s tangent{at} is {np.max(steepest, initial=0.0) / high:.3g} times its Lipschitz "
                    f"bound {high:.4g} Pa at the last iterate {reach}",
                    f"the {name}: a law Lipschitz at every strain with the constant it was checked with (give "
                    "lipschitz=, or a strain_scale near the run's strains)")
        ratio = bound.lipschitz / bound.monotonicity
        if ratio > STIFFNESS_RATIO:
            return (f"the {name} has a stiffness ratio L/m = {ratio:.3g} (Lipschitz constant {bound.lipschitz:.4g}, "
                    f"monotonicity {bound.monotonicity:.4g}): Newton's linear systems lose as many digits",
                    f"the {name} with a ratio L/m below {STIFFNESS_RATIO:g} (a smaller stiffening ζ)")
        return None


def _first(mesh, found):
    """``found`` of this rank, or, if another rank found a violation, a message saying so."""
    if parallel.any_rank(mesh, found is not None):
        return found if found is not None else ("a violation found on another rank", None)
    return None


def _fmt(a):
    return np.array2string(np.asarray(a), precision=4, separator=", ").replace("\n", "")
