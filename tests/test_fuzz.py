"""Bad input, fuzzed: every invalid value of every public parameter (Simulation and its
options, run, advance, step, Contact, Body, Material, Loads, the obstacles, the geometries)
gives a ValueError or TypeError that names the parameter, before any work (no other
exception, no hang, no silently wrong result); the CLI prints that one line and exits with
status 2, a failed Newton solve included.

Hypothesis draws the values (non-finite numbers, out-of-range numbers, strings, None,
booleans, lists); each parameter's rule of validity filters them to the invalid ones.
"""
import contextlib
import math
import re
import subprocess
import sys

import ngsolve as ngs
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import ngcontact as ngc
from ngcontact import cli, demo, obstacles
from ngcontact.geometries import block, plate
from ngcontact.model.materials import isotropic_stiffness, transversely_isotropic_piezo
from ngcontact.scenes import reference

MESH = plate(maxh=0.01)
BODY = ngc.Body(MESH, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom")
HELD = ngc.Body(MESH, ngc.pzt5a(), clamped="left", grounded="top", supports={"right": "x"})
SIM = ngc.Simulation(BODY, keep_states=False)
MATERIAL = dict(c=isotropic_stiffness(1e9, 0.3), e=transversely_isotropic_piezo(-1, 2, 1), eps=1e-9 * np.eye(3))
PLACES = dict(clamped="left", grounded="top", contact_side="bottom")

ANYTHING = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e308, -1e-300, 5e-324, 0.5, 1.5, 2, -2, 30]),
    st.integers(min_value=-5, max_value=5),
    st.sampled_from(["2", "", "nan", "yes", None, True, False, [1.0], (1.0, 2.0), (), {}, 1j, np.nan]),
)


