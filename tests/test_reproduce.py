"""Figure 2, Figure 3 and Table I: what must hold whatever the setup.

No printed number of the paper is a target (reading notes, item 9); the tests
check convergence, balances and the paper's qualitative claims.
"""

import csv
import json

import numpy as np
import pytest
from click.testing import CliRunner

from backlash_df import make_model
from backlash_df.cli import main
from backlash_df.reproduce import PAPER_PLANT, SETUPS, Setup, TableOne, compare_torques, figure2_maps, integrated_torque

DT = 4e-5
WARMUP = 10


@pytest.fixture(scope="module")
def comparisons():
    return {
        (name, dt): compare_torques(name, dt=dt, warmup_cycles=WARMUP)
        for name in ("one-sided", "crossing") for dt in (DT, DT / 2)
    }


@pytest.mark.parametrize("setup", ["one-sided", "crossing"])
def test_halving_the_step_changes_table_1_integrals_by_less_than_0p1_percent(comparisons, setup):
    coarse, fine = comparisons[(setup, DT)], comparisons[(setup, DT / 2)]
    for name, value in fine.integral.items():
        assert abs(coarse.integral[name] - value) < 1e-3 * abs(value), name


@pytest.mark.parametrize("setup", ["one-sided", "crossing"])
def test_driving_law_integral_is_the_net_load_in_periodic_steady_state(comparisons, setup):
    """Periodic response: J_l w_l returns to its value, so the integral of T is -T_preload x period (item 9);
    the event-located quadrature of the sampled torque agrees with that momentum balance."""
    comparison = comparisons[(setup, DT / 2)]
    assert comparison.periodicity < 1e-6
    expected = -SETUPS[setup].preload * SETUPS[setup].period
    assert comparison.integral["phase-plane"] == pytest.approx(expected, rel=1e-6)
    model = make_model("phase-plane", **PAPER_PLANT.shaft)
    quadrature = integrated_torque(model, comparison.time, comparison.theta_d, comparison.dtheta_d)
    scale = np.trapezoid(np.abs(comparison.torque["phase-plane"]), comparison.time)
    assert quadrature == pytest.approx(expected, abs=1e-5 * scale)


def test_integrated_torque_locates_jumps_second_order():
    """A jump between samples: the dead-zone (26) switched on at x = alpha; integral in closed form.

    x = t, v = 1: T = k (t - a) + c for t > a, so the integral over [0, 1] is k (1 - a)^2 / 2 + c (1 - a).
    """
    k, c, a = 3.0, 0.7, 0.3141
    model = make_model("damped-dead-zone", stiffness=k, damping=c, half_gap=a)
    expected = 0.5 * k * (1 - a) ** 2 + c * (1 - a)
    for n in (11, 101):
        t = np.linspace(0.0, 1.0, n)
        assert integrated_torque(model, t, t, np.ones_like(t)) == pytest.approx(expected, rel=1e-12)
        trapezoid = np.trapezoid(model.torque(t, 1.0), t)
        assert abs(trapezoid - expected) > 1e-4  # the plain trapezoid misses the jump


def test_dead_zone_26_pulls_where_the_exact_torque_is_zero(comparisons):
    """One-sided setup: the shaft only touches the left side (T_exact <= 0); (26) pushes
    positive torque (a pull from the left side) on samples where the exact torque is zero."""
    comparison = comparisons[("one-sided", DT / 2)]
    exact, dead = comparison.torque["exact"], comparison.torque["damped-dead-zone"]
    assert np.all(exact <= 0.0) and np.all(comparison.theta_d < 0.0)
    pull = (exact == 0.0) & (dead > 0.0)
    assert pull.sum() > 10
    # in area A1: left of the gap while k x + c v > -k alpha
    k, c, alpha = PAPER_PLANT.stiffness, PAPER_PLANT.damping, PAPER_PLANT.half_gap
    x, v = comparison.theta_d[pull], comparison.dtheta_d[pull]
    assert np.all(x < -alpha) and np.all(k * x + c * v > -k * alpha)
    # the laws with the exact release condition never push there
    for name in ("phase-plane", "revised-dead-zone"):
        assert np.all(comparison.torque[name][exact == 0.0] <= 0.0)


@pytest.mark.parametrize("driver", ["phase-plane", "exact"])
def test_all_laws_agree_while_contact_is_never_lost(driver):
    """A preload of 200 N m keeps left contact: (23), (26), (27), ElastoBacklash equal the exact torque."""
    held = Setup("held", preload=200.0)
    comparison = compare_torques(held, driver=driver, dt=DT, warmup_cycles=WARMUP,
                                 models=("phase-plane", "damped-dead-zone", "revised-dead-zone", "elasto-backlash"))
    exact = comparison.torque["exact"]
    assert np.all(exact < 0.0)
    for name, torque in comparison.torque.items():
        np.testing.assert_allclose(torque, exact, rtol=1e-12, atol=1e-9, err_msg=name)
        assert comparison.integral[name] == pytest.approx(comparison.integral["exact"], rel=1e-6)


