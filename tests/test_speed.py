"""The fast paths give the same numbers as the plain forms; the benchmark's arithmetic.

No test here asserts a time: speed is measured by ``python -m ngcontact bench``.
"""
import csv

import numpy as np
import ngsolve as ngs
import pytest
import scipy.sparse as sp

import ngcontact as ngc
from ngcontact import cli
from ngcontact.model.forms import electric_displacement, strain, stress
from ngcontact.geometries import block, plate
from ngcontact.model.loads import as_cf
from ngcontact.scenes import reference as scene
from ngcontact.studies import bench
from ngcontact.schemes import StepCoefficients
from ngcontact.solve.system import StepSystem
from ngcontact.solve.weak_form import WeakForm


def monolithic_residual(body, loads, u_old, inv_dt):
    """The whole step residual as one nonlinear-ready BilinearForm (the reference): σ : ε(v)
    + D · ∇ξ with σ, D of (2.3)-(2.4), not the named forms of ``forms``."""
    dim = body.dim
    (u, phi), (v, xi) = body.X.TnT()
    sigma = stress(body.tensors, u, phi, inv_dt * (strain(u) - strain(u_old)))
    R = ngs.BilinearForm(body.X, symmetric=False)
    R += (ngs.InnerProduct(sigma, strain(v))
          + ngs.InnerProduct(electric_displacement(body.tensors, u, phi), ngs.grad(xi))) * ngs.dx
    R += -as_cf(loads.f0, dim, 'f0') * v * ngs.dx - as_cf(loads.q0, 1, 'q0') * xi * ngs.dx
    for names, f2 in loads.f2.items():
        R += -as_cf(f2, dim, 'f2') * v * ngs.ds(names)
    for names, qb in loads.qb.items():
        R += -as_cf(qb, 1, 'qb') * xi * ngs.ds(names)
    return R


@pytest.mark.parametrize("mesh", [plate(maxh=0.01), block(maxh=0.02)], ids=["2D", "3D"])
def test_step_system_equals_the_monolithic_form(mesh):
    """R(x) and R'(x) of StepSystem (K_el, K_A assembled once, f per step) equal the plain
    form's at a random state, anchor û, t and rate coefficient c, and again after t and c change."""
    dim = mesh.dim
    body = ngc.Body(mesh, ngc.pzt5a(relaxation_time=2e-3), clamped="left", grounded="top",
                    contact_side="bottom", order=2)
    t, inv_dt = ngs.Parameter(0.3), ngs.Parameter(400.0)
    x, y = ngs.CoefficientFunction(ngs.x), ngs.CoefficientFunction(ngs.y)
    loads = ngc.Loads(f0=tuple([1e6 * t * x] + [2e5 * y] * (dim - 1)), q0=3e-3 * t * y,
                      f2={"top": tuple([0] * (dim - 1) + [-2e6 * t])}, qb={"right": 1e-4 * t})
    rng = np.random.default_rng(3)
    u_old = ngs.GridFunction(body.V)
    u_old.vec.FV().NumPy()[:] = rng.normal(size=body.V.ndof) * 1e-5
    coefficients = StepCoefficients(t, body.V)
    system = StepSystem(WeakForm(body, loads, coefficients), body.space())
    reference = monolithic_residual(body, loads, u_old, inv_dt)
    gfu = ngs.GridFunction(system.X)
    state = gfu.vec
    state.FV().NumPy()[:] = rng.normal(size=body.ndof) * np.r_[np.full(body.V.ndof, 1e-5),
                                                               np.full(body.W.ndof, 50.0)]
    r1, r2 = state.CreateVector(), state.CreateVector()
    for time, rate in ((0.3, 400.0), (0.7, 100.0)):
        coefficients.set(time, rate, u_old.vec)             # a scheme's t_n, c, û
        system.begin_step(gfu)
        inv_dt.Set(rate)
        system.Apply(state, r1)
        reference.Apply(state, r2)
        a, b = r1.FV().NumPy(), r2.FV().NumPy()
        assert np.abs(a - b).max() < 1e-10 * np.abs(b).max()
        system.AssembleLinearization(state)
        reference.AssembleLinearization(state)
        J1, J2 = (sp.csr_matrix(m.CSR()) for m in (system.mat, reference.mat))
        assert abs(J1 - J2).max() < 1e-10 * abs(J2).max()


