"""Manufactured solutions of the strong form (2.1)-(2.6) of model.md.

Given smooth u(x, t), φ(x, t) as sympy expressions in x, y (, z) and t, the data
f0 = −div σ, q0 = −div D, f2 = σν on Γ2 and qb = D·ν on Γb make them the exact solution,
with σ = A ε(u̇) + F ε(u) + Eᵀ∇φ and D = E ε(u) − C∇φ.
"""
import math

import ngsolve as ngs
import numpy as np
import sympy as sp

from .loads import Loads
from .materials import VOIGT

x, y, z, t = sp.symbols("x y z t")


def _voigt_strain(u, X, dim):
    """ε(u) in Voigt order with engineering shear (ε_ii, then ∂_j u_i + ∂_i u_j)."""
    pairs = [(i, j) for (i, j) in VOIGT if i < dim and j < dim]
    return sp.Matrix([sp.diff(u[i], X[i]) if i == j else sp.diff(u[i], X[j]) + sp.diff(u[j], X[i])
                      for (i, j) in pairs]), pairs


class Manufactured:
    """Exact (u, φ) and the loads that produce them, for the tensors of a Body."""

    def __init__(self, tensors, u, phi, dim=2):
        X = (x, y, z)[:dim]
        self.dim, self.u, self.phi = dim, sp.Matrix(u), sp.sympify(phi)
        F, A, E, C = (sp.Matrix(np.asarray(m)) for m in (tensors.F, tensors.A, tensors.E, tensors.C))
        eps, pairs = _voigt_strain(self.u, X, dim)
        eps_dot = sp.diff(eps, t)
        grad_phi = sp.Matrix([sp.diff(self.phi, c) for c in X])
        s = F * eps + A * eps_dot + E.T * grad_phi
        sigma = sp.zeros(dim, dim)
        for k, (i, j) in enumerate(pairs):
            sigma[i, j] = sigma[j, i] = s[k]
        self.sigma = sigma
        self.D = E * eps - C * grad_phi
        self.f0 = sp.Matrix([-sum(sp.diff(sigma[i, j], X[j]) for j in range(dim)) for i in range(dim)])
        self.q0 = -sum(sp.diff(self.D[i], X[i]) for i in range(dim))

    @staticmethod
    def cf(expr, time):
        """A sympy expression (or matrix) as an ngsolve CoefficientFunction at ``time``."""
        names = {"x": ngs.x, "y": ngs.y, "z": ngs.z, "t": time, "sin": ngs.sin, "cos": ngs.cos,
                 "exp": ngs.exp, "pi": math.pi, "sqrt": ngs.sqrt}
        if isinstance(expr, sp.MatrixBase):
            values = tuple(Manufactured.cf(e, time) for e in expr)
            return ngs.CF(values, dims=expr.shape) if expr.shape[1] > 1 else ngs.CF(values)
        return ngs.CF(eval(str(sp.sympify(expr)), names)) if expr.free_symbols else ngs.CF(float(expr))

    def loads(self, body, time):
        """Loads making (u, φ) exact: f0, q0, and σν / D·ν on Γ2 / Γb \\ Γ3."""
        n = ngs.specialcf.normal(self.dim)
        sigma, D = self.cf(self.sigma, time), self.cf(self.D, time)
        f2 = {name: sigma * n for name in body.free_names(("clamped", "contact"))}
        qb = {name: D * n for name in body.free_names(("grounded", "contact"))}
        return Loads(f0=self.cf(self.f0, time), q0=self.cf(self.q0, time), f2=f2, qb=qb)

    def errors(self, sim):
        """‖ε(u − u_h)‖ and ‖∇(φ − φ_h)‖ (L²(Ω)) at the simulation's current time."""
        mesh, dim = sim.body.mesh, self.dim
        grad_u = ngs.CF(tuple(self.cf(sp.diff(self.u[i], c), sim.time) for i in range(dim)
                              for c in (x, y, z)[:dim]), dims=(dim, dim))
        grad_phi = ngs.CF(tuple(self.cf(sp.diff(self.phi, c), sim.time) for c in (x, y, z)[:dim]))
        de = ngs.Sym(grad_u - ngs.Grad(sim.u))
        dp = grad_phi - ngs.grad(sim.phi)
        order = 2 * max(sim.body.order, sim.body.order_phi) + 4
        return (math.sqrt(ngs.Integrate(ngs.InnerProduct(de, de), mesh, order=order)),
                math.sqrt(ngs.Integrate(ngs.InnerProduct(dp, dp), mesh, order=order)))
