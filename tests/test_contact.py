"""Contact on Γ3 by Nitsche's method: equilibrium, refinement, θ and γ0, adhesion, conduction."""
import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from conftest import C33, E33, EPS33
from support import StiffLayer, without
from ngcontact import Contact
from ngcontact.contact_laws import conductance_literal
from ngcontact.model.forms import matrix_cf, normal_stress, strain
from ngcontact.geometries import plate

GAP, P = 2e-5, 2e6


def pressed_plate(contact, order=1, refine=0, maxh=0.01, material=None, pressure=P, **kw):
    """The reference plate pressed onto the foundation, the pressure ramped over t in [0, 1]:
    contact near the free end."""
    t = ngs.Parameter(0)
    body = ngc.Body(plate(maxh=maxh, refine=refine), material or ngc.pzt5a(), clamped="left",
                    grounded="top", contact_side="bottom", order=order)
    return ngc.Simulation(body, ngc.Loads(f2={"top": (0, -pressure * t)}), contact=contact, time=t, **kw)


@pytest.mark.parametrize("theta", [1, 0, -1])
@pytest.mark.parametrize("order", [1, 2])
def test_force_balance(theta, order):
    """Foundation force + support reaction = applied load (to 1e-6), partial contact."""
    sim = pressed_plate(Contact(gap=GAP, theta=theta), order=order)
    h = sim.run(dt=1, T=1)
    c = h[-1].contact
    assert 0.1 * 0.1 < c.contact_area < 0.9 * 0.1
    assert np.dot(c.contact_set, sim.side.measure) == pytest.approx(c.contact_area, rel=1e-12)
    assert np.all(c.pressure[c.contact_set == 0] <= 0) and np.all(c.pressure[c.contact_set == 1] > 0)
    total = h[-1].reaction + c.force + np.array([0, -P * 0.1])
    assert np.abs(total).max() < 1e-6 * P * 0.1
    assert c.force[1] > 0.3 * P * 0.1


def test_penetration_and_complementarity_shrink_under_refinement():
    pen, comp = [], []
    for refine in range(3):
        c = pressed_plate(Contact(gap=GAP), refine=refine).run(dt=1, T=1)[-1].contact
        pen.append(c.max_penetration)
        comp.append(c.complementarity)
    assert pen[0] > 0 and pen[2] < 0.5 * pen[0] and np.all(np.diff(pen) < 0)
    assert comp[2] < 0.5 * comp[0] and np.all(np.diff(comp) < 0)
    assert max(pen) < 1e-2 * GAP


def test_theta_minus_one_converges_for_every_gamma0():
    """Skew-symmetric Nitsche converges for every γ0 > 0 tried; θ = 1, 0 for γ0 large enough.
    All converged solutions agree on the contact force."""
    forces = {}
    for gamma0 in (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0):
        h = pressed_plate(Contact(gap=GAP, theta=-1, gamma0=gamma0)).run(dt=1, T=1)
        forces[(-1, gamma0)] = h[-1].contact.force[1]
        assert h[-1].newton_iterations <= 25
    for theta in (1, 0):
        for gamma0 in (10.0, 100.0):
            h = pressed_plate(Contact(gap=GAP, theta=theta, gamma0=gamma0)).run(dt=1, T=1)
            forces[(theta, gamma0)] = h[-1].contact.force[1]
    reference = forces[(1, 100.0)]
    for key in [(1, 10.0), (0, 10.0), (0, 100.0), (-1, 10.0), (-1, 100.0)]:
        assert forces[key] == pytest.approx(reference, rel=2e-2), key


