"""Admissible data: the gap on Γ3 (or an obstacle) and the supports' values at t = 0.

Checked before any step is solved, each failure a ValueError naming the parameter, the value
and the tolerance.
"""
import ngsolve as ngs
import numpy as np

from . import parallel


class GapCheck:
    """The gap must be >= 0 on Γ3 (to 1e-8 of the body's size) at time t (the time Parameter
    set to it): on the facets, with the facet normals (a gap written with
    ``specialcf.normal`` is zero inside elements), and at the sample points. With an obstacle
    this is its intersection with the body, checked at t = 0 only: a moving obstacle may then
    be driven into the body. Built once (its facet integrals are reassembled per call), so
    that a time-dependent gap can be checked at every step."""

    def __init__(self, body, gamma3):
        self.gamma3, self.tolerance, self.mesh = gamma3, 1e-8 * body.size, body.mesh
        gap = gamma3.gap
        self._negative = gamma3.side.facet_integrals(ngs.IfPos(-gap, -gap, 0.0))

    def __call__(self, t):
        g = self.gamma3
        negative = max(parallel.maximum(self.mesh, self._negative() / g.side.measure),
                       0.0 if g.sampled_normal is None else -parallel.minimum(self.mesh, g.side.sample(g.gap)))
        if negative > self.tolerance:
            what = ("Contact.obstacle intersects the body at t = 0" if g.contact.obstacle is not None
                    else f"Contact.gap must be >= 0 on Γ3 at t = {t:.6g} s")
            raise ValueError(f"{what}: the gap reaches {-negative:.3g} m (tolerance {self.tolerance:.2g} m, "
                             "1e-8 of the body's size)")


def check_supports_at_start(body, u, given):
    """u0 (``given`` at the held DOFs, 0 if not given) must equal the supports' prescribed
    displacements at t = 0, which ``u`` holds."""
    held = ~np.array(list(body.V.FreeDofs()), dtype=bool)
    prescribed = u.vec.FV().NumPy()[held]
    mesh = body.mesh
    scale = max(parallel.maximum(mesh, np.abs(prescribed), 0.0), parallel.maximum(mesh, np.abs(given), 0.0))
    difference = parallel.maximum(mesh, np.abs(prescribed - given), 0.0)
    if body.supports and difference > 1e-8 * scale + 1e-14:
        raise ValueError("u0 must equal Loads.displacement on the supports at t = 0; they differ by "
                         f"up to {difference:.3g} m: start the prescribed "
                         "displacements from 0 or pass a matching u0")


class PhysicsWarning(UserWarning):
    """A computed step that makes no physical sense for the model (``flags``)."""


PENETRATION_LIMIT = 0.1      # of the smallest facet of Γ3
DISPLACEMENT_LIMIT = 0.05    # of the body's size (small strain)


def flags(body, record, u, side=None):
    """What in a computed step makes no physical sense for the model, as messages naming the
    step, the quantity, its value and the threshold: penetration into the foundation beyond
    ``PENETRATION_LIMIT`` of the smallest facet of Γ3 (the contact law is not met), a
    displacement beyond ``DISPLACEMENT_LIMIT`` of the body's size (the small-strain model
    does not hold), non-finite fields."""
    found = []
    values = u.vec.FV().NumPy()
    if parallel.any_rank(body.mesh, not np.all(np.isfinite(values))):
        found.append(f"step {record.step}: the displacement has NaN or inf entries")
        return found
    size = body.size
    largest = parallel.maximum(body.mesh, np.abs(values), 0.0)
    if largest > DISPLACEMENT_LIMIT * size:
        found.append(f"step {record.step} (t = {record.time:.6g} s): displacement {largest:.3g} m exceeds "
                     f"{DISPLACEMENT_LIMIT:g} of the body's size {size:.3g} m: the small-strain model does not hold")
    if record.contact is not None and side is not None:
        facet = parallel.minimum(body.mesh, side.measure) ** (1 / (body.dim - 1))
        if record.contact.max_penetration > PENETRATION_LIMIT * facet:
            found.append(f"step {record.step} (t = {record.time:.6g} s): penetration {record.contact.max_penetration:.3g}"
                         f" m exceeds {PENETRATION_LIMIT:g} of the smallest facet of Γ3 ({facet:.3g} m): the "
                         "contact law is not met (a larger γ0 or penalty, or a finer mesh)")
    return found
