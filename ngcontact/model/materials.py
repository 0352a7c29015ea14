"""The constitutive tensors of (2.3)-(2.4): elasticity F, viscosity A, piezoelectric E, permittivity C.

Data are entered as in data sheets, in 3D Voigt notation with the order
(11, 22, 33, 23, 13, 12) and engineering shear strains:

* ``c``   -- elastic stiffness c_IJ at constant electric field, 6x6, Pa (the paper's F);
* ``eta`` -- viscosity η_IJ, 6x6, Pa·s (the paper's A); ``None`` for a purely elastic body;
* ``e``   -- piezoelectric stress constants e_iJ, 3x6, C/m² (the paper's E);
* ``eps`` -- permittivity at constant strain ε_ij, 3x3, F/m (the paper's C).

Axis 3 of the data is the poling direction. ``Material.tensors(kinematics)`` turns the data
into the matrices the forms use: the material axes are rotated (cyclically, a proper
rotation) so that axis 3 points along ``poling``, and the kinematics keeps its own rows and
columns (``Kinematics.indices_3d``): in plane strain the in-plane ones -- ε_zz = ε_xz = ε_yz = 0
and E_z = 0 -- so F is 3x3 on (11, 22, 12), E is 2x3 and C is 2x2.

With ``σ = A ε(u̇) + F ε(u) + Eᵀ∇φ`` and ``D = E ε(u) − C∇φ`` (docs/model.md), a column
loaded along its poling axis is stiffer open-circuit than short-circuit:
c33 + e33²/ε33 against c33.
"""
from dataclasses import dataclass, replace

import ngsolve as ngs
import numpy as np

from ngcontact.checks import number
from ngcontact.model import axisymmetric as axisymmetric_model
from ngcontact.model import kinematics as kinematics_model
from ngcontact.model.laws import StrainLaw
from ngcontact.model.voigt import matrix_cf

EPS0 = 8.8541878128e-12
"""Vacuum permittivity ε0 in F/m."""

VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
"""Voigt order of the index pairs (11, 22, 33, 23, 13, 12), zero-based."""


def _full4(c):
    """6x6 Voigt matrix -> 3x3x3x3 tensor."""
    t = np.zeros((3, 3, 3, 3))
    for I, (i, j) in enumerate(VOIGT):
        for J, (k, l) in enumerate(VOIGT):
            for a, b in {(i, j), (j, i)}:
                for m, n in {(k, l), (l, k)}:
                    t[a, b, m, n] = c[I, J]
    return t


def _full3(e):
    """3x6 Voigt matrix -> 3x3x3 tensor."""
    t = np.zeros((3, 3, 3))
    for J, (k, l) in enumerate(VOIGT):
        t[:, k, l] = t[:, l, k] = e[:, J]
    return t


def _rotation(poling):
    """Q[g, m] = 1 where material axis m lies along global axis g; material axis 3 -> poling."""
    shift = {"z": 0, "y": -1, "x": 1}[poling]
    Q = np.zeros((3, 3))
    for m in range(3):
        Q[(m + shift) % 3, m] = 1.0
    return Q


def _symmetric_positive_definite(name, M, unit, allow_zero=False):
    if not np.all(np.isfinite(M)):
        raise ValueError(f"Material: {name} has non-finite entries")
    if not np.allclose(M, M.T, rtol=1e-10, atol=1e-12 * np.abs(M).max()):
        raise ValueError(f"Material: {name} must be symmetric")
    if allow_zero and not np.any(M):
        return
    lmin = np.linalg.eigvalsh(M).min()
    if lmin <= 1e-12 * np.abs(M).max():
        raise ValueError(f"Material: {name} must be positive definite (allowed: symmetric with all "
                         f"eigenvalues > 0); its smallest eigenvalue is {lmin:.4g} {unit}")


COUPLING_LIMIT = 1e8
"""The largest piezoelectric stiffening λ_max(c^-½ eᵀ ε⁻¹ e c^-½) accepted: the factor by which the
coupling stiffens the body at open circuit (PZT-5A 1.05; the strong-coupling study runs to
10⁴). Beyond it the charges outweigh the forces by its square root in Newton's scaled norms, and
a residual of the forces would hide under the tolerance of the charges."""


