"""When a Newton solve may stop: a convergence test that a wrong state cannot pass at any scale.

The residual R(x) of a step sums forces (N; N/m in 2D) and charges (C); Newton measures it in
the scaled norm ‖·‖ of ``residual_norm.ResidualNorm`` (J^½). The test compares it with the step's
**force scale**

    S(x) = max(‖f_n‖, ‖K x − (1/k) K_A x_{n−1}‖),

the loads of the step and the internal forces of the bulk at x (elastic, viscous and
electric), measured over every DOF, the held ones included: there the internal forces are
the reactions of the supports and the charges of the electrodes, so that a body driven only
by prescribed displacements or potentials has its scale too (``StepSystem.force_scale``). The terms on Γ3 (Nitsche's
γ, the penalty, the glue, the compliant layer, the conduction) are *not* part of S: a state
that penetrates the foundation, or a contact term made absurdly stiff, cannot inflate the
scale it is measured against, and a rigid motion of the body adds nothing to K x. At a
solution the bulk's internal forces balance the loads and the contact forces, so S is the
size of every force that acts.

A solve has converged at x when

1. ``‖R(x)‖ <= rtol · S(x)``, or
2. the residual is down to round-off and small against S:
   ``‖R(x)‖ <= F(x)`` and ``‖R(x)‖ <= FLOOR_LIMIT · S(x)``, with
   ``F(x) = ROUNDOFF · ‖ |K||x| + |b| + |R_Γ3'||x| ‖`` the size of the terms that sum to R
   (``StepSystem.magnitude``) times 10 machine epsilons. Newton cannot reduce a residual
   below the round-off of its terms, which on fine meshes or with a stiff contact term may lie
   above rtol · S; F is an upper bound of that round-off, so it only says when to stop trying,
   and what is certified is the residual actually reached, at most ``FLOOR_LIMIT`` of S. (The
   error of x is then bounded through the bulk's smallest eigenvalue: a stiff contact term
   adds large eigenvalues only.)

A step on which nothing acts beyond round-off — no loads, and the body moved rigidly by its
prescribed displacements (K x = 0), as when an obstacle is not reached — has S at the
round-off of the bulk's own terms (|K||x| + |b|, the Γ3 terms left out: a floor raised by absurdly
stiff contact terms does not count): a residual at its floor is then certified as well (the
coarse 3D Hertz half-ball, whose
flat lowest facet the prescribed 0.01 R did not bring onto the plane, failed as
"uncertifiable" before).

A zero-iteration convergence is the same test at the start, with the step's own data (its
loads, its prescribed values, its time step). A residual above ``FLOOR_LIMIT · S`` that stalls
at its round-off floor cannot be certified: ``Verdict.uncertifiable`` is then set and the
solve fails (``newton.NewtonError``) naming the share of the Γ3 terms in that floor. The
test never uses the initial residual or the size of x: both grow with a bad start or an
exploded state.

Each field must balance on its own as well: forces and charges enter S and ‖R‖ together, so
where one field's scale dwarfs the other's (a coupling e²/(c ε) of 10²⁰) a residual of the
other could hide under rtol · S. A state counts as converged only if each field's residual is at
most max(rtol, ``FLOOR_LIMIT``) of that field's own scale S_b (``StepSystem.block_force_scales``);
a field whose S_b is below ``FLOOR_LIMIT`` of S (nothing acts on it), and a step on which
nothing acts beyond round-off, are left to the test on ‖R‖; a field that stalls out of balance
cannot be certified. Where the fields are of comparable scale (every
material of the presets) this is looser than the test on ‖R‖ and changes nothing.

A system without ``force_scale`` (a plain nonlinear ``BilinearForm``) gets the classical
relative test ``‖R(x)‖ <= rtol ‖R(x_0)‖``.
"""
from dataclasses import dataclass

import numpy as np

ROUNDOFF = 10 * np.finfo(float).eps
"""Factor of the round-off floor F on ‖ |J||x| + |b| ‖."""
FLOOR_LIMIT = 1e-6
"""The largest residual, relative to the force scale S, that is certified where round-off stops
Newton short of rtol: a state out of equilibrium by more than 1e-6 of the forces that act is
not taken for a solution."""


