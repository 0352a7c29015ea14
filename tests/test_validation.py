"""Bad input is rejected with an error naming the parameter; a failed step says where."""
import contextlib
import inspect
import re

import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact import checks, obstacles
from ngcontact.model.materials import isotropic_stiffness, transversely_isotropic_piezo
from ngcontact.solve.newton import Newton
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
    (lambda: plate(L1=-1), r"L1 must be a finite number in \(0, 1000\] m"),
    (lambda: plate(maxh=0), "maxh must be a finite"), (lambda: plate(refine=-1), "refine must be an integer >= 0"),
    (lambda: block(L3=0), r"L3 must be a finite number in \(0,"),
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


def test_a_law_given_as_a_function_is_sampled():
    """A compliance law p must be >= 0 and vanish for r <= 0, a conductance law ψ >= 0 and
    vanish a metre from the foundation (both
    finite, real, scalar): sampled at r = 0, ±10^k m before any mesh is used."""
    with pytest.raises(ValueError, match=r"Contact.compliance: the law p\(r\) is -0.001 at r = 1e-12 m; p must be "
                                         r"finite, >= 0, and 0 for r <= 0 m"):
        ngc.Contact(compliance=lambda r: -1e9 * r)
    with pytest.raises(ValueError, match=r"Contact.compliance: the law p\(r\) is 1e-12 at r = -1e-12 m"):
        ngc.Contact(compliance=lambda r: ngs.IfPos(r, r, -r))
    with pytest.raises(ValueError, match=r"Contact.conductance: the law ψ\(r\) is -0.0001 at r = 0 m"):
        ngc.Contact(conductance=lambda r: -1e-4 + 0 * r)
    with pytest.raises(ValueError, match=r"Contact.conductance: the law ψ\(r\) is nan"):
        ngc.Contact(conductance=lambda r: ngs.sqrt(r))
    with pytest.raises(ValueError, match="Contact.compliance must return a real scalar CoefficientFunction, got a "
                                         "2-component one"):
        ngc.Contact(compliance=lambda r: ngs.CF((r, r)))
    with pytest.raises(ValueError, match=r"Contact.conductance: the law ψ\(r\) is 0.0001 at r = -1 m; ψ must be "
                                         r"finite, >= 0, and 0 for r <= -1 m"):     # conducts through a metre of air
        ngc.Contact(conductance=lambda r: 1e-4 + 0 * r)
    with pytest.raises(TypeError, match="Contact.conductance must be a function r ↦ CoefficientFunction; called"):
        ngc.Contact(conductance=lambda r, s: r)
    laws = ngc.contact_laws
    ngc.Contact(compliance=laws.compliance_law(1e12), conductance=laws.conductance_literal(1e-4, 1e-6))
    ngc.Contact(compliance=lambda r: 1e12 * ngs.IfPos(r, r * r, 0))


def test_complex_or_untyped_material_data_are_refused():
    """Complex data were cast to their real part; strings and dicts ended in numpy's errors."""
    with pytest.raises(TypeError, match=r"Material: c must be a \(6, 6\) array of real numbers, got complex128"):
        ngc.Material(**{**GOOD, "c": GOOD["c"] * (1 + 1e-3j)})
    with pytest.raises(TypeError, match=r"Material: eps must be a \(3, 3\) array of real numbers, got object"):
        ngc.Material(**{**GOOD, "eps": {}})
    with pytest.raises(ValueError, match=r"Material: e must have shape \(3, 6\)"):
        ngc.Material(**{**GOOD, "e": [[1, 2], [3]]})
    assert ngc.Material(**{**GOOD, "c": GOOD["c"].astype(complex).real}).c.dtype == float


