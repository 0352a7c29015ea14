"""What several test modules share and the hostile suite's fork server imports too (it cannot
import ``conftest``, which names the repository's own there): a contact method of the user's, the
closed form of a viscous column, a small adaptive Hertz scene."""
from ngcontact.contact_laws import positive_part
from ngcontact.methods import boundary_stiffness

import ngsolve as ngs


class StiffLayer:
    """A contact method of the user's with every member of the protocol (``ngcontact.methods.Method``),
    written with the public names only: the penalty law under its own name, with one parameter."""
    name, keeps_symmetry, skew_symmetric = "stiff layer", True, False
    condensable, distributable, takes_obstacle = True, True, True

    def __init__(self, factor=1e4):
        self.factor = factor

    def contact_fields(self):
        return {}

    def stiffness_factors(self):
        return {"the stiff layer": self.factor}

    def flags(self):
        return []

    def build(self, body, contact, side, *, gap, coefficients, normal):
        return LayerTerms(self.factor * boundary_stiffness(body, coefficients.rate), gap, normal)


class LayerTerms:
    """StiffLayer's Γ3 expressions (``ngcontact.methods.Enforcement``): the contact pressure
    λ = ε [u_ν − g]_+ with ε = factor × ``boundary_stiffness`` (Pa/m), as ``Penalty``'s."""
    newton_hook = None

    def __init__(self, epsilon, gap, normal):
        self.epsilon, self.gap, self.n = epsilon, gap, normal

    def multiplier(self, u, phi, traction):
        return self.epsilon * positive_part(u * self.n - self.gap)

    def signorini(self, u, phi, v, xi, traction):
        return self.multiplier(u, phi, traction) * (v * self.n)

    def active(self, u, phi, traction):
        return ngs.IfPos(self.gap - u * self.n, 0, 1)

    def contact_distance(self, u, phi, traction):
        return u * self.n - self.gap


METHOD_MEMBERS = ("name", "keeps_symmetry", "skew_symmetric", "condensable", "distributable", "takes_obstacle",
                  "contact_fields", "stiffness_factors", "flags", "build")
"""The members of ``enforcement.Method`` that every method has."""


def without(*names, class_name="Broken", **changes):
    """A StiffLayer(1e4) of a class ``class_name`` that lacks the members ``names`` and has ``changes``
    (class attributes)."""
    namespace = {n: getattr(StiffLayer, n) for n in METHOD_MEMBERS + ("__init__",) if n not in names}
    namespace.update(changes)
    return type(class_name, (), namespace)()


def viscous_slab_column(P, tau, c33, zeta, q, k, n):
    """Backward Euler's strains ε_0 = 0, ..., ε_n of a uniaxial Kelvin–Voigt column (stiffness
    ``c33`` Pa, relaxation time ``tau`` s) under the stress −``P`` Pa, whose viscosity law adds
    ζ (ε̇ − max(ε̇, −q)) (``laws.ProjectionLaw(zeta, laws.Slab(1, lower=-q))``), steps of ``k`` s:
    each step solves c ε + τ c ε̇ (+ ζ (ε̇ + q) where ε̇ < −q) = −P in closed form."""
    strains = [0.0]
    for _ in range(n):
        prev, a = strains[-1], tau * c33 / k
        s = (a * prev - P) / (c33 + a)
        if (s - prev) / k < -q:
            b = zeta / k
            s = (a * prev + b * prev - P - zeta * q) / (c33 + a + b)
        strains.append(s)
    return strains


def small_hertz(max_ndof=400):
    """``studies.adaptivity``'s Hertz disk on its coarsest mesh with a DOF limit of ``max_ndof``,
    named "hertz" (install it as ``adaptivity.SCENES["hertz"]``: an adapt run of a few seconds)."""
    from ngcontact.scenes import hertz
    from ngcontact.studies import adaptivity
    scene = adaptivity.SCENES["hertz3d"]()
    scene.name, scene.max_ndof = "hertz", max_ndof
    scene.mesh = lambda order: hertz.mesh(2, h_contact=0.2, curve=order)
    scene.scene = lambda order: (lambda mesh: hertz.simulation(order, mesh=mesh, keep_states=False))
    return scene
