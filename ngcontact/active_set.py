"""The paper's own discrete constraint for P1: U_ad^h = {u_ν ≤ g at the nodes of Γ3} (4.3).

The Signorini part of (2.8) becomes R(x) + Bᵀλ = 0 with nodal multipliers λ_i >= 0 and
(Bx)_i = n_i·u(x_i) <= g(x_i), λ_i ((Bx)_i − g_i) = 0, solved exactly (no penalty, no
penetration at the nodes) by a primal–dual active set method (a semismooth Newton method on
λ_i = max(0, λ_i + c((Bx)_i − g_i))): each iteration solves the saddle point system
[J B_Aᵀ; B_A 0] on the active nodes A = {λ_i + c((Bx)_i − g_i) > 0}. The Γ3 residual keeps
only j_a (p and the glue) and the conduction term. λ_i are nodal forces; the recorded
pressure is the P1 field with nodal values λ_i / w_i, w_i = ∫_Γ3 φ_i da.
"""
import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .newton import Newton, NewtonError, NewtonResult, Timings
from .nitsche import NitscheContact


class NodalContact(NitscheContact):
    """Γ3 expressions when the constraint is nodal: the multiplier is a P1 pressure field."""

    def __init__(self, body, contact, beta, inv_dt, gap):
        if body.order != 1:
            raise ValueError(f"Contact.method 'active_set' is the paper's P1 scheme: it needs "
                             f"Body order 1, got {body.order}")
        super().__init__(body, contact, beta, inv_dt, gap)
        self.pressure = ngs.GridFunction(ngs.H1(body.mesh, order=1), name="nodal_pressure")

    def multiplier(self, u, phi, u_old):
        return self.pressure

    def active(self, u, phi, u_old):
        return ngs.IfPos(self.pressure, 1, 0)

    def residual(self, u, phi, v, xi, u_old):
        return self.surface_traction(u) * (v * self.n)


class ActiveSetNewton(Newton):
    """Primal–dual active set iteration for the nodal constraint; same interface as Newton.

    After ``solve``, ``constraint_vector`` holds Bᵀλ (part of the returned residual)."""

    def __init__(self, form, gfu, side, gap, pressure, **kwargs):
        super().__init__(form, gfu, **kwargs)
        mesh, dim = side.mesh, side.dim
        nv = mesh.nv
        free = np.array(list(self.freedofs), dtype=bool)
        nodes = {}
        for numbers, normal, length in zip(side.facet_vertex_numbers, side.normals, side.measure):
            for nr in numbers:
                n, w = nodes.get(nr, (np.zeros(dim), 0.0))
                nodes[nr] = (n + normal * length, w + length / dim)
        self.nodes = [nr for nr in sorted(nodes) if all(free[c * nv + nr] for c in range(dim))]
        normals = np.array([nodes[nr][0] / np.linalg.norm(nodes[nr][0]) for nr in self.nodes])
        self.weights = np.array([nodes[nr][1] for nr in self.nodes])
        rows = np.repeat(np.arange(len(self.nodes)), dim)
        cols = np.array([c * nv + nr for nr in self.nodes for c in range(dim)])
        self.B = sp.csr_matrix((normals.ravel(), (rows, cols)), shape=(len(self.nodes), len(gfu.vec)))
        points = np.array([mesh.vertices[nr].point for nr in self.nodes])
        self.g = np.array([gap(mesh(*p)) for p in points]).ravel()
        self.lam = np.zeros(len(self.nodes))
        self.pressure = pressure
        self.constraint_vector = gfu.vec.CreateVector()
        self.free = np.flatnonzero(free)

    def solve(self, *, step=None, time=None):
        x, r = self.gfu.vec, self.r
        xa = x.FV().NumPy()
        residuals, active, clock = [], None, Timings()
        for it in range(self.maxit + 1):
            self._residual(x, clock)
            self.constraint_vector.FV().NumPy()[:] = self.B.T @ self.lam
            r.data += self.constraint_vector
            gap = self.B @ xa - self.g
            new_active = self.lam + self.scales[0] * gap > 0
            norm = np.hypot(self._norm(r, -1), np.linalg.norm(np.where(new_active, gap, 0))
                            * np.sqrt(self.scales[0]))
            residuals.append(norm)
            if not np.isfinite(norm):
                raise NewtonError("diverged (non-finite residual)", iteration=it, residuals=residuals,
                                  step=step, time=time, hint="a smaller time step")
            if active is not None and np.array_equal(active, new_active) and (
                    norm <= self.rtol * residuals[0] or norm <= 1e-13 * self._norm(x, 1)):
                self._publish()
                return NewtonResult(it, residuals, r, clock)
            if it == self.maxit:
                break
            active = new_active
            with clock("assembly"):
                self.form.AssembleLinearization(x)
            vals, cols, ptr = self.form.mat.CSR()
            J = sp.csr_matrix((vals, cols, ptr))[self.free][:, self.free]
            BA = self.B[active][:, self.free]
            K = sp.bmat([[J, BA.T], [BA, None]], format="csc")
            rhs = np.concatenate([-(r.FV().NumPy() - self.constraint_vector.FV().NumPy())[self.free],
                                  -gap[active]])
            with clock("factorization"):                      # factorisation and solve
                sol = spla.spsolve(K, rhs)
            xa[self.free] += sol[:len(self.free)]
            self.lam[:] = 0.0
            self.lam[active] = sol[len(self.free):]
        raise NewtonError(f"did not converge in {self.maxit} iterations", iteration=self.maxit,
                          residuals=residuals, step=step, time=time,
                          hint="a smaller time step or a larger maxit")

    def _publish(self):
        """Nodal pressures λ_i / w_i into the P1 field used by the records."""
        values = self.pressure.vec.FV().NumPy()
        values[:] = 0.0
        values[self.nodes] = self.lam / self.weights