def run_reference(steps=6, **kw):
    sim = scene.simulation(1, **kw)
    sim.run(2.5e-3, steps * 2.5e-3)
    return sim


def test_predictor_changes_the_start_not_the_solution():
    """With the linear predictor Newton reaches the same states (to its tolerance) in the
    reference scene's first steps, first contact included. With full Newton steps the
    extrapolated start penetrates deep at first contact (first residual 10.6 and 64.8 against
    9e-3 from the warm start): a test relative to the first residual would stop there at
    residuals 1e-9, 1e-7 of the step's force scale; the certified test asks the same of both
    starts, and the predictor then costs iterations (26 against 24 in these 6 steps)."""
    plain, predicted = run_reference(predictor=False), run_reference(predictor=True)
    for a, b in zip(plain.history[1:], predicted.history[1:]):
        assert np.abs(a.state - b.state).max() < 1e-7 * np.abs(a.state).max()
        assert b.contact.force[1] == pytest.approx(a.contact.force[1], rel=1e-7, abs=1e-6)
    plain, predicted = (run_reference(predictor=p, limit_steps=False) for p in (False, True))
    for a, b in zip(plain.history[1:], predicted.history[1:]):
        assert np.abs(a.state - b.state).max() < 1e-7 * np.abs(a.state).max()
    deep = max(predicted.history[3].residuals[0], predicted.history[4].residuals[0])
    assert deep > 1e3 * plain.history[4].residuals[0]


@pytest.mark.long
def test_first_contact_iterations_do_not_grow_with_the_mesh():
    """The 6-step first-contact window of the reference scene (P1, maxh 5 mm, levels 0-2), plain
    corrections: with the step-length limit the first-contact step takes 5 Newton iterations on
    every mesh; with full steps 11, 12, 14 (docs/speed.md). With full steps and the switch loop
    (which follows the overshoot's release at a glued first contact) at most 6 on the finest
    (measured 6, 4, 5 on levels 0-2). All reach the same states."""
    for level in (0, 1, 2):
        limited, full = (scene.simulation(1, 0.005, level, keep_states=False, limit_steps=limit, switch_loop=False)
                         for limit in (True, False))
        runs = [limited, full]
        if level == 2:
            runs.append(scene.simulation(1, 0.005, level, keep_states=False, limit_steps=False))
        for sim in runs:
            sim.run(2.5e-3, 6 * 2.5e-3)
        assert limited.history.newton_iterations.max() <= 6
        assert full.history.newton_iterations.max() >= 11
        if level == 2:
            assert runs[2].history.newton_iterations.max() <= 6
        y = full.gfu.vec.FV().NumPy()
        for sim in runs:
            assert np.abs(sim.gfu.vec.FV().NumPy() - y).max() <= 1e-8 * np.abs(y).max()


def test_a_solve_that_starts_touching_cuts_deeper():
    """The 2D Hertz half-disk rests on its plane when the solve begins (P2, refined twice): the
    step length lets open points reach ``eta_touching`` = 0.03 of a correction's largest normal
    motion over up to ``max_cuts_touching`` = 4 corrections, and Newton takes 9 iterations
    where the open start's cut (η = 1e-3 over 2 corrections) takes 18, to the same state. The
    reference plate's first step starts open and keeps the open start's cut."""
    from ngcontact.scenes import hertz
    runs = []
    for previous in (False, True):
        sim = hertz.simulation(2, refine=2, keep_states=False)
        limit = sim.newton.step_length
        if previous:
            limit.eta_touching, limit.max_cuts_touching = limit.eta, limit.max_cuts
        record = sim.step(1.0)
        assert limit.touching is True
        runs.append((record.newton_iterations + record.discarded_iterations, sim.gfu.vec.FV().NumPy().copy()))
    (deeper, x), (previous, y) = runs
    assert deeper <= 10 and previous >= 15, (deeper, previous)
    assert np.abs(x - y).max() <= 1e-8 * np.abs(y).max()
    plate_sim = scene.simulation(1, 0.01, keep_states=False)
    plate_sim.step(2.5e-3)
    assert plate_sim.newton.step_length.touching is False


