"""The contact side Γ3 (B^h, P_B) and the bonding field β (adhesion.py).

* B^h survives ``ds(skeleton=True)``: ∫ β x over ``ContactSide.ds`` equals the plain
  boundary integral (the silent-zero trap of ngsolve-notes).
* P_B and the facet measures against exact facet averages, in 2D and 3D.
* The bonding ODE (2.9) with u held fixed at a separation s, so R_ν = min(s, L) and
  β̇ = −[β a − b]_+ with a = γ_ν R_ν², b = ε_a: the explicit update (4.5) and the implicit
  one against their exact discrete solutions, first-order convergence to the closed form
  β(t) = b/a + (β0 − b/a) e^{−a t}, no change where β a ≤ b, the truncation at L, and
  the behaviour of both updates for a step with k a > 2.
"""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.geometries import block, plate
from ngcontact.gamma3.adhesion import BondingField
from ngcontact.gamma3.contact import Contact
from ngcontact.gamma3.contact_side import ContactSide

# bond length L (m), separation s < L (m), γ_ν with a = γ_ν s² = 2 /s, ε_a = b = 0.5 /s
L, S, GAMMA, EPS_A = 1e-4, 5e-5, 8e8, 0.5
A, B = GAMMA * S ** 2, EPS_A


def contact_side(mesh):
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    return ContactSide(body)


@pytest.fixture(scope="module")
def side():
    """Γ3 = the bottom y = 0 of the unit square, 5 facets."""
    return contact_side(plate(L1=1, L2=1, maxh=0.2))


@pytest.fixture(scope="module")
def side3d():
    """Γ3 = the bottom z = 0 of the block [0, 1] × [0, 0.5] × [0, 0.4]."""
    return contact_side(block(L1=1, L2=0.5, L3=0.4, maxh=0.2))


def field(side, **kwargs):
    args = dict(adhesion=GAMMA, eps_a=EPS_A, bond_length=L, beta0=1.0)
    return BondingField(side, Contact(**{**args, **kwargs}))


# ---------------------------------------------------------------------------------- Γ3, B^h, P_B

def test_beta_is_not_zero_inside_skeleton_forms(side):
    """∫_Γ3 β x over side.on_facets (LinearForm and BilinearForm) = ∫ over plain ds, and ≠ 0."""
    mesh = side.mesh
    beta = ngs.GridFunction(side.B)
    beta.vec.FV().NumPy()[:] = side.project(1 + ngs.x)
    assert np.ptp(beta.vec.FV().NumPy()) > 0.5                       # non-constant
    plain = ngs.Integrate(beta * ngs.x * ngs.ds(definedon=mesh.Boundaries("bottom")), mesh)
    # β = 1 + x_m per facet, x linear: ∫ β x = Σ (1 + x_m) x_m |f|
    xm = side.midpoints[:, 0]
    assert plain == pytest.approx(np.sum((1 + xm) * xm * side.measure), rel=1e-12)
    assert plain > 0.5

    V = ngs.H1(mesh, order=1)
    u, v = V.TnT()
    ones = ngs.GridFunction(V).vec
    ones[:] = 1.0                                                    # Σ of all hat functions
    lf = ngs.LinearForm(side.on_facets(beta * ngs.x * v)).Assemble()
    bf = ngs.BilinearForm(side.on_facets(beta * ngs.x * u * v)).Assemble()
    assert ngs.InnerProduct(lf.vec, ones) == pytest.approx(plain, rel=1e-12)
    assert ngs.InnerProduct(ones, bf.mat * ones) == pytest.approx(plain, rel=1e-12)


def test_the_trap_exists_for_a_space_defined_on_gamma3_only(side):
    """The check above has teeth: SurfaceL2(definedon=Γ3) integrates to 0 over side.on_facets
    (NGSolve 6.2.2608). If this fails, NGSolve fixed the trap upstream."""
    mesh = side.mesh
    gamma3 = mesh.Boundaries("bottom")
    beta = ngs.GridFunction(ngs.SurfaceL2(mesh, order=0, definedon=gamma3))
    beta.Set(1 + ngs.x, definedon=gamma3)
    v = ngs.H1(mesh, order=1).TestFunction()
    lf = ngs.LinearForm(side.on_facets(beta * ngs.x * v)).Assemble()
    assert ngs.Integrate(beta * ngs.x * ngs.ds(definedon=gamma3), mesh) > 0.5
    assert np.abs(lf.vec.FV().NumPy()).max() == 0


def test_measure_and_projection_of_linear_function_2d(side):
    """|facets| sum to L1 = 1 and match the vertex distances; P_B x = facet midpoints."""
    fv = side.facet_vertices
    assert side.measure.sum() == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(side.measure, np.linalg.norm(fv[:, 1] - fv[:, 0], axis=1), rtol=1e-12)
    np.testing.assert_allclose(side.project(ngs.x), fv[:, :, 0].mean(axis=1), rtol=0, atol=1e-14)
    np.testing.assert_allclose(side.project(3 - 2 * ngs.x), 3 - 2 * fv[:, :, 0].mean(axis=1), rtol=0, atol=1e-14)
    assert np.all(fv[:, :, 1] == 0)                                  # all on y = 0


