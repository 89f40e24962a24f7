"""`backlash-df df`: the table, the JSON, and one-line errors with exit code 2."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from backlash_df.cli import main

RIG = """
[plant]
motor_inertia = 0.4
load_inertia = 5.6
stiffness = 5895.0
damping = 3.0
half_gap = 0.05
"""


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
