"""Rig file parsing: every problem is one line naming the file and the key."""

import pytest

from backlash_df import RigError, load_rig, rig_from_dict

PLANT = dict(motor_inertia=0.4, load_inertia=5.6, stiffness=5895.0, damping=3.0, half_gap=0.05)

GOOD = """
[plant]
motor_inertia = 0.4
load_inertia = 5.6
stiffness = 5895.0
damping = 3.0
half_gap = 0.05

[controller]
kp = 30.0
ti = 0.5
"""


def write(tmp_path, text):
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_good_rig_round_trips(tmp_path):
    rig = load_rig(write(tmp_path, GOOD))
    assert rig.plant.stiffness == 5895.0
    assert rig.controller.ki == pytest.approx(60.0)
    assert rig.controller.feedback == "load"
    assert rig.model == "phase-plane"
    assert rig.make_model().torque(0.06, 0.0) == pytest.approx(5895.0 * 0.01)


@pytest.mark.parametrize(
    "text, match",
    [
        (GOOD.replace("motor_inertia = 0.4", "motor_inertia = -0.4"), r"\[plant\] motor_inertia must be > 0"),
        (GOOD.replace("damping = 3.0", "damping = nan"), r"\[plant\] damping must be finite"),
        (GOOD.replace("half_gap = 0.05", "half_gap = 0.05\nbacklash = 1"), r"unknown key \[plant\] backlash"),
        (GOOD.replace("stiffness = 5895.0", ""), r"missing key \[plant\] stiffness"),
        (GOOD + '\n[model]\nbacklash = "hysteresis"\n', r"unknown model 'hysteresis'"),
        (GOOD.replace("kp = 30.0", 'kp = "fast"'), r"\[controller\] kp must be a number"),
        (GOOD + "\n[plant\n", r"malformed TOML"),
        (GOOD + "\n[extras]\nx = 1\n", r"unknown table \[extras\]"),
        (GOOD.replace("half_gap = 0.05", "half_gap = 0.05\nrubber_thickness = 0.5"), r"rubber_thickness must be <="),
    ],
)
def test_bad_rig_is_one_line_naming_file_and_key(tmp_path, text, match):
    path = write(tmp_path, text)
    with pytest.raises(RigError, match=match) as info:
        load_rig(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(str(path))


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match="cannot read rig file"):
        load_rig(tmp_path / "nope.toml")


def test_load_table_and_gear_ratio():
    rig = rig_from_dict({"plant": dict(PLANT, gear_ratio=120.0), "load": {"torque": -40.0, "coulomb": 5.0}})
    assert rig.plant.gear_ratio == 120.0
    assert (rig.load.torque, rig.load.coulomb) == (-40.0, 5.0)
    assert rig_from_dict({"plant": PLANT}).load.torque == 0.0


@pytest.mark.parametrize("table, key, value, match", [
    ("plant", "gear_ratio", 0.0, r"\[plant\] gear_ratio must be > 0"),
    ("load", "coulomb", -1.0, r"\[load\] coulomb must be >= 0"),
    ("load", "force", 1.0, r"unknown key \[load\] force"),
])
def test_load_and_gear_ratio_errors(table, key, value, match):
    data = {"plant": dict(PLANT), "load": {}}
    data[table][key] = value
    with pytest.raises(RigError, match=match):
        rig_from_dict(data)
