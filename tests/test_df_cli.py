"""`backlash-df df`: the table, the JSON, and one-line errors with exit code 2."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from backlash_df.cli import main
from conftest import PLANT_TOML

RIG = PLANT_TOML


@pytest.fixture
def rig(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_text(RIG)
    return path


def run(*args):
    return CliRunner().invoke(main, [str(arg) for arg in args])


def test_json_holds_every_combination_and_matches_the_closed_form(rig, tmp_path):
    out = tmp_path / "df.json"
    result = run("df", "--rig", rig, "--model", "damped-dead-zone", "--amplitude", "0.06,0.2",
                 "--omega", 10, "--omega", 1000, "--json", out)
    assert result.exit_code == 0, result.output
    points = json.loads(out.read_text())["points"]
    assert len(points) == 4
    for point in points:
        # (26): N = (k + j c w) F(alpha / A)
        r = 0.05 / point["amplitude"]
        f = 1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))
        expected = (5895.0 + 3j * point["omega"]) * f
        assert point["gain"] == pytest.approx(abs(expected), rel=1e-12)
        assert point["phase_deg"] == pytest.approx(np.degrees(np.angle(expected)), rel=1e-12)
    assert "phase (deg)" in result.output and "gain (N m/rad)" in result.output


@pytest.mark.parametrize(
    "args, message",
    [
        (["--amplitude", "-0.1", "--omega", "10"], "'--amplitude': must be > 0"),
        (["--amplitude", "0.1", "--omega", "-10"], "'--omega': must be >= 0"),
        (["--amplitude", "abc", "--omega", "10"], "'--amplitude': not a number"),
        (["--model", "hysteresis", "--amplitude", "0.1", "--omega", "10"], "'hysteresis' is not one of"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(rig, tmp_path, args, message):
    out = tmp_path / "df.json"
    result = run("df", "--rig", rig, *args, "--json", out)
    assert result.exit_code == 2
    assert message in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_bad_rig_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(RIG.replace("stiffness = 5895.0", "stiffness = -1.0"))
    result = run("df", "--rig", path, "--amplitude", "0.1", "--omega", "10")
    assert result.exit_code == 2
    assert str(path) in result.output and "stiffness" in result.output


def test_mean_torque_is_zero_at_zero_bias_relative_to_the_torque_scale(rig, tmp_path):
    """An odd law has no mean torque without bias: printed 0 at A = 1e300 as at A = 0.06 rad
    (the quadrature's round-off scales with |N| A, so the zeroing is relative)."""
    out = tmp_path / "df.json"
    result = run("df", "--rig", rig, "--model", "phase-plane", "--amplitude", "0.06,1e3,1e300", "--omega", "100",
                 "--json", out)
    assert result.exit_code == 0, result.output
    points = json.loads(out.read_text())["points"]
    assert [point["mean_torque"] for point in points] == [0.0, 0.0, 0.0]
    assert points[2]["gain"] == pytest.approx(abs(5895.0 + 300j), rel=1e-9)  # A >> alpha: N -> k + j c w


@pytest.mark.parametrize("bias", [0.02, -0.07, 1e-6])
def test_mean_torque_with_bias_matches_an_independent_quadrature(rig, tmp_path, bias):
    """Dead-zone (24) with bias b: the mean torque (1 / 2 pi) int T(b + A sin phi) dphi, by scipy's quad."""
    from scipy.integrate import quad

    k, alpha, amplitude = 5895.0, 0.05, 0.1

    def torque(phi):
        x = bias + amplitude * np.sin(phi)
        return k * (x - alpha) if x > alpha else (k * (x + alpha) if x < -alpha else 0.0)

    ratios = (np.array([alpha, -alpha]) - bias) / amplitude
    crossings = np.arcsin(ratios[np.abs(ratios) <= 1.0])  # where x crosses +-alpha
    breaks = sorted(np.concatenate([crossings, np.pi - crossings]) % (2 * np.pi))
    expected = quad(torque, 0.0, 2 * np.pi, points=breaks, epsabs=1e-10, epsrel=1e-12, limit=200)[0] / (2 * np.pi)
    out = tmp_path / "df.json"
    result = run("df", "--rig", rig, "--model", "dead-zone", "--amplitude", amplitude, "--omega", "10",
                 "--bias", bias, "--json", out)
    assert result.exit_code == 0, result.output
    mean = json.loads(out.read_text())["points"][0]["mean_torque"]
    assert mean != 0.0
    assert mean == pytest.approx(expected, rel=1e-8, abs=1e-9 * k * amplitude)


def test_help_lists_the_valid_models():
    result = run("df", "--help")
    assert result.exit_code == 0
    text = " ".join(result.output.split())
    for name in ("dead-zone", "damped-dead-zone", "phase-plane", "rubber", "exact", "elasto-backlash"):
        assert name in text


def _text_rows(output):
    """The table rows of the df text as lists of numbers (after the title and the column names)."""
    return [[float(cell) for cell in line.split()] for line in output.splitlines()[2:] if line.strip()]


def test_rubber_header_names_beta_and_the_other_laws_have_none(tmp_path):
    path = tmp_path / "rubber.toml"
    path.write_text(RIG + "rubber_thickness = 0.02\n")
    rubber = run("df", "--rig", path, "--model", "rubber", "--amplitude", "0.1", "--omega", "10")
    plain = run("df", "--rig", path, "--model", "phase-plane", "--amplitude", "0.1", "--omega", "10")
    assert rubber.exit_code == 0 and plain.exit_code == 0, rubber.output + plain.output
    assert rubber.output.splitlines()[0] == ("describing function of rubber (k = 5895 N m/rad, c = 3 N m s/rad, "
                                             "alpha = 0.05 rad, beta = 0.02 rad, bias = 0 rad)")
    assert "beta" not in plain.output


def test_phase_round_off_prints_as_zero_and_the_json_keeps_the_computed_value(rig, tmp_path):
    """A static law (w = 0) has no phase: round-off below 1e-12 rad prints 0.0000, never -0.0000."""
    out = tmp_path / "df.json"
    result = run("df", "--rig", rig, "--model", "phase-plane", "--amplitude", "0.06,0.3,1e3", "--omega", "0,100",
                 "--json", out)
    assert result.exit_code == 0, result.output
    points = json.loads(out.read_text())["points"]
    rows = _text_rows(result.output)
    assert "-0.0000" not in result.output
    for point, row in zip(points, rows, strict=True):
        if point["omega"] == 0.0:
            assert abs(np.radians(point["phase_deg"])) <= 1e-12 and row[5] == 0.0
        else:  # (23) leads: the phase prints as computed
            assert row[5] == pytest.approx(point["phase_deg"], abs=5e-5) and row[5] > 0.5
