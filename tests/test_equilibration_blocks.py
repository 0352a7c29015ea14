"""The element blocks of the patch problems combined at once (``Equilibration._blocks``: one
tensor contraction of the kept RT mass blocks with the weight) against the term-by-term sum
that it replaced, and the estimate computed through either."""
import ngsolve as ngs
import numpy as np
import pytest
from netgen.csg import unit_cube
from netgen.geom2d import unit_square

from ngcontact.estimators import equilibration
from ngcontact.estimators.equilibrated import EquilibratedEstimator
from ngcontact.estimators.equilibration import Equilibration
from ngcontact.scenes import reference


def _term_by_term(eq, weight):
    """K_YY, K_YX, K_XX of every element, summed weight entry by weight entry (the reference)."""
    rows, d, data = eq.rows, eq.mesh.dim, eq.data
    nF, nI, nR, ne = eq.nF_loc, eq.nI_loc, eq.nQ_loc - 1, eq.mesh.ne
    K_YY, K_YX, K_XX = np.zeros((ne, eq.nY, eq.nY)), np.zeros((ne, eq.nY, eq.nX)), np.zeros((ne, eq.nX, eq.nX))
    F = lambda i: slice(i * nF, (i + 1) * nF)
    I = lambda i: slice(i * nI, (i + 1) * nI)
    R = lambda i: slice(rows * nI + i * nR, rows * nI + (i + 1) * nR)
    for j in range(rows):
        for i in range(rows):
            for l in range(d):
                for k in range(d):
                    c = weight[j, l, i, k]
                    if c != 0.0:
                        FF, FI, II = data.mass(l, k)
                        K_YY[:, F(j), F(i)] += c * FF
                        K_YX[:, F(j), I(i)] += c * FI
                        K_XX[:, I(j), I(i)] += c * II
    for i in range(rows):
        m = rows * nF + i
        K_YY[:, F(i), m] = K_YY[:, m, F(i)] = data.div_F[:, 0, :]
        K_YX[:, m, I(i)] = data.div_I[:, 0, :]
        K_YX[:, F(i), R(i)] = np.transpose(data.div_F[:, 1:, :], (0, 2, 1))
        K_XX[:, I(i), R(i)] = np.transpose(data.div_I[:, 1:, :], (0, 2, 1))
        K_XX[:, R(i), I(i)] = data.div_I[:, 1:, :]
    return K_YY, K_YX, K_XX


@pytest.mark.parametrize("dim, order, rows", [(2, 2, 2), (2, 1, 1), (3, 1, 3), (3, 2, 1)])
def test_the_contracted_blocks_equal_the_term_by_term_sum(dim, order, rows):
    """A random symmetric positive definite weight with some zero entries, on a coarse square and
    cube: the blocks agree to round-off."""
    geometry = unit_square if dim == 2 else unit_cube
    mesh = ngs.Mesh(geometry.GenerateMesh(maxh=0.4))
    rng = np.random.default_rng(dim * 10 + rows)
    n = rows * dim
    root = rng.standard_normal((n, n)) * (rng.random((n, n)) > 0.3)
    weight = root @ root.T + n * np.eye(n)
    eq = Equilibration(mesh, rows, order, weight, lambda name, i: True)
    for new, old in zip(eq._blocks(weight.reshape(rows, dim, rows, dim)),
                        _term_by_term(eq, weight.reshape(rows, dim, rows, dim))):
        assert np.abs(new - old).max() <= 1e-13 * np.abs(old).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_the_estimate_equals_the_term_by_term_one(dim, monkeypatch):
    """The reference scene after first contact (P1, coarse): total and element indicators equal,
    to 1e-10, to those of the term-by-term blocks."""
    sim = reference.simulation(1, 0.01 if dim == 2 else 0.02, 0, dim, keep_states=False)
    sim.run(2.5e-3, 1e-2)
    new = EquilibratedEstimator(sim)()
    monkeypatch.setattr(equilibration.Equilibration, "_blocks", _term_by_term)
    old = EquilibratedEstimator(sim)()
    assert new.total == pytest.approx(old.total, rel=1e-10)
    assert np.abs(new.indicators - old.indicators).max() <= 1e-10 * old.indicators.max()
    for name, value in old.parts.items():
        assert new.parts[name] == pytest.approx(value, rel=1e-10, abs=1e-14 * old.total)


def test_the_condensed_matrices_of_a_key_are_made_once_whatever_the_threads():
    """``ElementData.condensed``: two threads asking for one key at once get one result, made
    once (the background set-up of ``Rows`` reads what the caller's thread condenses); a new
    key is made anew, and an error reaches every thread that asked."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor
    data = equilibration.Patches(ngs.Mesh(unit_square.GenerateMesh(maxh=0.5))).elements(1)
    made, started = [], threading.Event()

    def make():
        made.append(1)
        started.set()
        time.sleep(0.05)
        return "matrices"
    with ThreadPoolExecutor(1) as other:
        first = other.submit(data.condensed, ("key",), make)
        started.wait()                              # the other thread is making them
        assert data.condensed(("key",), make) == "matrices" and first.result() == "matrices"
    assert len(made) == 1
    assert data.condensed(("another",), lambda: "new") == "new"

    def fail():
        raise ArithmeticError("singular")
    with pytest.raises(ArithmeticError):
        data.condensed(("bad",), fail)
    with pytest.raises(ArithmeticError):
        data.condensed(("bad",), lambda: "not made again")
