"""The bonding field β on Γ3 and its update: (2.9) and the paper's explicit scheme (4.5).

β^h lives in B^h (piecewise constant on the facets of Γ3). Step n updates β from the
previous displacement u_{n-1}, before (u_n, φ_n) are solved (k = dt in the paper's notation):

* "explicit" (4.5):  β_n = β_{n-1} − k P_B[β_{n-1} γ_ν R_ν(u_{n-1,ν})² − ε_a]_+, then
  clipped to [0, 1]. Its decay factor per step is 1 − k γ_ν R², so it overshoots below 0
  (and is clipped) or oscillates once k γ_ν L² > 1.
* "implicit": β_n = β_{n-1} − k [β_n a − b]_+ with a = P_B(γ_ν R_ν(u_{n-1,ν})²), b = P_B ε_a,
  solved exactly per facet: β_n = (β_{n-1} + k b)/(1 + k a) where β_{n-1} a > b, else
  β_n = β_{n-1}. The factor 1/(1 + k a) lies in (0, 1] for every k: β stays in [0, 1]
  and decays monotonically, whatever the step (the discrete analogue of (2.9)).

A second-order scheme (``schemes.bdf2``) solves (2.9) by its own formula through ``solve``:
β_n = β̂ − κ [β_n a − b]_+ with its combination β̂ of earlier values, κ = 1/c and a from an
extrapolated u_ν: the implicit update is the case β̂ = β_{n−1}, κ = k, a from u_{n−1}.
"""
import ngsolve as ngs
import numpy as np

from ngcontact import parallel
from ngcontact.gamma3.contact_laws import positive_part


class BondingField:
    """β^h ∈ B^h with its initial value P_B β0 and one of the two updates.

    ``values``: the facet values of β (a numpy view). ``unclipped``: the values the last
    update computed before clipping to [0, 1] (the implicit update needs no clipping)."""

    def __init__(self, side, contact):
        self.side, self.contact = side, contact
        self.gf = ngs.GridFunction(side.B, name="beta")
        beta0 = side.project(ngs.CF(contact.beta0))
        low, high = parallel.minimum(side.mesh, beta0), parallel.maximum(side.mesh, beta0)
        if not (low >= -1e-12 and high <= 1 + 1e-12):          # NaN fails too
            raise ValueError(f"Contact.beta0 must lie in [0, 1] on Γ3; its facet averages range "
                             f"over [{low:.3g}, {high:.3g}]")
        self.values[:] = np.clip(beta0, 0, 1)
        self.unclipped = self.values.copy()
        self._forms = {}          # per u_ν expression: (the expression, its facet integrals)

    def _integrals(self, u_normal):
        """Facet integrals of the explicit rate and of γ_ν R², built once per u_ν expression
        (a scheme may use several: BDF2 takes R² at an extrapolated u and at u_n, and compiled
        the forms anew at every switch, a large part of a controlled run's time)."""
        found = self._forms.get(id(u_normal))
        if found is None:
            c, R2 = self.contact, self.contact.R(u_normal) ** 2
            found = self._forms[id(u_normal)] = (u_normal, (
                self.side.facet_integrals(positive_part(self.gf * c.adhesion * R2 - c.eps_a)),
                self.side.facet_integrals(c.adhesion * R2)))
        return found[1]

    @property
    def values(self):
        """The facet values of β (a numpy view)."""
        return self.gf.vec.FV().NumPy()

    @property
    def clipped(self):
        """Number of facets the last update pushed out of [0, 1] (then clipped), beyond
        round-off (1e-12: an update to exactly 0 may land at −1e-24)."""
        return int(np.count_nonzero((self.unclipped < -1e-12) | (self.unclipped > 1 + 1e-12)))

    def update(self, u_normal, dt):
        """β_{n-1} -> β_n with u_{n-1,ν} given as a CoefficientFunction, time step dt in s
        (pass the same CoefficientFunction object each step: its forms are built once)."""
        c, beta = self.contact, self.values
        rate, decay = self._integrals(u_normal)
        if c.beta_update == "explicit":
            self.unclipped = beta - dt * rate() / self.side.weighted_measure
            beta[:] = np.clip(self.unclipped, 0, 1)
        else:
            self.solve(u_normal, dt, beta.copy())

    def solve(self, u_normal, kappa, beta_hat):
        """β_n = β̂ − κ [β_n a − b]_+ per facet, exactly: a = P_B(γ_ν R_ν(u_ν)²) with u_ν the
        CoefficientFunction ``u_normal``, b = ε_a, κ (s) and β̂ = ``beta_hat`` (facet values):
        β_n = (β̂ + κ b)/(1 + κ a) where β̂ a > b, else β̂; then clipped to [0, 1] (a
        combination β̂ of earlier values may leave it; ``unclipped`` keeps the values before)."""
        a, b = self._integrals(u_normal)[1]() / self.side.weighted_measure, self.contact.eps_a
        decays = beta_hat * a > b
        self.unclipped = np.where(decays, (beta_hat + kappa * b) / (1 + kappa * a), beta_hat)
        self.values[:] = np.clip(self.unclipped, 0, 1)