@dataclass
class Verdict:
    """The outcome of the test at one iterate: ``converged``; ``residual`` ‖R‖ and ``target``,
    the residual to reach (rtol S, or rtol ‖R_0‖ for the classical test), J^½; ``scale`` S
    (None for the classical test); ``floor`` F (None where it was not needed) and
    ``contact_share``, the share of the Γ3 terms in F (0 to 1, None where unknown);
    ``uncertifiable``: the residual stalls at its round-off floor above ``FLOOR_LIMIT`` S."""
    converged: bool
    residual: float
    target: float
    scale: float = None
    floor: float = None
    contact_share: float = None
    uncertifiable: bool = False
    quiet: bool = False
    """Nothing acts on the step beyond the round-off of the bulk's own terms (certified so)."""
    unbalanced: tuple = None
    """(field name, its residual, its own scale S_b, the tolerance) of a field out of balance, or None."""

    def explain(self):
        """(why the residual cannot be certified, what to try), for ``NewtonError``."""
        if self.unbalanced is not None:
            name, value, own, tolerance = self.unbalanced
            return (f"cannot be certified: the {name} stay out of balance by {value:.3e}, more than "
                    f"{tolerance:g} of their own scale {own:.3e}, while the residual of both fields together "
                    f"({self.residual:.3e}) is small against the step's force scale {self.scale:.3e}: the "
                    "other field's scale hides them, and Newton no longer reduces them",
                    "material data of sensible scales (the coupling e²/(c ε) and the permittivity, in SI "
                    "units), or loads of comparable size on both fields")
        share = self.contact_share
        where = "" if share is None else f"; the terms on Γ3 make up {100 * share:.3g} % of that floor"
        advice = ("a smaller Nitsche gamma0, penalty, adhesion or compliance (the contact terms are too "
                  "stiff for double precision)" if share is not None and share > 0.5 else
                  "supports that hold the body, or data of a sensible scale (the terms of the residual are "
                  "far larger than the forces that act)")
        ratio = f"{self.residual / self.scale:.3g} times" if self.scale > 0 else "above"
        return (f"cannot be certified: the residual {self.residual:.3e}, {ratio} the step's force scale "
                f"{self.scale:.3e} (at most {FLOOR_LIMIT:g} of it is certified), stalls at its round-off "
                f"floor {self.floor:.3e}{where}", advice)


STALL = 3
"""Iterations without halving the residual after which a solve counts as stalled."""


class ConvergenceTest:
    """The stopping test of ``newton.Newton`` (see the module).

    Parameters
    ----------
    system : the step system: ``force_scale(norm)`` (S at the last ``Apply``) and
        ``magnitude(x)`` (the size of the terms of R, numpy), with the optional
        ``contact_magnitude(x)`` (their Γ3 part); without ``force_scale`` the classical relative
        test is used.
    norm : ``residual_norm.ResidualNorm`` of the solve.
    """

    def __init__(self, system, norm):
        self.system, self.norm = system, norm
        self.certified = hasattr(system, "force_scale")

    def __call__(self, x, residuals, rtol, r=None):
        """The Verdict at the iterate x for the relative tolerance ``rtol``; ``residuals``: the
        scaled residuals of the solve so far, the last one x's (right after ``system.Apply``),
        ``r`` the residual vector R(x) (for the balance of each field; None: not checked).
        A solve stalls when its residual has not halved over the last ``STALL`` iterations."""
        value, first = residuals[-1], residuals[0]
        if not self.certified:
            return Verdict(value <= rtol * first, value, rtol * first)
        scale = self.system.force_scale(self.norm)
        verdict = Verdict(value <= rtol * scale, value, rtol * scale, scale)
        stalling = len(residuals) > STALL and value > 0.5 * residuals[-STALL - 1]
        verdict = self._overall(verdict, x, value, scale, stalling)
        if verdict.converged and r is not None and hasattr(self.system, "block_force_scales"):
            self._fields(verdict, x, r, max(rtol, FLOOR_LIMIT), stalling)
        return verdict

    FIELDS = ("forces", "charges")

    def _fields(self, verdict, x, r, tolerance, stalling):
        """Unset ``verdict.converged`` where a field's residual exceeds ``tolerance`` of its own
        scale (see the module); ``uncertifiable`` where it stalls so. A field whose scale is
        below ``FLOOR_LIMIT`` of the step's is left to the test on ‖R‖, and so is a step on which
        nothing acts beyond round-off (``Verdict.quiet``)."""
        if verdict.quiet:
            return
        own = self.system.block_force_scales(self.norm)
        values = self.norm.block_duals(r)
        for name, value, scale in zip(self.FIELDS, values, own):
            if value <= tolerance * scale or scale <= FLOOR_LIMIT * verdict.scale:
                continue
            verdict.converged, verdict.uncertifiable = False, stalling
            verdict.unbalanced = (name, value, scale, tolerance)
            return

    def _overall(self, verdict, x, value, scale, stalling):
        """The test on ‖R‖ against S, with the round-off floor (see the module)."""
        small = value <= FLOOR_LIMIT * scale
        if verdict.converged or not (small or stalling):
            return verdict                                   # the floor cannot decide
        contact = self.system.contact_magnitude(x) if hasattr(self.system, "contact_magnitude") else None
        magnitude = self.system.magnitude(x) if contact is None else self.system.magnitude(x, contact)
        verdict.floor = ROUNDOFF * self.norm.dual(magnitude)
        if contact is not None and verdict.floor > 0:
            verdict.contact_share = min(1.0, ROUNDOFF * self.norm.dual(contact) / verdict.floor)
        if value <= verdict.floor:                           # round-off: no iteration can do better
            # nothing acts beyond the round-off of the bulk's own terms (no loads, a prescribed rigid
            # motion: K x = 0): certified too; a floor raised by stiff Γ3 terms does not count here
            bulk = magnitude if contact is None else magnitude - contact
            quiet = scale <= ROUNDOFF * self.norm.dual(bulk)
            verdict.converged, verdict.uncertifiable, verdict.quiet = small or quiet, not (small or quiet), quiet
        return verdict
