"""Estimates of the error in what a user asks for, besides the energy: the contact pressure on
Γ3 and the contact force.

* ``"pressure"``: the relative L² error ‖λ − λ_h‖_Γ3 / ‖λ_h‖_Γ3 of the contact pressure λ_h
  (``Simulation.contact_pressure``). Its estimate is the consistency residual of Γ3,

    η_p,F = ‖λ_h + σ̃_ν(u_h)‖_F   on each facet F of Γ3,

  the distance between the pressure the enforcement imposes and the normal stress of the
  discrete state (σ̃_ν = σ_ν + p − γ_ν β² R_ν; both are λ for the exact solution). Nitsche's
  λ_h = −[P_γ]₋ kinks inside the facets that hold the contact edges; there the two differ by
  what neither resolves, and that is where the pressure error sits. The residual is the
  contact term of Chouly–Fabre–Hild–Pousin–Renard's estimator without its weight h^½ (it is
  taken in L², not in the energy). It is not a bound: its effectivity is in
  docs/adaptivity.md, "Goals".
* ``"force"``: the relative error |F − F_h| / |F_h| of the contact resultant. For a linear
  conforming problem loaded by a prescribed displacement d alone, Galerkin orthogonality gives
  (F_h − F) d = |||u − u_h|||² and F_h d = |||u_h|||², so the relative force error is the square
  of the relative energy error; its estimate is (η / |||x_h|||)² with η the averaging
  indicator's bulk parts (stress and electric flux, ``estimators.averaging``; its Γ3 residual
  is the pressure's). Nitsche's contact is not conforming and the force error changes sign
  along a refinement, so this is an estimate, not a bound (docs/adaptivity.md, "Goals"). A body
  loaded by forces alone along F_h (nothing held takes force along it) has F_h balanced by its
  loads, exactly as the exact solution: its estimate is 0.

``edges`` marks the volume elements whose Γ3 facet holds a contact edge (λ_h > 0 on part of
the facet only), where the pressure's kink sits; ``edge_points`` gives, in 2D, the position
of each edge along its facet, for refining there more than once.
"""
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np

from ngcontact import meshes
from ngcontact.gamma3.contact_side import element_boundary_layer
from ngcontact.model import forms

GOALS = ("energy", "pressure", "force")
"""What ``adapt.step``/``adapt.solve`` can refine for (``goal=``)."""


@dataclass
class GoalEstimate:
    """The estimate of one goal on one level: ``goal``, its discrete ``value`` (‖λ_h‖_Γ3 in
    Pa m^½ in 2D (Pa m in 3D) for the pressure; F_h in N/m in 2D (N in 3D) for the force), the
    ``estimate`` of its error (same unit) and the ``relative`` one; ``indicators`` per volume
    element (the pressure residual on the elements at Γ3, 0 elsewhere) and ``edges`` (bool per
    volume element: its Γ3 facet holds a contact edge)."""
    goal: str
    value: float
    estimate: float
    relative: float
    indicators: np.ndarray = field(repr=False, default=None)
    edges: np.ndarray = field(repr=False, default=None)


class PressureResidual:
    """η_p,K = ‖λ_h + σ̃_ν(u_h)‖_{∂K∩Γ3} per volume element K (0 away from Γ3), ‖λ_h‖_Γ3, and
    the elements at contact edges, for the simulation ``sim`` (its steps' state; the forms are
    built once, ``__call__`` evaluates the current state)."""

    SUBPOINTS = 24
    """Quadrature orders added on Γ3: λ_h kinks inside the edge facets."""

    def __init__(self, sim):
        steps = getattr(sim, "steps", sim)
        body, g = steps.body, steps.gamma3
        if g is None:
            raise ValueError("the pressure goal needs a contact side Γ3 (Simulation(contact=...))")
        self.body, self.steps = body, steps
        u, phi = steps.u, steps.phi
        lam = g.multiplier(u, phi)
        coefficients = steps.system.coefficients
        sigma_n = forms.step_normal_stress(body.tensors, u, phi, coefficients.rate, coefficients.anchor, g.normal)
        # counted where the body presses or could within its facet (opening below the facet's
        # size): the traction residual of a clearly free surface is an energy matter
        opening = g.gap - u * g.normal
        near = ngs.IfPos(lam, 1.0, ngs.IfPos(ngs.specialcf.mesh_size - opening, 1.0, 0.0))
        residual = near * (lam + sigma_n + g.traction(u))
        tests = ngs.L2(body.mesh, order=0)
        v = tests.TestFunction()
        on_layer, indicator = element_boundary_layer(body.kinematics, body.mesh, body.region("contact_side"),
                                                     self.SUBPOINTS + 2 * body.order)

        def layer(cf):
            form = ngs.LinearForm(tests)
            form += on_layer((indicator * cf).Compile() * v)
            return form
        self._forms = dict(residual=layer(residual * residual), norm=layer(lam * lam),
                           active=layer(ngs.IfPos(lam, 1.0, 0.0)), measure=layer(ngs.CF(1.0)))

    def __call__(self):
        values = {}
        for name, form in self._forms.items():
            form.Assemble()
            values[name] = form.vec.FV().NumPy().copy()
        squares = np.maximum(values["residual"], 0.0)
        norm = float(np.sqrt(max(values["norm"].sum(), 0.0)))
        measure = values["measure"]
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(measure > 0, values["active"] / np.where(measure > 0, measure, 1.0), 0.0)
        edges = (share > 1e-9) & (share < 1 - 1e-9)
        estimate = float(np.sqrt(squares.sum()))
        return GoalEstimate("pressure", norm, estimate, estimate / norm if norm > 0 else np.inf,
                            np.sqrt(squares), edges)


