"""Voigt data, poling rotation and plane-strain reduction against their formulas."""
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.model.materials import EPS0, lame_stiffness


def test_isotropic_plane_strain_matrix():
    E, nu = 2e11, 0.3
    F = ngc.Material.isotropic(E, nu, permittivity=1e-9).tensors(2).F
    expected = E / ((1 + nu) * (1 - 2 * nu)) * np.array([[1 - nu, nu, 0], [nu, 1 - nu, 0],
                                                          [0, 0, (1 - 2 * nu) / 2]])
    assert np.allclose(F, expected, rtol=1e-14)


def test_isotropic_viscosity_is_lame_form():
    A = ngc.Material.isotropic(1e9, 0.25, 1e-9, viscosity=3.0, bulk_viscosity=2.0).tensors(3).A
    assert np.allclose(A, lame_stiffness(2.0, 3.0))
    assert A[0, 0] == 2 + 2 * 3 and A[0, 1] == 2 and A[5, 5] == 3


@pytest.mark.parametrize("poling, rows", [
    ("y", [[0, 0, 12.3], [-5.4, 15.8, 0]]),         # x = data axis 2, y = data axis 3
    ("x", [[15.8, -5.4, 0], [0, 0, 12.3]]),         # x = data axis 3
])
def test_poling_axis_in_plane_strain(poling, rows):
    m = ngc.pzt5a()
    T = ngc.Material(m.c, m.e, m.eps, poling=poling).tensors(2)
    assert np.allclose(T.E, rows)
    c33, c13, c11 = 111e9, 75.2e9, 121e9
    F = [[c11, c13, 0], [c13, c33, 0], [0, 0, 21.1e9]] if poling == "y" else \
        [[c33, c13, 0], [c13, c11, 0], [0, 0, 21.1e9]]
    assert np.allclose(T.F, F)
    eps = np.diag([916, 830]) if poling == "y" else np.diag([830, 916])
    assert np.allclose(T.C, eps * EPS0)


def test_rotation_is_proper_and_keeps_isotropy():
    m = ngc.Material.isotropic(1e9, 0.2, 1e-9, e31=-1, e33=2, e15=3)
    for poling in "xyz":
        T = ngc.Material(m.c, m.e, m.eps, poling=poling).tensors(3)
        assert np.allclose(T.F, m.c)
        axis = "xyz".index(poling)
        assert T.E[axis, axis] == pytest.approx(2.0)          # e33 along the poling axis


@pytest.mark.parametrize("preset", [ngc.academic, ngc.pzt5a, ngc.batio3])
def test_presets_are_valid_and_coupled(preset):
    m = preset(relaxation_time=1e-3)
    T = m.tensors(2)
    assert np.linalg.eigvalsh(T.F).min() > 1e10 and np.linalg.eigvalsh(T.C).min() > 0
    assert np.allclose(T.A, 1e-3 * T.F) and T.viscous
    k2 = T.E[1, 1] ** 2 / (T.F[1, 1] * T.C[1, 1])       # coupling factor e33² / (c33 ε33)
    assert 1e-3 < k2 < 1
