"""The time schemes on the glued column against an independent semi-discrete system
(``studies.semidiscrete_column``): ngcontact's steps are that system's steps, and BDF2
converges at second order to its Radau solution (``studies.column_order``)."""
import numpy as np
import pytest

from ngcontact.studies import column_order
from ngcontact.studies.semidiscrete_column import SemiDiscreteColumn

F0, T = column_order.HISTORIES["lift"]


@pytest.fixture(scope="module")
def system():
    return column_order.semidiscrete(F0, column_order.NGCONTACT_QUADRATURE)


@pytest.mark.parametrize("scheme", column_order.SCHEMES)
def test_ngcontact_steps_the_semidiscrete_system(system, scheme):
    """16 steps of T/16 (β falls to 0.90-0.91, u_ν to −0.21 L) of ngcontact equal the same scheme
    written on the semi-discrete system, to the Newton tolerance (BDF2: its β passes asked to stop
    at changes of 1e-10, as consistent as the replica's joint solve of u and β; by default they
    stop at 1e-6); Γ3 stays open, so the Nitsche term vanishes (θ = 0)."""
    sim, info = column_order.run(F0, T, scheme, 16, beta_tolerance=1e-10)
    assert info["max_contact_area"] == 0 and info["max_multiplier"] == 0 and info["max_penetration"] < 0
    u, beta = getattr(system, scheme)(16, T)
    U, P = system.full(u)
    found = column_order.errors(column_order._fields(sim, system), (U, beta, P))
    tolerance = 1e-12 if scheme == "backward_euler" else 1e-9
    assert found["error_u"] < tolerance and found["error_beta"] < tolerance and found["error_phi"] < tolerance, found
    assert beta.max() < 0.95                        # the glue has debonded in part: β is tested


def test_bdf2_is_second_order_against_radau(system):
    """BDF2 at 8, 16 and 32 steps over the lift: its error at T against Radau (rtol 1e-10, ~1e-12
    from rtol 1e-12) falls by >= 3.3x per halving in u, β and φ (first order would give 2x)."""
    u, beta, _ = system.radau(T, rtol=1e-10)
    U, P = system.full(u)
    found = [column_order.errors(column_order._fields(column_order.run(F0, T, "bdf2", n)[0], system), (U, beta, P))
             for n in (8, 16, 32)]
    for field in ("error_u", "error_beta", "error_phi"):
        ratios = [a[field] / b[field] for a, b in zip(found, found[1:])]
        assert min(ratios) >= 3.3, (field, ratios, found)


def test_semidiscrete_column_refuses_what_it_does_not_model():
    import ngcontact as ngc
    from ngcontact.scenes import column
    with pytest.raises(ValueError, match="conductance"):
        SemiDiscreteColumn(column.body(), ngc.Contact(adhesion=1e11, conductance=1e-4), lambda t: 0.0)
    with pytest.raises(ValueError, match="quadrature"):
        SemiDiscreteColumn(column.body(), ngc.Contact(adhesion=1e11), lambda t: 0.0, quadrature=(2,))
    with pytest.raises(ValueError, match="steps must increase"):
        column_order.study(steps=(32, 16))
    with pytest.raises(ValueError, match="histories"):
        column_order.study(histories=("peel",))


def test_bdf2_s_clipped_glue_is_flagged_under_its_own_name():
    """On the debonding history at 16 steps (λk = γ_ν L² k = 1.09) BDF2's β̂ falls below 0 and is
    clipped: the flag names BDF2's update, not backward Euler's explicit (4.5)."""
    import ngcontact as ngc
    from ngcontact.scenes import column
    F0_debond, T_debond = column_order.HISTORIES["debond"]
    sim = column.simulation(column_order.pull(F0_debond), column_order.contact(), scheme="bdf2", keep_states=False)
    with pytest.warns(ngc.PhysicsWarning, match=r"the bdf2 update of β left \[0, 1\] on \d+ facets and was clipped"):
        sim.run(T_debond / 16, T_debond)
    assert not any("(4.5)" in flag for flag in sim.flags)
