"""The paper's own discrete constraint for P1: U_ad^h = {u_ν ≤ g at the nodes of Γ3}, (4.1)-(4.3).

The Signorini part of (2.8) becomes R(x) + Bᵀλ = 0 with nodal multipliers λ_i >= 0 and
(Bx)_i = n_i·u(x_i) <= g(x_i), λ_i ((Bx)_i − g_i) = 0, solved exactly (no penalty, no
penetration at the nodes) by a primal–dual active set method, a semismooth Newton method on
λ_i = max(0, λ_i + c((Bx)_i − g_i)): each iteration solves the saddle point system
[J B_Aᵀ; B_A 0] on the active nodes A = {λ_i + c((Bx)_i − g_i) > 0}, with c the Newton
scale of the u block. The Γ3 residual keeps only j_a (p and the glue) and the conduction
term: S = 0. λ_i are nodal forces; the recorded pressure is the P1 field with nodal values
λ_i / w_i, w_i = ∫_Γ3 φ_i da; at a node of Γ3 held by a support (no multiplier: its share
of the contact force is in the reaction) it takes the mean of its free neighbours on Γ3.

``NodalConstraint`` is the enforcement method; its ``newton_hook``, ``PrimalDualActiveSet``,
takes part in the one Newton loop (``enforcement.NewtonHook``): it adds Bᵀλ to the residual, measures
the nodal gap on the active set, and makes the Newton correction of (x, λ) itself.
"""
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np


@dataclass(frozen=True)
class NodalConstraint:
    """The paper's nodal constraint for P1: ``Contact(method=NodalConstraint())``; no parameter."""

    name = "active_set"
    """The shorthand ``Contact(method=...)`` takes."""
    condensable = False                    # the saddle point systems take the full Jacobian
    distributable = False
    serial_only = ("the nodal constraint", "its saddle point systems are scipy matrices of one rank; "
                   "use 'nitsche' or 'penalty'")
    """(what it is, why it runs on one rank only) for the refusal under MPI."""
    takes_obstacle = False
    keeps_symmetry = True
    skew_symmetric = False

    @classmethod
    def from_contact(cls, contact):
        """The method of ``Contact(method="active_set")``."""
        return cls()

    def contact_fields(self):
        return {}

    def stiffness_factors(self):
        return {}

    def flags(self):
        return []

    def check_obstacle(self):
        """Raise: the constraint acts along the body's nodal normals, not an obstacle's."""
        raise ValueError("Contact.method 'active_set' constrains u·ν at the nodes with the body's "
                         "normals: it does not take an obstacle; use 'nitsche' or 'penalty'")

    def build(self, body, contact, side, *, gap, coefficients, normal):
        """The Γ3 expressions on ``body`` (``enforcement.Enforcement``)."""
        return NodalConstraintTerms(body, side, gap=gap, normal=normal)


class NodalConstraintTerms:
    """The Γ3 expressions of the nodal constraint (``enforcement.Enforcement``): the
    multiplier is the P1 pressure field of the nodal multipliers."""

    def __init__(self, body, side, *, gap, normal):
        if body.order != 1:
            raise ValueError(f"Contact.method 'active_set' is the paper's P1 scheme: it needs "
                             f"Body order 1, got {body.order}")
        self.pressure = ngs.GridFunction(ngs.H1(body.mesh, order=1), name="nodal_pressure")
        self.gap, self.n = gap, normal
        self.newton_hook = PrimalDualActiveSet(body, side, gap, self.pressure)

    def signorini(self, u, phi, v, xi, traction):
        return ngs.CF(0.0)

    def multiplier(self, u, phi, traction):
        return self.pressure

    def active(self, u, phi, traction):
        return ngs.IfPos(self.pressure, 1, 0)

    def contact_distance(self, u, phi, traction):
        """u_ν − g (m): 0 on the nodes the constraint holds, between them too (P1)."""
        return u * self.n - self.gap


