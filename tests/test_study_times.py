"""The time a study charts is the solve time, its time steps as their records give it, with
what a run pays once (mesh, forms, compiled integrands, step 0) apart, and the least over the
repeats; a ``--quick`` run says that its times are indicative (``studies.common``)."""
import pytest
from matplotlib.figure import Figure

from ngcontact.output.records import History, StepRecord
from ngcontact.studies import axisymmetric, common, convergence
from ngcontact.studies.stability import shared


def _history(walls):
    return History(StepRecord(step=n, time=0.1 * n, newton_iterations=2, residuals=[], wall_s=wall, reaction=None,
                              electrode_charge={}) for n, wall in enumerate(walls))


def test_a_run_is_split_into_its_steps_and_what_it_paid_once():
    """Steps 1 on are the solve (0.2 + 0.3 s); step 0 (0.5 s) and the build are the setup; the
    study's own error measurement (0.25 s) is in neither."""
    history = _history([0.5, 0.2, 0.3])
    assert common.solve_seconds(history) == pytest.approx(0.5, abs=1e-15)
    setup, solve = common.split_seconds(2.0, history, measured_s=0.25)
    assert (setup, solve) == pytest.approx((1.25, 0.5), abs=1e-15)


def test_repeats_keep_their_least_time_not_the_median():
    rows = [dict(kind="a", setup_s=10.0, solve_s=3.0), dict(kind="b", setup_s=1.0, solve_s=7.0),
            dict(kind="a", setup_s=12.0, solve_s=1.0), dict(kind="a", setup_s=9.0, solve_s=2.0)]
    a, b = common.fastest(rows, lambda r: r["kind"])
    assert (a["kind"], a["setup_s"], a["solve_s"], a["repeats"]) == ("a", 9.0, 1.0, 3)
    assert (b["kind"], b["setup_s"], b["solve_s"], b["repeats"]) == ("b", 1.0, 7.0, 1)


def _axisymmetric_rows(rounds):
    """Two cases of each kind, ``rounds`` rounds; the solve time of round k is (k + 1) × the
    case's least, its setup 5 s more than its solve."""
    rows = [dict(kind="reference", h_contact=0.001, ndof=9, error=0.0, solve_s=50.0, setup_s=5.0)]
    for k in range(rounds):
        for kind, h, ndof, error, least in (("section", 0.02, 800, 0.08, 0.05), ("section", 0.01, 2100, 0.02, 0.2),
                                            ("quarter", 0.08, 1300, 0.2, 0.4), ("quarter", 0.04, 2900, 0.09, 1.6)):
            rows.append(dict(kind=kind, h_contact=h, ndof=ndof, error=error, solve_s=least * (rounds - k),
                             setup_s=least * (rounds - k) + 5.0))
    return rows


def test_the_axisymmetric_chart_plots_the_least_solve_time(tmp_path):
    fig = axisymmetric.chart(_axisymmetric_rows(3), tmp_path / "axisymmetric.png")
    (ax,) = fig.axes
    section, quarter = ax.lines
    assert list(section.get_xdata()) == [0.05, 0.2] and list(quarter.get_xdata()) == [0.4, 1.6]
    assert list(section.get_ydata()) == [0.08, 0.02]
    assert "the least of 3 rounds" in ax.get_xlabel() and "quick" not in ax.get_title()
    # the time to an error, log-log between the least solve times: 4 % halfway from (0.05 s, 8 %)
    # to (0.2 s, 2 %), at 0.1 s (the medians would give 0.2 s)
    assert axisymmetric.time_to(_axisymmetric_rows(3), "section", 0.04) == pytest.approx(0.1, rel=1e-12)


def test_a_quick_axisymmetric_chart_says_it_holds_single_timings(tmp_path):
    fig = axisymmetric.chart(_axisymmetric_rows(1), tmp_path / "axisymmetric.png", quick=True)
    (ax,) = fig.axes
    assert common.QUICK in ax.get_title()
    assert "a single timing" in ax.get_xlabel() and "median" not in ax.get_xlabel()


def test_the_work_precision_chart_plots_the_solve_time():
    """Runs whose setup (5 s) dwarfs their solve: the chart's x are the solve times."""
    runs = [convergence.Run(1, level, 0.25 / 2**level, 0.25, 42 * 3**level, dict(u=e, phi=e, beta=0.0, total=2 * e),
                            dict(u=e, phi=e, beta=0.0, total=2 * e), [4], setup_s=5.0 + level, solve_s=0.1 * 2**level)
            for level, e in enumerate((0.5, 0.25, 0.125))]
    attr, label, _ = convergence.CHARTS["h"][2]
    (ax,) = convergence.chart(runs, attr, label, "t").axes
    total = next(line for line in ax.lines if line.get_label() == "P1 (4.12) total")
    assert list(total.get_xdata()) == [0.1, 0.2, 0.4] and list(total.get_ydata()) == [1.0, 0.5, 0.25]
    assert "solve time" in ax.get_xlabel()


def test_a_solved_step_is_timed_by_its_own_record():
    """A real run (the coarsest section, P1): the solve time is the step's recorded wall time,
    to the bit (the setup is what the run took besides)."""
    sim, setup, solve = axisymmetric.solve("section", 1, 0.02)
    assert len(sim.history) == 2 and solve == sim.history[1].wall_s


def test_a_quick_stability_chart_is_marked(tmp_path):
    for quick in (False, True):
        fig = Figure()
        fig.add_subplot().plot([0, 1], [0, 1])
        shared.save(fig, tmp_path / f"chart_{quick}.png", quick)
        assert (tmp_path / f"chart_{quick}.png").stat().st_size > 1000
        assert any(common.QUICK in text.get_text() for text in fig.texts) == quick
