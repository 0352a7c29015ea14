"""The kinematics objects (``model.kinematics``): strains, Voigt maps, measures and rigid motions
checked against formulas, one representation at a time."""
import math

import ngsolve as ngs
import numpy as np
import pytest
from netgen.geom2d import unit_square
from netgen.csg import unit_cube

from ngcontact.model import kinematics

SQUARE = ngs.Mesh(unit_square.GenerateMesh(maxh=0.3))
CUBE = ngs.Mesh(unit_cube.GenerateMesh(maxh=0.5))
KINDS = [(kinematics.PlaneStrain(), SQUARE), (kinematics.Solid3D(), CUBE), (kinematics.Axisymmetric(), SQUARE)]


def _max_abs(cf, mesh):
    return math.sqrt(ngs.Integrate(ngs.InnerProduct(cf, cf), mesh, order=4))


@pytest.mark.parametrize("kin, mesh", KINDS, ids=lambda k: getattr(k, "name", ""))
def test_rigid_motions_do_not_strain_and_a_radial_shift_does(kin, mesh):
    """Every rigid motion of a kinematics has zero strain (interpolated exactly: they are linear);
    on a body of revolution a radial translation is no rigid motion (ε_θθ = 1/r)."""
    V = ngs.VectorH1(mesh, order=1)
    for field, name in kin.rigid_motions([0.5] * kin.mesh_dim, 1.0):
        u = ngs.GridFunction(V)
        u.Set(field)
        assert _max_abs(kin.strain(u), mesh) < 1e-12, name
    if isinstance(kin, kinematics.Axisymmetric):
        u = ngs.GridFunction(V)
        u.Set(ngs.CF((1.0, 0.0)))
        assert _max_abs(kin.strain(u), mesh) > 1.0                       # ∫ (1/r)² r dr is large


@pytest.mark.parametrize("kin, mesh", KINDS, ids=lambda k: getattr(k, "name", ""))
def test_the_voigt_maps_are_inverse_and_keep_the_work(kin, mesh):
    """strain_vector(strain_matrix(s)) = s, and σ : ε of the matrices equals the dot product of
    the Voigt vectors (engineering shear on the strain only)."""
    rng = np.random.default_rng(5)
    s = ngs.CF(tuple(float(v) for v in rng.normal(size=kin.size)))
    t = ngs.CF(tuple(float(v) for v in rng.normal(size=kin.size)))
    point = mesh(0.3, 0.4) if kin.mesh_dim == 2 else mesh(0.3, 0.4, 0.2)
    back = np.array(kin.strain_vector(kin.strain_matrix(s))(point))
    assert np.allclose(back, np.array(s(point)), rtol=0, atol=1e-14)
    work = ngs.InnerProduct(kin.stress_matrix(t), kin.strain_matrix(s))(point)
    assert work == pytest.approx(float(np.dot(t(point), s(point))), rel=1e-13)


@pytest.mark.parametrize("kin, mesh", KINDS, ids=lambda k: getattr(k, "name", ""))
def test_the_measures_carry_the_body_s_weight(kin, mesh):
    """∫ 1 dx is the body's volume: 1 for the unit square per metre of depth and the unit cube,
    π for the cylinder of radius 1 and height 1 swept by the square about its y axis; ∫ 1 ds of
    the square's right side is 1, or 2π for the cylinder's mantle (``weighted=False``: the mesh's
    measure). The hat functions' shares of a facet add up to its measure on the body: a unit
    segment from r = 1 to (1, 1) sweeps 2π."""
    volume = ngs.Integrate(kin.dx(ngs.CF(1.0)), mesh)
    assert volume == pytest.approx(math.pi if isinstance(kin, kinematics.Axisymmetric) else 1.0, rel=1e-12)
    assert ngs.Integrate(kin.dx(ngs.CF(1.0), weighted=False), mesh) == pytest.approx(1.0, rel=1e-12)
    if kin.mesh_dim == 2:                                               # the side x = r = 1
        side = ngs.Integrate(kin.ds(ngs.CF(1.0), SQUARE.Boundaries("right")), mesh)
        assert side == pytest.approx(2 * math.pi if isinstance(kin, kinematics.Axisymmetric) else 1.0, rel=1e-12)
    shares = kin.hat_shares(np.array([[1.0, 0.0, 0.0][:kin.mesh_dim], [1.0, 1.0, 0.0][:kin.mesh_dim]]), 1.0) \
        if kin.mesh_dim == 2 else kin.hat_shares(np.eye(3), math.sqrt(3) / 2)
    expected = 2 * math.pi if isinstance(kin, kinematics.Axisymmetric) else (1.0 if kin.mesh_dim == 2 else
                                                                              math.sqrt(3) / 2)
    assert sum(shares) == pytest.approx(expected, rel=1e-14)


def test_of_names_the_kinematics_and_refuses_a_3d_section():
    assert isinstance(kinematics.of(2), kinematics.PlaneStrain)
    assert isinstance(kinematics.of(3), kinematics.Solid3D)
    assert isinstance(kinematics.of(2, axisymmetric=True), kinematics.Axisymmetric)
    with pytest.raises(ValueError, match="must be 2D"):
        kinematics.of(3, axisymmetric=True)
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        kinematics.of(1)
