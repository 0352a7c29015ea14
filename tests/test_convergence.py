"""The convergence study, CI-sized: P1 and P2 on three nested levels against the
manufactured contact solutions; the full study is ``python -m ngcontact convergence``."""
import csv

import numpy as np
import ngsolve as ngs
import pytest

import ngcontact as ngc
from ngcontact.studies import convergence as study
from ngcontact.cli import main
from ngcontact.gamma3.contact_side import ContactSide
from ngcontact.geometries import plate


@pytest.fixture(scope="module")
def viscous():
    return study.manufactured_study(orders=(1, 2), levels=3, case="viscous", progress=False)


def test_rates_of_the_paper_quantity(viscous):
    """(4.12) with contact, viscosity and conduction: P1 O(h) as the paper claims, P2 O(h²)
    (the solution is smooth enough: u ~ (x - x_c)_+^4). Observed: 0.89 and 1.83 (total),
    pre-asymptotic on the coarsest level."""
    assert 0.8 <= study.fitted_rate(viscous, 1) <= 1.3
    assert 1.7 <= study.fitted_rate(viscous, 2) <= 2.4
    assert 1.7 <= study.fitted_rate(viscous, 2, "u") <= 2.4
    finest = [r for r in viscous if r.level == 2]
    assert finest[0].error_max["total"] < 0.25 and finest[1].error_max["total"] < 5e-3
    assert all(r.error_max["total"] >= r.error_final["total"] for r in viscous)


@pytest.mark.long
def test_beta_part_is_first_order_for_every_order():
    """Adhesive case: β ∈ B^h (facet constants) is O(h) whatever the order of u, so the
    paper's total error is capped at O(h) once β0 varies."""
    runs = study.manufactured_study(orders=(1, 2), levels=3, case="adhesive", progress=False)
    for order in (1, 2):
        assert study.fitted_rate(runs, order, "beta") == pytest.approx(1.0, abs=0.05)
    assert 1.7 <= study.fitted_rate(runs, 2, "u") <= 2.4
    assert study.fitted_rate(runs, 2, "total") < 1.5


@pytest.mark.long
def test_first_order_in_the_time_step():
    runs = study.time_study(order=2, level=1, halvings=3, progress=False)
    assert 0.8 <= study.fitted_rate(runs, 2, by="dt") <= 1.2


def test_nested_transfer_is_exact():
    """What the reference study relies on: a coarse P3 function Set on the refined mesh,
    and a coarse facet field read at fine facet midpoints, are reproduced exactly."""
    coarse, fine = plate(maxh=0.01), plate(maxh=0.01, refine=2)
    gc = ngs.GridFunction(ngs.H1(coarse, order=3))
    gc.Set(ngs.sin(40 * ngs.x) * ngs.exp(50 * ngs.y))
    gf = ngs.GridFunction(ngs.H1(fine, order=3))
    gf.Set(gc)
    xs = np.random.default_rng(0).random((200, 2)) * [0.1, 0.02]
    assert np.abs(gc(coarse(xs[:, 0], xs[:, 1])) - gf(fine(xs[:, 0], xs[:, 1]))).max() < 1e-12
    sides = [ContactSide(ngc.Body(m, ngc.pzt5a(), clamped="left", grounded="top", contact_side="bottom"))
             for m in (coarse, fine)]
    values = sides[0].midpoints[:, 0] ** 2
    read = study._facet_lookup(sides[0], sides[1].midpoints, values)
    centre, half = sides[0].midpoints[:, 0], sides[0].measure / 2      # Γ3 is y = 0
    owner = [np.flatnonzero(np.abs(centre - x) <= half + 1e-15)[0] for x in sides[1].midpoints[:, 0]]
    assert np.array_equal(read, values[owner])


def test_cli_writes_csv_and_charts(tmp_path):
    main(["convergence", "--orders", "1", "--levels", "2", "--out", str(tmp_path)])
    rows = list(csv.DictReader(open(tmp_path / "errors.csv")))
    assert len(rows) == 2 and {"order", "level", "h", "dt", "ndof", "error_u", "error_phi",
                               "error_beta", "error_total", "rate_total", "setup_s", "solve_s"} <= set(rows[0])
    assert float(rows[1]["h"]) == float(rows[0]["h"]) / 2
    assert 0.5 < float(rows[1]["rate_total"]) < 1.5
    for name in ("error_vs_h.png", "error_vs_ndof.png", "work_precision.png"):
        assert (tmp_path / name).stat().st_size > 10_000


@pytest.mark.slow
def test_reference_scene_converges():
    """The reference scene against its fine solution: the P1 error halves per level."""
    runs = study.reference_study(orders=(1,), levels=2, progress=False)
    assert runs[1].error_max["total"] < 0.6 * runs[0].error_max["total"]
