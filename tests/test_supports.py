"""Supports: prescribed displacements, per component and normal (symmetry planes, rollers),
their reactions, and the errors of bad supports.

Homogeneous states (uniaxial stress or strain) are linear in x, so P1 and P2 reproduce them
to round-off: any inconsistency of the Dirichlet data or of the weak (Nitsche) normal
support shows at far above 1e-10.
"""
import ngsolve as ngs
import numpy as np
import pytest
from netgen.occ import Axis, Box, OCCGeometry, Pnt, Rectangle, X, Y, Z

import ngcontact as ngc
from ngcontact.model import supports as supports_module

E, NU, P = 1e9, 0.3, 1e6
ELASTIC = ngc.Material.isotropic(E, NU, permittivity=1e-9)


def square(angle=0.0, maxh=0.3, L=1.0):
    """The square [0, L]² turned by ``angle`` degrees about the origin; sides named as before."""
    face = Rectangle(L, L).Face()
    face.edges.Min(X).name, face.edges.Max(X).name = "left", "right"
    face.edges.Min(Y).name, face.edges.Max(Y).name = "bottom", "top"
    return ngs.Mesh(OCCGeometry(face.Rotate(Axis((0, 0, 0), Z), angle), dim=2).GenerateMesh(maxh=maxh))


def rotation(angle):
    a = np.radians(angle)
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def relative_error(u, exact, mesh):
    d = u - exact
    return np.sqrt(ngs.Integrate(ngs.InnerProduct(d, d), mesh) / ngs.Integrate(ngs.InnerProduct(exact, exact), mesh))


@pytest.mark.parametrize("angle", [0.0, 30.0])
@pytest.mark.parametrize("order", [1, 2])
def test_rollers_give_uniaxial_stress_at_any_angle(angle, order):
    """Rollers on two sides, pressure P on the opposite one: plane-strain uniaxial stress
    along the turned x axis, exact; the left roller carries the force P·L along its normal."""
    mesh, R = square(angle), rotation(angle)
    body = ngc.Body(mesh, ELASTIC, grounded="top", supports={"left": "normal", "bottom": "normal"}, order=order)
    assert [s.normal for s in body.supports] == [angle != 0.0] * 2      # weak where not along an axis
    sim = ngc.Simulation(body, ngc.Loads(f2={"right": tuple(-P * R @ [1.0, 0.0])}))
    sim.run(1.0, 1.0)
    strain = R @ np.diag([-P * (1 - NU ** 2) / E, P * NU * (1 + NU) / E]) @ R.T
    exact = ngs.CF((strain[0, 0] * ngs.x + strain[0, 1] * ngs.y, strain[1, 0] * ngs.x + strain[1, 1] * ngs.y))
    assert relative_error(sim.u, exact, mesh) < 1e-10
    reactions = sim.history[-1].boundary_reaction
    assert np.allclose(reactions["left"], P * R @ [1.0, 0.0], rtol=1e-9, atol=1e-9 * P)
    assert np.allclose(reactions["bottom"], 0.0, atol=1e-9 * P)


def test_weak_normal_support_is_consistent_for_a_viscous_piezoelectric_body(monkeypatch):
    """An axis-aligned roller as exact Dirichlet DOFs and as the weak Nitsche support (forced)
    give the same states over time steps to round-off for a viscous piezoelectric body under a
    ramped pressure (the homogeneous coupled state is linear in x, y): the Nitsche terms carry
    the step's stress σ_ν with its A ε(u̇) and Eᵀ∇φ parts correctly."""
    material = ngc.pzt5a(relaxation_time=1e-3)
    time = ngs.Parameter(0.0)

    def run():
        body = ngc.Body(square(maxh=0.25, L=0.01), material, grounded="top",
                        supports={"left": "normal", "bottom": "normal"}, order=2)
        sim = ngc.Simulation(body, ngc.Loads(f2={"right": (-P * time, 0.0)}), time=time)
        sim.run(1e-3, 3e-3)
        return body, sim
    exact_body, exact = run()
    monkeypatch.setattr(supports_module, "_normal_axis", lambda mesh, names, tol=1e-10: (None, 1.0))
    weak_body, weak = run()
    assert not exact_body.supports[0].normal and weak_body.supports[0].normal
    for a, b in zip(exact.history[1:], weak.history[1:]):
        assert np.abs(b.state - a.state).max() < 1e-9 * np.abs(a.state).max()
        assert np.allclose(b.boundary_reaction["left"], a.boundary_reaction["left"], rtol=1e-8, atol=1e-8 * P * 0.01)
    assert abs(exact.history[-1].boundary_reaction["left"][0] - P * time.Get() * 0.01) < 1e-8 * P * 0.01