def test_step_timings_split_the_wall_time():
    """The Newton phases of each step fit inside its wall time (records included); assembly
    and solve are zero exactly when no linear solve was made, the factorisation exactly
    when no factorisation was made (a kept one was reused)."""
    sim = run_reference(steps=3)
    for rec in sim.history:
        assert set(rec.timings) == {"residual", "assembly", "factorization", "solve", "other"}
        assert rec.timings["other"] >= 0 and rec.timings["residual"] > 0
        solved = [rec.timings[p] > 0 for p in ("assembly", "solve")]
        assert solved == [rec.newton_iterations > 0] * 2
        assert (rec.timings["factorization"] > 0) == (rec.factorizations > 0)
    assert sum(rec.factorizations for rec in sim.history[1:]) < sum(rec.newton_iterations for rec in sim.history[1:])


@pytest.mark.parametrize("residual", [False, pytest.param(True, marks=pytest.mark.long)],
                         ids=["jacobian", "jacobian and residual"])
def test_realcompiled_contact_terms_agree(residual, monkeypatch):
    """The Γ3 Jacobian's integrand compiled to machine code in the middle of a run (as
    ``machine_code`` decides), and with it the residual's on the elements at Γ3 (as on meshes of
    ``COMPILED_RESIDUAL_FACETS`` facets), gives the same steps to round-off."""
    from ngcontact.gamma3 import terms as gamma3_terms
    monkeypatch.setattr(gamma3_terms, "COMPILED_RESIDUAL_FACETS", 0 if residual else 10 ** 9)
    a = run_reference(steps=4)
    b = scene.simulation(1)
    b.run(2.5e-3, 2 * 2.5e-3)
    assert not b.realcompile
    b.system.use_machine_code()
    b.run(2.5e-3, 4 * 2.5e-3)
    assert b.realcompile and not a.realcompile
    for ra, rb in zip(a.history, b.history):
        assert np.abs(ra.state - rb.state).max() <= 1e-9 * np.abs(ra.state).max()
        assert ra.newton_iterations == rb.newton_iterations


class _System:
    machine_code = False

    def use_machine_code(self):
        self.machine_code = True


@pytest.mark.parametrize("facets, dim, electric, steps, compiles", [
    (39, 2, True, 200, False),       # the demo: 39 facets x 400 iterations x 0.5 ms = 7.8 s < 8 s
    (312, 2, True, 10, False),       # a 10-step bench at 30 879 DOFs: 6.2 s
    (312, 2, True, 200, True),       # the same over 200 steps: 62 s
    (164, 2, False, 1, False),       # a one-step Hertz solve at P2
    (392, 3, True, 6, True),         # the 3D block: 392 x 12 x 2.5 ms = 11.8 s
])
def test_machine_code_when_the_run_pays_for_it(facets, dim, electric, steps, compiles):
    """A run compiles when its expected iterations save more than the compile costs."""
    from ngcontact.model.machine_code import ITERATIONS_PER_STEP, MachineCode
    system = _System()
    MachineCode(system, facets, dim, electric).expect(steps * ITERATIONS_PER_STEP)
    assert system.machine_code == compiles


def test_machine_code_for_steps_made_by_hand():
    """Stepped by hand, a simulation compiles once the iterations made would have paid for it:
    the 3D block (392 facets, 0.98 s per iteration) after 9 iterations, not after 8."""
    from ngcontact.model.machine_code import MachineCode
    system = _System()
    policy = MachineCode(system, 392, 3, True)
    for _ in range(4):
        policy.account(2)
    assert not system.machine_code
    policy.account(1)
    assert system.machine_code