def test_a_reversed_obstacle_normal_is_refused(mesh):
    """SignedDistance(g = y, n_o) under the plate: n_o = (0, −1) points from the body into the
    obstacle; (0, 1) would let the plate pass through it with zero force. A disk under the
    middle of Γ3 (n_o·ν > 0 everywhere) and a plane touching only at a corner are fine."""
    t = ngs.Parameter(0.0)

    def simulation(obstacle, side="bottom|right"):
        body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side=side)
        return ngc.Simulation(body, ngc.Loads(), time=t, contact=ngc.Contact(obstacle=obstacle))
    with pytest.raises(ValueError, match=r"SignedDistance's normal must point from the body into the obstacle .* "
                                         r"normal·ν ranges over \[-1, 0\] on Γ3: is normal reversed\?"):
        simulation(obstacles.SignedDistance(ngs.y, (0.0, 1.0)))
    with pytest.raises(ValueError, match=r"normal·ν ranges over \[0, 0\]"):     # tangential
        simulation(obstacles.SignedDistance(ngs.y, (1.0, 0.0)), side="bottom")
    simulation(obstacles.SignedDistance(ngs.y, (0.0, -1.0)))              # ν = (1, 0) on "right": n_o·ν = 0
    simulation(obstacles.Cylinder((0.05, -0.01), 0.01))


def test_non_finite_contact_data_are_named_before_newton(mesh):
    """A gap that is NaN on part of Γ3 at t = 0, and a foundation potential or an obstacle
    that turns NaN later, are named with the time (not a Newton divergence); the steps before
    are kept."""
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    t = ngs.Parameter(0.0)
    loads = ngc.Loads(f2={"top": (0, -1e6 * t)})
    with pytest.raises(ValueError, match=r"Contact.gap is not finite \(NaN or inf\) on Γ3 at t = 0 s"):
        ngc.Simulation(body, loads, time=t, contact=ngc.Contact(gap=1e-5 * (1 + ngs.sqrt(ngs.x - 0.05)) + 0 * t))
    late = ngs.IfPos(t - 0.25, ngs.sqrt(-1 - t), 0.0)
    sim = ngc.Simulation(body, loads, time=t, contact=ngc.Contact(gap=2e-5, foundation_potential=10 + late))
    with pytest.raises(ValueError, match=r"Contact.foundation_potential is not finite \(NaN or inf\) on Γ3 at "
                                         r"t = 0.3 s"):
        sim.run(0.1, 1.0)
    assert [r.step for r in sim.history] == [0, 1, 2] and sim.cutbacks == []
    sim = ngc.Simulation(body, loads, time=t, contact=ngc.Contact(obstacle=obstacles.Plane((0, -2e-5 + late), (0, 1))))
    with pytest.raises(ValueError, match=r"Contact.obstacle: its gap \(the distance to it\) is not finite"):
        sim.run(0.1, 1.0)
    assert len(sim.history) == 3


def test_time_steps_and_run_arguments_are_checked_before_any_step(mesh, tmp_path):
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    sim = ngc.Simulation(body, keep_states=False)
    for dt in (5e-324, 1e-300, 1e-21):
        with pytest.raises(ValueError, match=r"time step dt must be > 0 s, finite and at least 1e-20 s"):
            sim.step(dt)
    sim.step(1e3)
    with pytest.raises(ValueError, match=r"at least 1e-10 s \(1e-20 s, and 1e-13 of the time t = 1000 s\)"):
        sim.step(5e-11)                                   # t + dt is t to 13 digits
    with pytest.raises(ValueError, match="time step dt = 4.94066e-324 s gives inf steps"):
        sim.run(5e-324, 2e3)
    with pytest.raises(ValueError, match="max_cutbacks must be an integer >= 0 and <= 20, got 1000"):
        sim.run(1e3, 2e3, max_cutbacks=1000)
    with pytest.raises(ValueError, match="vtk: the directory '/proc/ngcontact' cannot be written"):
        sim.run(1e3, 2e3, vtk="/proc/ngcontact/fields")
    with pytest.raises(ValueError, match="out: the directory '/proc/ngcontact' cannot be written"):
        sim.run(1e3, 2e3, out="/proc/ngcontact")
    with pytest.raises(TypeError, match="progress must be True or False, got 'no'"):
        sim.run(1e3, 2e3, progress="no")
    assert len(sim.history) == 2 and sim.t == 1e3