def test_prescribed_displacement_drives_uniaxial_strain():
    """The top pushed down by d·t/T (y component only), rollers left and bottom: uniaxial
    stress σ_yy = E/(1 − ν²) ε_yy; the reactions of top and bottom are ∓σ_yy·L."""
    L, d, time = 1.0, 1e-4, ngs.Parameter(0.0)
    body = ngc.Body(square(), ELASTIC, grounded="top", supports={"left": "x", "bottom": "normal", "top": "y"})
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": -d * time}), time=time)
    sim.run(0.5, 1.0)
    for record in sim.history[1:]:
        strain = -d * record.time / L
        exact = ngs.CF((-NU / (1 - NU) * strain * ngs.x, strain * ngs.y))
        sigma = E / (1 - NU ** 2) * strain
        assert np.allclose(record.boundary_reaction["top"], [0.0, sigma * L], rtol=1e-9, atol=1e-9 * E * d)
        assert np.allclose(record.boundary_reaction["bottom"], [0.0, -sigma * L], rtol=1e-9, atol=1e-9 * E * d)
    assert relative_error(sim.u, exact, body.mesh) < 1e-10


def test_two_prescribed_supports_each_hold_their_value():
    """Left and right pulled apart by d·t each (u_x = ∓d t), a roller at the bottom: uniform
    strain ε = 2 d t/L, u = (ε (x − L/2), −ν/(1 − ν) ε y) to round-off. NGSolve's
    ``Set(cf, BND, definedon=right)`` zeroes every other DOF: the left support's values were
    lost (u_x = 0 there)."""
    L, d, time = 1.0, 1e-4, ngs.Parameter(0.0)
    body = ngc.Body(square(), ELASTIC, grounded="top", supports={"left": "x", "right": "x", "bottom": "y"})
    sim = ngc.Simulation(body, ngc.Loads(displacement={"left": -d * time, "right": d * time}), time=time)
    sim.run(1.0, 1.0)
    strain = 2 * d / L
    exact = ngs.CF((strain * (ngs.x - L / 2), -NU / (1 - NU) * strain * ngs.y))
    assert relative_error(sim.u, exact, body.mesh) < 1e-10


def test_a_step_starts_from_the_last_state_away_from_the_supports():
    """Setting the supports' values at t_n leaves every other DOF of u and φ as the last step
    left it (Newton's warm start; it was reset to 0 wherever a support or electrode had data)."""
    time = ngs.Parameter(0.0)
    body = ngc.Body(square(), ELASTIC, grounded="bottom", supports={"left": "x", "bottom": "y", "top": "y"})
    sim = ngc.Simulation(body, ngc.Loads(displacement={"top": -1e-4 * time}, potential={"bottom": 5 * time}),
                         time=time)
    sim.step(0.5)
    before = sim.gfu.vec.FV().NumPy().copy()
    sim.scheme.coefficients.set(1.0, 2.0, sim.u.vec.CreateVector())      # as a scheme sets step 2
    sim.system.begin_step(sim.gfu)
    after = sim.gfu.vec.FV().NumPy()
    free = np.array(list(sim.gfu.space.FreeDofs()), dtype=bool)
    assert np.count_nonzero(before[free]) > 0.5 * free.sum()
    assert np.array_equal(after[free], before[free])
    assert not np.array_equal(after[~free], before[~free])


def test_rollers_on_a_turned_block_3d():
    """3D: a block turned about two axes, rollers (weak) on three faces through a corner,
    pressure on the face opposite the x roller: uniaxial stress, exact."""
    box = Box(Pnt(0, 0, 0), Pnt(1, 1, 1))
    box.faces.Min(X).name, box.faces.Max(X).name = "left", "right"
    box.faces.Min(Y).name, box.faces.Max(Y).name = "front", "back"
    box.faces.Min(Z).name, box.faces.Max(Z).name = "bottom", "top"
    turned = box.Rotate(Axis((0, 0, 0), Z), 30).Rotate(Axis((0, 0, 0), X), 20)
    mesh = ngs.Mesh(OCCGeometry(turned).GenerateMesh(maxh=0.6))
    a, b = np.radians(30), np.radians(20)
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    R = Rx @ Rz
    body = ngc.Body(mesh, ELASTIC, grounded="top",
                    supports={"left": "normal", "front": "normal", "bottom": "normal"})
    assert all(s.normal for s in body.supports)
    sim = ngc.Simulation(body, ngc.Loads(f2={"right": tuple(-P * R[:, 0])}))
    sim.run(1.0, 1.0)
    strain = R @ np.diag([-P / E, NU * P / E, NU * P / E]) @ R.T
    exact = ngs.CF(tuple(sum(strain[i, j] * c for j, c in enumerate((ngs.x, ngs.y, ngs.z))) for i in range(3)))
    assert relative_error(sim.u, exact, mesh) < 1e-9
    assert np.allclose(sim.history[-1].boundary_reaction["left"], P * R[:, 0], rtol=1e-8, atol=1e-8 * P)


