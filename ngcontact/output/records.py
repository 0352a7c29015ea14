"""Per-step records of a simulation: ``StepRecord``, ``ContactRecord`` and the ``History``.

Units are SI. In 2D (plane strain) every surface quantity is per metre of depth: an area on
a boundary is a length (m), a force N/m, a charge C/m. A body of revolution
(``Body(axisymmetric=True)``) is recorded in whole-body units, as in 3D: areas in m² (the rings
its facets sweep), forces in N, charges in C; of a force only the axial component (y) is a
resultant, the radial one is recorded as 0 (by symmetry), and facet averages are taken over
the rings. Signs follow docs/model.md: ν is the outward normal of the body.
"""
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ContactRecord:
    """Γ3 at one step. Arrays have one value per facet of Γ3 (``ContactSide.midpoints``):
    the facet average P_B of the quantity. pressure, multiplier and contact_set are averaged
    with the quadrature of the residual's Γ3 terms, so that the pressure integrates to the
    normal contact force even where it is kinked inside a facet (penalty, a varying gap).

    pressure : −σ_ν = λ_h + p(u_ν) − γ_ν β² R_ν(u_ν), the normal pressure of the foundation
        on the body (Pa; negative where the glue pulls).
    multiplier : λ_h >= 0, the contact pressure of the rigid foundation given by the
        enforcement method (Pa).
    beta : the bonding field β_n.
    beta_unclipped : β_n as the update computed it before clipping to [0, 1] (the explicit
        update (4.5) may leave it; the implicit one never does).
    beta_clipped : the number of facets the update pushed out of [0, 1] beyond round-off.
    potential : φ_h on Γ3 (V).
    charge_flux_density : D·ν = ψ(u_ν − g) φ_L(φ − φ_Γ) (C/m²): positive where charge leaves
        the body into the foundation.
    contact_set : the fraction of each facet in the contact zone {pressure > threshold} (0 to 1;
        the threshold, of round-off, ``observables.CONTACT_RELATIVE``).
    charge_flux : ∫_Γ3 D·ν da, the charge flux out of the body into the foundation (C; C/m
        in 2D), from the residual's Γ3 terms.
    contact_area : the measure of the contact zone (m²; in 2D per metre of depth: m), as contact_set.
    max_penetration : max (u_ν − g) at the sample points of Γ3 (m; > 0 means penetration).
    complementarity : ∫_Γ3 |λ_h (u_ν − g)| da (N·m; N·m/m in 2D), 0 for an exact solution.
    force : ∫_Γ3 σν da, the force of the foundation on the body (N; N/m in 2D), from the
        residual's Γ3 terms, so that it balances the reaction and the loads to the Newton
        tolerance.
    multiplier_points : λ_h itself at the Gauss points of the residual's order on each facet
        (facets × points, Pa; the points are ``ContactSide.gauss_points``, their weights
        ``gauss_weights``): what a facet average hides, such as a sawtooth inside facets.
    """
    pressure: np.ndarray
    multiplier: np.ndarray
    beta: np.ndarray
    beta_unclipped: np.ndarray
    potential: np.ndarray
    charge_flux_density: np.ndarray
    contact_set: np.ndarray
    charge_flux: float
    contact_area: float
    max_penetration: float
    complementarity: float
    force: np.ndarray
    beta_clipped: int
    multiplier_points: np.ndarray = None


@dataclass
class StepRecord:
    """The state at one time t_n (step 0 is the initial state). Units as the module says:
    per metre of depth in 2D; for a body of revolution whole-body (N, C, m²), as in 3D.

    step : n.  time : t_n (s).
    newton_iterations : linear solves of the step's Newton solve; residuals : its scaled
        residual norms (J^1/2); factorizations and krylov_iterations : what the linear
        solver did for them (a factorisation kept from an earlier step is reused);
        krylov_failures : GMRES solves that did not converge within their budget and were
        repeated after a fresh factorisation;
        discarded_iterations : the linear solves of a first try with shortened steps that
        did not converge and was repeated with full steps (``newton.Newton.solve``), else 0.
    wall_s : wall time of the step (s), records included; ``timings`` splits it into the
        Newton phases "residual", "assembly", "factorization", "solve" and "other" (s).
    reaction : ∫_Γ1 σν da, the force of the clamped boundary on the body (N; N/m in 2D).
    boundary_reaction : {name: ∫ σν da} for each boundary of Γ1 and of the supports, the
        force it exerts on the body (N; N/m in 2D) in its held components (0 in the free
        ones); a vertex shared by two of them counts for the first (Γ1, then the supports
        in order), so that they add up.
    electrode_charge : {name: Q}, the charge each named part of Γa carries,
        Q = −∫ D·ν da (C; C/m in 2D).
    state : copy of the (u, φ) coefficient vector (with ``keep_states``), else None.
    contact : ContactRecord, or None without a contact law.
    scheme : the time scheme's name; dt : the step's length k_n (s; None at step 0);
        order : the order of the scheme's formula for this step (1 or 2).
    error_estimate : with ``run(rtol=...)``, the step's estimated local error ÷ rtol (<= 1 for
        an accepted step; None where the scheme had no estimate yet); rejected : the tries of
        this step rejected before it (error, event or Newton failure; ``Simulation.rejections``);
        event : the event of Γ3 located at this step ("first contact", "lift-off", "β reaches 0"),
        or None; dt_next : the step the controller proposes next (s).
    """
    step: int
    time: float
    newton_iterations: int
    residuals: list
    wall_s: float
    reaction: np.ndarray
    electrode_charge: dict
    state: np.ndarray = field(repr=False, default=None)
    contact: ContactRecord = None
    timings: dict = field(default_factory=dict)
    factorizations: int = 0
    krylov_iterations: int = 0
    krylov_failures: int = 0
    discarded_iterations: int = 0
    boundary_reaction: dict = field(default_factory=dict)
    scheme: str = None
    dt: float = None
    order: int = None
    error_estimate: float = None
    rejected: int = 0
    event: str = None
    dt_next: float = None


class History(list):
    """The list of StepRecords (step 0 is the initial state), with column accessors."""

    def column(self, name):
        """A field of the StepRecords at every step, stacked."""
        _field("column", name, StepRecord)
        return np.array([getattr(r, name) for r in self])

    @property
    def times(self):
        return self.column("time")

    @property
    def reactions(self):
        return self.column("reaction")

    def contact_column(self, name):
        """A field of the ContactRecords at every step, stacked (steps × ...)."""
        _field("contact_column", name, ContactRecord)
        if any(r.contact is None for r in self):
            raise ValueError("contact_column: the simulation has no contact (Simulation(contact=...)): it records no "
                             "ContactRecords")
        return np.array([getattr(r.contact, name) for r in self])

    def boundary_reactions(self, name):
        """The reaction of the held boundary ``name`` at every step (steps × dim; N, N/m in 2D)."""
        return np.array([r.boundary_reaction[name] for r in self])

    def electrode_charges(self, name):
        """The charge on the electrode ``name`` at every step (C; C/m in 2D)."""
        return np.array([r.electrode_charge[name] for r in self])

    @property
    def newton_iterations(self):
        return self.column("newton_iterations")


def _field(what, name, record):
    """A TypeError or ValueError naming ``what`` unless ``name`` is a field of the dataclass ``record``."""
    fields = list(record.__dataclass_fields__)
    if not isinstance(name, str):
        raise TypeError(f"{what}: the name of a field of {record.__name__} (a str, one of {fields}), got {name!r}")
    if name not in fields:
        raise ValueError(f"{what}: {name!r} is not a field of {record.__name__}; its fields are {fields}")