@pytest.mark.parametrize("option, value, words", [
    ("keep_states", "no", "keep_states must be True or False, got 'no' (str)"),
    ("condense", "yes", "condense must be True, False or None (automatic), got 'yes'"),
    ("predictor", 2, "predictor must be True or False, got 2 (int)"),
    ("limit_steps", None, "limit_steps must be True or False, got None"),
    ("reuse_factorization", 1, "reuse_factorization must be True or False"),
    ("realcompile", "auto", "realcompile must be True, False or None"),
])
def test_options_are_booleans(mesh, option, value, words):
    """``keep_states="no"`` kept the states: the options are booleans (None: automatic)."""
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    with pytest.raises(TypeError, match=re.escape(words)):
        ngc.Simulation(body, **{option: value})
    earlier = option == "reuse_factorization"    # an earlier option of the solver: it warns, naming solver=
    with pytest.warns(DeprecationWarning, match="solver=") if earlier else contextlib.nullcontext():
        sim = ngc.Simulation(body, **{option: np.False_})
    assert sim.keep_states is (option != "keep_states")


def test_objects_of_the_wrong_type_are_named(mesh):
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    cases = [(lambda: ngc.Simulation(ngc.Contact()), "Simulation: body must be an ngcontact.Body, got Contact"),
             (lambda: ngc.Simulation(body, contact=body), "contact must be an ngcontact.Contact or None"),
             (lambda: ngc.Simulation(body, {"f2": {}}), "loads must be an ngcontact.Loads or None, got dict"),
             (lambda: ngc.Simulation(body, time=0.0), "time must be an ngsolve.Parameter or None"),
             (lambda: ngc.Body("mesh", ngc.pzt5a(), clamped="left"), "mesh must be an ngsolve.Mesh, got str"),
             (lambda: ngc.Body(mesh, {}, clamped="left"), "material must be an ngcontact.Material, got dict"),
             (lambda: ngc.Loads(f2=[(0, 1)]), "Loads.f2 must be a dict"),
             (lambda: ngc.Contact(method=None), "Contact.method must be one of"),
             (lambda: obstacles.SignedDistance("y", (0, 1)), "SignedDistance: distance must be a number")]
    for make, words in cases:
        with pytest.raises(TypeError, match=re.escape(words)):
            make()


def test_cutbacks_halve_without_recursion(mesh):
    """A step that converges only at dt <= dt0/2^k: advance with max_cutbacks = k makes 2^k
    steps of dt0/2^k after 2^k − 1 failed tries (each failed goal is halved once), and the
    stack under it is as deep for k = 10 as for k = 2 (a recursion per halving, which ended in
    a RecursionError for max_cutbacks = 1000, would be 8 frames deeper); with max_cutbacks =
    k − 1 it raises naming dt0 .. dt0/2^(k−1)."""
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    dt0 = 1.0

    def stack_depth():
        frame, depth = inspect.currentframe(), 0
        while frame is not None:
            frame, depth = frame.f_back, depth + 1
        return depth

    def attempt(k, max_cutbacks):
        sim, depths = ngc.Simulation(body, keep_states=False), []

        def take(dt, guess=None, target=None):
            depths.append(stack_depth())
            if dt > dt0 / 2 ** k * (1 + 1e-12):
                raise ngc.NewtonError("did not converge", iteration=1, residuals=[1.0, 0.5], step=len(sim.history),
                                      time=sim.t + dt)
            sim.scheme.t += dt
            sim.history.append(sim.scheme.t)
            return sim.scheme.t
        sim.steps.take, sim.steps.history = take, [0.0]
        return sim, sim.advance(dt0, max_cutbacks=max_cutbacks), max(depths)
    (sim, times, deep), (_, _, shallow) = attempt(10, 10), attempt(2, 2)
    assert np.allclose(times, np.arange(1, 2 ** 10 + 1) * dt0 / 2 ** 10)
    assert len(sim.cutbacks) == 2 ** 10 - 1 and deep == shallow
    with pytest.raises(ngc.NewtonError, match=r"dt = 1, 0.5, 0.25, 0.125 s"):
        attempt(5, 3)