class PrimalDualActiveSet:
    """The Newton hook of the nodal constraint (``enforcement.NewtonHook``).

    ``B`` (nodes × DOFs) takes the normal displacement at the free P1 vertices of Γ3, ``g``
    the gap there (m), ``lam`` the nodal multipliers (N; N/m in 2D), ``forces`` = Bᵀλ."""

    solver = "scipy.sparse.linalg.spsolve (SuperLU) on the saddle point system"

    def __init__(self, body, side, gap, pressure):
        mesh, dim, nv = body.mesh, body.dim, body.mesh.nv
        free = np.array(list(body.X.FreeDofs()), dtype=bool)
        nodes = {}
        for numbers, normal, length in zip(side.facet_vertex_numbers, side.normals, side.measure):
            points = np.array([mesh.vertices[nr].point for nr in numbers])
            shares = side.kinematics.hat_shares(points, length)     # ∫ of each hat function over the facet
            for nr, share in zip(numbers, shares):
                n, w = nodes.get(nr, (np.zeros(dim), 0.0))
                nodes[nr] = (n + normal * length, w + share)
        self.nodes = [nr for nr in sorted(nodes) if all(free[c * nv + nr] for c in range(dim))]
        # held nodes of Γ3 and the positions (in self.nodes) of their free neighbours on Γ3
        position = {nr: i for i, nr in enumerate(self.nodes)}
        neighbours = {}
        for numbers in side.facet_vertex_numbers:
            for nr in numbers:
                if nr not in position:
                    neighbours.setdefault(nr, set()).update(position[m] for m in numbers if m in position)
        self.held = [(nr, sorted(ids)) for nr, ids in neighbours.items() if ids]
        normals = np.array([nodes[nr][0] / np.linalg.norm(nodes[nr][0]) for nr in self.nodes])
        self.weights = np.array([nodes[nr][1] for nr in self.nodes])
        rows = np.repeat(np.arange(len(self.nodes)), dim)
        cols = np.array([c * nv + nr for nr in self.nodes for c in range(dim)])
        import scipy.sparse as sp                       # (here: SciPy loads when the method is used)
        self.B = sp.csr_matrix((normals.ravel(), (rows, cols)), shape=(len(self.nodes), body.X.ndof))
        points = np.array([mesh.vertices[nr].point for nr in self.nodes])
        self.g = np.array([gap(mesh(*p, VOL_or_BND=ngs.BND)) for p in points]).ravel()   # on Γ3
        self.lam = np.zeros(len(self.nodes))
        self.pressure = pressure
        self.forces = ngs.GridFunction(body.X).vec
        self.free = np.flatnonzero(free)
        self.active = self._candidate = self._gap = None

    def start(self):
        """A new solve: the active set is not known yet."""
        self.active = None

    def residual(self, x, r, norm):
        """r += Bᵀλ; returns (norm of (r, nodal gap on the candidate set), whether the set
        is the one of the last correction)."""
        self.forces.FV().NumPy()[:] = self.B.T @ self.lam
        r.data += self.forces
        self._gap = self.B @ x.FV().NumPy() - self.g
        c = norm.scales[0]
        self._candidate = self.lam + c * self._gap > 0
        value = np.hypot(norm.dual(r), np.linalg.norm(np.where(self._candidate, self._gap, 0)) * np.sqrt(c))
        settled = self.active is not None and np.array_equal(self.active, self._candidate)
        return value, settled

    def correct(self, system, x, r, timer):
        """The Newton correction of (x, λ) from the saddle point system on the candidate
        set, with the Jacobian in ``system.mat``; factorisation and solve are timed together."""
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla
        self.active = active = self._candidate
        vals, cols, ptr = system.mat.CSR()
        J = sp.csr_matrix((vals, cols, ptr))[self.free][:, self.free]
        BA = self.B[active][:, self.free]
        K = sp.bmat([[J, BA.T], [BA, None]], format="csc")
        rhs = np.concatenate([-(r.FV().NumPy() - self.forces.FV().NumPy())[self.free], -self._gap[active]])
        with timer("factorization"):
            solution = spla.spsolve(K, rhs)
        x.FV().NumPy()[self.free] += solution[:len(self.free)]
        self.lam[:] = 0.0
        self.lam[active] = solution[len(self.free):]

    def finish(self):
        """Converged: the nodal pressures λ_i / w_i into the P1 field used by the records."""
        values = self.pressure.vec.FV().NumPy()
        values[:] = 0.0
        values[self.nodes] = self.lam / self.weights
        for nr, ids in self.held:
            values[nr] = values[[self.nodes[i] for i in ids]].mean()

    def save(self):
        return self.lam.copy()

    def restore(self, saved):
        self.lam[:] = saved
        self.finish()
