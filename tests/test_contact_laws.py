"""The scalar laws on Γ3 (contact_laws.py) against their formulas in model.md, and Contact.

Each law returns r ↦ CoefficientFunction. It is evaluated at r = a x + b on a line of
mesh points, so that r sweeps a range crossing every kink, and compared with a numpy
version of the formula written piecewise from model.md (not with clip). The values
exactly at the kinks are checked with a constant argument. Bad parameters must raise a
ValueError naming the parameter; Contact validates its fields and says when the
Newton Jacobian is symmetric.
"""
import numpy as np
import ngsolve as ngs
import pytest

from ngcontact.geometries import plate
from ngcontact import contact_laws as laws
from ngcontact.gamma3.contact import Contact

L, L_PHI, C_NU, K_E, DELTA = 0.3, 0.25, 7.0, 3.0, 0.2


@pytest.fixture(scope="module")
def mesh():
    return plate(L1=1, L2=1, maxh=0.2)


def sweep(mesh, law, low, high, n=2001):
    """(r, law(r)) at n points with r running linearly from low to high along y = 0.5."""
    xs = np.linspace(0.0, 1.0, n)
    points = mesh(xs, np.full_like(xs, 0.5))
    r_cf = ngs.x * (high - low) + low
    return r_cf(points).ravel(), law(r_cf)(points).ravel()


def at(mesh, law, r):
    """law at the constant argument r (exactly, no rounding of r)."""
    return law(ngs.CF(r))(mesh(0.5, 0.5))


# numpy versions of model.md, written piecewise
def p_exact(r):
    return np.where(r > 0, C_NU * r, 0.0)


def R_exact(s):
    return np.where(s < -L, L, np.where(s <= 0, -s, 0.0))


def phi_L_exact(s):
    return np.where(s > L_PHI, L_PHI, np.where(s < -L_PHI, -L_PHI, s))


def psi_ramp_exact(r):
    return np.where(r >= 0, K_E, np.where(r >= -DELTA, K_E * (1 + r / DELTA), 0.0))


def psi_literal_exact(r):
    return np.where(r <= 0, 0.0, np.where(r < DELTA, K_E * r / DELTA, K_E))


LAWS = {
    "compliance": (laws.compliance_law(C_NU), p_exact, (-1.0, 1.0)),
    "bond_truncation": (laws.bond_truncation(L), R_exact, (-1.0, 0.5)),
    "potential_truncation": (laws.potential_truncation(L_PHI), phi_L_exact, (-1.0, 1.0)),
    "conductance_ramp": (laws.conductance_ramp(K_E, DELTA), psi_ramp_exact, (-0.5, 0.5)),
    "conductance_literal": (laws.conductance_literal(K_E, DELTA), psi_literal_exact, (-0.5, 0.5)),
}


@pytest.mark.parametrize("name", LAWS)
def test_law_matches_formula_across_its_kinks(mesh, name):
    """law(r) = formula(r) to 1e-12 on 2001 values of r that cross every kink."""
    law, exact, (low, high) = LAWS[name]
    r, values = sweep(mesh, law, low, high)
    assert r.min() == pytest.approx(low) and r.max() == pytest.approx(high)
    np.testing.assert_allclose(values, exact(r), rtol=0, atol=1e-12)
    # every piece of the formula is visited: the sweep is not confined to one side of a kink
    assert len(np.unique(np.round(np.diff(values) / np.diff(r), 6))) >= 2


@pytest.mark.parametrize("name, r, value", [
    ("compliance", 0.0, 0.0), ("compliance", -0.1, 0.0), ("compliance", 0.1, C_NU * 0.1),
    ("bond_truncation", 0.0, 0.0), ("bond_truncation", -L, L), ("bond_truncation", -2 * L, L),
    ("bond_truncation", -L / 3, L / 3), ("bond_truncation", 1e-3, 0.0),
    ("potential_truncation", L_PHI, L_PHI), ("potential_truncation", -L_PHI, -L_PHI),
    ("potential_truncation", 0.0, 0.0), ("potential_truncation", 10.0, L_PHI),
    ("potential_truncation", -10.0, -L_PHI),
    ("conductance_ramp", 0.0, K_E), ("conductance_ramp", -DELTA, 0.0),
    ("conductance_ramp", -DELTA / 2, K_E / 2), ("conductance_ramp", DELTA, K_E),
    ("conductance_ramp", -2 * DELTA, 0.0),
    ("conductance_literal", 0.0, 0.0), ("conductance_literal", DELTA, K_E),
    ("conductance_literal", DELTA / 2, K_E / 2), ("conductance_literal", -DELTA, 0.0),
    ("conductance_literal", 2 * DELTA, K_E),
])
def test_law_at_kinks(mesh, name, r, value):
    """Values exactly at r = 0, ±L, ±δ (and one point inside each piece)."""
    assert at(mesh, LAWS[name][0], r) == pytest.approx(value, abs=1e-14)


def test_the_bond_truncation_takes_the_slope_of_either_side_at_rest(mesh):
    """R_ν with ``pressed`` 0 or 1 has the same values on a sweep across its kinks, and its
    derivative at s = 0 (a body at rest) is the glued side's −1 or the pressed side's 0; a step
    away from 0 (±1e-9 m) both have the slope of that side."""
    shift = ngs.Parameter(0.0)
    glued, pressed = laws.bond_truncation(L, 0.0), laws.bond_truncation(L, ngs.Parameter(1.0))
    np.testing.assert_array_equal(sweep(mesh, glued, -1.0, 0.5)[1], sweep(mesh, pressed, -1.0, 0.5)[1])
    slope = lambda law, s: law(ngs.CF(s) + shift).Diff(shift)(mesh(0.5, 0.5))   # noqa: E731
    assert (slope(glued, 0.0), slope(pressed, 0.0)) == (-1.0, 0.0)
    assert slope(glued, -1e-9) == slope(pressed, -1e-9) == -1.0
    assert slope(glued, 1e-9) == slope(pressed, 1e-9) == 0.0


