"""Bad input, fuzzed: every invalid value of every public parameter gives a ValueError or
TypeError that names the parameter, before any work (no other exception, no hang, no
silently wrong result); the CLI prints that one line and exits with status 2.

Hypothesis draws the values (non-finite numbers, out-of-range numbers, strings, None,
booleans, lists); each parameter's rule of validity filters them to the invalid ones.
"""
import math
import subprocess
import sys

import ngsolve as ngs
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import ngcontact as ngc
from ngcontact import obstacles
from ngcontact.geometries import plate

MESH = plate(maxh=0.01)
BODY = ngc.Body(MESH, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
SIM = ngc.Simulation(BODY, keep_states=False)

ANYTHING = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e308, -1e-300, 0.5, 1.5, 2, -2]),
    st.integers(min_value=-5, max_value=5),
    st.sampled_from(["2", "", "nan", None, True, False, [1.0], (1.0, 2.0), {}]),
)


def real(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def positive(v):
    return real(v) and v > 0


def nonnegative(v):
    return real(v) and v >= 0


def whole(low):
    return lambda v: real(v) and int(v) == v and v >= low


# (what is built, parameter, the rule of a valid value, a call that uses the value)
CASES = [
    *[("Contact", p, rule, lambda v, p=p: ngc.Contact(**{p: v})) for p, rule in [
        ("gap", nonnegative), ("compliance", nonnegative), ("adhesion", nonnegative), ("eps_a", nonnegative),
        ("bond_length", positive), ("beta0", lambda v: real(v) and 0 <= v <= 1),
        ("conductance", nonnegative), ("ramp_width", positive), ("potential_truncation", positive),
        ("foundation_potential", real), ("gamma0", positive), ("penalty", positive),
        ("theta", lambda v: v in (1, 0, -1) and not isinstance(v, bool) and v == int(v))]],
    *[("Body", p, rule, lambda v, p=p: ngc.Body(MESH, ngc.pzt5a(), **{
        **dict(clamped="left", grounded="top", contact_side="bottom"), p: v})) for p, rule in [
        ("order", whole(1)), ("order_phi", lambda v: v is None or whole(1)(v))]],
    *[("Material.isotropic", p, rule, lambda v, p=p: ngc.Material.isotropic(**{
        **dict(E=1e9, nu=0.3, permittivity=1e-9), p: v})) for p, rule in [
        ("E", positive), ("nu", lambda v: real(v) and -1 < v < 0.5), ("permittivity", positive),
        ("viscosity", nonnegative)]],
    ("pzt5a", "relaxation_time", nonnegative, lambda v: ngc.pzt5a(relaxation_time=v)),
    ("Simulation", "rtol", lambda v: real(v) and 0 < v < 1, lambda v: ngc.Simulation(BODY, rtol=v)),
    ("Simulation", "maxit", whole(1), lambda v: ngc.Simulation(BODY, maxit=v)),
    ("run", "dt", lambda v: positive(v) and v >= 1e-6, lambda v: SIM.run(v, 1.0)),
    ("run", "T", lambda v: real(v) and v > 0, lambda v: SIM.run(0.5, v)),
    ("Loads", "f2", real, lambda v: ngc.Simulation(BODY, ngc.Loads(f2={"top": (0.0, v)}))),
    ("Plane", "normal", lambda v: isinstance(v, (tuple, list)) and len(v) > 0 and all(real(x) for x in v)
     and any(x != 0 for x in v), lambda v: obstacles.Plane((0, 0), v)),
    ("Cylinder", "radius", positive, lambda v: obstacles.Cylinder((0, 0), v)),
]


@pytest.mark.parametrize("what, parameter, valid, build", CASES, ids=[f"{c[0]}.{c[1]}" for c in CASES])
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(value=ANYTHING)
def test_invalid_values_are_named(what, parameter, valid, build, value):
    assume(not valid(value))
    with pytest.raises((ValueError, TypeError)) as err:
        build(value)
    assert parameter.split(".")[-1] in str(err.value), str(err.value)


@pytest.mark.parametrize("arguments, words", [
    (["demo", "--steps", "0"], "steps must be an integer >= 1"),
    (["demo", "--maxh", "-1"], "maxh"),
    (["demo", "--out", "/proc/ngcontact-cannot-write"], "cannot be written"),
    (["convergence", "--levels", "0"], "--levels must be an integer >= 1"),
    (["hertz", "--levels", "0"], "levels must be an integer >= 1"),
])
def test_the_cli_prints_one_line_and_exits_2(arguments, words):
    done = subprocess.run([sys.executable, "-m", "ngcontact", *arguments], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in done.stderr


def test_a_load_on_another_parameter_is_refused():
    """A Simulation built without ``time=t`` would never move loads written with t."""
    t = ngs.Parameter(0.0)
    with pytest.raises(ValueError, match=r"Loads.f2\['top'\] depends on an ngsolve.Parameter that is not the "
                                         r"simulation's time"):
        ngc.Simulation(BODY, ngc.Loads(f2={"top": (0, -1e6 * t)}))
    with pytest.raises(ValueError, match="Contact.foundation_potential depends on an ngsolve.Parameter"):
        ngc.Simulation(BODY, contact=ngc.Contact(foundation_potential=10 * t))


def test_meaningless_results_are_flagged():
    """2e14 Pa on the plate: |u| of metres and centimetres of penetration are flagged with the
    step, the quantity and the threshold."""
    t = ngs.Parameter(0.0)
    sim = ngc.Simulation(BODY, ngc.Loads(f2={"top": (0, -2e14 * t)}), contact=ngc.Contact(gap=2e-5), time=t)
    with pytest.warns(ngc.PhysicsWarning, match=r"step 1 \(t = 0.5 s\): displacement .* exceeds 0.05 of the "
                                                r"body's size"):
        sim.run(0.5, 1.0)
    assert any("penetration" in m and "exceeds 0.1 of the smallest facet" in m for m in sim.flags)
