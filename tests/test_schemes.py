"""The time scheme owns the step (issue 24, item 1): it alone writes t_n, the rate coefficient c
and the anchor û (``schemes.StepCoefficients``); a scheme is one class in ``schemes.SCHEMES``
that the rest reads through that protocol; results store the scheme's own restart state and
refuse a run of another scheme."""
import json
import pathlib
import re

import ngsolve as ngs
import numpy as np
import pytest

import ngcontact as ngc
from ngcontact import schemes
from ngcontact.scenes import reference

PACKAGE = pathlib.Path(ngc.__file__).parent
DT, COARSE = 2.5e-3, 0.01


def test_an_unknown_scheme_is_refused_before_any_work():
    body = reference.body(1, COARSE)
    for bad in ("bdf9", ""):
        with pytest.raises(ValueError, match=re.escape(f"scheme must be one of 'backward_euler', 'bdf2', got {bad!r}")):
            ngc.Simulation(body, scheme=bad)
    for bad in (2, None):
        with pytest.raises(TypeError, match=re.escape("scheme must be one of 'backward_euler', 'bdf2' or a time scheme "
                                                      f"class (ngcontact.schemes.TimeScheme") + f".* got {bad!r}"):
            ngc.Simulation(body, scheme=bad)


def test_only_the_scheme_writes_the_time_and_the_rate():
    """Outside ``ngcontact/schemes`` no module sets the time Parameter or the step coefficients:
    data at another time are read inside ``StepCoefficients.at``."""
    writes = re.compile(r"\.time\.Set\(|coefficients\.(set|rate\.Set)\(|anchor\.vec\.data\s*=")
    found = [f"{path.relative_to(PACKAGE)}:{n}" for path in PACKAGE.rglob("*.py") if "schemes" not in path.parts
             for n, line in enumerate(path.read_text().splitlines(), 1) if writes.search(line)]
    assert found == []


def test_at_puts_the_time_back_even_on_error():
    coefficients = schemes.StepCoefficients(ngs.Parameter(7.0), ngs.VectorH1(ngs.Mesh(ngs.unit_square.GenerateMesh(
        maxh=0.5))))
    assert coefficients.t == 0.0                     # t_0 = 0
    coefficients.set(0.25, 40.0)
    with pytest.raises(RuntimeError):
        with coefficients.at(3.0):
            assert coefficients.time.Get() == 3.0
            raise RuntimeError
    assert (coefficients.t, coefficients.rate.Get()) == (0.25, 40.0)


class Logged(schemes.BackwardEuler):
    """Backward Euler that logs the step coefficients it hands the system (a scheme defined
    outside the package, registered in SCHEMES)."""
    name = "logged_backward_euler"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.log = []

    def advance(self, dt, **kwargs):
        u_before = self.state.components[0].vec.FV().NumPy().copy()
        result = super().advance(dt, **kwargs)
        c = self.coefficients
        self.log.append((dt, c.t, c.rate.Get(), np.array_equal(c.anchor.vec.FV().NumPy(), u_before)))
        return result


def test_a_scheme_from_outside_the_package_runs_through_the_protocol(monkeypatch, tmp_path):
    """A registered scheme is chosen by name, sets c = 1/dt and û = u_{n−1} at t_n for every step
    (a cut-back step too), gives backward Euler's states bitwise, and its run refuses to resume
    into the default scheme (and the other way round), naming both."""
    monkeypatch.setitem(schemes.SCHEMES, Logged.name, Logged)
    runs = {}
    for name in (Logged.name, "backward_euler"):
        sim = reference.simulation(1, COARSE, scheme=name, solver={"ksp_type": "preonly"})
        sim.run(DT, 2 * DT, out=tmp_path / name)
        sim.step(DT / 2)
        runs[name] = sim
    logged = runs[Logged.name].scheme.log
    assert [(dt, t) for dt, t, _, _ in logged] == [(DT, DT), (DT, 2 * DT), (DT / 2, 2.5 * DT)]
    assert all(rate == 1.0 / dt and same for dt, _, rate, same in logged)
    assert np.array_equal(runs[Logged.name].gfu.vec.FV().NumPy(), runs["backward_euler"].gfu.vec.FV().NumPy())
    assert json.loads((tmp_path / Logged.name / "run.json").read_text())["scheme"] == Logged.name
    with pytest.raises(ValueError, match=f"holds a run of the time scheme '{Logged.name}', this simulation's "
                                         "scheme is 'backward_euler'"):
        reference.simulation(1, COARSE).resume(tmp_path / Logged.name)
    with pytest.raises(ValueError, match=f"^out: .*holds a run of the time scheme 'backward_euler', this "
                                         f"simulation's scheme is '{Logged.name}'"):
        reference.simulation(1, COARSE, scheme=Logged.name).run(DT, 2 * DT, out=tmp_path / "backward_euler")
    resumed = reference.simulation(1, COARSE, scheme=Logged.name, solver={"ksp_type": "preonly"})
    resumed.resume(tmp_path / Logged.name)
    assert resumed.t == 2 * DT and len(resumed.history) == 3