def test_exact_torque_along_its_own_trajectory_matches_the_simulation():
    """driver='exact': the table's exact torque comes from the simulation; the limited integrator
    along the sampled trajectory (torque_along) must give the same cycle integral."""
    comparison = compare_torques("crossing", driver="exact", dt=DT / 2, warmup_cycles=WARMUP)
    model = make_model("exact", **PAPER_PLANT.shaft)
    theta_b0 = -PAPER_PLANT.half_gap if comparison.torque["exact"][0] < 0 else 0.0
    along = integrated_torque(model, comparison.time, comparison.theta_d, comparison.dtheta_d, theta_b0=theta_b0)
    assert along == pytest.approx(comparison.integral["exact"], rel=2e-3)


def test_figure2_regions_follow_5_and_the_pull_areas_are_where_26_breaks_it():
    maps = figure2_maps(n=121)
    x, v, regions = maps["x"], maps["v"], maps["regions"]
    k, c, alpha = 1.0, 10.0, 1.0
    np.testing.assert_array_equal(regions == 0, np.abs(k * x + c * v) < k * alpha)
    phase = maps["torque"]["phase-plane"]
    assert np.all(phase[regions == 0] == 0.0)  # nothing is transmitted in the release set
    assert np.all(phase[phase > 0] == (k * (x - alpha) + c * v)[phase > 0])
    pull = maps["pull"]
    assert pull.any() and np.all(np.abs(x[pull]) > alpha)
    assert np.all(regions[pull & (x > 0)] <= 0) and np.all(regions[pull & (x < 0)] >= 0)


def test_table_one_plot_draws_the_table(comparisons):
    """The bars are the table: one per law and setup, heights = error_percent and rms_error_percent."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = TableOne((comparisons[("one-sided", DT)], comparisons[("crossing", DT)]))
    axes = table.plot().axes
    try:
        assert len(axes) == 2
        for ax, key in zip(axes, ("error_percent", "rms_error_percent")):
            heights = sorted(bar.get_height() for bar in ax.patches)
            expected = sorted(row[key] for row in table.rows if row["model"] != "exact")
            np.testing.assert_allclose(heights, expected, rtol=1e-12)
        assert [tick.get_text() for tick in axes[1].get_xticklabels()] == ["one-sided", "crossing"]
    finally:
        plt.close("all")


# ---------------------------------------------------------------- command line


def test_cli_table1_writes_csv_and_json(tmp_path):
    runner = CliRunner()
    for suffix in ("csv", "json"):
        out = tmp_path / f"table.{suffix}"
        result = runner.invoke(main, ["reproduce", "table1", "--dt", "5e-5", "--out", str(out)])
        assert result.exit_code == 0, result.output
        assert "phase plane (23)" in result.output and "crossing" in result.output
        assert "integral of the shaft torque T over one disturbance cycle (N m s)" in " ".join(result.output.split())
    payload = json.loads((tmp_path / "table.json").read_text())
    rows = payload["rows"]
    assert {row["setup"] for row in rows} == set(SETUPS)
    assert payload["units"]["integral"] == "N m s"
    with open(tmp_path / "table.csv", newline="") as handle:
        table = list(csv.DictReader(handle))
    assert list(table[0]) == ["setup", "model", "integral_N_m_s", "error_percent", "rms_error_N_m", "rms_error_percent"]
    for line, row in zip(table, rows, strict=True):
        assert float(line["integral_N_m_s"]) == row["integral"]
        assert line["error_percent"] == ("" if row["error_percent"] is None else repr(row["error_percent"]))


def test_cli_figures_write_png(tmp_path):
    runner = CliRunner()
    for what in ("figure2", "figure3"):
        out = tmp_path / f"{what}.png"
        result = runner.invoke(main, ["reproduce", what, "--dt", "5e-5", "--out", str(out)])
        assert result.exit_code == 0, result.output
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, message",
    [
        (["table1", "--out", "table.txt"], "table1 is written as .csv or .json"),
        (["figure2", "--out", "figure.csv"], "figure2 is written as .png"),
        (["figure3", "--setup", "nope"], "'nope' is not one of 'one-sided', 'crossing'"),
        (["table1", "--driver", "hysteresis"], "'hysteresis' is not one of 'exact'"),
        (["table1", "--dt", "0.01"], "'--dt': 0.01 is not in the range"),
    ],
)
def test_cli_bad_arguments_exit_2_with_one_line(tmp_path, args, message):
    result = CliRunner().invoke(main, ["reproduce", *args])
    assert result.exit_code == 2
    assert message in result.output
    assert not list(tmp_path.iterdir())