def test_reduces_to_chouly_hild():
    """p = 0, γ_ν = 0, A = 0, E = 0: the residual is Chouly & Hild's, term by term."""
    m = ngc.Material.isotropic(2e11, 0.3, permittivity=1e-9)
    for theta in (1, 0, -1):
        sim = pressed_plate(Contact(gap=GAP, theta=theta, gamma0=3.0), order=2, material=m)
        body, X = sim.body, sim.body.X
        (u, phi), (v, xi) = X.TnT()
        n = ngs.specialcf.normal(2)
        F = matrix_cf(body.tensors.F)
        sn = lambda w: normal_stress(body.tensors, F * strain(w), n)
        gamma = 3.0 * 4 * np.linalg.eigvalsh(body.tensors.F).max() / ngs.specialcf.mesh_size
        Pu = sn(u) - gamma * (u * n - GAP)
        ch = ngs.BilinearForm(X)
        ch += (ngs.InnerProduct(F * strain(u), strain(v))
               - 1e-9 * ngs.grad(phi) * ngs.grad(xi)) * ngs.dx          # −c(φ, ξ), electric negated
        ch += (-theta / gamma * sn(u) * sn(v) + 1 / gamma * ngs.IfPos(Pu, 0, Pu) * (theta * sn(v) - gamma * v * n)) \
            * ngs.ds(skeleton=True, definedon=body.region("contact_side"))
        ch += ngs.CF((0, P)) * sim.time * v * ngs.ds("top")
        x = sim.gfu.vec.CreateVector()
        rng = np.random.default_rng(1)
        x.FV().NumPy()[:] = rng.normal(size=len(x)) * 3e-5
        sim.scheme.coefficients.set(0.7, 10.0, sim.u.vec)                     # the loads at t = 0.7
        sim.system.begin_step(sim.gfu)
        r1, r2 = x.CreateVector(), x.CreateVector()
        sim.system.Apply(x, r1)
        ch.Apply(x, r2)
        assert np.allclose(r1.FV().NumPy(), r2.FV().NumPy(), rtol=1e-10, atol=1e-10 * np.abs(r2.FV().NumPy()).max())


@pytest.mark.parametrize("force, bonded", [(2e7, True), (1e9, False)])
def test_adhesion_pulls_back(uniaxial, force, bonded):
    """Column clamped on top, lifted by a body force f: the glue holds the bottom with
    σ_ν = γ_ν β² |u_ν| while |u_ν| <= L (and γ_ν β² L beyond). Open circuit at the bottom,
    so the stiffness is c_D = c33 + e33²/ε33; P2 holds the quadratic exact solution."""
    W, H, gamma_nu, L = 0.01, 0.03, 1e12, 1e-6
    body = ngc.Body(plate(L1=W, L2=H, maxh=0.01), uniaxial(), clamped="top", grounded="top",
                    contact_side="bottom", order=2)
    sim = ngc.Simulation(body, ngc.Loads(f0=(0, force)), contact=Contact(
        gap=1e-3, adhesion=gamma_nu, eps_a=1e9, bond_length=L, theta=1))
    h = sim.run(dt=1, T=1)
    cD = C33 + E33**2 / EPS33
    if bonded:
        sigma0 = gamma_nu * force * H**2 / (2 * (cD + gamma_nu * H))
        assert sigma0 / gamma_nu < L
    else:
        sigma0 = gamma_nu * L
    lift = sim.u(body.mesh(W / 2, 0))[1]
    assert lift == pytest.approx((force * H**2 / 2 - sigma0 * H) / cD, rel=1e-8)
    if bonded:
        assert lift == pytest.approx(sigma0 / gamma_nu, rel=1e-8)
    assert np.allclose(h[-1].contact.pressure, -sigma0, rtol=1e-8)
    assert np.all(h[-1].contact.beta == 1)


def conducting_plate(psi, gamma0=10.0):
    contact = Contact(gap=GAP, conductance=psi, ramp_width=1e-6, potential_truncation=50.0,
                      foundation_potential=20.0, gamma0=gamma0)
    return pressed_plate(contact, order=2, maxh=0.005)


def test_current_flows_through_the_contact_zone_only():
    """φ_Γ = 20 V: D·ν = ψ φ_L on Γ3 is nonzero only where u_ν - g > -δ; the charge flux
    through Γ3 is the charge on the grounded electrode (charge conservation, to 1e-8)."""
    sim = conducting_plate(1e-6)
    h = sim.run(dt=0.25, T=1)
    c = h[-1].contact
    opening = sim.side.normal_displacement(sim.u) - sim.side.sample(sim.gap)
    far = opening.max(axis=1) < -1e-6
    touching = opening.min(axis=1) > -1e-8
    assert far.sum() > 5 and touching.sum() > 3
    assert np.all(c.charge_flux_density[far] == 0)
    assert np.all(np.abs(c.charge_flux_density[touching]) > 0.1 * np.abs(c.charge_flux_density).max())
    assert c.charge_flux == pytest.approx(h[-1].electrode_charge["top"], rel=1e-8)
    # φ on Γ3 > φ_Γ here? then charge leaves the body (D·ν > 0), and vice versa
    assert np.all(np.sign(c.charge_flux_density[touching]) == np.sign(c.potential[touching] - 20.0))