def test_measure_and_projection_of_linear_function_3d(side3d):
    """Triangle areas sum to L1 L2 = 0.5 and match the vertices; P_B x = centroid x."""
    fv = side3d.facet_vertices
    areas = 0.5 * np.linalg.norm(np.cross(fv[:, 1] - fv[:, 0], fv[:, 2] - fv[:, 0]), axis=1)
    assert side3d.measure.sum() == pytest.approx(0.5, rel=1e-12)
    np.testing.assert_allclose(side3d.measure, areas, rtol=1e-12)
    np.testing.assert_allclose(side3d.project(ngs.x + 2 * ngs.y), (fv[:, :, 0] + 2 * fv[:, :, 1]).mean(axis=1),
                               rtol=0, atol=1e-14)
    assert np.all(fv[:, :, 2] == 0)                                  # all on z = 0


def test_projection_is_the_facet_average_2d(side):
    """P_B x² = (x1³ − x0³)/(3 (x1 − x0)), the exact facet average (not x_m²)."""
    x0, x1 = side.facet_vertices[:, 0, 0], side.facet_vertices[:, 1, 0]
    np.testing.assert_allclose(side.project(ngs.x ** 2), (x1 ** 3 - x0 ** 3) / (3 * (x1 - x0)),
                               rtol=1e-12, atol=0)


def test_integrate_is_exact_for_a_quadratic(side):
    """ContactSide.integrate(x²) = ∫_0^1 x² dx = 1/3."""
    assert side.integrate(ngs.x ** 2) == pytest.approx(1 / 3, rel=1e-12)


def test_projection_is_the_facet_average_3d(side3d):
    """P_B x² on a triangle = (Σ x_i² + Σ_{i<j} x_i x_j)/6, the exact average."""
    x = side3d.facet_vertices[:, :, 0]
    exact = (np.sum(x ** 2, axis=1) + x[:, 0] * x[:, 1] + x[:, 1] * x[:, 2] + x[:, 0] * x[:, 2]) / 6
    np.testing.assert_allclose(side3d.project(ngs.x ** 2), exact, rtol=1e-12, atol=0)


# ---------------------------------------------------------------------------------- bonding ODE

def separation(s):
    """u_ν = −s: the body is a distance s away from the foundation."""
    return ngs.CF(-s)


def discrete(update, k, n, a=A, b=B, beta0=1.0):
    """Exact solution of the update after n steps: b/a + q^n (β0 − b/a)."""
    q = 1 - k * a if update == "explicit" else 1 / (1 + k * a)
    return b / a + q ** n * (beta0 - b / a)


def closed_form(t, a=A, b=B, beta0=1.0):
    """β(t) of β̇ = −(β a − b) while β a > b."""
    return b / a + (beta0 - b / a) * np.exp(-a * t)


@pytest.mark.parametrize("update", ["explicit", "implicit"])
def test_update_follows_its_discrete_solution(side, update):
    """β_n − b/a = (1 − k a)^n (β0 − b/a) (explicit), (1 + k a)^{−n} (β0 − b/a) (implicit)."""
    f, k = field(side, beta_update=update), 0.1
    assert np.all(f.values == 1.0)
    for n in range(1, 31):
        f.update(separation(S), k)
        np.testing.assert_allclose(f.values, discrete(update, k, n), rtol=0, atol=1e-12)
        assert f.clipped == 0
    # the two are different schemes: after 30 steps they differ well beyond 1e-12
    assert abs(discrete("explicit", k, 30) - discrete("implicit", k, 30)) > 1e-4


@pytest.mark.parametrize("update, sign", [("explicit", -1), ("implicit", 1)])
def test_update_converges_with_first_order(side, update, sign):
    """β(T = 1 s) → b/a + (β0 − b/a) e^{−aT} as k halves three times; error ratio ≈ 2,
    with the leading error k a² T (β0 − b/a) e^{−aT}/2 (explicit below, implicit above)."""
    T, steps = 1.0, [10, 20, 40, 80]
    errors = []
    for n in steps:
        f = field(side, beta_update=update)
        for _ in range(n):
            f.update(separation(S), T / n)
        assert np.ptp(f.values) < 1e-14                              # the same on every facet
        errors.append(f.values[0] - closed_form(T))
    errors = np.array(errors)
    assert np.all(np.sign(errors) == sign)
    ratios = errors[:-1] / errors[1:]
    assert np.all(np.abs(ratios - 2) < 0.05), ratios
    ks = T / np.array(steps)
    assert np.polyfit(np.log(ks), np.log(np.abs(errors)), 1)[0] == pytest.approx(1.0, abs=0.03)
    leading = A ** 2 * T * (1.0 - B / A) * np.exp(-A * T) / 2
    assert abs(errors[-1]) / ks[-1] == pytest.approx(leading, rel=0.05)