def test_mesh_estimates_against_netgen():
    """The vertex estimate is within [0.9, 1.6] of Netgen's count on the plate and the block
    (refined: 2^dim per level), and a problem is refused exactly above memory / 2048 bytes."""
    for sides, h, refine, make in [((0.1, 0.02), 0.002, 0, lambda: plate(maxh=0.002)),
                                   ((0.1, 0.02), 0.005, 2, lambda: plate(maxh=0.005, refine=2)),
                                   ((0.1, 0.04, 0.02), 0.01, 1, lambda: block(maxh=0.01, refine=1))]:
        estimate = checks.estimated_ndof(checks.estimated_vertices(sides, h), len(sides), refine)
        actual = (len(sides) + 1) * make().nv
        assert 0.9 <= actual / estimate <= 1.6, (sides, h, refine, actual, estimate)
    assert checks.estimated_ndof(100, 3, refine=2, order=3) == 100 * 64 * 27 * 4
    limit = checks.memory() / checks.MEMORY_PER_DOF
    assert checks.fits_in_memory("x", 0.99 * limit) == 0.99 * limit
    with pytest.raises(ValueError, match=r"x: about .* DOFs \(estimated\), needing at least .*; this machine has"):
        checks.fits_in_memory("x", 1.01 * limit)
    with open("/proc/meminfo") as info:
        total = next(int(line.split()[1]) * 1024 for line in info if line.startswith("MemTotal:"))
    assert abs(checks.memory() - total) < 0.02 * total


@pytest.mark.parametrize("make, words", [
    (lambda: plate(L1=1e-12), "plate: the sides L1 = 1e-12 m, L2 = 0.02 m differ by more than 5000 times"),
    (lambda: plate(maxh=1e-6), "maxh must be a finite number in [2e-05, 0.1] m (0.0002 of the longest side"),
    (lambda: plate(maxh_contact=1e-9), "maxh_contact must be a finite number in [2e-05, 0.1] m"),
    (lambda: plate(maxh=float("inf")), "maxh must be a finite number in [2e-05, 0.1] m"),
    (lambda: plate(L1=1e308), "L1 must be a finite number in (0, 1000] m"),
    (lambda: plate(L1=1, L2=1, maxh=2e-4), "plate: L1 = 1 m, L2 = 1 m, maxh = 0.0002 m, refine = 0 (u and φ at P1): "
                                          "about 8.6e+07 DOFs (estimated), needing at least 165 GiB"),
    (lambda: plate(refine=10), "plate: L1 = 0.1 m, L2 = 0.02 m, maxh = 0.01 m, refine = 10 (u and φ at P1): about"),
    (lambda: block(refine=12), "refine must be an integer >= 0 and <= 10, got 12"),
    (lambda: block(maxh=1e-4), "block: L1 = 0.1 m, L2 = 0.04 m, L3 = 0.02 m, maxh = 0.0001 m, refine = 0"),
    (lambda: plate(comm=2), "comm must be None, False or an mpi4py communicator, got 2"),
    (lambda: ngc.Body(plate(maxh=0.05), ngc.pzt5a(), clamped="left", grounded="top", order=11),
     "order must be an integer >= 1 and <= 10, got 11"),
])
def test_sizes_are_bounded_before_meshing(make, words):
    with pytest.raises((ValueError, TypeError), match=re.escape(words)):
        make()
