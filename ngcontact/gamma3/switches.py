"""The semismooth switches of Γ3 at a state: which piece of each law of Γ3 every Gauss point is on.

Newton's Jacobian on Γ3 changes where a law crosses a kink: the Signorini switch (the
enforcement's active set), the compliant layer p at r = u_ν − g = 0, the glue's truncation R_ν
at u_ν = −L and 0, the conduction ψ at the ends of its ramp (r = −δ and 0 for the default ψ;
ψ > 0 for a law of the user's) and the potential truncation φ_L at ±L_φ. When Newton cycles,
the switches that differ between the iterates of the cycle name the law it cannot settle and
where (``newton.NewtonError``).
"""
import ngsolve as ngs
import numpy as np

from ngcontact.gamma3 import integrands
from ngcontact import parallel

HINTS = {
    "the contact set": "a smaller time step, theta = -1, or a larger gamma0 (the Signorini switch)",
    "the compliant layer p": "a smaller time step or a softer compliance",
    "the glue R_ν": "a smaller time step or beta_update='implicit' (the glue's truncation)",
    "the conduction ψ": "a wider ramp_width δ or a smaller conductance k_e: ψ switches the conduction on "
                        "within δ of contact, and the charges it lets through move the contact again",
    "the potential truncation φ_L": "a larger potential_truncation L_φ",
}
"""What to try when Newton cycles on each switch."""


class Switches:
    """The pieces of the laws of Γ3 at the current ``state`` (a GridFunction of (u, φ)); call it
    for {switch name: integer array, facets × Gauss points}."""

    def __init__(self, gamma3, state):
        g, contact = gamma3, gamma3.contact
        u, phi = state.components
        u_n = u * g.normal
        r = u_n - g.gap
        traction = integrands.adhesion_traction(contact, g.beta.gf, u_n)
        step = lambda cf: ngs.IfPos(cf, 1, 0)                     # noqa: E731
        cfs = {"the contact set": g.enforcement.active(u, phi, traction)}
        if callable(contact.compliance) or contact.compliance > 0:
            cfs["the compliant layer p"] = step(r)
        if contact.adhesion > 0:
            cfs["the glue R_ν"] = step(u_n + contact.bond_length) + step(u_n)
        if contact.conducts:
            r = integrands.conduction_distance(contact, g.enforcement, u, phi, g.gap, g.normal, traction)
            cfs["the conduction ψ"] = step(contact.psi(r)) if callable(contact.conductance) else \
                step(r + contact.ramp_width) + step(r)
            drop = phi - g.foundation_potential
            cfs["the potential truncation φ_L"] = step(drop - contact.potential_truncation) + \
                step(drop + contact.potential_truncation)
        self.side, self.cfs = g.side, {name: cf.Compile() for name, cf in cfs.items()}   # evaluated often

    def __call__(self):
        return {name: np.rint(self.side.at_gauss_points(cf)).astype(int) for name, cf in self.cfs.items()}

    def flipping(self, states):
        """[(switch name, facets that change, their midpoints' smallest and largest coordinates)]
        over ``states`` (outputs of calls), counted over every rank."""
        mesh, found = self.side.mesh, []
        for name in self.cfs:
            pieces = np.array([s[name] for s in states])
            changed = np.any(pieces != pieces[:1], axis=(0, 2))
            count = int(parallel.sum(mesh, int(changed.sum())))
            if count:
                points = self.side.midpoints[changed]
                low = [parallel.minimum(mesh, points[:, i]) for i in range(points.shape[1])]
                high = [parallel.maximum(mesh, points[:, i]) for i in range(points.shape[1])]
                found.append((name, count, low, high))
        return found


def describe(flips, dim, over="cycle"):
    """(what flips, where, in words; the remedies), for the ``NewtonError`` of a cycle (or of a
    line ``search`` that stalled)."""
    if not flips:
        return f"no law of Γ3 changes piece between the iterates of the {over}", \
            "a smaller time step, or a larger maxit"
    axes = "xyz"[:dim]
    parts = []
    for name, count, low, high in flips:
        box = ", ".join(f"{a} in [{lo:.4g}, {hi:.4g}] m" if hi > lo else f"{a} = {lo:.4g} m"
                        for a, lo, hi in zip(axes, low, high))
        parts.append(f"{name} changes on {count} facet{'s' if count > 1 else ''} of Γ3 ({box})")
    hints = [HINTS[name] for name, *_ in flips]
    return "; ".join(parts), "; or ".join(dict.fromkeys(hints))