@pytest.mark.parametrize("update", ["explicit", "implicit"])
def test_no_change_where_beta_a_does_not_exceed_b(side, update):
    """β0 = 0.2 + 0.6 x and b/a = 0.45: facets with β0 a ≤ b keep β0 exactly, the others
    decay to b/a by their discrete solution."""
    b = 0.45 * A
    f = field(side, beta_update=update, eps_a=b, beta0=0.2 + 0.6 * ngs.x)
    beta0 = 0.2 + 0.6 * side.midpoints[:, 0]
    np.testing.assert_allclose(f.values, beta0, rtol=0, atol=1e-14)
    still = beta0 * A <= b
    assert 0 < still.sum() < side.B.ndof                             # both kinds of facets
    initial = f.values.copy()
    k = 0.1
    for n in range(1, 11):
        f.update(separation(S), k)
        assert np.all(f.values[still] == initial[still])
        np.testing.assert_allclose(f.values[~still], discrete(update, k, n, b=b, beta0=beta0[~still]),
                                   rtol=0, atol=1e-12)


@pytest.mark.parametrize("update", ["explicit", "implicit"])
def test_no_change_without_separation_or_when_eps_a_is_large(side, update):
    """u_ν ≥ 0 gives R_ν = 0, and ε_a ≥ γ_ν s² β: β is unchanged."""
    f = field(side, beta_update=update, beta0=0.7)
    for u_normal in (ngs.CF(0.0), ngs.CF(1e-5)):
        f.update(u_normal, 0.1)
        np.testing.assert_allclose(f.values, 0.7, rtol=1e-14)   # P_B 0.7, to round-off
    f = field(side, beta_update=update, beta0=0.7, eps_a=0.75 * A)   # β a < b
    f.update(separation(S), 0.1)
    np.testing.assert_allclose(f.values, 0.7, rtol=1e-14)   # P_B 0.7, to round-off


@pytest.mark.parametrize("update", ["explicit", "implicit"])
@pytest.mark.parametrize("s", [2 * L, 10 * L])
def test_separation_beyond_bond_length_uses_L(side, update, s):
    """For s > L, R_ν = L: the decay follows a = γ_ν L² (not γ_ν s²)."""
    f, k, a = field(side, beta_update=update), 0.1, GAMMA * L ** 2
    for n in range(1, 6):
        f.update(separation(s), k)
        np.testing.assert_allclose(f.values, discrete(update, k, n, a=a), rtol=0, atol=1e-12)
    assert abs(discrete(update, k, 5, a=a) - discrete(update, k, 5, a=GAMMA * s ** 2)) > 1e-3


def test_large_step_explicit_is_clipped_implicit_decays_monotonically(side):
    """k a = 3 > 2: the explicit update jumps to 1 − k(a − b) < 0, is clipped to 0 and
    reports it; the implicit one stays in [b/a, 1] and decreases, as (1 + k a)^{−n}."""
    k = 3 / A
    explicit = field(side, beta_update="explicit")
    explicit.update(separation(S), k)
    assert 1 - k * (A - B) < 0
    assert explicit.clipped == side.B.ndof
    assert np.all(explicit.values == 0)
    explicit.update(separation(S), k)                                # from 0: rate [−b]_+ = 0
    assert np.all(explicit.values == 0) and explicit.clipped == 0

    implicit = field(side, beta_update="implicit")
    previous = implicit.values.copy()
    for n in range(1, 11):
        implicit.update(separation(S), k)
        values = implicit.values
        assert implicit.clipped == 0
        assert np.all((B / A < values) & (values < previous) & (values <= 1))
        np.testing.assert_allclose(values, discrete("implicit", k, n), rtol=0, atol=1e-12)
        previous = values.copy()


def test_initial_value_is_the_projection_of_beta0(side):
    """β^h(0) = P_B β0 for a β0 CoefficientFunction in [0, 1]."""
    f = field(side, beta0=ngs.x)
    np.testing.assert_allclose(f.values, side.midpoints[:, 0], rtol=0, atol=1e-14)


@pytest.mark.parametrize("beta0", [ngs.x - 0.5, 2 * ngs.x, 1.5 + 0 * ngs.x])
def test_beta0_outside_unit_interval_rejected(side, beta0):
    """A β0 CoefficientFunction passes Contact, but BondingField rejects it."""
    contact = Contact(adhesion=GAMMA, bond_length=L, beta0=beta0)
    with pytest.raises(ValueError, match=r"Contact.beta0 must lie in \[0, 1\] on Γ3"):
        BondingField(side, contact)
