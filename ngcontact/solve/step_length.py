"""Newton's step length on Γ3: a correction does not carry open points deep into the foundation.

The semismooth Newton step linearises the contact law at the iterate. From a state where part
of Γ3 is open, it misses the contact that the step itself creates: where the body first meets
the foundation it moves on freely and overshoots deep into it (on the reference scene, over
many facets of Γ3 at first contact, for a true contact zone of one facet). The next iterations
enforce contact on the whole overshoot and release it a few facets at a time, so their number
grows with the mesh. The step is cut where it
would carry an open point (u_ν < g) beyond a penetration δ = η max|Δu_ν|: then the contact
law is linearised where contact begins, and the front is resolved in a few iterations
whatever the mesh (docs/speed.md, "Newton iterations").

Where Γ3 already touches the foundation when the solve begins (a curved body set on the
obstacle, every step of a history after the first contact), the zone grows from the touching
points: a deeper penetration (``eta_touching`` = 0.03) over up to 4 corrections lets it grow
in a few steps, and fewer iterations release the overshoot after the last cut
(docs/stability.md, section 12).

Where a face meets the foundation flat and all at once (the soft column of the stability
study), the shortened steps can make Newton cycle; ``Newton`` then repeats the solve with
full steps, which converge there in a few iterations.
"""
import ngsolve as ngs
import numpy as np

from ngcontact import parallel


class StepLength:
    """The step length α ∈ (0, 1] of a Newton correction x ← x − α w.

    Parameters
    ----------
    side : ContactSide (Γ3 and its sample points, with the facet normals).
    state : GridFunction (u, φ) of the iterate.
    gap : the gap g (CoefficientFunction, m).
    normal : an obstacle normal n_o (CoefficientFunction), or None for the facet normals ν.
    eta : δ = eta · max |Δu_ν| over Γ3, the penetration an open point may reach in one step
        where Γ3 does not touch the foundation when the solve begins.
    max_cuts : the most corrections shortened in one Newton solve (later ones are full).
        Two resolve the first contact of the reference scene (one does not, as without the
        limit); more change nothing there.
    eta_touching : the same where it does: a point of Γ3 lies within eta · max |Δu_ν| of the
        foundation (or beyond it) at the solve's start (decided at its first correction).
    max_cuts_touching : ``max_cuts`` where it does.

    ``cuts``: the corrections shortened in the current solve; ``touching``: whether Γ3 touched
    at its start (None before its first correction).
    """

    def __init__(self, side, state, gap, eta=1e-3, max_cuts=2, normal=None, eta_touching=0.03, max_cuts_touching=4):
        for name, value in (("eta", eta), ("eta_touching", eta_touching)):
            if not 0 < value < 1:
                raise ValueError(f"{name} must lie in (0, 1), got {value}")
        self.side, self.state, self.gap, self.eta, self.max_cuts = side, state, gap, eta, max_cuts
        self.normal, self.eta_touching, self.max_cuts_touching = normal, eta_touching, max_cuts_touching
        self._direction = ngs.GridFunction(state.space)
        self.cuts, self._gap, self.touching = 0, None, None

    def start(self):
        """A Newton solve begins: the gap is sampled once for it (the time is fixed)."""
        self.cuts, self._gap, self.touching = 0, self.side.sample(self.gap), None

    @property
    def cut(self):
        """Whether the current solve shortened a step."""
        return self.cuts > 0

    @property
    def _most_cuts(self):
        """The corrections the current solve may shorten (``max_cuts``, or ``max_cuts_touching``)."""
        return self.max_cuts_touching if self.touching else self.max_cuts

    @property
    def spent(self):
        """Whether the current solve shortened all the corrections it may (later ones are full)."""
        return self.touching is not None and self.cuts >= self._most_cuts

    def __call__(self, w):
        """α for the correction w (the step is x − α w)."""
        if self.cuts >= self._most_cuts:
            return 1.0
        if self._gap is None:
            self.start()
        side = self.side
        self._direction.vec.data = w
        opening = side.normal_displacement(self.state.components[0], self.normal) - self._gap
        change = -side.normal_displacement(self._direction.components[0], self.normal)   # Δu_ν of −w
        mesh = side.mesh                              # on a distributed mesh: over all ranks
        largest = parallel.maximum(mesh, np.abs(change))
        if self.touching is None:                     # the solve's first correction
            self.touching = parallel.any_rank(mesh, bool((opening >= -self.eta * largest).any()))
        delta = (self.eta_touching if self.touching else self.eta) * largest
        limited = (opening < 0) & (opening + change > delta)
        if not parallel.any_rank(mesh, limited.any()):
            return 1.0
        self.cuts += 1
        return parallel.minimum(mesh, (delta - opening[limited]) / change[limited])