def _physical_scales(c, e, eps):
    """Refuse a permittivity below the vacuum's ε0 (relative permittivity < 1 in some direction)
    and a coupling so strong that the electric part swamps the mechanical one numerically."""
    lmin = np.linalg.eigvalsh(eps).min()
    if lmin < EPS0 * (1 - 1e-9):
        raise ValueError(f"Material: permittivity eps must be >= ε0 = {EPS0:.6g} F/m in every direction (a "
                         f"relative permittivity >= 1: no material is below the vacuum); its smallest "
                         f"eigenvalue is {lmin:.4g} F/m")
    w, v = np.linalg.eigh(c)
    root = v @ np.diag(w ** -0.5) @ v.T                        # c^-½
    stiffening = np.linalg.eigvalsh(root @ e.T @ np.linalg.solve(eps, e) @ root).max()
    if stiffening > COUPLING_LIMIT:
        raise ValueError(f"Material: the coupling e with the permittivity eps stiffens the body {stiffening:.3g}-fold "
                         f"(λ_max(c^-½ eᵀ eps⁻¹ e c^-½); allowed <= {COUPLING_LIMIT:g}, PZT-5A 1.05): the "
                         "electric part would swamp the mechanical one in the solver; check the units of e "
                         "(C/m²) and eps (F/m)")


@dataclass(frozen=True)
class MaterialTensors:
    """The model-dimensional matrices (Voigt, engineering shear) used by the forms."""
    F: np.ndarray
    A: np.ndarray
    E: np.ndarray
    C: np.ndarray
    F_law: object = None
    """A nonlinear elasticity (``laws.BoundLaw``) or None; F is then its tangent at ε = 0."""
    A_law: object = None
    """A nonlinear viscosity (``laws.BoundLaw``) or None; A is then its tangent at ε̇ = 0."""
    kinematics: kinematics_model.Kinematics = None
    """The representation the tensors act in (``model.kinematics``)."""

    @property
    def axisymmetric(self):
        """Tensors of a body of revolution (strains (rr, zz, rz, θθ))."""
        return isinstance(self.kinematics, kinematics_model.Axisymmetric)

    def strain(self, u):
        """ε(u) as the Voigt vector these tensors act on (``Kinematics.strain``): (ε11, ε22,
        2ε12) in plane strain, six components in 3D, (ε_rr, ε_zz, 2ε_rz, ε_θθ) for a body of
        revolution."""
        return self.kinematics.strain(u)

    @property
    def viscous(self):
        return bool(np.any(self.A)) or self.A_law is not None

    @property
    def linear(self):
        """True for the fast path: constant tensors, no law."""
        return self.F_law is None and self.A_law is None

    def tangent(self):
        """These tensors without their laws: F and A their tangents at 0."""
        return self if self.linear else replace(self, F_law=None, A_law=None)

    def elastic_stress(self, strain):
        """F ε (Voigt CF) for a Voigt strain CF: the law's, or the tensor's."""
        if self.F_law is not None:
            return self.F_law.voigt_stress(strain)
        return matrix_cf(self.F) * strain

    def viscous_stress(self, strain_rate):
        """A ε̇ (Voigt CF) for a Voigt strain rate CF: the law's, or the tensor's."""
        if self.A_law is not None:
            return self.A_law.voigt_stress(strain_rate)
        return matrix_cf(self.A) * strain_rate

    def stiffness(self, rate=0.0):
        """λ_max(F + Eᵀ C⁻¹ E) + c λ_max(A), in Pa: the scale of σ_ν per unit strain in a
        time step whose rate coefficient is c = ``rate`` (1/s, a number or a Parameter; 1/dt
        for a backward Euler step of length dt). The open-circuit tensor F + Eᵀ C⁻¹ E bounds
        the coupled stiffness; c A is the viscous stiffness of the step. With a law, each part
        is scaled by L / |F'(0)| where the law's Lipschitz constant L exceeds the norm of its
        tangent at 0 (both as maps of the strain matrix, Frobenius norms): the contact stiffness
        scale follows the law, and a law that is linear gives the linear scale exactly. L is
        the law's stiffness ``scale`` now (``laws.BoundLaw``: raised where the run's strains
        found the law steeper); ``contact_stiffness`` follows its later changes."""
        elastic = np.linalg.eigvalsh(self.F + self.E.T @ np.linalg.solve(self.C, self.E)).max()
        if self.F_law is not None:
            elastic *= max(1.0, self.F_law.scale.Get() / frobenius_norm(self.F))
        viscous = np.linalg.eigvalsh(self.A).max() if np.any(self.A) else 0.0
        if self.A_law is not None:
            viscous *= max(1.0, self.A_law.scale.Get() / frobenius_norm(self.A))
        return elastic + rate * viscous

    def contact_stiffness(self, rate=0.0):
        """``stiffness`` as a CoefficientFunction that follows the laws' stiffness ``scale``
        Parameters through the run (Nitsche's γ, the penalty: ``forms.boundary_stiffness``); the
        number itself without laws."""
        if self.linear:
            return self.stiffness(rate)

        def factor(law, tensor):
            if law is None:
                return 1.0
            norm = frobenius_norm(tensor)
            return ngs.IfPos(law.scale - norm, law.scale / norm, 1.0)
        elastic = np.linalg.eigvalsh(self.F + self.E.T @ np.linalg.solve(self.C, self.E)).max()
        viscous = np.linalg.eigvalsh(self.A).max() if np.any(self.A) else 0.0
        return elastic * factor(self.F_law, self.F) + rate * (viscous * factor(self.A_law, self.A))


