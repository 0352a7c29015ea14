"""The adaptive-against-uniform study (``python -m ngcontact adapt``): its summary's
interpolation and ratios on rows with known power laws, and one cheap run end to end."""
import csv
import math

import pytest

from ngcontact.studies import adaptivity


def _rows(method, ndofs, rate, constant, seconds_per_dof):
    """Levels of one run whose error is constant·N^(−rate) and whose elapsed time grows by
    seconds_per_dof·N per level."""
    rows, elapsed = [], 0.0
    for level, n in enumerate(ndofs):
        elapsed += seconds_per_dof * n
        rows.append(dict(scene="s", order=2, method=method, level=level, ndof=n, estimate=2 * constant * n ** -rate,
                         error=constant * n ** -rate, effectivity=2.0, build_s=0.1 * seconds_per_dof * n,
                         solve_s=0.5 * seconds_per_dof * n, elapsed_s=elapsed))
    return rows


def test_the_summary_interpolates_where_the_adaptive_run_reaches_the_finest_uniform_error():
    """Uniform: error N^(−1/2) up to N = 64 000 (error 1/√64000); adaptive: error N^(−1) from
    N = 100, which reaches it at N = √64000 = 253 (log-log interpolation is exact on a power
    law); elapsed times follow the DOFs, and the three time ratios are the uniform costs over
    the adaptive elapsed time at N = 253."""
    uniform = _rows("uniform", [1000, 4000, 16000, 64000], 0.5, 1.0, 1e-4)
    adaptive = _rows("adaptive", [100, 200, 400, 800], 1.0, 1.0, 1e-3)
    (result,) = adaptivity.summary(uniform + adaptive)
    assert result["measure"] == "error"
    assert result["adaptive_ndof"] == pytest.approx(64000 ** 0.5, rel=1e-12)
    assert result["dof_ratio"] == pytest.approx(64000 / 64000 ** 0.5, rel=1e-12)
    # elapsed between the levels at N = 200 (0.3 s) and 400 (0.7 s), log-log in N
    f = math.log(64000 ** 0.5 / 200) / math.log(2)
    elapsed = math.exp(math.log(0.3) + f * math.log(0.7 / 0.3))
    assert result["adaptive_elapsed_s"] == pytest.approx(elapsed, rel=1e-12)
    assert result["uniform_loop_s"] == pytest.approx(8.5, rel=1e-12)
    assert result["uniform_solves_s"] == pytest.approx(0.6 * 8.5, rel=1e-12)
    assert result["uniform_finest_s"] == pytest.approx(0.6 * 6.4, rel=1e-12)
    assert result["time_ratio_finest"] == pytest.approx(0.6 * 6.4 / elapsed, rel=1e-12)
    assert result["effectivity_range"] == "2.00-2.00"


def test_an_adaptive_run_that_never_reaches_the_uniform_error_has_no_ratio():
    uniform = _rows("uniform", [1000, 4000], 0.5, 1.0, 1e-4)
    adaptive = _rows("adaptive", [100, 120], 0.5, 1.0, 1e-3)
    (result,) = adaptivity.summary(uniform + adaptive)
    assert result["adaptive_ndof"] is None and result["dof_ratio"] is None and result["time_ratio_loop"] is None


@pytest.mark.long
def test_a_small_study_writes_its_tables_and_charts(tmp_path, monkeypatch):
    """The manufactured case, P1, up to 600 DOFs: errors.csv holds both methods' levels with
    effectivities in [1, 3] (the estimate is a bound), the charts are written."""
    made = adaptivity.SCENES["manufactured"]

    def small():
        scene = made()
        scene.max_ndof = 600
        return scene
    monkeypatch.setitem(adaptivity.SCENES, "manufactured", small)
    adaptivity.main(tmp_path, scenes=("manufactured",), orders=(1,))
    with open(tmp_path / "errors.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["method"] for r in rows} == {"uniform", "adaptive"}
    assert all(1.0 <= float(r["effectivity"]) <= 3.0 for r in rows)
    assert all(int(r["ndof"]) <= 600 for r in rows)
    for name in ("summary.csv", "adapt_dofs.png", "adapt_time.png", "meshes_manufactured.png"):
        assert (tmp_path / name).stat().st_size > 0
