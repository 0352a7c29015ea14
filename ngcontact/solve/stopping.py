"""When a Newton solve may stop: a convergence test that a wrong state cannot pass at any scale.

The residual R(x) of a step sums forces (N; N/m in 2D) and charges (C); Newton measures it in
the scaled norm ‖·‖ of ``residual_norm.ResidualNorm`` (J^½). The test compares it with the step's
**force scale**

    S(x) = max(‖f_n‖, ‖K x − (1/k) K_A x_{n−1}‖),

the loads of the step and the internal forces of the bulk at x (elastic, viscous and
electric), taken over every DOF, the held ones included: there the internal forces are
the reactions of the supports and the charges of the electrodes, so that a body driven only
by prescribed displacements or potentials has its scale too (``StepSystem.force_scale``). The terms on Γ3 (Nitsche's
γ, the penalty, the glue, the compliant layer, the conduction) are *not* part of S: a state
that penetrates the foundation, or a contact term made absurdly stiff, cannot inflate the
scale it is compared with, and a rigid motion of the body adds nothing to K x. At a
solution the bulk's internal forces balance the loads and the contact forces, so S is the
size of every force that acts.

A solve has converged at x when

1. ``‖R(x)‖ <= rtol · S(x)``, or
2. **the residual is at the round-off of the state it holds**, whatever the size of S: in each
   field (forces, charges) on its own ``‖R(x)‖ <= ‖F(x)‖``, with the floor
   ``F(x) = ROUNDOFF · (B + min(C, B))``, ``B = |K||x| + |b|`` the size of the bulk's terms that
   sum to R (``StepSystem.magnitude``), ``C = |R_Γ3'||x|`` that of the Γ3 terms (entrywise; the
   Γ3 terms count up to the size of the bulk's) and ``ROUNDOFF`` 10 machine epsilons. No
   iteration reduces a residual below the round-off of its terms, and a residual there makes x
   the solution to the precision of its own arithmetic: its error is at most ‖K⁻¹‖ ‖F‖ (the Γ3
   terms add large eigenvalues only). The floor belongs to the state, not to the load: a body
   moved rigidly by its prescribed displacements has K x = 0 while |K||x| is of the size of the
   stresses that displacement would cause in a held body; once its glue has let go (β small but
   not 0) S is the glue's last force (tiny on the pulled plate), and a fraction of S lies under
   that round-off, out of reach. A wrong state has a residual of the size of K
   times its error, above F unless that error is at the round-off of x itself. A contact term
   made absurdly stiff cannot raise F beyond twice the bulk's floor (the min): the residual of
   a wrong state that it hides (γ0 = 1e30: a contact force far too small) stalls at that
   term's round-off, far above F; or
3. the residual is down to the round-off of all its terms and small against S:
   ``‖R(x)‖ <= F_Γ(x)`` and ``‖R(x)‖ <= FLOOR_LIMIT · S(x)``, with
   ``F_Γ(x) = ROUNDOFF · ‖ B + C ‖`` (``Verdict.floor``). Stiff contact terms (γ0 or the penalty
   at 1e4) hold the residual above F and above rtol · S; what is certified is the residual
   reached, at most ``FLOOR_LIMIT`` of S.

The floors cost a product with |K| (and |R_Γ3'|): they are evaluated where they can decide,
not at every iteration of a converging solve: where the residual fell by less than ``SLOW``
over the last iteration, stalls, or is small against S.

A zero-iteration convergence is the same test at the start, with the step's own data (its
loads, its prescribed values, its time step; the floors there only where the residual is small
against S). A residual above F and above ``FLOOR_LIMIT · S``
that stalls at F_Γ cannot be certified: the Γ3 terms hold it there (``Verdict.uncertifiable``);
the solve fails (``newton.NewtonError``) naming their share in F_Γ. The test never uses the
initial residual or the size of x: both grow with a bad start or an exploded state.

Each field must balance on its own as well: forces and charges enter S and ‖R‖ together, so
where one field's scale dwarfs the other's (a coupling e²/(c ε) of 10²⁰) a residual of the
other could hide under rtol · S. A state counts as converged only if each field's residual is at
most max(rtol, ``FLOOR_LIMIT``) of that field's own scale S_b (``StepSystem.block_force_scales``);
a field whose S_b is below ``FLOOR_LIMIT`` of S (nothing acts on it) is left to the test on
‖R‖, and the round-off test (2) is made per field already; a field that stalls out of balance
cannot be certified. Where the fields are of comparable scale (every
material of the presets) this is looser than the test on ‖R‖ and changes nothing.

A system without ``force_scale`` (a plain nonlinear ``BilinearForm``) gets the classical
relative test ``‖R(x)‖ <= rtol ‖R(x_0)‖``.
"""
from dataclasses import dataclass

import numpy as np

ROUNDOFF = 10 * np.finfo(float).eps
"""Factor of the round-off floors F and F_Γ on the size of the terms of R."""
FLOOR_LIMIT = 1e-6
"""The largest residual, relative to the force scale S, that is certified where the round-off of
stiff Γ3 terms stops Newton short of rtol: a state out of equilibrium by more than 1e-6 of the
forces that act is not taken for a solution unless its residual is at the round-off of its state."""
SLOW = 0.1
"""The floors are evaluated at an iterate whose residual fell by less than this factor over the
last iteration (a converging Newton solve keeps falling until round-off stops it)."""


