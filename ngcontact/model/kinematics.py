"""Kinematics: how a body's displacement makes its strain, and how its integrals are taken.

One object per representation, chosen once by the Body (``of``):

* ``PlaneStrain``: a 2D mesh, u = (u_x, u_y), ε_i3 = 0; Voigt (ε11, ε22, 2ε12); integrals per
  metre of depth.
* ``Solid3D``: a 3D mesh; Voigt (ε11, ε22, ε33, 2ε23, 2ε13, 2ε12).
* ``Axisymmetric``: a 2D mesh read as the meridian section of a body of revolution
  (``model.axisymmetric``): Voigt (ε_rr, ε_zz, 2ε_rz, ε_θθ) in the frame (e_r, e_z, e_θ) =
  (x, y, z); every integral carries 2π r, so that it is over the whole body.

Each gives the strain of u as a Voigt vector (engineering shear) and the matrix ↔ vector maps
of its strains and stresses (``pairs``: the entry (i, j) of the strain matrix each Voigt
component stands for; laws act on the matrices, ``matrix_size`` square), the positions of its
components in the 3D Voigt vector (``indices_3d``, for the material's tensors), the measures
``dx`` and ``ds`` with the weight folded in, and the rigid motions.
"""
from __future__ import annotations


import ngsolve as ngs
import numpy as np

from ngcontact.model import axisymmetric

VOIGT_3D = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
"""The entries (i, j) of the 3D Voigt vector (11, 22, 33, 23, 13, 12)."""
AXES = "xyz"


class Kinematics:
    """The common part: Voigt maps from ``pairs``, unweighted measures."""

    name = ""
    mesh_dim = 0
    """The dimension of the mesh, of u and of ∇φ."""
    pairs: tuple = ()
    """The entry (i, j) of the strain matrix (i <= j) of each Voigt component."""
    matrix_size = 0
    """The size of the strain and stress matrices (laws act on them)."""
    weight = None
    """The measure's weight per unit mesh measure (a CoefficientFunction), None for 1."""

    @property
    def size(self):
        """The length of the Voigt vectors."""
        return len(self.pairs)

    @property
    def indices_3d(self):
        """The positions of the Voigt components in the 3D Voigt vector (``VOIGT_3D``)."""
        return [VOIGT_3D.index(pair) for pair in self.pairs]

    @property
    def default_poling(self):
        """The axis along which a material's data axis 3 points unless it says otherwise."""
        return AXES[self.mesh_dim - 1]

    # ------------------------------------------------------------------ strains and stresses
    def strain(self, u):
        """ε(u) as a Voigt vector (engineering shear)."""
        return self.strain_vector(ngs.Sym(ngs.Grad(u)))

    def strain_vector(self, e):
        """The Voigt vector of a symmetric strain matrix CF ``e`` (engineering shear)."""
        return ngs.CF(tuple(e[i, j] if i == j else 2 * e[i, j] for i, j in self.pairs))

    def stress_vector(self, S):
        """The Voigt vector of a stress matrix CF ``S``."""
        return ngs.CF(tuple(S[i, j] for i, j in self.pairs))

    def strain_matrix(self, s):
        """The symmetric strain matrix CF of a Voigt strain vector ``s``."""
        return self._matrix(s, 2)

    def stress_matrix(self, s):
        """The symmetric stress matrix CF of a Voigt stress vector ``s``."""
        return self._matrix(s, 1)

    def _matrix(self, s, shear):
        where = {}
        for k, (i, j) in enumerate(self.pairs):
            where[i, j] = where[j, i] = (k, 1 if i == j else shear)
        n = self.matrix_size
        entries = []
        for i in range(n):
            for j in range(n):
                k, divisor = where.get((i, j), (None, 1))
                entries.append(ngs.CF(0.0) if k is None else s[k] / divisor if divisor != 1 else s[k])
        return ngs.CF(tuple(entries), dims=(n, n))

    def plane_stress_matrix(self, s):
        """The stress matrix CF of a Voigt stress vector ``s`` in the mesh's own dimensions (its
        rows are the fluxes whose divergence balances the loads)."""
        return self.stress_matrix(s)

    def traction(self, s, n):
        """σn for a Voigt stress vector ``s`` and a vector ``n`` of the mesh's dimension."""
        return self.plane_stress_matrix(s) * n

    def symmetric_vector(self, S):
        """The Voigt vector (stress convention: no factor 2) of the symmetric part of a square
        matrix CF ``S`` of this kinematics' size."""
        return ngs.CF(tuple(S[i, j] if i == j else 0.5 * (S[i, j] + S[j, i]) for i, j in self.pairs))

    def skew_square(self, S):
        """|skew S|² (Frobenius) of a square matrix CF ``S`` of this kinematics' size."""
        return sum(0.5 * (S[i, j] - S[j, i]) ** 2 for i, j in sorted(self.pairs) if i != j)

    def project(self, strain):
        """A strain matrix (numpy) with the entries this kinematics has no component for set
        to 0 (the strains its laws are sampled at)."""
        if len(self.pairs) == self.matrix_size * (self.matrix_size + 1) // 2:
            return strain
        kept = np.zeros_like(strain)
        for i, j in self.pairs:
            kept[i, j], kept[j, i] = strain[i, j], strain[j, i]
        return kept

    # ------------------------------------------------------------------ measures
    def weighted(self, integrand):
        """``integrand`` times the measure's weight (as it is for a plane or solid body)."""
        return integrand if self.weight is None else integrand * self.weight

    def dx(self, integrand, *args, weighted=True, **options):
        """∫_Ω integrand: ``integrand * ngs.dx(*args, **options)`` with the weight folded in
        (``weighted=False``: over the mesh as it is)."""
        return (self.weighted(integrand) if weighted else integrand) * ngs.dx(*args, **options)

    def ds(self, integrand, *args, weighted=True, **options):
        """∫_∂Ω integrand: ``integrand * ngs.ds(*args, **options)`` with the weight folded in."""
        return (self.weighted(integrand) if weighted else integrand) * ngs.ds(*args, **options)

    @property
    def resultants(self):
        """The axes along which a boundary integral of σν is a resultant force (all of them; a
        body of revolution's radial integral is none)."""
        return tuple(range(self.mesh_dim))

    def hat_shares(self, points, size):
        """∫ of each vertex's hat function over a straight facet of measure ``size`` (m; m² in
        3D) whose vertices are at ``points`` (numpy, vertices × mesh_dim), on the body's measure."""
        return np.full(len(points), size / self.mesh_dim)

    def point_weights(self, points):
        """The weight at ``points`` (numpy, (..., mesh_dim) coordinates): the body's measure per
        unit mesh measure there (1 unless weighted)."""
        return np.ones(np.shape(points)[:-1])

    # ------------------------------------------------------------------ rigid motions
    def rigid_motions(self, centre, size):
        """The motions of zero strain as (CoefficientFunction, name): translations along the
        axes, rotations about ``centre`` divided by ``size`` (m), all of unit size."""
        dim = self.mesh_dim
        x = [(ngs.x, ngs.y, ngs.z)[i] - centre[i] for i in range(dim)]
        result = [(ngs.CF(tuple(float(i == j) for j in range(dim))), f"translation along {AXES[i]}")
                  for i in range(dim)]
        for i, j in self.rotation_planes:
            field = [ngs.CF(0.0)] * dim
            field[i], field[j] = -x[j] / size, x[i] / size
            result.append((ngs.CF(tuple(field)), f"rotation about {AXES[3 - i - j]}"))
        return result

    rotation_planes = ()

    def __repr__(self):
        return f"{type(self).__name__}()"

    def __eq__(self, other):
        return type(self) is type(other)

    def __hash__(self):
        return hash(type(self))


