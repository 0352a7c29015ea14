"""Admissible data: the gap on Γ3 (or an obstacle) and the supports' values at t = 0.

Checked before any step is solved, each failure a ValueError naming the parameter, the value
and the tolerance.
"""
import ngsolve as ngs
import numpy as np

from ngcontact import parallel


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


def check_initial_displacement(body, u0, gamma3=None):
    """u0 (a CoefficientFunction, m) must vanish on Γ1 and be admissible on Γ3 (u0_ν <= g, with
    the contact normal of ``gamma3``, an ``observables.Gamma3`` or None)."""
    mesh, square = body.mesh, ngs.InnerProduct(u0, u0)
    whole = parallel.sum(mesh, ngs.Integrate(square, mesh))
    if not np.isfinite(whole):
        raise ValueError("u0 is not finite (NaN or inf) in the body")
    if body.boundaries["clamped"]:
        on_gamma1 = parallel.sum(mesh, ngs.Integrate(body.kinematics.ds(square, body.region("clamped"), weighted=False),
                                                      mesh))
        if on_gamma1 > 1e-20 * (1 + whole):                            # (all ranks' sums)
            raise ValueError(f"u0 must vanish on the clamped boundary Γ1 ({body.region_names('clamped')!r})")
    if gamma3 is not None:
        side = gamma3.side
        excess = parallel.maximum(mesh, side.normal_displacement(u0, gamma3.sampled_normal) - side.sample(gamma3.gap))
        if excess > 1e-12 * (1 + parallel.maximum(mesh, np.abs(side.sample(u0)))):
            raise ValueError(f"u0 must be admissible, u0_ν <= g on Γ3; it exceeds g by {excess:.3g} m")


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


PENETRATION_LIMIT = 0.1      # of the smallest facet of Γ3, and of the largest displacement
DISPLACEMENT_LIMIT = 0.05    # of the body's size (small strain)


def scene_flags(contact):
    """What in the data of a scene makes its results unreliable, as messages (flagged once,
    when the simulation is built): the enforcement method's own (``Method.flags``: a Nitsche γ0
    below ``enforcement.nitsche.ACCURATE_FROM`` of its θ)."""
    return [] if contact is None else list(contact.enforcement_method.flags())


STIFF_CONTACT = 1e4
"""A Γ3 stiffness more than this many times the body's own at Γ3 is named when Newton fails."""


def stiff_contact_terms(body, contact, side):
    """A sentence naming the Γ3 stiffnesses (Pa/m) above ``STIFF_CONTACT`` times the body's
    stiffness at Γ3, p² λ_max(F + Eᵀ C⁻¹ E)/h (h the smallest facet of Γ3), or "": between
    Jacobians that differ by such factors semismooth Newton may cycle or stall."""
    h = parallel.minimum(body.mesh, side.measure) ** (1 / (body.dim - 1))
    bulk = body.order ** 2 * body.tensors.stiffness(0.0) / h
    ratios = {"Contact.adhesion γ_ν": contact.adhesion / bulk,
              "Contact.compliance c_ν": 0.0 if callable(contact.compliance) else contact.compliance / bulk,
              **contact.enforcement_method.stiffness_factors()}
    named = [f"{name} is {ratio:.3g} times that" for name, ratio in ratios.items() if ratio > STIFF_CONTACT]
    if not named:
        return ""
    return f"; the body's stiffness at Γ3 is p²λ/h = {bulk:.3g} Pa/m, and {', '.join(named)}"


def flags(body, record, u, side=None):
    """What in a computed step makes no physical sense for the model, as messages naming the
    step, the quantity, its value and the threshold: penetration into the foundation beyond
    ``PENETRATION_LIMIT`` of the smallest facet of Γ3 or of the largest displacement of the
    body (the contact law is not met: the body goes through the foundation by a sizeable part
    of its own motion, e.g. of the gap it closed), a displacement beyond
    ``DISPLACEMENT_LIMIT`` of the body's size (the small-strain model does not hold), a
    bonding field that the explicit update (4.5) pushed out of [0, 1] (clipped: the update is
    unstable at this time step, dt γ_ν L² > 1), non-finite fields."""
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
        penetration = record.contact.max_penetration
        for limit, what in ((facet, "the smallest facet of Γ3"), (largest, "the largest displacement of the body")):
            if penetration > PENETRATION_LIMIT * limit:
                found.append(f"step {record.step} (t = {record.time:.6g} s): penetration {penetration:.3g} m "
                             f"exceeds {PENETRATION_LIMIT:g} of {what} ({limit:.3g} m): the contact law is not "
                             "met (a larger γ0 or penalty, or a finer mesh)")
                break
        clipped, scheme = record.contact.beta_clipped, getattr(record, "scheme", None) or "backward_euler"
        if clipped and scheme == "backward_euler":
            found.append(f"step {record.step} (t = {record.time:.6g} s): the explicit β update (4.5) left [0, 1] on "
                         f"{clipped} facets and was clipped: it is unstable at this time step "
                         "(dt γ_ν L² > 1); a smaller dt, or Contact(beta_update='implicit')")
        elif clipped:                               # a multistep scheme: its combination of past β went below 0
            found.append(f"step {record.step} (t = {record.time:.6g} s): the {scheme} update of β left [0, 1] on "
                         f"{clipped} facets and was clipped: β decays faster than the time step resolves (the "
                         "combination of its past values fell below 0); a smaller dt, or an error target "
                         "run(rtol=...)")
    return found
