"""The forms of (2.30)-(2.31) as NGSolve symbolic expressions.

a(u, v) = (A ε(u), ε(v)),  b(u, v) = (F ε(u), ε(v)),
c(φ, ξ) = (C ∇φ, ∇ξ),      e(v, ξ) = (E ε(v), ∇ξ).

Strains and stresses are Voigt vectors with engineering shear, so that σ : ε(v) is the
dot product of the Voigt vectors. The electric equation is written negated,
-c(φ, ξ) + e(u, ξ) = ..., so that the coupled Jacobian is symmetric quasi-definite:
the residual of one backward Euler step n is

R((u, φ); (v, ξ)) = ∫ σ : ε(v) + ∫ D · ∇ξ − ∫ f0 · v − ∫_Γ2 f2 · v − ∫ q0 ξ − ∫_Γb qb ξ

with σ = A ε((u − u_{n−1})/k) + F ε(u) + Eᵀ∇φ and D = E ε(u) − C∇φ (model.md).
"""
import ngsolve as ngs

from .loads import as_cf


def matrix_cf(M):
    """A numpy matrix as a constant matrix-valued CoefficientFunction."""
    return ngs.CF(tuple(float(v) for v in M.flat), dims=M.shape)


def strain(u, dim):
    """ε(u) as a Voigt vector: (ε11, ε22, 2ε12) in 2D, (ε11, ε22, ε33, 2ε23, 2ε13, 2ε12) in 3D."""
    e = ngs.Sym(ngs.Grad(u))
    if dim == 2:
        return ngs.CF((e[0, 0], e[1, 1], 2 * e[0, 1]))
    return ngs.CF((e[0, 0], e[1, 1], e[2, 2], 2 * e[1, 2], 2 * e[0, 2], 2 * e[0, 1]))


def stress(tensors, u, phi, dim, strain_rate=None):
    """σ = A ε(u̇) + F ε(u) + Eᵀ ∇φ (2.3), Voigt vector; ``strain_rate`` is ε(u̇) (Voigt),
    None for the elastic part only."""
    s = matrix_cf(tensors.F) * strain(u, dim) + matrix_cf(tensors.E).trans * ngs.grad(phi)
    if tensors.viscous and strain_rate is not None:
        s = s + matrix_cf(tensors.A) * strain_rate
    return s


def electric_displacement(tensors, u, phi, dim):
    """D = E ε(u) − C ∇φ (2.4)."""
    return matrix_cf(tensors.E) * strain(u, dim) - matrix_cf(tensors.C) * ngs.grad(phi)


def normal_stress(sigma_voigt, n, dim):
    """σ_ν = σν · ν from a Voigt stress vector."""
    s = sigma_voigt
    if dim == 2:
        S = ngs.CF((s[0], s[2], s[2], s[1]), dims=(2, 2))
    else:
        S = ngs.CF((s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2]), dims=(3, 3))
    return n * (S * n)


def body_residual(body, loads, u_old, inv_dt):
    """The bulk and load part of the step residual R, as a (nonlinear-ready) BilinearForm.

    ``u_old`` is the GridFunction of u_{n−1}; ``inv_dt`` a Parameter holding 1/k.
    Contact terms on Γ3 are added to the same form by the contact module.
    """
    dim, mesh = body.dim, body.mesh
    (u, phi), (v, xi) = body.X.TnT()
    sigma = stress(body.tensors, u, phi, dim, inv_dt * (strain(u, dim) - strain(u_old, dim)))
    D = electric_displacement(body.tensors, u, phi, dim)
    R = ngs.BilinearForm(body.X, symmetric=False)
    R += (ngs.InnerProduct(sigma, strain(v, dim)) + ngs.InnerProduct(D, ngs.grad(xi))) * ngs.dx
    if loads.f0 is not None:
        R += -as_cf(loads.f0, dim, "f0") * v * ngs.dx
    if loads.q0 is not None:
        R += -as_cf(loads.q0, 1, "q0") * xi * ngs.dx
    for names, f2 in loads.f2.items():
        R += -as_cf(f2, dim, f"f2[{names!r}]") * v * ngs.ds(mesh.Boundaries(names))
    for names, qb in loads.qb.items():
        R += -as_cf(qb, 1, f"qb[{names!r}]") * xi * ngs.ds(mesh.Boundaries(names))
    return R
