"""diagnose finds the effect hidden in records of a rig that is not the fitted model."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from backlash_df import load_rig
from backlash_df.cli import main
from backlash_df.identify import diagnose, synthesize

RIG_FILE = "examples/diagnose_rig.toml"


@pytest.fixture(scope="module")
def rig():
    return load_rig(RIG_FILE)


# (cause, seed): records of 2 s at 1 kHz, random sizes; rubber seed 10 is the bundled
# example, diagnosed through the command line below.
CASES = [("none", 10), ("none", 11), ("rubber", 11), ("rubber", 12),
         ("coulomb_friction", 10), ("coulomb_friction", 11), ("viscous_friction", 10), ("viscous_friction", 11),
         ("actuator_delay", 10), ("actuator_delay", 11)]


@pytest.mark.parametrize(("cause", "seed"), CASES)
def test_hidden_effect_is_named(rig, cause, seed):
    record = synthesize(rig, cause, seed=seed, duration=2.0)
    result = diagnose(record.measurements, rig)
    assert result.cause == cause
    if cause == "none":
        assert result.extended is result.baseline
        assert not any(candidate.accepted for candidate in result.candidates)
        return
    assert result.extended.mean_fit_percent > result.baseline.mean_fit_percent
    for name, value in result.extended.rms.items():
        assert value < result.baseline.rms[name]
    estimate = result.extended.parameter.value
    assert estimate == pytest.approx(record.size, rel=0.3)


def test_cli_names_the_rubber_of_the_bundled_example(tmp_path):
    """The paper's story: a coupling with rubber (seed 10, beta = 0.0119 rad) modelled without it."""
    out_json, out_html = tmp_path / "d.json", tmp_path / "d.html"
    result = CliRunner().invoke(main, ["diagnose", "examples/diagnose_rubber.csv", "--rig", RIG_FILE,
                                       "--json", str(out_json), "--report", str(out_html)])
    assert result.exit_code == 0, result.output
    data = json.loads(out_json.read_text())
    assert data["cause"] == "rubber"
    assert data["extended"]["fit_percent"] > data["baseline"]["fit_percent"]
    assert data["extended"]["parameters"]["rubber_thickness"]["value"] == pytest.approx(0.0119, rel=0.1)
    assert {candidate["cause"] for candidate in data["candidates"]} == {
        "none", "rubber", "coulomb_friction", "viscous_friction", "actuator_delay"}
    assert all("fit_percent" in candidate for candidate in data["candidates"])
    page = out_html.read_text()
    assert page.startswith("<!DOCTYPE html>") and "data:image/png;base64," in page and "Cause: rubber" in page


def test_cli_reports_a_bad_file_in_one_line(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,motor_torque\n0,1\n")
    result = CliRunner().invoke(main, ["diagnose", str(bad), "--rig", RIG_FILE, "--json", str(tmp_path / "o.json")])
    assert result.exit_code == 2
    assert "missing column motor_speed" in result.output
    assert not (tmp_path / "o.json").exists()


def test_speeds_in_rpm_are_refused_by_the_momentum_balance(rig):
    """30/pi = 9.55 times too fast for the rig's inertias: refused before any fit."""
    record = synthesize(rig, "none", seed=1, duration=0.5)
    m = record.measurements
    rpm = type(m)(time=m.time, motor_torque=m.motor_torque, motor_speed=m.motor_speed * 30 / np.pi,
                  load_speed=m.load_speed * 30 / np.pi, load_torque=m.load_torque, source="rpm.csv")
    with pytest.raises(ValueError, match="speeds must be in rad/s"):
        diagnose(rpm, rig)


def test_unknown_candidate(rig):
    record = synthesize(rig, "none", seed=1, duration=0.5)
    with pytest.raises(ValueError, match="unknown effect 'backlash_wear'"):
        diagnose(record.measurements, rig, candidates=["backlash_wear"])
