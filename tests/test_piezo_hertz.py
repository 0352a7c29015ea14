"""The 2D piezoelectric Hertz problem against its closed form: the Stroh solver
(``scenes.stroh``) and the electrode scene's finite element solution (``scenes.electrode``)."""
import math

import numpy as np
import pytest

import ngcontact as ngc
from ngcontact.model.materials import EPS0, Material, isotropic_stiffness
from ngcontact.scenes import electrode, stroh

REFERENCE = dict(uncoupled=66.654e9, insulating=95.746e9, conducting=73.124e9)
"""E* (Pa) of PZT-5A's half-plane, /work/shared/piezo-hertz.md."""


def test_stroh_reproduces_the_pzt5a_reference():
    moduli = stroh.effective_moduli(ngc.pzt5a())
    for key, value in REFERENCE.items():
        assert moduli[key] == pytest.approx(value, rel=1e-3), key
    assert stroh.charge_per_force(ngc.pzt5a()) > 0


def test_stroh_isotropic_and_dielectric_limits():
    E, nu = 200e9, 0.3
    c = isotropic_stiffness(E, nu)
    c[2, 2] *= 1 + 1e-6                 # an exactly isotropic c is degenerate for the eigenproblem
    material = Material(c, np.zeros((3, 6)), np.diag([700.0, 916.0, 830.0]) * EPS0)
    K = stroh.surface_compliance(material)
    assert K[0, 0] == pytest.approx(2 * (1 - nu ** 2) / E, rel=1e-5)
    C = material.tensors(2).C           # the permittivity in ngcontact's plane (x, y), poling along y
    assert K[1, 1] == pytest.approx(-1 / math.sqrt(C[0, 0] * C[1, 1]), rel=1e-10)
    assert abs(K[0, 1]) < 1e-8 * math.sqrt(-K[0, 0] * K[1, 1])


def hertz_modulus(sim):
    """(E*_h, a_h) of a solved electrode run, from the second moment of its contact pressure.

    For Hertz's p = p0 sqrt(1 − x²/a²): ∫ p dx = F and ∫ x² p dx = F a²/4, so a² = 4 M/F and
    E* = 4 F R/(π a²) = F² R/(π M), with F the recorded normal force and M = ∫ x² λ_h dx from
    the multiplier at the residual's Gauss points. An integral of the whole profile does not
    depend on where the edge of the contact zone falls inside a facet: for h from R/50 to R/140
    the moment's ratios stayed within 0.3 % of the closed form, a least-squares fit of a (p0 tied
    to F) strayed by up to 2.3 % and the measure of the discrete contact zone by up to 8 %."""
    record = sim.history[-1].contact
    x, w = sim.side.gauss_points[..., 0], sim.side.gauss_weights
    force = record.force[1]
    moment = np.sum(w * x * x * record.multiplier_points)
    return force ** 2 * electrode.RADIUS / (math.pi * moment), math.sqrt(4 * moment / force)


@pytest.fixture(scope="module")
def runs():
    """The three runs at the scene's default mesh (h = R/100 near the contact, a ≈ 10 h; about
    4 s together): {name: (E*_h, a_h, potential on the facets inside |x| < a_h)}."""
    cases = dict(uncoupled=dict(coupled=False), insulating=dict(conductance=0.0),
                 conducting=dict(conductance=1.0, ramp_width=1e-7))
    out = {}
    for name, options in cases.items():
        sim = electrode.simulation(**options)
        sim.step(1.0)
        modulus, a = hertz_modulus(sim)
        inside = np.abs(sim.side.facet_vertices[..., 0]).max(axis=1) < a
        out[name] = modulus, a, sim.history[-1].contact.potential[inside]
    return out


def test_effective_modulus_ratios(runs):
    exact = stroh.effective_moduli(ngc.pzt5a())
    uncoupled = runs["uncoupled"][0]
    assert uncoupled == pytest.approx(exact["uncoupled"], rel=0.02)     # the half-disk's bias: +1 %
    other = dict(insulating="conducting", conducting="insulating")
    for key in other:
        ratio = runs[key][0] / uncoupled
        assert ratio == pytest.approx(exact[key] / exact["uncoupled"], rel=0.02), key
        # the wrong electrical contact law is far outside the tolerance (1.44 against 1.10)
        assert ratio != pytest.approx(exact[other[key]] / exact["uncoupled"], rel=0.1), key


def test_conducting_contact_zone_is_equipotential(runs):
    conducting, insulating = runs["conducting"][2], runs["insulating"][2]
    assert len(conducting) >= 10 and len(insulating) >= 10
    assert np.abs(conducting).max() < 1e-4 * np.abs(insulating).max()      # about 1 V against 2e5 V