class PlaneStrain(Kinematics):
    """A 2D body in plane strain (ε_i3 = 0), quantities per metre of depth."""
    name = "plane strain"
    mesh_dim = 2
    matrix_size = 2
    pairs = ((0, 0), (1, 1), (0, 1))
    rotation_planes = ((0, 1),)


class Solid3D(Kinematics):
    """A 3D body."""
    name = "3D"
    mesh_dim = 3
    matrix_size = 3
    pairs = VOIGT_3D
    rotation_planes = ((1, 2), (2, 0), (0, 1))


class Axisymmetric(Kinematics):
    """A torsion-free body of revolution on its meridian section x = r >= 0, y the axis
    (``model.axisymmetric``); strain matrices in the frame (e_r, e_z, e_θ)."""
    name = "axisymmetric"
    mesh_dim = 2
    matrix_size = 3
    pairs = ((0, 0), (1, 1), (0, 1), (2, 2))
    default_poling = "y"

    @property
    def weight(self):
        """2π r (m): the body's measure per unit area of its meridian section."""
        return axisymmetric.weight()

    def strain(self, u):
        """(ε_rr, ε_zz, 2ε_rz, ε_θθ), ε_θθ = u_r/r (its limit ∂u_r/∂r on the axis)."""
        return axisymmetric.strain(u)

    def point_weights(self, points):
        return 2 * np.pi * np.asarray(points)[..., 0]

    resultants = (1,)

    def hat_shares(self, points, size):
        """2π ∫ r φ_a ds = 2π L (2 r_a + r_b)/6 on a segment of length L from r_a to r_b."""
        r = np.asarray(points)[:, 0]
        return 2 * np.pi * size * (2 * r + r[::-1]) / 6

    def plane_stress_matrix(self, s):
        """The meridian block (σ_rr, σ_rz; σ_rz, σ_zz): the hoop stress has no flux."""
        return ngs.CF((s[0], s[2], s[2], s[1]), dims=(2, 2))

    def rigid_motions(self, centre, size):
        """The translation along the axis (a radial translation or a rotation of the section
        strains the ring)."""
        return [(ngs.CF((0.0, 1.0)), "translation along y (the axis)")]


def mesh_dx(integrand, *args, **options):
    """``integrand * ngs.dx(*args, **options)``: over the mesh as it is, for geometric
    integrals (areas, mean normals) of code that holds a mesh and no body."""
    return integrand * ngs.dx(*args, **options)


def mesh_ds(integrand, *args, **options):
    """``integrand * ngs.ds(*args, **options)``: over the mesh's boundary as it is (``mesh_dx``)."""
    return integrand * ngs.ds(*args, **options)


def of(dim, axisymmetric=False):
    """The kinematics of a ``dim``-D mesh (2 or 3), a meridian section if ``axisymmetric``;
    a Kinematics is returned as it is."""
    if isinstance(dim, Kinematics):
        return dim
    if axisymmetric:
        if dim != 2:
            raise ValueError(f"axisymmetric: the mesh must be 2D, the (r, z) half-plane of the body's meridian "
                             f"section, got a {dim}D mesh")
        return Axisymmetric()
    kinds = {2: PlaneStrain, 3: Solid3D}
    if dim not in kinds:
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    return kinds[dim]()
