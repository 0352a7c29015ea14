"""The surface compliance of a piezoelectric half-plane (generalised Stroh formalism,
Barnett–Lothe) and the effective moduli of the 2D piezoelectric Hertz problem.

Plane strain in the x1-x2 plane, the half-plane's surface normal x2 along the poling axis
(data axis 3 of ``Material``, as ``Material.tensors(2)`` places it along y; ``Material.poling`` and
the nonlinear laws are ignored: linear c, e, ε only). The potential φ is
a fourth displacement, the electric displacement D a fourth row of stresses, with ngcontact's
constitutive law σ = c ε + eᵀ∇φ, D = e ε − ε∇φ. Hertz (F per unit depth, radius R):
a² = 4 F R / (π E*), p(x) = p0 sqrt(1 − x²/a²), p0 = 2 F / (π a), with E* from the compliance
K of the surface (normal displacement u2 and potential φ against normal force and charge):

* insulating contact (D·n = 0 on the whole surface): E* = 2 / K11;
* conducting, equipotential contact zone: E* = 2 / (K11 − K12 K21 / K22);
* no coupling (e = 0): 2 / K11 of the elastic problem, E / (1 − ν²) when isotropic.

Units: SI (Pa, C/m², F/m). K maps (normal traction, surface charge) to the slopes of
(u2, φ) along the surface: K11 in 1/Pa, K12 = K21 in m²/C, K22 < 0 in m/F.
"""
import numpy as np

from ngcontact.model.materials import Material, _full3, _full4, _rotation


def generalised_moduli(material):
    """C[I, j, K, l] (4x3x4x3): σ_Ij = C_IjKl U_K,l with U = (u1, u2, u3, φ), σ_4j = D_j, the
    data rotated so that the poling axis is x2 (``Material`` data axis 3 -> global y)."""
    Q = _rotation("y")
    c = np.einsum("ga,hb,kc,ld,abcd->ghkl", Q, Q, Q, Q, _full4(material.c))
    e = np.einsum("ga,hb,kc,abc->ghk", Q, Q, Q, _full3(material.e))
    eps = Q @ material.eps @ Q.T
    C = np.zeros((4, 3, 4, 3))
    C[:3, :, :3, :] = c
    C[:3, :, 3, :] = np.einsum("lij->ijl", e)          # σ_ij += e_lij φ,l
    C[3, :, :3, :] = e                                  # D_j += e_jkl u_k,l
    C[3, :, 3, :] = -eps                                # D_j −= ε_jl φ,l
    return C


def impedance(material):
    """(L, s): the real 4x4 Stroh impedance L = −2i B Bᵀ of the half-plane in the scaled
    variables ψ = φ / s, D̃ = s D (for conditioning), and the scale s = sqrt(max|c| / max|ε|)."""
    s = np.sqrt(np.abs(material.c).max() / np.abs(material.eps).max())
    scale = np.array([1.0, 1.0, 1.0, s])
    C = generalised_moduli(material) * scale[:, None, None, None] * scale[None, None, :, None]
    Q, R, T = C[:, 0, :, 0], C[:, 0, :, 1], C[:, 1, :, 1]
    Ti = np.linalg.inv(T)
    N = np.block([[-Ti @ R.T, Ti], [R @ Ti @ R.T - Q, -R @ Ti]])
    p, xi = np.linalg.eig(N)
    upper = np.argsort(-p.imag)[:4]
    if not np.all(p[upper].imag > 0) or np.any(p[np.argsort(-p.imag)[4:]].imag >= 0):
        raise ValueError(f"Stroh: the eigenvalues are not four conjugate pairs off the real axis: {p}")
    A, B = xi[:4, upper], xi[4:, upper]
    B = B / np.sqrt(2 * np.einsum("ia,ia->a", A, B))    # 2 aᵀb = 1 (unconjugated)
    L = -2j * B @ B.T
    if np.abs(L.imag).max() > 1e-6 * np.abs(L.real).max():
        raise ValueError(f"Stroh: L is not real (the eigenvectors are degenerate): {L}")
    return L.real, s


def surface_compliance(material):
    """K (2x2): the (u2, φ) block of Re(L)⁻¹ (SI, module docstring). K is symmetric,
    K11 > 0 and K22 < 0."""
    L, s = impedance(material)
    M = np.linalg.inv(L)[np.ix_([1, 3], [1, 3])]
    scale = np.array([1.0, s])
    return M * scale[:, None] * scale[None, :]


def uncoupled(material):
    """The same material without its piezoelectric coupling (e = 0)."""
    return Material(material.c, 0 * material.e, material.eps, name=f"{material.name} uncoupled")


def effective_moduli(material):
    """dict(uncoupled, insulating, conducting): Hertz's E* (Pa) of the 2D contact of the
    material poled along the contact normal, without coupling, with an insulating contact
    (2/K11) and with an equipotential one (2/(K11 − K12 K21/K22))."""
    K = surface_compliance(material)
    return dict(uncoupled=2 / surface_compliance(uncoupled(material))[0, 0],
                insulating=2 / K[0, 0],
                conducting=2 / (K[0, 0] - K[0, 1] * K[1, 0] / K[1, 1]))


def charge_per_force(material):
    """−K21/K22 (C/N): the charge Q = −(K21/K22) F drawn through a grounded conducting contact
    by the normal force F (per unit depth in 2D: C/m per N/m)."""
    K = surface_compliance(material)
    return -K[1, 0] / K[1, 1]