def test_bad_supports_are_named():
    mesh = square()
    def body(**kw):
        return ngc.Body(mesh, ELASTIC, grounded="top", **kw)
    with pytest.raises(ValueError, match="component 'z' does not exist in 2D"):
        body(supports={"left": "z"})
    with pytest.raises(ValueError, match=r"supports\['nope'\]: boundary \['nope'\] not in the mesh"):
        body(supports={"nope": "x"})
    with pytest.raises(TypeError, match=r"supports\['left'\] must be a string"):
        body(supports={"left": 1})
    with pytest.raises(ValueError, match="listed twice"):
        body(supports={"left": "x", "left|right": "y"})
    with pytest.raises(ValueError, match="must not overlap clamped"):
        body(clamped="left", supports={"left": "x"})
    with pytest.raises(ValueError, match="contact_side Γ3 must not overlap supports"):
        body(supports={"left": "x", "bottom": "y"}, contact_side="bottom")
    with pytest.raises(ValueError, match="clamped or supports must name at least one boundary"):
        body()
    held = body(supports={"left": "x", "bottom": "normal"})
    with pytest.raises(ValueError, match="'right' is not a support"):
        ngc.Simulation(held, ngc.Loads(displacement={"right": 0.0}))
    with pytest.raises(ValueError, match=r"Loads.displacement\['left'\].*1 fixed component"):
        ngc.Simulation(held, ngc.Loads(displacement={"left": (0.0, 1.0)}))
    turned = ngc.Body(square(30), ELASTIC, grounded="top", supports={"left": "normal", "bottom": "normal"})
    with pytest.raises(ValueError, match="only u·ν = 0 is offered"):
        ngc.Simulation(turned, ngc.Loads(displacement={"left": 1e-3}))
    with pytest.raises(ValueError, match="u0 must equal Loads.displacement on the supports at t = 0"):
        ngc.Simulation(held, ngc.Loads(displacement={"left": 1e-3}))


def test_a_scene_without_electric_part_solves_u_alone():
    """An elastic body without coupling, conduction or electric loads: φ is no unknown (its
    DOFs are in no solve), the displacement equals that of the same scene with φ kept to
    round-off, and the simulation says which model it solves; any electric part brings φ
    back, and asking for u alone then is an error."""
    mesh, R = square(30), rotation(30)
    loads = ngc.Loads(f2={"right": tuple(-P * R @ [1.0, 0.0])})

    def run(electric, grounded="top"):
        body = ngc.Body(mesh, ELASTIC, grounded=grounded, supports={"left": "normal", "bottom": "normal"}, order=2)
        sim = ngc.Simulation(body, loads, electric=electric)
        sim.run(1.0, 1.0)
        return sim
    alone, kept = run(None, grounded=None), run(True)
    assert alone.model.startswith("u alone") and kept.model.startswith("u and φ")
    free = alone.X.FreeDofs()
    assert all(not free[d] for d in range(alone.X.Range(1).start, alone.X.Range(1).stop))
    assert free.NumSet() == alone.body.V.FreeDofs().NumSet()
    nu = alone.body.V.ndof
    assert np.abs(alone.gfu.vec.FV().NumPy()[:nu] - kept.gfu.vec.FV().NumPy()[:nu]).max() < \
        1e-12 * np.abs(kept.gfu.vec.FV().NumPy()[:nu]).max()
    assert "u alone" in repr(alone)
    piezo = ngc.Body(mesh, ngc.pzt5a(), grounded="top", supports={"left": "normal", "bottom": "normal"})
    assert ngc.Simulation(piezo, loads).model == "u and φ (piezoelectric coupling)"
    elastic = ngc.Body(mesh, ELASTIC, supports={"left": "normal", "bottom": "normal"})
    with pytest.raises(ValueError, match="electric=False, but the scene has piezoelectric coupling"):
        ngc.Simulation(piezo, loads, electric=False)
    with pytest.raises(ValueError, match=r"Body.grounded must name at least one boundary: the scene solves for φ "
                                         r"\(charges or electrode potentials\)"):
        ngc.Simulation(elastic, ngc.Loads(qb={"top": 1e-3}))
    with pytest.raises(ValueError, match="grounded must name at least one boundary"):
        ngc.Body(mesh, ngc.pzt5a(), supports={"left": "normal"})


def test_two_electrodes_each_carry_their_charge():
    """A dielectric square between two electrodes at 0 V (bottom) and V(t) (top), the sides
    charge-free: a parallel-plate capacitor, Q_top = ε V L / H = −Q_bottom per metre of depth
    (the field is uniform, so P1 is exact)."""
    eps, L, volts = 1e-9, 1.0, 100.0
    t = ngs.Parameter(0.0)
    body = ngc.Body(square(), ngc.Material.isotropic(E, NU, permittivity=eps), clamped="left",
                    grounded="top|bottom")
    sim = ngc.Simulation(body, ngc.Loads(potential={"top": volts * t}), time=t)
    assert sim.model == "u and φ (charges or electrode potentials)"
    sim.run(0.5, 1.0)
    for record in sim.history:
        charge = eps * volts * record.time * L / L
        assert record.electrode_charge["top"] == pytest.approx(charge, rel=1e-9, abs=1e-20)
        assert record.electrode_charge["bottom"] == pytest.approx(-charge, rel=1e-9, abs=1e-20)
