"""Bad input is rejected with an error naming the parameter; a failed step says where."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.materials import isotropic_stiffness, transversely_isotropic_piezo
from ngcontact.newton import Newton
from ngcontact.geometries import block, plate

GOOD = dict(c=isotropic_stiffness(1e9, 0.3), e=transversely_isotropic_piezo(-1, 2, 1), eps=1e-9 * np.eye(3))


@pytest.mark.parametrize("change, match", [
    (dict(c=-isotropic_stiffness(1e9, 0.3)), "elasticity c .* positive definite"),
    (dict(c=isotropic_stiffness(1e9, 0.3) + np.triu(np.ones((6, 6)), 1) * 1e8), "elasticity c .* symmetric"),
    (dict(c=np.eye(5)), r"c must have shape \(6, 6\)"),
    (dict(eps=-1e-9 * np.eye(3)), "permittivity eps .* positive definite"),
    (dict(eps=np.diag([1e-9, 1e-9, 0.0])), "permittivity eps .* positive definite"),
    (dict(eta=-np.eye(6)), "viscosity eta .* positive definite"),
    (dict(e=np.full((3, 6), np.nan)), "e has non-finite"),
    (dict(poling="w"), "poling must be"),
])
def test_material_rejected(change, match):
    with pytest.raises(ValueError, match=match):
        ngc.Material(**{**GOOD, **change})


def test_material_accepts_zero_viscosity_and_rejects_out_of_plane_poling():
    assert not ngc.Material(**GOOD, eta=np.zeros((6, 6))).tensors(2).viscous
    with pytest.raises(ValueError, match="poling must be 'x' or 'y' in 2D"):
        ngc.Material(**GOOD, poling="z").tensors(2)


@pytest.mark.parametrize("kwargs, match", [
    (dict(E=-1.0, nu=0.3), "E must be a finite number > 0 Pa"),
    (dict(E=1.0, nu=0.5), r"nu must be a finite number in \(-1, 0.5\)"),
    (dict(E=1.0, nu=0.3, viscosity=-1.0), "viscosity must be a finite number >= 0 Pa·s"),
])
def test_isotropic_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ngc.Material.isotropic(permittivity=1e-9, **kwargs)


def test_relaxation_time_rejected():
    with pytest.raises(ValueError, match="relaxation_time must be a finite number >= 0 s, got -1.0"):
        ngc.pzt5a().with_viscosity(-1.0)


@pytest.fixture(scope="module")
def mesh():
    return plate(maxh=0.01)


@pytest.mark.parametrize("kwargs, match", [
    (dict(clamped="side"), r"clamped: boundary \['side'\] not in the mesh"),
    (dict(grounded="top|lid"), r"grounded: boundary \['lid'\] not in the mesh"),
    (dict(clamped=""), "clamped or supports must name at least one boundary"),
    (dict(grounded=None), "grounded must name at least one boundary"),
    (dict(contact_side="left"), "contact_side Γ3 must not overlap clamped"),
    (dict(contact_side="top"), "contact_side Γ3 must not overlap grounded"),
    (dict(order=0), "order must be an integer >= 1"),
    (dict(order_phi=1.5), "order_phi must be an integer >= 1"),
])
def test_body_rejected(mesh, kwargs, match):
    args = {**dict(clamped="left", grounded="top", contact_side="bottom"), **kwargs}
    with pytest.raises((ValueError, TypeError), match=match):
        ngc.Body(mesh, ngc.pzt5a(), **args)


@pytest.mark.parametrize("loads, match", [
    (ngc.Loads(f2={"left": (0, 1)}), r"Loads.f2: boundary \['left'\] is not allowed"),
    (ngc.Loads(f2={"bottom": (0, 1)}), r"Loads.f2: boundary \['bottom'\] is not allowed"),
    (ngc.Loads(qb={"top": 1.0}), r"Loads.qb: boundary \['top'\] is not allowed"),
    (ngc.Loads(potential={"right": 1.0}), r"Loads.potential: boundary \['right'\] is not allowed"),
    (ngc.Loads(f0=(1, 2, 3)), "f0 must have 2 components"),
])
def test_loads_rejected(mesh, loads, match):
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    with pytest.raises(ValueError, match=match):
        ngc.Simulation(body, loads)


def test_time_data_and_initial_state_rejected(mesh):
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    with pytest.raises(ValueError, match="u0 must vanish on the clamped boundary"):
        ngc.Simulation(body, u0=(1e-6, 0))
    sim = ngc.Simulation(body)
    with pytest.raises(ValueError, match="time step dt must be a finite number > 0 s, got 0.0"):
        sim.run(dt=0, T=1)
    with pytest.raises(ValueError, match="final time T must be >"):
        sim.run(dt=0.1, T=0)
    with pytest.raises(ValueError, match=r"rtol must be a finite number in \(0, 1\), got 0.0"):
        ngc.Simulation(body, rtol=0)


@pytest.mark.parametrize("make, match", [
    (lambda: plate(L1=-1), "L1 must be a finite number > 0 m"), (lambda: plate(maxh=0), "maxh must be a finite number in"),
    (lambda: plate(refine=-1), "refine must be an integer >= 0"), (lambda: block(L3=0), "L3 must be a finite number > 0"),
])
def test_geometry_rejected(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_failed_step_says_where_and_keeps_the_computed_steps(mesh):
    """A load that turns non-finite at t = 0.25 s is named at the step that meets it (not
    reported as a Newton failure after cut-backs); steps 1-2 are kept."""
    t = ngs.Parameter(0)
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    bad = ngs.IfPos(t - 0.25, 1e300 * 1e300, 1e6)
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -bad)}), time=t)
    with pytest.raises(ValueError, match=r"Loads.f2\['top'\] is not finite at t = 0.3 s"):
        sim.run(dt=0.1, T=1)
    assert [r.step for r in sim.history] == [0, 1, 2] and sim.cutbacks == []
    assert sim.history[2].reaction[1] == pytest.approx(1e6 * 0.1, rel=1e-9)


def test_newton_error_reports_residual_history():
    """Newton on u³ - 8 = 0 (one DOF) with maxit = 2 fails and lists 3 residuals."""
    mesh = plate(maxh=0.1)
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    (u, phi), (v, xi) = body.X.TnT()
    form = ngs.BilinearForm(body.X)
    form += (1e9 * (u[0] ** 3 - 1e-6) * v[0] + u[1] * v[1] + phi * xi) * ngs.dx
    gfu = ngs.GridFunction(body.X)
    gfu.vec[:] = 1.0
    with pytest.raises(ngc.NewtonError, match="did not converge in 2 iterations") as err:
        Newton(form, gfu, maxit=2).solve(step=7, time=0.5)
    assert err.value.step == 7 and len(err.value.residuals) == 3
    assert err.value.residuals[1] < err.value.residuals[0]
