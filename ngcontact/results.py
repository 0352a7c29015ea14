"""Per-step results of a simulation."""
from dataclasses import dataclass, field

import numpy as np


@dataclass
class StepRecord:
    """One time step t_n.

    reaction: ∫_Γ1 σν da, the force of the support on the body (N; N/m in 2D).
    charge: {electrode name: ∫ D·ν da}, the flux of D out of the body through each named
        part of Γa (C; C/m in 2D); the charge an electrode carries is its negative.
    state: copy of the (u, φ) coefficient vector.
    """
    step: int
    time: float
    newton_iterations: int
    residuals: list
    wall_s: float
    reaction: np.ndarray
    charge: dict
    state: np.ndarray = field(repr=False, default=None)


class History(list):
    """The list of StepRecords (step 0 is the initial state), with column accessors."""

    def column(self, name):
        return np.array([getattr(r, name) for r in self])

    @property
    def times(self):
        return self.column("time")

    @property
    def reactions(self):
        return self.column("reaction")

    def charges(self, name):
        """Flux of D through the electrode ``name`` at every step."""
        return np.array([r.charge[name] for r in self])

    @property
    def newton_iterations(self):
        return self.column("newton_iterations")
