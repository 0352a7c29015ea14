"""Inexact Newton: how accurately the linear solver solves each correction.

An iterative solver is asked for the accuracy that brings the residual to Newton's target
(with the solver's margin), no more than Eisenstat and Walker's forcing term allows while Newton
contracts slowly, and, with an energy target (``adapt``), no more than a share of that target.
"""

ALGEBRAIC = 0.5
"""With an energy target, the linear solver is asked for the correction to the share
ALGEBRAIC × target / (the last correction's energy) (the algebraic error a fraction of the
linearisation error allowed)."""

def forcing_term(gamma, ratio):
    """The relative accuracy a correction needs no more than, for a linear solver with the
    forcing γ, after the correction that changed the residual by ``ratio`` = ‖r_k‖ / ‖r_{k−1}‖:

      γ ratio²   if the residual fell (Eisenstat–Walker's choice 2: S. C. Eisenstat, H. F. Walker,
                 SIAM J. Sci. Comput. 17 (1996) 16–32), the contraction the next linearisation
                 can use;
      γ / ratio  if it rose (the contact set changed): the linearised residual back to γ times
                 the level before the rise, no further. Choice 2 itself gives ≥ γ there (capped at
                 1e-3 by Newton), which on 2 ranks cut the 3D block's first step back where
                 the serial run did not; asking the step's final accuracy instead made the
                 GMRES of a rise run to its iteration limit (docs/scale.md).

    Both give γ at ratio 1."""
    return gamma * (ratio ** 2 if ratio <= 1.0 else 1.0 / ratio)



def correction_tolerance(solver, target, residuals, energy_target=None, correction=None):
    """The relative accuracy (in [1e-12, 1e-3]) to ask of ``solver`` for the correction after the
    residuals ``residuals`` (scaled norms, the last one the current): ``margin`` (the solver's
    attribute, default 0.1) × target / ‖r_k‖; with a ``forcing`` γ (its attribute), at least
    ``forcing_term`` (a tighter correction is wasted on the next linearisation while the contact
    set moves); with ``energy_target`` (J^½) and the last ``correction``'s energy, at least
    ``ALGEBRAIC`` × target / energy."""
    value = residuals[-1]
    tol = getattr(solver, "margin", 0.1) * target / value
    forcing = getattr(solver, "forcing", None)
    if forcing is not None and len(residuals) > 1:
        tol = max(tol, forcing_term(forcing, value / residuals[-2]))
    if energy_target is not None and correction:
        tol = max(tol, ALGEBRAIC * energy_target / correction)
    return min(1e-3, max(1e-12, tol))