def test_a_run_json_without_a_scheme_is_backward_euler(tmp_path):
    """Runs streamed before run.json named the scheme were backward Euler's: they resume."""
    reference.simulation(1, COARSE).run(DT, 2 * DT, out=tmp_path)
    info = json.loads((tmp_path / "run.json").read_text())
    del info["scheme"]
    (tmp_path / "run.json").write_text(json.dumps(info))
    assert reference.simulation(1, COARSE).resume(tmp_path).t == 2 * DT


def test_save_and_load_put_the_scheme_back_bitwise():
    """The scheme's restart arrays, loaded into a fresh simulation, continue as the first one
    does, bitwise (state, β, predictor memory)."""
    first = reference.simulation(1, COARSE, predictor=True, solver={"ksp_type": "preonly"})
    first.run(DT, 3 * DT)
    saved = {k: np.copy(v) for k, v in first.scheme.save().items()}
    assert {"t", "state", "beta", "beta_unclipped", "last_state", "last_dt"} <= set(saved)
    second = reference.simulation(1, COARSE, predictor=True, solver={"ksp_type": "preonly"})
    second.scheme.load(saved)
    assert second.time.Get() == first.t == second.t
    for sim in (first, second):
        sim.step(DT)
    assert np.array_equal(first.gfu.vec.FV().NumPy(), second.gfu.vec.FV().NumPy())
    assert np.array_equal(first.beta.values, second.beta.values)
    with pytest.raises(ValueError, match="the restart state lacks state"):
        second.scheme.load(dict(t=np.asarray(0.0)))


def test_nested_meshes_keep_their_coarse_mesh():
    from netgen.geom2d import unit_square
    mesh = ngc.meshes.nested_mesh(unit_square.GenerateMesh(maxh=0.5), refine=2)
    coarse, levels = ngc.meshes.coarse(mesh)
    assert levels == ngc.meshes.refinements(mesh) == 2
    assert mesh.ne == 16 * ngs.Mesh(coarse).ne                  # each refinement splits a triangle in 4
    assert ngc.meshes.refinements(ngs.Mesh(unit_square.GenerateMesh(maxh=0.5))) is None
    with pytest.raises(ValueError, match="refine must be an integer >= 0, got 1.5"):
        ngc.meshes.nested_mesh(unit_square.GenerateMesh(maxh=0.5), refine=1.5)


class LoggedBDF2(schemes.BDF2):
    """BDF2 that logs (t_n, c, û) of every step."""
    name = "logged_bdf2"

    def advance(self, dt, **kwargs):
        result = super().advance(dt, **kwargs)
        c = self.coefficients
        self.log.append((c.t, c.rate.Get(), c.anchor.vec.FV().NumPy().copy()))
        return result

    log = None


def test_bdf2_differentiates_the_quadratic_through_the_last_three_states(monkeypatch):
    """For steps of varying length, c (u_n − û) is the derivative at t_n of the quadratic through
    (t_{n−2}, u_{n−2}), (t_{n−1}, u_{n−1}), (t_n, u_n) (numpy's polyfit, DOF by DOF); the first
    step and a step more than 1 + √2 times the last are backward Euler's."""
    monkeypatch.setitem(schemes.SCHEMES, LoggedBDF2.name, LoggedBDF2)
    sim = reference.simulation(1, COARSE, scheme=LoggedBDF2.name)
    sim.scheme.log = []
    steps = [DT, DT, 0.5 * DT, 1.2 * DT, 3 * 1.2 * DT, DT]
    for dt in steps:
        sim.step(dt)
    assert sim.scheme.orders == [1, 2, 2, 2, 1, 2]
    times = np.array(sim.history.times)
    states = np.array([r.state[:sim.body.V.ndof] for r in sim.history])
    moving = np.abs(states[-1]) > 1e-3 * np.abs(states[-1]).max()
    for n in range(1, len(steps) + 1):
        t_n, c, anchor = sim.scheme.log[n - 1]
        assert t_n == pytest.approx(times[n], rel=1e-14)
        rate = c * (states[n] - anchor)
        if sim.scheme.orders[n - 1] == 1:
            expected = (states[n] - states[n - 1]) / (times[n] - times[n - 1])
        else:
            fit = np.polyfit(times[n - 2:n + 1] - times[n], states[n - 2:n + 1], 2)
            expected = fit[1]                            # d/dt at t_n of a t² + b t + c, in t − t_n
        assert np.allclose(rate[moving], expected[moving], rtol=1e-7, atol=0), n


