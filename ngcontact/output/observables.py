"""What is recorded of a converged step: reactions, electrode charges and the state of Γ3.

Forces and charges come from the residual itself: for a test function w that is e_i on Γ1
(or 1 on one electrode) and 0 at the other boundary DOFs, R(w) is the reaction ∫_Γ1 σν·e_i
(or the flux ∫ D·ν through that electrode; exact when electrodes held at different
potentials do not touch). Likewise the force and charge flux through Γ3 are −R_Γ3(w) for
the rigid modes w = (e_i, 0) and w = (0, 1), so that the balances hold to the Newton
tolerance. The facet fields on Γ3 are exact facet averages (``ContactSide.facet_integrals``).
"""
import ngsolve as ngs
import numpy as np

from ngcontact.model import forms
from ngcontact import parallel
from ngcontact.gamma3 import integrands
from ngcontact.gamma3.contact_side import element_boundary_layer
from ngcontact.output.records import ContactRecord, StepRecord
from ngcontact.model.supports import SLIP_GAMMA0

CONTACT_RELATIVE, CONTACT_NOISE = 1e-10, 1e-11
"""The contact zone is {pressure > threshold}, threshold = max(CONTACT_RELATIVE × the step's
largest |pressure| on Γ3, CONTACT_NOISE × the body's stiffness (Pa per unit strain,
``Tensors.stiffness``)): a pressure of round-off (a gap of 1e-17 m under a mm-sized body
gives 0.1 Pa on PZT, 1e-12 of its stiffness) is not contact, and the edge of a loaded zone
moves by at most where p falls below 1e-10 of its peak."""