def test_literal_conductance_is_off_where_the_ramp_is_on(mesh):
    """For every admissible state r = u_ν − g ≤ 0 the literal ψ is 0; the ramp is k_e at contact."""
    r, literal = sweep(mesh, LAWS["conductance_literal"][0], -0.5, 0.0)
    assert np.all(literal == 0)
    assert at(mesh, LAWS["conductance_ramp"][0], 0.0) == K_E


def test_zero_coefficients_are_allowed(mesh):
    """c_ν = 0 and k_e = 0 switch the law off (they are valid, not rejected)."""
    for law in (laws.compliance_law(0.0), laws.conductance_ramp(0.0, DELTA), laws.conductance_literal(0, DELTA)):
        assert np.all(sweep(mesh, law, -1, 1)[1] == 0)


@pytest.mark.parametrize("make, match", [
    (lambda: laws.compliance_law(-1.0), "compliance c_nu must be >= 0"),
    (lambda: laws.compliance_law(float("nan")), "compliance c_nu must be >= 0"),
    (lambda: laws.bond_truncation(0.0), "bond length L must be > 0"),
    (lambda: laws.bond_truncation(-1e-4), "bond length L must be > 0"),
    (lambda: laws.potential_truncation(0.0), "potential truncation L_phi must be > 0"),
    (lambda: laws.potential_truncation(-1.0), "potential truncation L_phi must be > 0"),
    (lambda: laws.conductance_ramp(-1.0, DELTA), "conductance k_e must be >= 0"),
    (lambda: laws.conductance_ramp(K_E, 0.0), "ramp width delta must be > 0"),
    (lambda: laws.conductance_ramp(K_E, -DELTA), "ramp width delta must be > 0"),
    (lambda: laws.conductance_literal(-1.0, DELTA), "conductance k_e must be >= 0"),
    (lambda: laws.conductance_literal(K_E, 0.0), "ramp width delta must be > 0"),
])
def test_law_rejects_bad_parameter(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("kwargs, match", [
    (dict(theta=2), "Contact.theta must be 1, 0 or -1"),
    (dict(theta=0.5), "Contact.theta must be 1, 0 or -1"),
    (dict(gamma0=0.0), r"Contact.gamma0 \(Nitsche parameter\) must be a finite number > 0"),
    (dict(gamma0=-10.0), r"Contact.gamma0 \(Nitsche parameter\) must be a finite number > 0"),
    (dict(beta_update="Explicit"), "Contact.beta_update must be 'explicit' or 'implicit'"),
    (dict(beta_update="crank-nicolson"), "Contact.beta_update must be 'explicit' or 'implicit'"),
    (dict(adhesion=-1.0), "Contact.adhesion must be a finite number >= 0"),
    (dict(eps_a=-1e-3), "Contact.eps_a must be a finite number >= 0"),
    (dict(beta0=-0.1), r"Contact.beta0 must be a finite number in \[0, 1\]"),
    (dict(beta0=1.1), r"Contact.beta0 must be a finite number in \[0, 1\]"),
    (dict(gap=-1e-6), r"Contact.gap must be a finite number >= 0 m"),
    (dict(gap=float("nan")), r"Contact.gap must be a finite number >= 0 m"),
    # delegated to the laws: the message names the law's parameter
    (dict(bond_length=0.0), "Contact.bond_length must be a finite number > 0 m"),
    (dict(ramp_width=0.0), "Contact.ramp_width must be a finite number > 0 m"),
    (dict(potential_truncation=-1.0), "Contact.potential_truncation must be a finite number > 0 V"),
    (dict(compliance=-1.0), "Contact.compliance must be a finite number >= 0"),
    (dict(conductance=-1.0), "Contact.conductance must be a finite number >= 0"),
])
def test_contact_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Contact(**kwargs)


def test_contact_accepts_edge_values(mesh):
    """The closed ends of the allowed ranges are valid; the laws are built from the fields."""
    c = Contact(theta=-1, beta0=0.0, gap=0.0, adhesion=0.0, eps_a=0.0, beta_update="implicit",
                bond_length=L, compliance=C_NU, conductance=K_E, ramp_width=DELTA,
                potential_truncation=L_PHI)
    assert Contact(beta0=1.0, theta=0).beta0 == 1.0
    for law, exact, low, high in ((c.p, p_exact, -1, 1), (c.R, R_exact, -1, 0.5),
                                  (c.phi_L, phi_L_exact, -1, 1), (c.psi, psi_ramp_exact, -0.5, 0.5)):
        r, values = sweep(mesh, law, low, high, n=401)
        np.testing.assert_allclose(values, exact(r), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kwargs, symmetric", [
    (dict(), True),
    (dict(gap=1e-6, beta0=0.5, eps_a=1e-3, gamma0=100.0), True),   # none enters the Jacobian unsymmetrically
    (dict(theta=0), False),
    (dict(theta=-1), False),
    (dict(compliance=1e9), False),
    (dict(compliance=laws.compliance_law(0.0)), False),          # a user law is not inspected
    (dict(adhesion=1e6), False),
    (dict(conductance=1.0), False),
    (dict(conductance=laws.conductance_literal(0.0, DELTA)), False),
])
def test_contact_symmetric(kwargs, symmetric):
    """Symmetric Jacobian only for θ = 1 with no compliance, no adhesion and no conduction."""
    assert Contact(**kwargs).symmetric is symmetric