def test_a_bdf2_run_resumes_bitwise(tmp_path):
    """The scheme's memory (u_{n−2}, β_{n−2}, k_{n−1}) is in its restart state: a run resumed
    from disk continues as the run that went on, bitwise, with BDF2 steps at once."""
    first = reference.simulation(1, COARSE, scheme="bdf2", solver={"ksp_type": "preonly"})
    first.run(DT, 3 * DT, out=tmp_path)
    second = reference.simulation(1, COARSE, scheme="bdf2", solver={"ksp_type": "preonly"}).resume(tmp_path)
    for sim in (first, second):
        sim.step(DT)
    assert second.scheme.orders == [2]
    assert np.array_equal(first.gfu.vec.FV().NumPy(), second.gfu.vec.FV().NumPy())
    assert np.array_equal(first.beta.values, second.beta.values)


def test_a_failed_bdf2_step_leaves_the_memory_as_it_was():
    """Transactional: a step that fails (here: a load that is NaN at t = 3 DT) restores the
    state and the scheme's memory, and the next step is the one the run would have made."""
    time = ngs.Parameter(0.0)
    body = reference.body(1, COARSE)
    bad = ngs.IfPos(time - 2.5 * DT, ngs.CF(float("nan")), 1.0)
    loads = ngc.Loads(f2={"top": (0, -reference.PRESSURE * time / reference.PUSH_END * bad)})
    sim = ngc.Simulation(body, loads, contact=reference.contact(), time=time, scheme="bdf2",
                         solver={"ksp_type": "preonly"})
    sim.run(DT, 2 * DT)
    saved = sim.scheme.save()
    with pytest.raises(ValueError, match="not finite"):
        sim.step(DT)
    after = sim.scheme.save()
    assert saved.keys() == after.keys()
    assert all(np.array_equal(saved[k], after[k]) for k in saved)
    assert sim.scheme.orders == [1, 2]


@pytest.mark.parametrize("tolerance, close", [(None, True), (1.0, False)])
def test_bdf2_s_glue_is_taken_at_u_n_across_the_pull_off(tolerance, close):
    """BDF2 takes β_n at the extrapolated ũ, then again at u_n while β_n changes by more than
    ``beta_tolerance``: across the reverse of the load ũ overshoots into tension. The reference
    plate at k = T/16 ends with min β = 0.856 against 0.8606 of an 8192-step run (Nitsche and the
    nodal constraint alike); with no passes (a tolerance of 1) 0.663."""
    sim = reference.simulation(1, COARSE, scheme="bdf2", keep_states=False)
    if tolerance is not None:
        sim.scheme.beta_tolerance = tolerance
    sim.run(0.25 / 16, 0.25)
    assert (abs(sim.beta.values.min() - 0.8606) < 0.01) == close, sim.beta.values.min()


class Euler(schemes.TimeScheme):
    """Backward Euler written from scratch through the protocol (a class of the user's handed to
    ``Simulation(scheme=...)``, not registered): the bonding update (4.5) from u_{n−1}, then
    t_n, c = 1/dt and û = u_{n−1}, and one Newton solve; no predictor, no enforcement hook."""
    name = "my_euler"

    def __init__(self, coefficients, system, newton, state, beta=None, predictor=False, normal=None):
        self.coefficients, self.system, self.newton, self.state = coefficients, system, newton, state
        self.beta, self.predictor, self.t = beta, predictor, 0.0
        self.u = state.components[0]
        self.u_normal = None if normal is None else self.u * normal

    def start(self):
        self.coefficients.set(0.0, 1.0, self.u.vec)
        self.system.begin_step(self.state)

    def advance(self, dt, *, step=None, timer=None, start=None, target=None):
        if self.beta is not None:
            self.beta.update(self.u_normal, dt)
        before, self.t = self.t, self.t + dt if target is None else target
        self.coefficients.set(self.t, 1.0 / dt, self.u.vec)
        self.system.begin_step(self.state)
        if start is not None:
            start(self.u, before, self.t)
        return self.newton.solve(step=step, time=self.t, timer=timer)

    def checkpoint(self):
        return dict(t=np.asarray(self.t), state=self.state.vec.FV().NumPy().copy(),
                    beta=self.beta.values.copy(), unclipped=self.beta.unclipped.copy())

    def restore(self, saved):
        self.t = float(saved["t"])
        self.state.vec.FV().NumPy()[:] = saved["state"]
        self.beta.values[:] = saved["beta"]
        self.beta.unclipped = np.array(saved["unclipped"])
        self.coefficients.set(self.t)

    save, load = checkpoint, restore


