"""``backlash-df predict``: bad input is one line naming key and file, exit code 2; verdicts in every output."""

import json
import math

import pytest
from click.testing import CliRunner

from backlash_df.cli import main
from conftest import PLANT_TOML

GOOD = PLANT_TOML + """
[controller]
feedback = "load"
kp = 30.0
ti = 0.5
"""


def run(tmp_path, text, *args):
    path = tmp_path / "rig.toml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["predict", str(path), *args])
    return path, result


@pytest.mark.parametrize(
    "text, args, words",
    [
        (GOOD.replace("kp = 30.0", "kp = 30.0\ngain = 2.0"), (), ["unknown key", "[controller] gain"]),
        (GOOD.replace("ti = 0.5", "ti = -0.5"), (), ["[controller] ti", "> 0"]),
        (GOOD.replace('feedback = "load"', 'feedback = "both"'), (), ["[controller] feedback"]),
        (GOOD.replace("half_gap = 0.05", "half_gap = 0.05\n[[oops"), (), ["malformed TOML"]),
        (GOOD.split("[controller]")[0], (), ["no [controller] table"]),
        (GOOD, ("--model", "coulomb"), ["'--model'", "'coulomb' is not one of", "phase-plane"]),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, text, args, words):
    path, result = run(tmp_path, text, *args)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:")
    assert str(path) in lines[0] or args  # a bad option is named instead of the file
    for word in words:
        assert word in lines[0]


def test_missing_file_names_it(tmp_path):
    result = CliRunner().invoke(main, ["predict", str(tmp_path / "nope.toml")])
    assert result.exit_code == 2
    assert "nope.toml" in result.output and "cannot read rig file" in result.output


def test_unstable_loop_gets_its_verdict_everywhere(tmp_path):
    # kp = 3000 on the load speed: the loop in contact is unstable (tests/test_verdict.py checks its poles)
    json_path, report_path = tmp_path / "out.json", tmp_path / "out.html"
    path, result = run(tmp_path, GOOD.replace("kp = 30.0", "kp = 3000.0"), "--json", str(json_path),
                       "--report", str(report_path))
    assert result.exit_code == 0, result.output
    assert "RuntimeWarning" not in result.output
    data = json.loads(json_path.read_text())
    entry = data["models"][0]
    assert entry["model"] == "phase-plane" and entry["verdict"] == "unstable"
    assert entry["contact_loop"]["stable"] is False and entry["contact_loop"]["max_real"] > 0.0
    assert entry["contact_loop"]["poles"][0][0] == entry["contact_loop"]["max_real"]
    assert entry["open_loop"]["status"] in ("stable", "marginal", "unstable")
    assert {probe["outcome"] for probe in entry["probes"]} == {"diverged"}
    assert "limit_cycles" in data and all(cycle["simulated"] is None for cycle in data["limit_cycles"])
    verdict_lines = [line for line in result.output.splitlines() if line.startswith("phase-plane  unstable")]
    pole = entry["contact_loop"]["poles"][0]
    assert len(verdict_lines) == 1
    assert f"unstable (rightmost pole {pole[0]:.4g} +- {abs(pole[1]):.4g}j 1/s)" in verdict_lines[0]
    page = report_path.read_text()
    assert "Verdict and linear stability" in page and "verdict: unstable" in page


def test_exact_adds_the_orbits_next_to_the_df(tmp_path):
    # examples/load_feedback.toml: one stable cycle; the exact orbit must sit on the simulated one
    json_path = tmp_path / "out.json"
    path, result = run(tmp_path, GOOD.replace("ti = 0.5", "ti = 0.5\nspeed_filter = 0.002"), "--exact",
                       "--json", str(json_path))
    assert result.exit_code == 0, result.output
    entry = json.loads(json_path.read_text())["models"][0]
    assert entry["verdict"] == "limit cycle" and entry["df_agrees"] is True
    (orbit,) = entry["exact_orbits"]
    simulated = entry["simulated_cycle"]
    assert orbit["stable"] and abs(orbit["multipliers"][0][0] - 1.0) < 1e-6  # the trivial multiplier
    assert abs(orbit["amplitude"] / simulated["amplitude"] - 1.0) < 1e-3
    assert abs(orbit["omega"] / simulated["omega"] - 1.0) < 1e-3
    assert abs(orbit["period"] * orbit["omega"] - 2.0 * math.pi) < 1e-9
    header = [line for line in result.output.splitlines() if line.startswith("model") and "A exact (rad)" in line]
    assert len(header) == 1