def test_bare_scene_uses_cholesky_and_matches_umfpack():
    """θ = 1 without glue and conduction: symmetric Jacobian, sparse Cholesky by default, the same steps
    as UMFPACK to the Newton tolerance."""
    steps = []
    for solver in (None, "umfpack"):
        sim = scene.simulation(1, contact=scene.contact(bare=True), solver=solver)
        sim.run(2.5e-3, 0.03)
        steps.append(sim)
    assert "sparsecholesky" in steps[0].solver and steps[0].history[-1].contact.contact_area > 0
    for a, b in zip(steps[0].history, steps[1].history):
        assert np.abs(a.state - b.state).max() <= 1e-8 * np.abs(b.state).max()


def test_growth_exponent_recovers_a_power_law():
    ndof = np.array([1e3, 4e3, 1.6e4, 6.4e4, 2.56e5])
    seconds = 3e-6 * ndof ** 1.27
    seconds[0] *= 10                                   # below min_ndof: ignored
    assert bench.growth_exponent(ndof, seconds) == pytest.approx(1.27, abs=1e-12)
    assert np.isnan(bench.growth_exponent(ndof[:3], seconds[:3]))


@pytest.mark.parametrize("dim, order, max_ndof", [(2, 1, 3000), (2, 2, 1e4),
                                                    pytest.param(3, 1, 5000, marks=pytest.mark.long)])
def test_levels_stay_below_the_size_limit(dim, order, max_ndof):
    """The chosen refinement levels have ndof <= max_ndof; one more would not."""
    found = bench.levels(order, dim, max_ndof)
    sizes = [scene.body(order, bench.MAXH[dim], refine=level, dim=dim).ndof for level in found]
    assert max(sizes) <= max_ndof and sizes == sorted(sizes)
    assert scene.body(order, bench.MAXH[dim], refine=found[-1] + 1, dim=dim).ndof > max_ndof


def test_bench_command_writes_its_table(tmp_path, capsys):
    cli.main(["bench", "--out", str(tmp_path), "--orders", "1", "--max-ndof", "2500",
                  "--steps", "2", "--threads", "no"])
    rows = list(csv.DictReader(open(tmp_path / "bench.csv")))
    assert [int(r["level"]) for r in rows] == [0, 1]
    for r in rows:
        assert int(r["ndof"]) == scene.body(1, refine=int(r["level"])).ndof
        parts = sum(float(r[f"{p}_s"]) for p in ("assembly", "factorization", "solve", "residual", "other"))
        assert parts == pytest.approx(float(r["step_s"]), rel=1e-9)
        assert float(r["overhead"]) == pytest.approx(
            float(r["step_s"]) / (float(r["newton_mean"]) * float(r["one_solve_s"])), rel=1e-9)
    assert (tmp_path / "time_per_step.png").stat().st_size > 10_000
    assert "time per step ~ ndof^a" in capsys.readouterr().out


def test_static_condensation_gives_the_same_steps():
    """P3: the interior DOFs condensed (those at Γ3 kept) give the same states as the full
    system to round-off, with the same Newton iterations; P2 in 2D has none to condense."""
    runs = []
    for condense in (False, None):
        sim = scene.simulation(3, 0.01, condense=condense)
        sim.run(2.5e-3, 0.015)
        runs.append(sim)
    full, condensed = runs
    assert condensed.condense and not full.condense
    assert condensed.history[-1].contact.contact_area > 0
    assert list(condensed.history.newton_iterations) == list(full.history.newton_iterations)
    for a, b in zip(full.history[1:], condensed.history[1:]):
        assert np.abs(a.state - b.state).max() <= 1e-10 * np.abs(a.state).max()
    assert not scene.simulation(2, 0.01).condense


def test_realcompile_falls_back_without_a_compiler():
    """If compiling to machine code fails, the integrand is Compile()d with a warning."""
    from ngcontact.model.machine_code import compiled

    class NoCompiler:
        def Compile(self, realcompile=False, maxderiv=2, wait=False):
            if realcompile:
                raise Exception("cannot compile: g++ not found")
            return "compiled"
    with pytest.warns(RuntimeWarning, match="realcompile failed.*g\\+\\+ not found"):
        assert compiled(NoCompiler(), True) == "compiled"
