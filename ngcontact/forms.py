"""The forms of (2.30)-(2.31) as NGSolve symbolic expressions.

a(u, v) = (A ε(u), ε(v)),  b(u, v) = (F ε(u), ε(v)),
c(φ, ξ) = (C ∇φ, ∇ξ),      e(v, ξ) = (E ε(v), ∇ξ).

Strains and stresses are Voigt vectors with engineering shear, so that σ : ε(v) is the
dot product of the Voigt vectors. The electric equation is written negated,
-c(φ, ξ) + e(u, ξ) = ..., so that the coupled Jacobian is symmetric quasi-definite:
the residual of one backward Euler step n is

R((u, φ); (v, ξ)) = ∫ σ : ε(v) + ∫ D · ∇ξ − ∫ f0 · v − ∫_Γ2 f2 · v − ∫ q0 ξ − ∫_Γb qb ξ

with σ = A ε((u − u_{n−1})/k) + F ε(u) + Eᵀ∇φ and D = E ε(u) − C∇φ (model.md); it is
assembled in parts by ``system.StepSystem``.
"""
import ngsolve as ngs



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

