"""The cheap parts of adaptivity: the block-diagonal patch solver, the averaging indicator and
the marking by it (the equilibrated bound computed where it decides, and on the last level)."""
import math

import ngsolve as ngs
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ngcontact import adapt
from ngcontact.estimators import block_diagonal
from ngcontact.estimators.averaging import AveragingIndicator
from ngcontact.estimators.block_diagonal import BlockDiagonal
from ngcontact.estimators.equilibrated import EquilibratedEstimator
from ngcontact.scenes import hertz, reference


def _saddle_blocks(sizes, seed=0):
    """COO entries of a block-diagonal matrix of saddle-point blocks [A Bᵀ; B 0] (the last
    unknown of each block a multiplier, zero diagonal), every entry given twice (halves)."""
    rng = np.random.default_rng(seed)
    rows, cols, values, start = [], [], [], 0
    for n in sizes:
        A = rng.standard_normal((n - 1, n - 1))
        M = np.zeros((n, n))
        M[:n - 1, :n - 1] = A @ A.T + n * np.eye(n - 1)
        M[n - 1, :n - 1] = M[:n - 1, n - 1] = rng.uniform(0.5, 1.5, n - 1)
        r, c = np.nonzero(M)
        for half in (0.5, 0.5):
            rows.append(r + start), cols.append(c + start), values.append(half * M[r, c])
        start += n
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(values), start


@pytest.mark.parametrize("sizes", [[5, 7, 5, 3, 7, 7], [5, block_diagonal.DENSE + 10, 4]])
def test_the_block_diagonal_solver_solves_like_a_sparse_direct_solver(sizes):
    """Dense batches (small blocks) and SuperLU (a block above DENSE, factorised in the
    background) against scipy's spsolve, at the first right-hand side and at the next ones (kept
    inverses), after a refill, and after two refills with no solve between them."""
    rows, cols, values, size = _saddle_blocks(sizes)
    block = np.repeat(np.arange(len(sizes)), sizes)
    system = BlockDiagonal(block, rows, cols)
    assert system.dense == (max(sizes) <= block_diagonal.DENSE)
    for scale in (1.0, 2.0):
        system.fill(scale * values)
        matrix = sp.csc_matrix((scale * values, (rows, cols)), shape=(size, size))
        for seed in range(3):
            rhs = np.random.default_rng(seed).standard_normal(size)
            assert np.allclose(system.solve(rhs), spla.spsolve(matrix, rhs), rtol=1e-10, atol=1e-12)
    system.fill(3.0 * values)                     # refilled before a solve (SuperLU in the background):
    system.fill(0.5 * values)                     # the last values count
    matrix = sp.csc_matrix((0.5 * values, (rows, cols)), shape=(size, size))
    assert np.allclose(system.solve(rhs), spla.spsolve(matrix, rhs), rtol=1e-10, atol=1e-12)


def test_a_sparse_system_in_parts_solves_alike_whichever_thread_factorises_them():
    """Many blocks above DENSE: the system is factorised in parts (whole blocks). Whether the
    background thread makes every part (the caller waits for it) or the caller makes them all
    (the background thread busy), the solution is the same to the last bit, and that of
    scipy's spsolve; an entry coupling blocks of two parts is refused when solving."""
    import threading
    sizes = [block_diagonal.DENSE + 1 + 7 * (k % 5) for k in range(3 * block_diagonal.CHUNKS)]
    rows, cols, values, size = _saddle_blocks(sizes, seed=3)
    block = np.repeat(np.arange(len(sizes)), sizes)
    rhs = np.random.default_rng(4).standard_normal((size, 2))
    system = BlockDiagonal(block, rows, cols)
    assert len(system._layout) == block_diagonal.CHUNKS
    system.fill(values)
    block_diagonal.in_background(lambda: None).result()       # (tasks run in order: every part made there)
    by_worker = system.solve(rhs)
    release = threading.Event()
    busy = block_diagonal.in_background(release.wait)
    system.fill(values)
    by_caller = system.solve(rhs)                              # (the parts made here)
    release.set()
    busy.result()
    assert np.array_equal(by_worker, by_caller)
    matrix = sp.csc_matrix((values, (rows, cols)), shape=(size, size))
    assert np.allclose(by_worker, spla.spsolve(matrix, rhs), rtol=1e-10, atol=1e-12)
    coupled = BlockDiagonal(block, np.r_[rows, 0], np.r_[cols, size - 1])
    coupled.fill(np.r_[values, 1.0])
    with pytest.raises(ValueError, match="couples two blocks"):
        coupled.solve(rhs)


def test_an_entry_that_couples_two_blocks_is_refused():
    with pytest.raises(ValueError, match="couples two blocks"):
        BlockDiagonal(np.array([0, 0, 1, 1]), np.array([0, 1, 2]), np.array([0, 2, 2]))