class Recorder:
    """Builds the records of a simulation's steps; the forms are built once.

    Parameters
    ----------
    body : Body.  state : GridFunction (u, φ) on the simulation's space.
    system : the StepSystem (its ``boundary_residual`` is R_Γ3 at the last residual).
    gamma3 : Gamma3, or None without a contact law.
    """

    def __init__(self, body, state, system, gamma3=None):
        self.body, self.state, self.system = body, state, system
        self.gamma3 = gamma3
        self._charge = {name: self._test(1, 1.0, name) for name in body.boundaries["grounded"]}
        self._held = self._held_tests()
        self._weak = self._weak_supports()
        if gamma3 is not None:
            self._facet_fields = self._build_facet_fields()
            self._rigid_modes = self._build_rigid_modes()

    def _test(self, component, value, names):
        w = ngs.GridFunction(self.state.space)
        w.components[component].Set(value, ngs.BND, definedon=self.body.mesh.Boundaries(names))
        return w.vec

    def _held_tests(self):
        """{name: [w_i]}: the test vectors e_i at the held DOFs of each boundary of Γ1 and of
        the supports along axes, each DOF in the first boundary that holds it."""
        body, dim = self.body, self.body.dim
        held = ~np.array(list(body.V.FreeDofs()), dtype=bool)
        taken = np.zeros(len(held), dtype=bool)
        parts = [(name, range(dim)) for name in body.boundaries["clamped"]]
        parts += [(name, s.axes) for s in body.supports if not s.normal for name in s.names]
        tests = {}
        for name, axes in parts:
            tests[name] = []
            for i in range(dim):
                w = self._test(0, ngs.CF(tuple(float(i == j) for j in range(dim))), name)
                values = w.FV().NumPy()[:len(held)]
                values[~held | taken | (i not in axes)] = 0.0
                tests[name].append(w)
            for w in tests[name]:
                taken |= w.FV().NumPy()[:len(held)] != 0
        return tests

    def _weak_supports(self):
        """{name: [∫ λ ν_i da]} of the weak normal supports, as functions of the state."""
        body, weak = self.body, {}
        u, phi = self.state.components
        n = ngs.specialcf.normal(body.dim)
        for support in body.supports:
            if support.normal:
                for name in support.names:
                    integral, indicator = element_boundary_layer(body.kinematics, body.mesh, body.mesh.Boundaries(name))
                    coefficients = self.system.coefficients           # the time scheme's c and û
                    lam = forms.support_multiplier(body.tensors, body.order, u, phi, coefficients.anchor,
                                                   coefficients.rate, SLIP_GAMMA0)
                    weak[name] = [integral((indicator * lam * n[i]).Compile()) for i in range(body.dim)]
        return weak

    def boundary_reaction(self, residual):
        """{name: ∫ σν da} of the held boundaries (``StepRecord.boundary_reaction``)."""
        reactions = {name: np.array([ngs.InnerProduct(residual, w) for w in tests])
                     for name, tests in self._held.items()}
        for name, integrals in self._weak.items():
            reactions[name] = parallel.sum(self.body.mesh, np.array([ngs.Integrate(f, self.body.mesh)
                                                                   for f in integrals]))
        return reactions

    def _build_rigid_modes(self):
        """The test vectors of Γ3's force (e_i) and charge flux (1); 0 along an axis that is no
        resultant (``Kinematics.resultants``: for a body of revolution the radial one, whose
        resultant vanishes by symmetry; ∫ σν·e_r da is no force)."""
        modes = []
        for i in range(self.body.dim + 1):
            if i < self.body.dim and i not in self.body.kinematics.resultants:
                modes.append(ngs.GridFunction(self.state.space).vec)
            elif i < self.body.dim:
                modes.append(self._constant(0, i))
            else:
                modes.append(self._constant(1))
        return modes

    def _constant(self, component, axis=0):
        """The vector of the state's space whose ``component`` (0: u, 1: φ) is the constant 1
        (u: along ``axis``) and the other 0, written at the vertex DOFs: a constant has no
        higher-order part in NGSolve's H1, which numbers vertex k as DOF k. ``Set`` (a projection,
        a fifth of a level's build at P2, docs/speed.md) on a distributed mesh or where that
        numbering is not found."""
        space, mesh = self.state.space, self.body.mesh
        part = space.components[component]
        scalar = part.components[axis] if component == 0 else part
        vertices = [scalar.GetDofNrs(ngs.NodeId(ngs.VERTEX, k)) for k in (0, mesh.nv - 1)] if mesh.nv else []
        w = ngs.GridFunction(space)
        if parallel.is_distributed(mesh) or vertices != [(0,), (mesh.nv - 1,)]:
            value = ngs.CF(tuple(float(axis == j) for j in range(self.body.dim))) if component == 0 else 1.0
            w.components[component].Set(value)
            return w.vec
        start = space.Range(component).start + (axis * scalar.ndof if component == 0 else 0)
        w.vec.FV().NumPy()[start:start + mesh.nv] = 1.0
        return w.vec

    def _build_facet_fields(self):
        """Facet integrals over Γ3 of the recorded fields, built once."""
        g = self.gamma3
        u, phi = self.state.components
        n = g.normal
        traction = integrands.adhesion_traction(g.contact, g.beta.gf, u * n)
        lam = g.enforcement.multiplier(u, phi, traction)
        pressure = lam + traction                               # −σ_ν = λ_h + p − γ_ν β² R_ν
        opening = u * n - g.gap
        self._threshold, self._pressure = ngs.Parameter(0.0), pressure.Compile()
        self._noise = CONTACT_NOISE * self.body.tensors.stiffness()
        fields = dict(pressure=pressure, multiplier=lam, potential=phi,
                      charge_flux_density=integrands.charge_flux_density(g.contact, u, phi, g.gap, g.foundation_potential,
                                                                    n, g.enforcement, traction),
                      contact_area=ngs.IfPos(pressure - self._threshold, 1, 0),
                      complementarity=ngs.IfPos(lam * opening, lam * opening, -lam * opening))
        residual = ("pressure", "multiplier", "contact_area", "complementarity")   # as R_Γ3 integrates
        self._multiplier = lam.Compile()                       # evaluated at Gauss points per record
        return {name: g.side.facet_integrals(cf, "residual" if name in residual else "exact")
                for name, cf in fields.items()}

    def record(self, n, time, result, *, keep_state):
        """The StepRecord of step n at ``time`` (s) from the converged NewtonResult;
        ``wall_s`` and ``timings`` are left for the caller."""
        r = result.residual
        reactions = self.boundary_reaction(r)
        return StepRecord(
            step=n, time=time, newton_iterations=result.iterations, residuals=result.residuals,
            factorizations=result.factorizations, krylov_iterations=result.krylov_iterations,
            krylov_failures=result.krylov_failures, discarded_iterations=result.discarded,
            wall_s=0.0, boundary_reaction=reactions,     # Γ1's DOFs are each in one of its names:
            reaction=sum((reactions[n] for n in self.body.boundaries["clamped"]), np.zeros(self.body.dim)),
            electrode_charge={name: -ngs.InnerProduct(r, w) for name, w in self._charge.items()},
            state=self.state.vec.FV().NumPy().copy() if keep_state else None,
            contact=self._contact_record() if self.gamma3 is not None else None)

    def _contact_record(self):
        g = self.gamma3
        side = g.side
        mesh = self.body.mesh
        scale = parallel.maximum(mesh, np.abs(side.at_gauss_points(self._pressure)), initial=0.0)
        self._threshold.Set(max(CONTACT_RELATIVE * scale, self._noise))
        integrals = {name: assemble() for name, assemble in self._facet_fields.items()}
        residual = self.system.boundary_residual.FV().NumPy()
        hook = g.enforcement.newton_hook
        if hook is not None:                         # the constraint forces Bᵀλ are Γ3 terms too
            residual = residual + hook.forces.FV().NumPy()
        # a distributed residual times cumulated rigid modes: the ranks' dot products sum up
        flux = [-float(f) for f in parallel.sum(mesh, np.array([np.dot(residual, w.FV().NumPy())
                                                                for w in self._rigid_modes]))]
        facets = {name: integrals[name] / side.weighted_measure for name in
                  ("pressure", "multiplier", "potential", "charge_flux_density", "contact_area")}
        facets.update(beta=g.beta.values.copy(), beta_unclipped=g.beta.unclipped.copy(),
                      multiplier_points=side.at_gauss_points(self._multiplier))
        # on a distributed mesh: every rank's facets, in rank order
        facets = {name: parallel.gather(mesh, values) for name, values in facets.items()}
        u = self.state.components[0]
        facets["contact_set"] = facets.pop("contact_area")
        return ContactRecord(
            **facets,
            charge_flux=flux[-1], contact_area=parallel.sum(mesh, integrals["contact_area"].sum()),
            max_penetration=parallel.maximum(mesh, side.normal_displacement(u, g.sampled_normal)
                                             - side.sample(g.gap)),
            complementarity=parallel.sum(mesh, integrals["complementarity"].sum()), force=np.array(flux[:-1]),
            beta_clipped=parallel.sum(mesh, g.beta.clipped))