@dataclass
class Verdict:
    """The outcome of the test at one iterate: ``converged``; ``residual`` ‖R‖ and ``target``,
    the residual to reach (rtol S, or rtol ‖R_0‖ for the classical test), J^½; ``scale`` S
    (None for the classical test); ``floor`` F_Γ (None where it was not needed) and
    ``contact_share``, the share of the Γ3 terms in F_Γ (0 to 1, None where unknown);
    ``uncertifiable``: the residual stalls at F_Γ above the state's floor F and ``FLOOR_LIMIT`` S."""
    converged: bool
    residual: float
    target: float
    scale: float = None
    floor: float = None
    contact_share: float = None
    uncertifiable: bool = False
    roundoff: bool = False
    """Certified as at the round-off of the state (test 2 of the module), whatever S."""
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
        ratio = f"{self.residual / self.scale:.3g} times" if self.scale > 0 else "above"
        return (f"cannot be certified: the residual {self.residual:.3e}, {ratio} the step's force scale "
                f"{self.scale:.3e} (at most {FLOOR_LIMIT:g} of it is certified), stalls at the round-off "
                f"floor {self.floor:.3e} of its terms{where}, above the round-off of the bulk's own terms",
                "a smaller Nitsche gamma0, penalty, adhesion, compliance or conductance (the contact terms "
                "are too stiff for double precision)")


STALL = 3
"""Iterations without halving the residual after which a solve counts as stalled."""


class ConvergenceTest:
    """The stopping test of ``newton.Newton`` (see the module).

    Parameters
    ----------
    system : the step system: ``force_scale(norm)`` (S at the last ``Apply``) and
        ``magnitude(x, contact=None)`` (the size of the terms of R, numpy; with ``contact`` 0 the
        bulk's only), with the optional ``contact_magnitude(x)`` (their Γ3 part); without
        ``force_scale`` the classical relative test is used.
    norm : ``residual_norm.ResidualNorm`` of the solve.
    """

    def __init__(self, system, norm):
        self.system, self.norm = system, norm
        self.certified = hasattr(system, "force_scale")

    def __call__(self, x, residuals, rtol, r=None):
        """The Verdict at the iterate x for the relative tolerance ``rtol``; ``residuals``: the
        scaled residuals of the solve so far, the last one x's (right after ``system.Apply``),
        ``r`` the residual vector R(x) (for the balance of each field; None: the round-off test
        on ‖R‖ only and no field checked). A solve stalls when its residual has not halved over
        the last ``STALL`` iterations."""
        value, first = residuals[-1], residuals[0]
        if not self.certified:
            return Verdict(value <= rtol * first, value, rtol * first)
        scale = self.system.force_scale(self.norm)
        verdict = Verdict(value <= rtol * scale, value, rtol * scale, scale)
        stalling = len(residuals) > STALL and value > 0.5 * residuals[-STALL - 1]
        slow = len(residuals) > 1 and value > SLOW * residuals[-2]
        verdict = self._overall(verdict, x, r, stalling, slow)
        if verdict.converged and r is not None and hasattr(self.system, "block_force_scales"):
            self._fields(verdict, x, r, max(rtol, FLOOR_LIMIT), stalling)
        return verdict

    FIELDS = ("forces", "charges")

    def _fields(self, verdict, x, r, tolerance, stalling):
        """Unset ``verdict.converged`` where a field's residual exceeds ``tolerance`` of its own
        scale (see the module); ``uncertifiable`` where it stalls so. A field whose scale is
        below ``FLOOR_LIMIT`` of the step's is left to the test on ‖R‖, and so is a state at
        the round-off of its terms (``Verdict.roundoff``: tested per field)."""
        if verdict.roundoff:
            return
        own = self.system.block_force_scales(self.norm)
        values = self.norm.block_duals(r)
        for name, value, scale in zip(self.FIELDS, values, own):
            if value <= tolerance * scale or scale <= FLOOR_LIMIT * verdict.scale:
                continue
            verdict.converged, verdict.uncertifiable = False, stalling
            verdict.unbalanced = (name, value, scale, tolerance)
            return

    def _overall(self, verdict, x, r, stalling, slow):
        """The round-off tests 2 and 3 of the module where the test on S did not pass."""
        value, scale = verdict.residual, verdict.scale
        small = value <= FLOOR_LIMIT * scale
        if verdict.converged or not (small or stalling or slow):
            return verdict                                   # the floors cannot decide
        split = hasattr(self.system, "contact_magnitude")
        bulk = self.system.magnitude(x, 0.0) if split else self.system.magnitude(x)
        if not (small or stalling) and value > 2 * ROUNDOFF * self.norm.dual(bulk):
            return verdict                                   # above F (at most twice the bulk's floor)
        contact = self.system.contact_magnitude(x) if split else None
        total = bulk if contact is None else bulk + contact
        verdict.floor = ROUNDOFF * self.norm.dual(total)
        if contact is not None and verdict.floor > 0:
            verdict.contact_share = min(1.0, ROUNDOFF * self.norm.dual(contact) / verdict.floor)
        own = bulk if contact is None else bulk + np.minimum(contact, bulk)
        if self._at_roundoff(value, r, own):                 # test 2: at the round-off of the state
            verdict.converged = verdict.roundoff = True
        elif value <= verdict.floor and (small or stalling):  # test 3, or stuck at the Γ3 terms' round-off
            verdict.converged, verdict.uncertifiable = small, not small
        return verdict

    def _at_roundoff(self, value, r, own):
        """Whether the residual (``value``, and each field of the vector ``r`` if given) is at most
        ``ROUNDOFF`` times the size ``own`` of the state's terms (test 2 of the module)."""
        if value > ROUNDOFF * self.norm.dual(own):
            return False
        if r is None:
            return True
        return all(v <= ROUNDOFF * f for v, f in zip(self.norm.block_duals(r), self.norm.block_duals(own)))