BALANCED = 1e-10
"""The held boundaries' force along F_h, relative to |F_h|, at or below which F_h counts as balanced
by the loads alone (``force_estimate``)."""


def force_estimate(force, relative_energy, held=None):
    """The force goal's ``GoalEstimate`` from the level's contact force F_h (a vector, N/m in 2D,
    N in 3D; or its norm) and its relative energy estimate η / |||x_h|||: the relative error
    (η / |||x_h|||)² (module docstring). ``held``: the force the held boundaries (Γ1 and the
    supports) exert on the body (a vector; the sum of ``StepRecord.boundary_reaction``), or None.
    Where its component along F_h is at most ``BALANCED`` |F_h| (a load-controlled body: nothing
    held takes force along F_h), the discrete equilibrium tested with the constant translation
    along F_h gives F_h = −(the loads' resultant) along it, as for the exact solution: the error
    is 0 (the loads' quadrature aside), whatever the energy estimate."""
    vector = np.atleast_1d(np.asarray(force, dtype=float))
    value = float(np.linalg.norm(vector))
    relative = float(relative_energy) ** 2
    if held is not None and value > 0 and vector.size > 1:
        along = abs(float(np.dot(np.asarray(held, dtype=float), vector / value)))
        if along <= BALANCED * value:
            relative = 0.0
    return GoalEstimate("force", value, value * relative, relative)


EDGE_SAMPLES = 64
"""Points per Γ3 facet at which λ_h is sampled to place a contact edge inside its facet."""


def edge_points(steps):
    """The contact edges of the current state of ``steps`` (a Simulation's ``time.step.Step``) in
    2D (plane or meridian section): one point
    (x, y) (m) per Γ3 facet where λ_h > 0 on part of the facet only, placed between the two
    samples (of ``EDGE_SAMPLES`` + 1 along the facet) where λ_h turns 0; an empty array in 3D
    (there an edge is a curve across facets)."""
    mesh = steps.body.mesh
    if mesh.dim != 2:
        return np.zeros((0, mesh.dim))
    names = set(steps.body.boundaries["contact_side"])
    rule = ngs.IntegrationRule([(t,) for t in np.linspace(0.0, 1.0, EDGE_SAMPLES + 1)], [1.0] * (EDGE_SAMPLES + 1))
    points = mesh.MapToAllElements(rule, ngs.BND)
    pressure = ngs.BoundaryFromVolumeCF(steps.gamma3.multiplier(steps.u, steps.phi))
    pressed = (pressure(points) > 0).reshape(-1, EDGE_SAMPLES + 1)
    xy = np.stack([ngs.x(points).ravel(), ngs.y(points).ravel()], axis=-1).reshape(-1, EDGE_SAMPLES + 1, 2)
    found = []
    for el in mesh.Elements(ngs.BND):
        row = pressed[el.nr]
        if el.mat in names and row.any() and not row.all():
            j = int(np.flatnonzero(np.diff(row.astype(int)))[0])
            found.append(0.5 * (xy[el.nr, j] + xy[el.nr, j + 1]))
    return np.array(found).reshape(-1, 2)


def elements_at_points(mesh, region_names, points, reach=0.7):
    """Boolean array over the volume elements of a 2D ``mesh``: True on those with a facet on
    the boundaries ``region_names`` whose chord, lengthened by ``reach`` times its length at
    both ends, passes within that distance of one of ``points`` ((n, 2), m)."""
    marked = np.zeros(mesh.ne, dtype=bool)
    if len(points) == 0:
        return marked
    vertices = meshes.vertex_points(mesh)
    for el in mesh.Elements(ngs.BND):
        if el.mat not in region_names:
            continue
        a, b = vertices[[v.nr for v in el.vertices]]
        length = np.linalg.norm(b - a)
        t = np.clip((points - a) @ (b - a) / length ** 2, -reach, 1 + reach)
        if np.min(np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1)) <= reach * length:
            for facet in meshes.facets_of(mesh, el):
                for volume in mesh[facet].elements:
                    marked[volume.nr] = True
    return marked