def test_a_scheme_class_of_the_user_s_gives_backward_euler_s_steps(tmp_path):
    """A scheme class handed to ``Simulation(scheme=...)`` (from scratch through ``TimeScheme``,
    taking its defaults: no error estimate) makes the built-in backward Euler's steps on the
    reference plate to round-off, a step off the run's grid too; a streamed run records its name and
    class, resumes into the same class and is refused by backward Euler, naming both."""
    runs = {}
    for scheme in (Euler, "backward_euler"):
        sim = reference.simulation(1, COARSE, scheme=scheme, solver={"ksp_type": "preonly"})
        sim.run(DT, 3 * DT, out=tmp_path / str(getattr(scheme, "name", scheme)))
        sim.advance(3.5 * DT, max_cutbacks=2)
        runs[scheme] = sim
    mine, built_in = runs[Euler], runs["backward_euler"]
    assert [r.time for r in mine.history] == [r.time for r in built_in.history]
    assert {r.scheme for r in mine.history} == {"my_euler"} and {r.order for r in mine.history[1:]} == {1}
    for a, b in zip(mine.history, built_in.history):
        assert np.allclose(a.state, b.state, rtol=0, atol=1e-12 * np.abs(b.state).max()), a.step
    assert np.allclose(mine.beta.values, built_in.beta.values, rtol=0, atol=1e-12)
    stored = json.loads((tmp_path / "my_euler" / "run.json").read_text())
    assert stored["scheme"] == "my_euler" and stored["fingerprint"]["scheme.class"].endswith("test_schemes.Euler")
    resumed = reference.simulation(1, COARSE, scheme=Euler, solver={"ksp_type": "preonly"})
    resumed.resume(tmp_path / "my_euler")
    assert resumed.t == 3 * DT and np.array_equal(resumed.gfu.vec.FV().NumPy(), mine.history[3].state)
    with pytest.raises(ValueError, match="holds a run of the time scheme 'my_euler', this simulation's scheme is "
                                         "'backward_euler'"):
        reference.simulation(1, COARSE).resume(tmp_path / "my_euler")
    with pytest.raises(ValueError, match=r"run\(rtol=0.001\): the scheme 'my_euler' has no local error estimate"):
        mine.run(DT, 5 * DT, rtol=1e-3)


def _scheme(*lacking, base=Euler, **changes):
    """A class with ``base``'s members but ``lacking``, and ``changes``, not a subclass of the protocol."""
    namespace = {n: v for cls in reversed(base.__mro__[:-1]) for n, v in vars(cls).items()
                 if n in ("__init__", "name", "estimates_error", "estimate", "last_order") + tuple(
                     schemes.protocol.METHODS)}
    namespace = {n: v for n, v in namespace.items() if n not in lacking}
    return type("Bad", (), {**namespace, **changes})


@pytest.mark.parametrize("scheme, words", [
    (_scheme("checkpoint"), "lacks checkpoint"),
    (_scheme("restart", "control", "estimates_error"), "lacks estimates_error, restart, control"),
    (type("Half", (schemes.TimeScheme,), {"name": "half", "start": Euler.start}),
     "lacks advance, checkpoint, load, restore, save"),
    (_scheme(advance=lambda self, dt: None), r"advance\(self, dt\): got an unexpected keyword argument 'step'"),
    (_scheme(__init__=lambda self, coefficients, system: None), r"cannot be built as Scheme\(coefficients, system, "),
    (_scheme(name=""), "has name = '': it must be a nonempty str"),
    (_scheme(name="bdf2"), "has name = 'bdf2', the name of the built-in BDF2"),
    (_scheme(estimates_error=None), "has estimates_error = None: it must be True or False"),
    (_scheme(save=3), "has save = 3: not callable"),
    (_scheme(__init__=lambda self, *args: None), "built as Scheme.* lacks t, coefficients, system, newton, state, "
                                                 "predictor"),
])
def test_a_scheme_class_without_the_protocol_is_named(scheme, words):
    """A scheme class that lacks a member of ``TimeScheme``, or has one that cannot take the
    package's arguments, is a TypeError naming ``scheme``, the class and the member (before any
    work; what the constructor sets, once it has run); an instance is not a scheme class."""
    body = reference.body(1, COARSE)
    with pytest.raises(TypeError, match=rf"^scheme: the time scheme class .*{words}"):
        ngc.Simulation(body, contact=reference.contact(), scheme=scheme)


def test_a_scheme_instance_is_refused_naming_the_class_to_pass():
    sim = reference.simulation(1, COARSE)
    with pytest.raises(TypeError, match=r"a time scheme class \(ngcontact.schemes.TimeScheme: the class, not an "
                                        r"instance.*got <ngcontact.time.schemes.backward_euler.BackwardEuler"):
        ngc.Simulation(sim.body, scheme=sim.scheme)
    assert type(ngc.Simulation(sim.body, scheme=schemes.BDF2).scheme) is schemes.BDF2