@dataclass(frozen=True)
class Material:
    """A linear electro-viscoelastic material, data in 3D Voigt notation (SI units).

    Parameters
    ----------
    c : (6, 6) array_like of real numbers (complex data is refused), elastic stiffness c_IJ
        in Pa (F in (2.3)).
    e : (3, 6) array_like, piezoelectric constants e_iJ in C/m² (E in (2.3)-(2.4)).
    eps : (3, 3) array_like, permittivity ε_ij in F/m (C in (2.4)).
    eta : (6, 6) array_like or None, viscosity in Pa·s (A in (2.3)); None or zero for an
        elastic body, solved quasi-statically step by step.
    poling : {"x", "y", "z"} or None, the global axis along which data axis 3 points;
        None means the last axis of the mesh ("y" in 2D, "z" in 3D).
    name : str, for printing.
    """
    c: np.ndarray
    e: np.ndarray
    eps: np.ndarray
    eta: np.ndarray = None
    poling: str = None
    name: str = ""
    elasticity_law: StrainLaw = None
    """A nonlinear elasticity F(ε) (``laws``), or None: the linear c."""
    viscosity_law: StrainLaw = None
    """A nonlinear viscosity A(ε̇) (``laws``), or None: the linear eta."""

    def __post_init__(self):
        def arr(name, shape):
            value = getattr(self, name)
            try:
                a = np.array(value)
            except ValueError:                                   # ragged nested lists
                raise ValueError(f"Material: {name} must have shape {shape}, got {value!r}") from None
            if np.iscomplexobj(a) or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
                raise TypeError(f"Material: {name} must be a {shape} array of real numbers, got {a.dtype} "
                                f"entries ({type(value).__name__})")
            a = a.astype(float)
            if a.shape != shape:
                raise ValueError(f"Material: {name} must have shape {shape}, got {a.shape}")
            object.__setattr__(self, name, a)
        arr("c", (6, 6))
        arr("e", (3, 6))
        arr("eps", (3, 3))
        if self.eta is None:
            object.__setattr__(self, "eta", np.zeros((6, 6)))
        arr("eta", (6, 6))
        if not np.all(np.isfinite(self.e)):
            raise ValueError("Material: e has non-finite entries")
        _symmetric_positive_definite("elasticity c (F)", self.c, "Pa")
        _symmetric_positive_definite("viscosity eta (A)", self.eta, "Pa·s", allow_zero=True)
        _symmetric_positive_definite("permittivity eps (C)", self.eps, "F/m")
        _physical_scales(self.c, self.e, self.eps)
        if not isinstance(self.name, str):
            raise TypeError(f"Material: name must be a str, got {type(self.name).__name__}")
        if self.poling not in (None, "x", "y", "z"):
            raise ValueError(f"Material: poling must be 'x', 'y', 'z' or None, got {self.poling!r}")
        for key in ("elasticity_law", "viscosity_law"):
            value = getattr(self, key)
            if value is not None and not isinstance(value, StrainLaw):
                object.__setattr__(self, key, _law(value))

    @classmethod
    def isotropic(cls, E, nu, permittivity, e31=0.0, e33=0.0, e15=0.0,
                  viscosity=0.0, bulk_viscosity=0.0, poling=None, name="isotropic"):
        """Isotropic elasticity (Young's modulus E in Pa, Poisson ratio nu), isotropic
        permittivity (F/m), transversely isotropic piezo coupling (C/m²), and isotropic
        viscosity A ε = 2 viscosity ε + bulk_viscosity tr(ε) I (Pa·s)."""
        E, nu = number("E", E, 0, low_open=True, unit="Pa"), number("nu", nu, -1, 0.5, low_open=True, high_open=True)
        permittivity = number("permittivity", permittivity, EPS0, unit="F/m")   # ε0: the vacuum's
        for key, value in dict(e31=e31, e33=e33, e15=e15).items():
            number(key, value, unit="C/m²")
        for key, value in dict(viscosity=viscosity, bulk_viscosity=bulk_viscosity).items():
            number(key, value, 0, unit="Pa·s")
        return cls(c=isotropic_stiffness(E, nu), e=transversely_isotropic_piezo(e31, e33, e15),
                   eps=permittivity * np.eye(3),
                   eta=lame_stiffness(bulk_viscosity, viscosity, "bulk_viscosity", "viscosity"),
                   poling=poling, name=name)

    def with_viscosity(self, relaxation_time):
        """The same material with Kelvin-Voigt viscosity: a number τ (s) gives the
        proportional A = τ F (c as data); a law (``laws.StrainLaw``, or a Python function of
        the strain-rate matrix CF returning the stress, Pa) the nonlinear A(ε̇) of (2.16),
        whose linear part, for the built-in laws, is this material's eta."""
        if callable(relaxation_time) or isinstance(relaxation_time, StrainLaw):
            return replace(self, viscosity_law=_law(relaxation_time))
        relaxation_time = number("relaxation_time", relaxation_time, 0, unit="s")
        return replace(self, eta=relaxation_time * self.c, viscosity_law=None)

    def with_elasticity(self, law):
        """The same material with the nonlinear elasticity F(ε) of (2.17): a ``laws.StrainLaw``
        or a Python function of the strain matrix CF returning the stress (Pa); the built-in
        laws add to this material's c. ``None``: back to the linear c."""
        return replace(self, elasticity_law=None if law is None else _law(law))

    def tensors(self, kinematics, axisymmetric=False):
        """F, A, E, C in the representation of ``kinematics`` (``model.kinematics``; or a mesh
        dimension 2 or 3, plane strain for 2, with ``axisymmetric`` a body of revolution about
        the mesh's y axis, components (rr, zz, rz, θθ), the poling along the axis)."""
        kinematics = kinematics_model.of(kinematics, axisymmetric)
        dim = kinematics.mesh_dim
        poling = self.poling or kinematics.default_poling
        if "xyz".index(poling) >= dim:
            raise ValueError("Material: poling must be 'x' or 'y' in 2D (plane strain in the x-y plane)")
        if kinematics.default_poling != poling and isinstance(kinematics, kinematics_model.Axisymmetric):
            raise ValueError(f"Material: poling must be along the axis of revolution ('y', the mesh's axis) for an "
                             f"axisymmetric body, got {poling!r}")
        Q = _rotation(poling)

        def four(c):                             # the 6 × 6 Voigt matrix in the global frame
            t = np.einsum("ga,hb,kc,ld,abcd->ghkl", Q, Q, Q, Q, _full4(c))
            return np.array([[t[i, j, k, l] for (k, l) in VOIGT] for (i, j) in VOIGT])

        c3, eta3 = four(self.c), four(self.eta)
        e = np.einsum("ga,hb,kc,abc->ghk", Q, Q, Q, _full3(self.e))
        e = np.array([[e[i, k, l] for (k, l) in VOIGT] for i in range(3)])
        eps = Q @ self.eps @ Q.T
        if isinstance(kinematics, kinematics_model.Axisymmetric):
            twist = axisymmetric_model.twist_coupling(c3, eta3, e, eps)
            if twist:
                raise ValueError(f"Material {self.name or ''}: its data couple the axisymmetric fields to twist "
                                 f"({twist}) with the poling along the axis of revolution: torsion-free "
                                 "axisymmetric fields would not be in balance; an axisymmetric body needs a "
                                 "material transversely isotropic about its poling axis (isotropic, or a poled "
                                 "ceramic, class 6mm), read in the frame (e_r, e_z, e_θ) at each point")
        idx = kinematics.indices_3d
        F, A = c3[np.ix_(idx, idx)], eta3[np.ix_(idx, idx)]
        F_law = A_law = None
        if self.elasticity_law is not None:
            F_law = self.elasticity_law.bind(F, kinematics, "elasticity")
            F = F_law.linear
        if self.viscosity_law is not None:
            A_law = self.viscosity_law.bind(A, kinematics, "viscosity")
            A = A_law.linear
        return MaterialTensors(F=F, A=A, E=e[:dim][:, idx], C=eps[:dim, :dim], F_law=F_law, A_law=A_law,
                               kinematics=kinematics)


