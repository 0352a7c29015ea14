"""Per-step results of a simulation."""
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ContactRecord:
    """Γ3 at one step; arrays have one value per facet of Γ3 (``ContactSide.midpoints``),
    the facet averages P_B of the quantity.

    pressure: −σ_ν = λ_h + p(u_ν) − γ_ν β² R_ν(u_ν), the normal pressure of the foundation
        on the body (Pa; negative where the glue pulls).
    multiplier: λ_h = −[P]_-, the Nitsche contact pressure of the rigid foundation (Pa).
    raw_pressure: −σ_ν(u_h), the pressure computed from the stress itself (Pa).
    beta: the bonding field β_n.  potential: φ_h on Γ3 (V).
    current_density: ψ φ_L (= D·ν, C/m²); current: ∫_Γ3 ψ φ_L da (C; C/m in 2D).
    contact_set: the fraction of each facet in the contact zone {pressure > 0} (0 to 1).
    contact_length: measure of the contact zone (m; m² in 3D).
    active_length: measure of the Signorini active set {P <= 0}, where u_ν reaches g.
    max_penetration: max (u_ν − g) at the sample points (m; > 0 means penetration).
    complementarity: ∫_Γ3 |λ_h (u_ν − g)| da.
    force: ∫_Γ3 σν da, the force of the foundation on the body (N; N/m in 2D).
    beta_clipped: facets the explicit β update pushed out of [0, 1] (then clipped).
    """
    pressure: np.ndarray
    multiplier: np.ndarray
    raw_pressure: np.ndarray
    beta: np.ndarray
    potential: np.ndarray
    current_density: np.ndarray
    contact_set: np.ndarray
    current: float
    contact_length: float
    active_length: float
    max_penetration: float
    complementarity: float
    force: np.ndarray
    beta_clipped: int


@dataclass
class StepRecord:
    """One time step t_n.

    reaction: ∫_Γ1 σν da, the force of the support on the body (N; N/m in 2D).
    charge: {electrode name: ∫ D·ν da}, the flux of D out of the body through each named
        part of Γa (C; C/m in 2D); the charge an electrode carries is its negative.
    state: copy of the (u, φ) coefficient vector.
    wall_s: wall time of the step (s), records included; ``timings`` splits it into the
        Newton phases "residual", "assembly", "factorization", "solve" and "other" (s).
    """
    step: int
    time: float
    newton_iterations: int
    residuals: list
    wall_s: float
    reaction: np.ndarray
    charge: dict
    state: np.ndarray = field(repr=False, default=None)
    contact: ContactRecord = None
    timings: dict = field(default_factory=dict)


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

    def contact_column(self, name):
        """A field of the ContactRecords at every step, stacked (steps × ...)."""
        return np.array([getattr(r.contact, name) for r in self])

    def charges(self, name):
        """Flux of D through the electrode ``name`` at every step."""
        return np.array([r.charge[name] for r in self])

    @property
    def newton_iterations(self):
        return self.column("newton_iterations")
