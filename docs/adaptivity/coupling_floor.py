#!/usr/bin/env python3
"""The floor under every equilibrated bound on the 3D effectivity test of docs/adaptivity.md.

For the piezoelectric step problem the Prager–Synge bound's energy part,
‖C_c^{−½}(σ* − σ_h)‖² + ‖C^{−½}(D* − D_h)‖², is smallest, over all equilibrated σ* (symmetric)
and D*, at the dual norm of the residual: R_u² + R_φ² with
R_u = sup_v (σ(e), ε(v)) / ‖C_c^{½} ε(v)‖ and R_φ = sup_ψ (D(e), ∇ψ) / ‖C^{½} ∇ψ‖,
σ(e) = C_c ε(e_u) + Eᵀ∇e_φ and D(e) = E ε(e_u) − C ∇e_φ the stress and displacement of the error.
This script solves for the Riesz representers of both at order 4 on the meshes of
``scenes.manufactured.smooth_block``, the 3D test's case (a lower bound of
each supremum) and prints (R_u² + R_φ²)^½ ÷ |||e||| next to the default estimator's η ÷ |||e|||:
without coupling the floor is 1 (the symmetric case), with coupling it is what no estimator of
this kind can go below.

    python docs/adaptivity/coupling_floor.py
"""
import math

import ngsolve as ngs
import numpy as np
import sympy as sp

import ngcontact as ngc
from ngcontact.estimators.equilibrated import EquilibratedEstimator
from ngcontact.scenes.manufactured import VOIGT, smooth_block, x, y, z

RIESZ_ORDER = 4


def _strain(w):
    g = ngs.Grad(w)
    return ngs.CF(tuple(g[i, j] if i == j else g[i, j] + g[j, i] for (i, j) in VOIGT))


def _riesz(space, a, f):
    """f(z) = a(z, z) for the Riesz representer z of f in the inner product a."""
    a.Assemble()
    f.Assemble()
    z = ngs.GridFunction(space)
    z.vec.data = a.mat.Inverse(space.FreeDofs(), "sparsecholesky") * f.vec
    return ngs.InnerProduct(z.vec, f.vec)


def floor(coupling=1.0):
    """Rows (order, level, η ÷ |||e|||, energy part ÷ |||e|||, floor ÷ |||e|||) of the 3D test with
    PZT-5A's e scaled by ``coupling`` (0: uncoupled; 1: the test's material)."""
    m = ngc.pzt5a()
    material = ngc.Material(m.c / 1e10, coupling * m.e, m.eps / 1e-9, name="scaled PZT-5A")
    rows = []
    for order, level in ((1, 0), (1, 1), (2, 0)):
        sim, mms = smooth_block(material, order, level)
        body = sim.body
        estimate, error = EquilibratedEstimator(sim)(), mms.energy_error(sim)
        T, mesh = body.tensors, body.mesh
        grad_u = ngs.CF(tuple(mms.cf(sp.diff(mms.u[i], c), sim.time) for i in range(3) for c in (x, y, z)),
                        dims=(3, 3))
        grad_phi = ngs.CF(tuple(mms.cf(sp.diff(mms.phi, c), sim.time) for c in (x, y, z)))
        e = grad_u - ngs.Grad(sim.u)
        strain_e = ngs.CF(tuple(e[i, j] if i == j else e[i, j] + e[j, i] for (i, j) in VOIGT))
        dphi = grad_phi - ngs.grad(sim.phi)
        F, E, C = (ngs.CF(tuple(np.asarray(M, dtype=float).flat), dims=np.shape(M)) for M in (T.F, T.E, T.C))
        V = ngs.VectorH1(mesh, order=RIESZ_ORDER, dirichlet="left")
        w, v = V.TnT()
        R_u = _riesz(V, ngs.BilinearForm(ngs.InnerProduct(F * _strain(w), _strain(v)) * ngs.dx),
                     ngs.LinearForm(ngs.InnerProduct(F * strain_e + E.trans * dphi, _strain(v)) * ngs.dx(bonus_intorder=6)))
        W = ngs.H1(mesh, order=RIESZ_ORDER, dirichlet="bottom")
        p, q = W.TnT()
        R_phi = _riesz(W, ngs.BilinearForm(ngs.InnerProduct(C * ngs.grad(p), ngs.grad(q)) * ngs.dx),
                       ngs.LinearForm(ngs.InnerProduct(E * strain_e - C * dphi, ngs.grad(q)) * ngs.dx(bonus_intorder=6)))
        energy = math.hypot(estimate.parts["stress"], estimate.parts["flux"])
        rows.append((order, level, estimate.total / error, energy / error, math.sqrt(R_u + R_phi) / error))
    return rows


if __name__ == "__main__":
    for coupling, name in ((0.0, "uncoupled"), (1.0, "the test's coupling"), (1 / math.sqrt(10), "PZT-5A's (e/√10)")):
        for order, level, effectivity, energy, bound in floor(coupling):
            print(f"{name:22s} P{order} level {level}: η/|||e||| {effectivity:.3f}, stress and flux parts "
                  f"{energy:.3f}, floor {bound:.3f}")