def test_literal_conductance_conducts_only_through_penetration():
    """ψ = 0 for u_ν − g <= 0 read literally: the charge flux comes from the numerical
    penetration alone, tiny against the ramp's, and it shrinks as γ0 grows."""
    ramp = conducting_plate(1e-6).run(dt=0.25, T=1)[-1].contact.charge_flux
    literal = [conducting_plate(conductance_literal(1e-6, 1e-6), gamma0=g).run(dt=0.25, T=1)[-1].contact
               for g in (10.0, 1000.0)]
    assert abs(literal[0].charge_flux) < 1e-2 * abs(ramp)
    assert abs(literal[1].charge_flux) < 0.1 * abs(literal[0].charge_flux)
    assert literal[1].max_penetration < literal[0].max_penetration


def test_contact_input_rejected():
    mesh = plate(maxh=0.01)
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top")
    with pytest.raises(ValueError, match="no contact side"):
        ngc.Simulation(body, contact=Contact())
    body = ngc.Body(mesh, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    with pytest.raises(ValueError, match="Contact.gap must be >= 0"):
        ngc.Simulation(body, contact=Contact(gap=ngs.x - 0.05))
    with pytest.raises(ValueError, match="u0 must be admissible"):
        ngc.Simulation(body, contact=Contact(gap=1e-6), u0=(0, -3e-5 * ngs.x))
    with pytest.raises(ValueError, match="beta0 must lie in"):
        ngc.Simulation(body, contact=Contact(beta0=ngs.x * 20))


def test_non_convergence_names_the_step_and_keeps_earlier_steps():
    """maxit = 2 is too few when the plate first touches the foundation."""
    t = ngs.Parameter(0)
    body = ngc.Body(plate(maxh=0.01), ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
    sim = ngc.Simulation(body, ngc.Loads(f2={"top": (0, -P * t)}), contact=Contact(gap=GAP), time=t, maxit=2)
    with pytest.raises(ngc.NewtonError, match=r"did not converge in 2 iterations .*at step \d+") as err:
        sim.run(dt=0.05, T=1, max_cutbacks=0)
    steps = err.value.history
    assert len(steps) == err.value.step and err.value.step > 1
    assert steps[-1].contact.contact_area == 0 and len(err.value.residuals) == 3


def test_penalty_method_penetrates_like_one_over_epsilon():
    """Penalty (stiff normal compliance): balanced, symmetric (sparse Cholesky), penetration
    ∝ 1/penalty, and the contact force tends to Nitsche's as the penalty grows."""
    nitsche = pressed_plate(Contact(gap=GAP, theta=-1, gamma0=100.0)).run(dt=1, T=1)[-1].contact.force[1]
    penetration, force = [], []
    for factor in (10.0, 100.0, 1000.0):
        sim = pressed_plate(Contact(gap=GAP, method="penalty", penalty=factor))
        assert "sparsecholesky" in sim.solver
        h = sim.run(dt=1, T=1)
        c = h[-1].contact
        assert np.abs(h[-1].reaction + c.force - [0, P * 0.1]).max() < 1e-6 * P * 0.1
        penetration.append(c.max_penetration)
        force.append(c.force[1])
    ratios = np.array(penetration[:-1]) / penetration[1:]
    assert np.all(ratios > 7) and np.all(ratios < 13), ratios
    assert abs(force[-1] - nitsche) < 0.1 * abs(force[0] - nitsche) + 1e-3 * abs(nitsche)


def test_nodal_active_set_is_the_papers_p1_constraint():
    """method="active_set": u_ν <= g exactly at the nodes of Γ3 (no penetration), balanced,
    and the same contact force as Nitsche and the penalty method (to 1e-3)."""
    nitsche = pressed_plate(Contact(gap=GAP, theta=-1, gamma0=100.0), refine=1).run(dt=1, T=1)[-1].contact
    sim = pressed_plate(Contact(gap=GAP, method="active_set"), refine=1)
    h = sim.run(dt=1, T=1)
    c = h[-1].contact
    assert c.max_penetration <= 1e-15 and nitsche.max_penetration > 1e-10
    assert np.abs(h[-1].reaction + c.force - [0, P * 0.1]).max() < 1e-9 * P * 0.1
    assert c.force[1] == pytest.approx(nitsche.force[1], rel=1e-3)
    nodal = sim.enforcement.newton_hook
    lam = nodal.lam
    assert np.all(lam >= 0) and np.count_nonzero(lam) >= 3
    gap = nodal.B @ sim.gfu.vec.FV().NumPy() - nodal.g
    assert np.abs(lam * gap).max() < 1e-12 * P * 0.1 * GAP            # complementarity, nodal


def test_active_set_needs_p1():
    body = ngc.Body(plate(maxh=0.01), ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom", order=2)
    with pytest.raises(ValueError, match="'active_set' is the paper's P1 scheme: it needs Body order 1"):
        ngc.Simulation(body, contact=Contact(method="active_set"))
    with pytest.raises(ValueError, match="Contact.method must be"):
        Contact(method="lagrange")
    with pytest.raises(ValueError, match="Contact.penalty must be a finite number > 0"):
        Contact(method="penalty", penalty=0)


# ------------------------------------------------------------------------------- methods as objects

@pytest.mark.parametrize("given, shorthand", [
    (ngc.Nitsche(theta=-1, gamma0=100.0), dict(theta=-1, gamma0=100.0)),
    (ngc.Penalty(factor=1e4), dict(method="penalty", penalty=1e4)),
    (ngc.NodalConstraint(), dict(method="active_set")),
])
def test_a_method_object_is_its_shorthand(given, shorthand):
    """``Contact(method=Nitsche(...))`` and the shorthand with Contact's fields give the same run,
    bit for bit, and the same fingerprint of the method."""
    runs = []
    for contact in (Contact(gap=GAP, method=given), Contact(gap=GAP, **shorthand)):
        sim = pressed_plate(contact)
        runs.append((sim.run(dt=0.5, T=1)[-1], contact))
    (a, ca), (b, cb) = runs
    assert np.array_equal(a.contact.force, b.contact.force) and np.array_equal(a.reaction, b.reaction)
    assert ca.enforcement_method == cb.enforcement_method
    assert (ca.theta, ca.gamma0, ca.penalty) == (cb.theta, cb.gamma0, cb.penalty)
    assert a.contact.force[1] > 0.3 * P * 0.1


def test_a_method_of_the_users_runs_without_an_edit_of_the_package():
    """A method object written here (the penalty law with its own name, of about 20 lines)
    takes part through the ``enforcement.Method`` protocol: the same force as ``Penalty``,
    its own name in the simulation and the refusal of an obstacle it says it does not take."""
    from ngcontact.gamma3.enforcement.penalty import PenaltyTerms

    class NormalLayer:
        name, keeps_symmetry, skew_symmetric = "stiff layer", True, False
        condensable, distributable, takes_obstacle = True, True, False

        def __init__(self, factor):
            self.factor = factor

        def contact_fields(self):
            return {}

        def stiffness_factors(self):
            return {"the stiff layer": self.factor}

        def flags(self):
            return ["the stiff layer penetrates"] if self.factor < 10 else []

        def check_obstacle(self):
            raise ValueError("the stiff layer acts along the body's normal only")

        def build(self, body, contact, side, *, gap, coefficients, normal):
            return PenaltyTerms(self, body, gap=gap, coefficients=coefficients, normal=normal)

    mine = pressed_plate(Contact(gap=GAP, method=NormalLayer(1e4)))
    theirs = pressed_plate(Contact(gap=GAP, method=ngc.Penalty(1e4)))
    a, b = mine.run(dt=0.5, T=1)[-1], theirs.run(dt=0.5, T=1)[-1]
    assert np.abs(a.contact.force - b.contact.force).max() <= 1e-12 * np.abs(b.contact.force).max()
    assert "contact: stiff layer" in repr(mine)
    with pytest.warns(ngc.PhysicsWarning, match="the stiff layer penetrates"):
        pressed_plate(Contact(gap=GAP, method=NormalLayer(1.0)))
    with pytest.raises(ValueError, match="the stiff layer acts along the body's normal only"):
        Contact(method=NormalLayer(1e4), obstacle=ngc.obstacles.Plane((0.0, -GAP), (0.0, 1.0)))


def test_a_method_object_and_contacts_fields_must_agree():
    with pytest.raises(ValueError, match=r"Contact.gamma0 = 7 contradicts method=Nitsche\(theta=1, gamma0=5.0\) "
                                         r"\(its gamma0 is 5.0\): give gamma0 in one place"):
        Contact(method=ngc.Nitsche(gamma0=5.0), gamma0=7)
    with pytest.raises(ValueError, match="Contact.theta = -1 means nothing with method Penalty"):
        Contact(method=ngc.Penalty(), theta=-1)
    with pytest.raises(ValueError, match="Nitsche.theta must be 1, 0 or -1, got 2"):
        ngc.Nitsche(theta=2)
    with pytest.raises(ValueError, match="Penalty.factor"):
        ngc.Penalty(factor=-1.0)
    with pytest.raises(TypeError, match="Contact.method must be one of .* or a method object"):
        Contact(method=object())
    assert Contact(method=ngc.Nitsche(theta=0, gamma0=5.0)).theta == 0


@pytest.mark.parametrize("data, words", [
    (dict(method=ngc.Nitsche(theta=-1), theta=1), r"Contact.theta = 1 contradicts method=Nitsche\(theta=-1, "),
    (dict(method=ngc.Nitsche(gamma0=5.0), gamma0=10.0), r"Contact.gamma0 = 10.0 contradicts method=Nitsche\("),
    (dict(method=ngc.Penalty(1e4), penalty=1e3), r"Contact.penalty = 1000.0 contradicts method=Penalty\("),
    (dict(method="penalty", gamma0=10.0), r"Contact.gamma0 = 10.0 means nothing with method 'penalty'"),
    (dict(method="active_set", penalty=1e3), r"Contact.penalty = 1000.0 means nothing with method 'active_set'"),
    (dict(penalty=1e3), r"Contact.penalty = 1000.0 means nothing with method 'nitsche'"),
    (dict(method=ngc.NodalConstraint(), theta=1), r"Contact.theta = 1 means nothing with method NodalConstraint\(\)"),
])
def test_only_the_parameters_given_count_and_each_must_fit_the_method(data, words):
    """θ, γ0 and penalty given are compared with the method (also at the values they default
    to): a contradiction with the method object, or one the method does not take, is refused."""
    with pytest.raises(ValueError, match=words):
        Contact(**data)


def test_the_parameters_left_out_take_the_methods_and_replace_round_trips():
    import dataclasses
    from ngcontact.gamma3.contact import NOT_GIVEN
    nitsche, penalty = Contact(gap=GAP), Contact(gap=GAP, method="penalty")
    assert (nitsche.theta, nitsche.gamma0, nitsche.penalty) == (1, 10.0, NOT_GIVEN)
    assert (penalty.theta, penalty.gamma0, penalty.penalty) == (NOT_GIVEN, NOT_GIVEN, 1e3)
    assert Contact(method=ngc.Nitsche(theta=-1), theta=-1).enforcement_method == ngc.Nitsche(theta=-1)
    for contact in (nitsche, penalty, Contact(method=ngc.Nitsche(theta=0, gamma0=3.0))):
        again = dataclasses.replace(contact, gap=1e-5)
        assert again.enforcement_method == contact.enforcement_method and again.gap == 1e-5


@pytest.mark.parametrize("names, changes, words", [
    (("condensable",), {}, "lacks condensable"),
    (("flags", "contact_fields"), {}, "lacks contact_fields, flags"),
    ((), dict(distributable=False), r"lacks serial_only \(needed as its distributable is False\)"),
    ((), dict(takes_obstacle=False), r"lacks check_obstacle \(needed as its takes_obstacle is False\)"),
    ((), dict(condensable="yes"), "has condensable = 'yes': each must be True or False"),
    ((), dict(contact_fields=lambda self: {"gamma": 1}), r"returned \{'gamma': 1\} from contact_fields\(\)"),
    ((), dict(build=lambda self, body: None), "has a build that does not take"),
])
def test_a_user_method_is_checked_member_by_member_at_contact(names, changes, words):
    with pytest.raises(TypeError, match=rf"Contact.method: the method object .*Lacking {words}"):
        Contact(method=without(*names, class_name="Lacking", **changes))
    with pytest.raises(TypeError, match=r"got the class StiffLayer: give an instance, e.g. StiffLayer\(\)"):
        Contact(method=StiffLayer)


def test_what_a_user_methods_build_returns_is_checked():
    class Nothing(StiffLayer):
        def build(self, body, contact, side, **kw):
            return None

    with pytest.raises(TypeError, match=r"Contact.method: .*Nothing.build returned None: it must return the Γ3 "
                                        r"expressions .*Enforcement"):
        pressed_plate(Contact(gap=GAP, method=Nothing(1e4)), maxh=0.02)


def test_a_user_method_written_with_the_public_names_runs_as_penalty():
    """StiffLayer (tests/support.py: its Γ3 terms written with ``ngcontact.methods.boundary_stiffness``
    and ``ngcontact.contact_laws`` only) makes Penalty's steps with the same factor, through
    contact, to round-off."""
    runs = []
    for method in (StiffLayer(1e4), ngc.Penalty(1e4)):
        sim = pressed_plate(Contact(gap=GAP, method=method), maxh=0.02)
        sim.run(0.25, 1.0)
        runs.append(sim)
    mine, penalty = runs
    assert penalty.history[-1].contact.contact_area > 0
    for a, b in zip(mine.history, penalty.history):
        assert np.abs(a.state - b.state).max() <= 1e-12 * np.abs(penalty.history[-1].state).max()
    assert ngc.methods.boundary_stiffness is ngc.model.forms.boundary_stiffness


def test_a_user_methods_class_and_parameters_are_in_the_fingerprint():
    """Two user methods that differ in a parameter are two scenes; the package's methods keep
    their fields (no class, no parameters: earlier runs keep their fingerprint)."""
    from ngcontact.output import fingerprint
    prints = [pressed_plate(Contact(gap=GAP, method=m), maxh=0.02).fingerprint(1.0)
              for m in (StiffLayer(1e4), StiffLayer(2e4), StiffLayer(1e4), ngc.Penalty(1e4))]
    assert prints[0]["contact.method.class"] == "support.StiffLayer"
    assert prints[0]["contact.method.parameters.factor"] == 1e4
    assert [k for k, _, _ in fingerprint.differences(prints[0], prints[1])] == ["contact.method.parameters.factor"]
    assert fingerprint.differences(prints[0], prints[2]) == []
    assert not any(k.startswith("contact.method.") for k in prints[3])
    assert (prints[3]["contact.theta"], prints[3]["contact.gamma0"], prints[3]["contact.penalty"]) == (1, 10.0, 1e4)


def test_a_user_methods_parameters_come_from_parameters_or_its_public_attributes():
    """``parameters()`` where the method has it; else its attributes without the private ones
    (a cache of its own is no parameter)."""
    from ngcontact.output import fingerprint

    class Cached(StiffLayer):
        def build(self, body, contact, side, **kw):
            self._terms = super().build(body, contact, side, **kw)
            return self._terms

    class Declared(StiffLayer):
        def parameters(self):
            return {"ε factor": self.factor, "law": "linear"}

    cached = pressed_plate(Contact(gap=GAP, method=Cached(1e4)), maxh=0.02).fingerprint(1.0)
    declared = pressed_plate(Contact(gap=GAP, method=Declared(2e4)), maxh=0.02).fingerprint(1.0)
    assert {k: v for k, v in cached.items() if k.startswith("contact.method.parameters")} == {
        "contact.method.parameters.factor": 1e4}
    assert {k: v for k, v in declared.items() if k.startswith("contact.method.parameters")} == {
        "contact.method.parameters.law": "linear", "contact.method.parameters.ε factor": 2e4}
