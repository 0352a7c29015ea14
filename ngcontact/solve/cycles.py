"""Newton iterates that cycle: the period in the residual history, and the account of a cycle.

A semismooth Newton whose Jacobian switches between pieces of the laws of Γ3 can cycle: the
iterates repeat, and so do their residuals, to round-off. ``CycleWatch`` reads the residual
history (the same on every rank), records the laws' pieces (``switches.Switches``) over one
more period once the residuals repeat, and then says which laws flip, where, and what to try;
a cycling solve stops after a few periods instead of at maxit.
"""
import numpy as np

from ngcontact.gamma3.switches import describe

CYCLE_PERIODS = 6
"""The longest cycle of iterates recognised (``repeating``)."""
CYCLE_RTOL = 1e-9
"""Residuals equal to this relative difference count as repeated (cycling iterates repeat theirs
to round-off)."""


def repeating(residuals):
    """The shortest period p in 2..``CYCLE_PERIODS`` with which the last p + 1 residuals repeat
    the p + 1 before them (r_i = r_{i-p} to ``CYCLE_RTOL``), or None; None for a stall (the last
    three equal: period 1, not a cycle)."""
    r = np.asarray(residuals)
    if len(r) < 5 or np.all(np.abs(r[-3:] - r[-1]) <= CYCLE_RTOL * abs(r[-1])):
        return None
    for p in range(2, CYCLE_PERIODS + 1):
        if len(r) < 2 * p + 1:
            break
        last, before = r[-(p + 1):], r[-(2 * p + 1):-p]
        if np.all(np.abs(last - before) <= CYCLE_RTOL * np.abs(last)):
            return p
    return None


class CycleWatch:
    """Called with the residual history after each residual of a solve: (reason, hint) once
    the iterates cycle and, with ``switches`` (``switches.Switches`` at the iterate, or None),
    its laws' pieces were recorded over one more period; None before."""

    def __init__(self, switches=None):
        self.switches, self.states = switches, []

    def __call__(self, residuals):
        period = repeating(residuals)
        if period is None:
            self.states.clear()
            return None
        if self.switches is not None and len(self.states) <= period:
            self.states.append(self.switches())
            return None
        values = ", ".join(f"{r:.4e}" for r in residuals[-period:])
        reason = f"cycles: the iterates repeat with period {period} (scaled residuals {values} over and over)"
        if self.switches is None:
            return reason, "a smaller time step"
        where, hint = describe(self.switches.flipping(self.states), self.switches.side.dim)
        return f"{reason}: {where}", hint