def real(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def positive(v):
    return real(v) and v > 0


def nonnegative(v):
    return real(v) and v >= 0


def whole(low, high=math.inf):
    return lambda v: real(v) and int(v) == v and low <= v <= high


def boolean(v):
    return isinstance(v, bool)


def automatic(v):
    return v is None or isinstance(v, bool)


def vector(v):
    return isinstance(v, (tuple, list)) and len(v) > 0 and all(real(x) for x in v)


def scalar(v):
    return real(v) or (vector(v) and len(v) == 1)


def never(v):
    return False


def path(v):
    return v is None or (isinstance(v, str) and v != "")


def band(invalid_below, valid_from, valid_to, invalid_above=None):
    """A length or mesh size: valid in [valid_from, valid_to], invalid below ``invalid_below``
    and above ``invalid_above`` (default valid_to); None (not drawn) in between, where whether
    the mesh fits in memory depends on the machine, and within 1 % of the edges."""
    invalid_above = valid_to if invalid_above is None else invalid_above

    def rule(v):
        if not positive(v) or v < 0.99 * invalid_below or v > 1.01 * invalid_above:
            return False
        return True if 1.01 * valid_from <= v <= 0.99 * valid_to else None
    return rule


def optional(rule):
    return lambda v: True if v is None else rule(v)


def earlier_inverse(v):
    """A Simulation with the earlier option ``inverse=v``: a string passes its type check and
    warns (a DeprecationWarning naming ``solver=``) before the name is refused; any other value
    is refused before that."""
    with pytest.warns(DeprecationWarning) if isinstance(v, str) else contextlib.nullcontext():
        return ngc.Simulation(BODY, inverse=v)


# (what is built, parameter, the rule of a valid value, a call that uses the value)
CASES = [
    *[("Contact", p, rule, lambda v, p=p: ngc.Contact(**{p: v})) for p, rule in [
        ("gap", nonnegative), ("compliance", nonnegative), ("adhesion", nonnegative), ("eps_a", nonnegative),
        ("bond_length", positive), ("beta0", lambda v: real(v) and 0 <= v <= 1),
        ("conductance", nonnegative), ("ramp_width", positive), ("potential_truncation", positive),
        ("foundation_potential", real), ("gamma0", positive), ("penalty", positive),
        ("theta", lambda v: v in (1, 0, -1) and not isinstance(v, bool) and v == int(v)),
        ("method", lambda v: isinstance(v, str) and v in ngc.METHODS),
        ("beta_update", lambda v: v in ("explicit", "implicit")), ("obstacle", lambda v: v is None)]],
    *[("Body", p, rule, lambda v, p=p: ngc.Body(MESH, ngc.pzt5a(), **{**PLACES, p: v})) for p, rule in [
        ("order", whole(1, 10)), ("order_phi", lambda v: v is None or whole(1, 10)(v)),
        ("clamped", never), ("grounded", never), ("contact_side", lambda v: v in (None, "")),
        ("supports", lambda v: v is None or v == {})]],
    ("Body", "mesh", never, lambda v: ngc.Body(v, ngc.pzt5a(), **PLACES)),
    ("Body", "material", never, lambda v: ngc.Body(MESH, v, **PLACES)),
    *[("Material", p, rule, lambda v, p=p: ngc.Material(**{**MATERIAL, p: v})) for p, rule in [
        ("c", never), ("e", never), ("eps", never), ("eta", lambda v: v is None),
        ("poling", lambda v: v in (None, "x", "y", "z")), ("name", lambda v: isinstance(v, str))]],
    *[("Material.isotropic", p, rule, lambda v, p=p: ngc.Material.isotropic(**{
        **dict(E=1e9, nu=0.3, permittivity=1e-9), p: v})) for p, rule in [
        ("E", positive), ("nu", lambda v: real(v) and -1 < v < 0.5), ("permittivity", lambda v: real(v) and v >= 8.8541878128e-12),
        ("e31", real), ("e33", real), ("e15", real), ("viscosity", nonnegative), ("bulk_viscosity", nonnegative),
        ("poling", lambda v: v in (None, "x", "y", "z"))]],
    *[(preset.__name__, "relaxation_time", nonnegative, lambda v, preset=preset: preset(relaxation_time=v))
      for preset in (ngc.pzt5a, ngc.batio3, ngc.academic)],
    ("with_viscosity", "relaxation_time", nonnegative, lambda v: ngc.pzt5a().with_viscosity(v)),
    *[("Simulation", p, boolean, lambda v, p=p: ngc.Simulation(BODY, **{p: v}))
      for p in ("keep_states", "predictor", "limit_steps", "reuse_factorization", "physical_checks")],
    *[("Simulation", p, automatic, lambda v, p=p: ngc.Simulation(BODY, **{p: v}))
      for p in ("condense", "realcompile", "iterative", "electric")],
    *[("Simulation", p, lambda v: v is None, lambda v, p=p: ngc.Simulation(BODY, **{p: v}))
      for p in ("loads", "contact", "time", "u0")],
    ("Simulation", "body", never, lambda v: ngc.Simulation(v)),
    ("Simulation", "solver", lambda v: v is None or v == {}, lambda v: ngc.Simulation(BODY, solver=v)),
    ("Simulation", "inverse", lambda v: v is None, earlier_inverse),
    ("Simulation", "rtol", lambda v: real(v) and 0 < v < 1, lambda v: ngc.Simulation(BODY, rtol=v)),
    ("Simulation", "maxit", whole(1), lambda v: ngc.Simulation(BODY, maxit=v)),
    ("run", "dt", lambda v: positive(v) and v >= 1e-6, lambda v: SIM.run(v, 1.0)),
    ("run", "T", lambda v: real(v) and v > 0, lambda v: SIM.run(0.5, v)),
    ("run", "max_cutbacks", whole(0, 20), lambda v: SIM.run(0.5, 1.0, max_cutbacks=v)),
    ("run", "progress", boolean, lambda v: SIM.run(0.5, 1.0, progress=v)),
    ("run", "on_step", lambda v: v is None, lambda v: SIM.run(0.5, 1.0, on_step=v)),
    ("run", "vtk", path, lambda v: SIM.run(0.5, 1.0, vtk=v)),
    ("run", "out", path, lambda v: SIM.run(0.5, 1.0, out=v)),
    ("advance", "target", positive, lambda v: SIM.advance(v)),
    ("advance", "max_cutbacks", whole(0, 20), lambda v: SIM.advance(1.0, max_cutbacks=v)),
    ("advance", "on_step", lambda v: v is None, lambda v: SIM.advance(1.0, on_step=v)),
    ("step", "dt", lambda v: real(v) and v >= 1e-20, lambda v: SIM.step(v)),
    ("Loads", "f0", lambda v: v is None or (vector(v) and len(v) == 2),
     lambda v: ngc.Simulation(BODY, ngc.Loads(f0=v))),
    ("Loads", "q0", lambda v: v is None or scalar(v), lambda v: ngc.Simulation(BODY, ngc.Loads(q0=v))),
    *[("Loads", p, lambda v: v == {}, lambda v, p=p: ngc.Loads(**{p: v}))
      for p in ("f2", "qb", "potential", "displacement")],
    ("Loads", "f2", real, lambda v: ngc.Simulation(BODY, ngc.Loads(f2={"top": (0.0, v)}))),
    ("Loads", "qb", scalar, lambda v: ngc.Simulation(BODY, ngc.Loads(qb={"right": v}))),
    ("Loads", "potential", scalar, lambda v: ngc.Simulation(BODY, ngc.Loads(potential={"top": v}))),
    ("Loads", "displacement", scalar, lambda v: ngc.Simulation(HELD, ngc.Loads(displacement={"right": v}))),
    ("Plane", "point", lambda v: real(v) or vector(v), lambda v: obstacles.Plane(v, (0, 1))),
    ("Plane", "normal", lambda v: vector(v) and any(x != 0 for x in v), lambda v: obstacles.Plane((0, 0), v)),
    ("Cylinder", "center", lambda v: real(v) or vector(v), lambda v: obstacles.Cylinder(v, 1.0)),
    ("Cylinder", "radius", positive, lambda v: obstacles.Cylinder((0, 0), v)),
    ("Sphere", "center", lambda v: real(v) or vector(v), lambda v: obstacles.Sphere(v, 1.0)),
    ("Sphere", "radius", positive, lambda v: obstacles.Sphere((0, 0, 0), v)),
    ("SignedDistance", "distance", scalar, lambda v: obstacles.SignedDistance(v, (0, -1))),
    ("SignedDistance", "normal", lambda v: real(v) or vector(v), lambda v: obstacles.SignedDistance(ngs.y, v)),
    # the sides within 5000 times of each other, the mesh sizes in [2e-4, 1] of the longest
    # side (Netgen's resolution) and the estimated mesh within the machine's memory
    *[("plate", p, rule, lambda v, p=p: plate(**{p: v})) for p, rule in [
        ("L1", band(4e-6, 4e-6, 50)), ("L2", band(4e-5, 4e-5, 500)), ("maxh", optional(band(2e-5, 1e-4, 0.1))),
        ("maxh_contact", optional(band(2e-5, 2e-5, 0.1))),
        ("refine", lambda v: None if whole(0, 10)(v) else False), ("comm", lambda v: v is None or v is False)]],
    *[("block", p, rule, lambda v, p=p: block(**{p: v})) for p, rule in [
        ("L1", band(8e-6, 1e-3, 50)), ("L2", band(2e-5, 1e-3, 50)), ("L3", band(4e-5, 1e-2, 500)),
        ("maxh", optional(band(2e-5, 1e-3, 0.1))), ("refine", lambda v: None if whole(0, 10)(v) else False),
        ("comm", lambda v: v is None or v is False)]],
]


@pytest.mark.parametrize("what, parameter, valid, build", CASES, ids=[f"{c[0]}.{c[1]}" for c in CASES])
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(value=ANYTHING)
def test_invalid_values_are_named(what, parameter, valid, build, value):
    """(``valid``: True for a valid value, False for an invalid one, None where it depends on
    the machine's memory: only the invalid ones are built.)"""
    assume(valid(value) is False)
    with pytest.raises((ValueError, TypeError)) as err:
        build(value)
    assert re.search(rf"(?<!\w){re.escape(parameter)}(?!\w)", str(err.value)), str(err.value)


@pytest.mark.parametrize("build, side", [(lambda: block(L2=51.0), "L2"), (lambda: plate(L1=60.0), "L1")])
def test_a_long_side_that_makes_the_default_maxh_too_fine_is_named(build, side):
    """A side long enough that the default maxh (half the shortest side) falls below Netgen's
    resolution of the longest: the error names that side with the maxh bound (a case the
    property test above once drew at random)."""
    with pytest.raises(ValueError, match=rf"maxh \(by default .*longest side, {side} = .* m,"):
        build()


@pytest.mark.parametrize("arguments, words", [
    (["demo", "--steps", "0"], "steps must be an integer >= 1"),
    (["demo", "--maxh", "-1"], "maxh"),
    (["demo", "--maxh", "inf"], "maxh must be a finite number in (0, 0.02] m"),
    (["demo", "--maxh", "1e-6"], "maxh = 1e-06 m, refine = 0, order = 1: about 6.9e+09 DOFs (estimated)"),
    (["demo", "--refine", "12"], "refine must be an integer >= 0 and <= 10, got 12"),
    (["demo", "--refine", "9"], "refine = 9, order = 1: about"),
    (["demo", "--order", "30"], "order must be an integer >= 1 and <= 10, got 30"),
    (["demo", "--gamma0", "nan"], "gamma0"),
    (["demo", "--out", "/proc/ngcontact-cannot-write"], "cannot be written"),
    (["convergence", "--levels", "0"], "--levels must be an integer >= 1"),
    (["convergence", "--levels", "100"], "--levels must be an integer >= 1 and <= 10, got 100"),
    (["convergence", "--orders", "1", "11"], "--orders must be an integer >= 1 and <= 10, got 11"),
    (["convergence", "--dt-halvings", "40"], "--dt-halvings must be an integer >= 0 and <= 12, got 40"),
    (["hertz", "--levels", "0"], "levels must be an integer >= 1"),
    (["hertz", "--levels", "50"], "levels must be an integer >= 1 and <= 10, got 50"),
    (["bench", "--max-ndof", "nan"], "max_ndof must be a finite number >= 1 DOFs, got nan"),
    (["bench", "--max-ndof", "0"], "max_ndof must be a finite number >= 1 DOFs, got 0.0"),
    (["bench", "--max-ndof", "-1"], "max_ndof must be a finite number >= 1 DOFs, got -1.0"),
    (["bench", "--max-ndof", "1e12"], "max_ndof = 1e+12: about 1e+12 DOFs (estimated), needing at least"),
    (["bench", "--orders", "1", "--max-ndof", "100"], "max_ndof = 100 is below the coarsest mesh's DOFs (P1: "),
    (["bench", "--steps", "0"], "steps must be an integer >= 1 and <= 1000000, got 0"),
    (["adapt", "--stop-newton", "0"], "--stop-newton must be a finite number in (0, 1], got 0.0"),
    (["adapt", "--stop-newton", "nan"], "--stop-newton must be a finite number in (0, 1], got nan"),
    (["adapt", "--orders", "1", "11"], "--orders must be an integer >= 1 and <= 10, got 11"),
])
def test_the_cli_prints_one_line_and_exits_2(arguments, words, tmp_path, capsys):
    """Each before any mesh of the run is made (the bench's coarsest meshes are counted):
    the sizes, levels, orders and DOF limits that would never finish or mean nothing.
    ``cli.main`` is called as ``python -m ngcontact`` calls it; the first two cases run
    ``python -m ngcontact`` itself."""
    out = [] if "--out" in arguments else ["--out", str(tmp_path / "out")]
    if arguments in (["demo", "--steps", "0"], ["bench", "--max-ndof", "nan"]):
        done = subprocess.run([sys.executable, "-m", "ngcontact", *arguments, *out], capture_output=True, text=True,
                              timeout=600)
        code, stderr = done.returncode, done.stderr
    else:
        with pytest.raises(SystemExit) as done:
            cli.main([*arguments, *out])
        code, stderr = done.value.code, capsys.readouterr().err
    assert code == 2
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in stderr, stderr
    assert not (tmp_path / "out").exists() or "--out" in arguments or arguments[0] == "bench"


def test_a_newton_failure_in_the_cli_is_one_line(monkeypatch, tmp_path, capsys):
    """A run whose Newton cannot pass the first contact (two iterations allowed, one cut-back):
    one line with the step, time, iteration, last residuals and time steps tried, where the
    steps before it are kept, and the error's hint; status 2. ``--traceback`` re-raises."""
    def failing(**kwargs):
        sim = reference.simulation(1, 0.01, maxit=2)
        sim.run(dt=2.5e-3, T=0.05, max_cutbacks=1, out=tmp_path / "out" / "run")
    monkeypatch.setattr(demo, "run", failing)
    with pytest.raises(SystemExit) as done:
        cli.main(["demo", "--out", str(tmp_path / "out")])
    assert done.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    found = re.fullmatch(r"ngcontact demo: error: Newton did not converge in 2 iterations at step (\d+) \(t = "
                         r"[0-9.]+ s\), iteration 2 \(last residuals [0-9.e+-]+, [0-9.e+-]+, [0-9.e+-]+; "
                         r"dt = 0.0025, 0.00125 s tried\); the steps before it are kept in (.*)/run \(continue "
                         r"with --resume\); try: a smaller time step, .*", lines[0])
    assert found and found.group(2) == str(tmp_path / "out"), lines[0]
    kept = sorted((tmp_path / "out" / "run" / "steps").glob("*.npz"))
    assert len(kept) == int(found.group(1)) >= 2          # steps 0 .. step - 1 on disk
    with pytest.raises(ngc.NewtonError):
        cli.main(["demo", "--traceback", "--out", str(tmp_path / "out")])


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