def test_the_averaging_indicator_vanishes_for_a_continuous_flux_and_follows_the_bound():
    """A uniform stretch (σ constant, continuous) has no averaging part (its contact part, the
    unbalanced Γ3 traction, remains); on the reference plate after
    first contact (P1 and P2, piezoelectric) the indicator lies between a fifth of the
    equilibrated bound and twice it (a compliance not inverted, or the flux part left out, would
    be off by orders of magnitude), and most of what it marks the bound marks too."""
    sim = reference.simulation(1, 0.005, keep_states=False)
    stretch = ngs.CF((1e-4 * ngs.x, -3e-5 * ngs.y))
    sim.steps.u.Set(stretch)
    stretched = AveragingIndicator(sim)()
    bound = EquilibratedEstimator(sim)().total
    assert stretched.parts["stress"] < 1e-9 * bound and stretched.parts["flux"] < 1e-9 * bound
    assert stretched.parts["contact"] > 1e-3 * bound          # σ_h ν against the Γ3 traction: not balanced
    for order in (1, 2):
        sim = reference.simulation(order, 0.005, keep_states=False)
        dt = 2.5e-3
        sim.run(dt, 5 * dt)
        cheap, bound = AveragingIndicator(sim)(), EquilibratedEstimator(sim)()
        assert cheap.parts["flux"] > 0 and cheap.parts["stress"] > 0
        assert 1 / 5 < cheap.total / bound.total < 2, (cheap.total, bound.total)
        assert len(cheap.indicators) == sim.body.mesh.ne
        mine, theirs = adapt.mark(cheap.indicators, 0.5), adapt.mark(bound.indicators, 0.5)
        assert (mine & theirs).sum() >= 0.5 * mine.sum(), (mine.sum(), theirs.sum(), (mine & theirs).sum())


def _hertz(mesh):
    return hertz.simulation(2, mesh=mesh, keep_states=False)


@pytest.fixture(scope="module")
def plain():
    """Hertz P2 adapted by the equilibrated estimate, five levels."""
    return adapt.step(_hertz, hertz.mesh(2, h_contact=0.1, curve=2), 1.0, max_levels=5)


def test_marking_by_averaging_certifies_the_first_and_the_last_level(plain):
    """Hertz P2: the averaging loop makes about as many DOFs as the equilibrated one for the
    same levels and ends within 30 % of its bound; its first and last levels carry the
    equilibrated bound (the last's equal to an estimator's of that level), the others do not."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=2)
    cheap = adapt.step(_hertz, mesh, 1.0, max_levels=5, marking="averaging")
    assert cheap.reason == "level limit" and len(cheap.levels) == 5
    assert [level.certified for level in cheap.levels] == [True, False, False, False, True]
    assert all(math.isnan(level.estimate) and level.parts == {} for level in cheap.levels[1:-1])
    assert all(level.indicator > 0 for level in cheap.levels)
    last = cheap.last
    assert last.estimate == pytest.approx(EquilibratedEstimator(last.sim)().total, rel=1e-12)
    assert 0.7 < last.ndof / plain.last.ndof < 1.5, (last.ndof, plain.last.ndof)
    assert last.estimate < 1.3 * plain.last.estimate, (last.estimate, plain.last.estimate)


def test_marking_by_averaging_stops_at_a_certified_target(plain):
    """With a target, the loop certifies a level only where the scaled indicator says it is met,
    and stops only on a certified level whose bound meets it."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=2)
    tol = plain.levels[3].relative
    cheap = adapt.step(_hertz, mesh, 1.0, tol=tol, max_levels=12, marking="averaging")
    assert cheap.reached and cheap.reason == "target reached"
    assert cheap.last.certified and cheap.last.relative <= tol
    assert all(level.relative > tol for level in cheap.levels[:-1] if level.certified)


@pytest.mark.parametrize("marking", ["residual", "", 1])
def test_an_unknown_marking_is_refused(marking):
    with pytest.raises(ValueError, match="marking must be one of 'equilibrated', 'averaging'"):
        adapt.step(_hertz, hertz.mesh(2, h_contact=0.1, curve=2), 1.0, marking=marking)


def test_solve_to_a_tolerance_returns_a_certificate():
    """adapt.solve: the last level's equilibrated bound meets tol (recomputed here), Newton was
    stopped at the estimate on some level, and a missing tol is refused."""
    mesh = hertz.mesh(2, h_contact=0.1, curve=2)
    result = adapt.solve(_hertz, mesh, 0.02)
    last = result.last
    assert result.reached and last.certified and last.relative <= 0.02
    assert EquilibratedEstimator(last.sim)().total / adapt.energy(last.sim) == pytest.approx(last.relative, rel=1e-12)
    assert len(result.levels) >= 2 and not all(level.certified for level in result.levels)
    with pytest.raises(ValueError, match="tol must be a finite number > 0"):
        adapt.solve(_hertz, mesh, None)


def test_the_estimate_cost_summary_reports_medians_of_ratios_and_the_first_round_apart():
    """``bench-estimate``'s summary: the median of the rounds' ratios estimate ÷ step (not the
    ratio of medians), the first estimate of the process on its own line, and the split's rest."""
    from ngcontact.studies import estimate_cost
    rows = [dict(step_s=2.0, cold_s=3.0, warm_s=1.0, cold_split={"block solves": 1.0}, warm_split={}),
            dict(step_s=1.0, cold_s=0.9, warm_s=0.5, cold_split={"block solves": 0.5}, warm_split={}),
            dict(step_s=4.0, cold_s=3.2, warm_s=1.2, cold_split={"block solves": 0.7}, warm_split={})]
    lines = estimate_cost.summary(1234, rows)
    assert lines[0].startswith("1234 DOFs, 3 rounds, medians: step 2.000 s, estimate cold 3.000 s (÷ step 0.90)")
    assert "warm 1.000 s (÷ step 0.50)" in lines[0]
    assert lines[1] == "first estimate of the process (round 0): cold 3.000 s (÷ step 1.50)"
    assert lines[2] == "cold split (s, medians): block solves 0.700, other 2.300"