def frobenius_norm(M):
    """The norm of a Voigt matrix (engineering strain -> stress) as a map of strain matrices in
    the Frobenius norm (|ε|² = Σ ε_ij², σ likewise)."""
    n = M.shape[0]
    shear = n - (2 if n == 3 else 3)
    strain = np.concatenate([np.ones(n - shear), np.full(shear, 2.0)])       # γ = 2 ε_ij
    stress = np.concatenate([np.ones(n - shear), np.full(shear, np.sqrt(2.0))])
    return float(np.linalg.norm(stress[:, None] * M * strain[None, :] / np.sqrt(2.0) ** (strain > 1), 2))


def _law(law):
    """A StrainLaw from a law or a Python function (a string or other object: TypeError)."""
    return law if isinstance(law, StrainLaw) else StrainLaw(law)


def lame_stiffness(lam, mu, lam_name="lam", mu_name="mu"):
    """6x6 Voigt matrix of λ tr(ε) I + 2 μ ε (Lamé parameters, Pa or Pa·s)."""
    if mu < 0 or lam < 0 and 3 * lam + 2 * mu <= 0:
        raise ValueError(f"{mu_name} must be >= 0 and 3 {lam_name} + 2 {mu_name} > 0 "
                         f"(got {lam_name}={lam}, {mu_name}={mu})")
    c = np.zeros((6, 6))
    c[:3, :3] = lam
    c[np.arange(3), np.arange(3)] += 2 * mu
    c[np.arange(3, 6), np.arange(3, 6)] = mu
    return c


def isotropic_stiffness(E, nu):
    """6x6 Voigt stiffness from Young's modulus E (Pa) and Poisson ratio nu."""
    if not E > 0:
        raise ValueError(f"Young's modulus E must be > 0 Pa, got {E}")
    if not -1 < nu < 0.5:
        raise ValueError(f"Poisson ratio nu must lie in (-1, 0.5), got {nu}")
    return lame_stiffness(E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu)))


def transversely_isotropic_piezo(e31, e33, e15):
    """3x6 Voigt e_iJ of a poled ceramic (class 6mm) with poling along data axis 3, C/m²."""
    e = np.zeros((3, 6))
    e[2, 0] = e[2, 1] = e31
    e[2, 2] = e33
    e[0, 4] = e[1, 3] = e15
    return e


def transversely_isotropic_stiffness(c11, c12, c13, c33, c44, c66=None):
    """6x6 Voigt c_IJ of a poled ceramic (class 6mm), Pa; c66 = (c11 - c12)/2 by default."""
    c66 = (c11 - c12) / 2 if c66 is None else c66
    return np.array([[c11, c12, c13, 0, 0, 0],
                     [c12, c11, c13, 0, 0, 0],
                     [c13, c13, c33, 0, 0, 0],
                     [0, 0, 0, c44, 0, 0],
                     [0, 0, 0, 0, c44, 0],
                     [0, 0, 0, 0, 0, c66]], dtype=float)


def academic(relaxation_time=0.0):
    """Isotropic elasticity with ZnO-like coupling, the kind of set used in the
    mathematical contact literature.

    λ = 105 GPa, μ = 45 GPa; e31 = -0.61, e33 = 1.14, e15 = -0.59 C/m²;
    ε11 = 8.3 ε0, ε33 = 8.8 ε0. These are the numbers of the piezoelectric examples of
    the conmech package (KOS-UJ/conmech, ``examples/example_piezo_quasistatic.py``, on
    its "Barboteu2008" mesh), read as GPa, C/m² and relative permittivities; they were
    not checked against Barboteu, Fernández & Ouafik, ESAIM M2AN 42 (2008) 667-682.
    Viscosity A = τ F with τ = ``relaxation_time`` (s).
    """
    c = lame_stiffness(105e9, 45e9)
    return Material(c, transversely_isotropic_piezo(-0.61, 1.14, -0.59),
                    np.diag([8.3, 8.3, 8.8]) * EPS0, number("relaxation_time", relaxation_time, 0, unit="s") * c, name="academic")


def pzt5a(relaxation_time=0.0):
    """PZT-5A (poled ceramic, class 6mm), constants as commonly tabulated after
    Berlincourt, Curran & Jaffe, Physical Acoustics I-A (1964), ch. 3:

    c11 = 121, c12 = 75.4, c13 = 75.2, c33 = 111, c44 = 21.1, c66 = 22.6 GPa;
    e31 = -5.4, e33 = 15.8, e15 = 12.3 C/m²; ε11^S = 916 ε0, ε33^S = 830 ε0.
    (Checked against a second tabulation, the FreeFem piezoelectricity module:
    docs/measurements.md, section ngcontact/model/materials.py; not checked against the
    primary text.) Viscosity A = τ F with τ = ``relaxation_time`` (s).
    """
    c = transversely_isotropic_stiffness(121e9, 75.4e9, 75.2e9, 111e9, 21.1e9, 22.6e9)
    return Material(c, transversely_isotropic_piezo(-5.4, 15.8, 12.3),
                    np.diag([916.0, 916.0, 830.0]) * EPS0, number("relaxation_time", relaxation_time, 0, unit="s") * c, name="PZT-5A")


def batio3(relaxation_time=0.0):
    """BaTiO3 (poled ceramic), constants as tabulated by Dunn & Taya, Int. J. Solids
    Struct. 30 (1993) 161-175, after Berlincourt & Jaffe, Phys. Rev. 111 (1958) 143:

    c11 = 166, c12 = 77, c13 = 78, c33 = 162, c44 = 43 GPa, c66 = (c11 - c12)/2;
    e31 = -4.4, e33 = 18.6, e15 = 11.6 C/m²; ε11 = 11.2e-9, ε33 = 12.6e-9 F/m.
    (Quoted from memory of that table and cross-checked only on c13, c33, c44 and e
    against another public tabulation.) Viscosity A = τ F with τ = ``relaxation_time``.
    """
    c = transversely_isotropic_stiffness(166e9, 77e9, 78e9, 162e9, 43e9)
    return Material(c, transversely_isotropic_piezo(-4.4, 18.6, 11.6),
                    np.diag([11.2e-9, 11.2e-9, 12.6e-9]), number("relaxation_time", relaxation_time, 0, unit="s") * c, name="BaTiO3")
