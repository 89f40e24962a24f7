"""Rig file parsing: every problem is one line naming the file and the key."""

import pytest

from backlash_df import RigError, load_rig, rig_from_dict
from conftest import PLANT_TOML

PLANT = dict(motor_inertia=0.4, load_inertia=5.6, stiffness=5895.0, damping=3.0, half_gap=0.05)

GOOD = PLANT_TOML + """
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
    rig = rig_from_dict({"plant": dict(PLANT, gear_ratio=120.0), "load": {"torque": -40.0, "torque_offset": -2.5}})
    assert rig.plant.gear_ratio == 120.0
    assert (rig.load.torque, rig.load.torque_offset) == (-40.0, -2.5)
    assert rig_from_dict({"plant": PLANT}).load.torque == 0.0


@pytest.mark.parametrize("table, key, value, match", [
    ("plant", "gear_ratio", 0.0, r"\[plant\] gear_ratio must be > 0"),
    ("load", "coulomb", 0.0, r"\[load\] coulomb is now \[friction\] coulomb_load"),
    ("load", "coulomb", 5.0, r"\[load\] coulomb is now \[friction\] coulomb_load"),
    ("load", "force", 1.0, r"unknown key \[load\] force"),
])
def test_load_and_gear_ratio_errors(table, key, value, match):
    data = {"plant": dict(PLANT), "load": {}}
    data[table][key] = value
    with pytest.raises(RigError, match=match):
        rig_from_dict(data)


@pytest.mark.parametrize("table, key, value, shown", [
    ("plant", "stiffness", 1e300, "1e+300 N m/rad is outside the accepted range [1e-06, 1e+12] N m/rad"),
    ("plant", "motor_inertia", 1e-300, "1e-300 kg m^2 is outside the accepted range [1e-10, 1e+10] kg m^2"),
    ("plant", "half_gap", 1e300, "1e+300 rad is outside the accepted range [1e-09, 3.14159] rad"),
    ("plant", "damping", 1e13, "[0, 1e+12] N m s/rad"),
    ("plant", "gear_ratio", 1e6, "1e+06 is outside the accepted range [0.0001, 100000]"),
    ("controller", "kp", 1e300, "[0, 1e+10] N m s/rad"),
    ("controller", "ti", 1e-300, "[1e-06, 1e+06] s"),
    ("controller", "delay", 1e300, "1e+300 s is outside the accepted range [0, 10] s"),
    ("controller", "torque_lag", 1e3, "[0, 100] s"),
    ("load", "torque", -1e300, "-1e+300 N m is outside the accepted range [-1e+09, 1e+09] N m"),
])
def test_extreme_values_are_refused_with_key_value_and_range(table, key, value, shown):
    data = {"plant": dict(PLANT), "controller": {"kp": 30.0, "ti": 0.5}, "load": {}}
    data[table][key] = value
    with pytest.raises(RigError, match=r"\[" + table + r"\] " + key) as info:
        rig_from_dict(data, source="rig.toml")
    assert shown in str(info.value)
    assert str(info.value).startswith("rig.toml: ")


def test_real_drives_at_both_ends_of_the_ranges_are_accepted():
    """A miniature servo and a wind-turbine drive train load (documented in backlash_df.config)."""
    servo = dict(motor_inertia=2e-7, load_inertia=1e-6, stiffness=0.5, damping=1e-4, half_gap=1e-4)
    turbine = dict(motor_inertia=500.0, load_inertia=3e8, stiffness=5e9, damping=1e7, half_gap=2e-3,
                   gear_ratio=120.0)
    for plant in (servo, turbine):
        rig = rig_from_dict({"plant": plant, "controller": {"kp": 1e-3 if plant is servo else 1e8, "ti": 0.05,
                                                             "delay": 1e-4}})
        assert rig.plant.stiffness == plant["stiffness"]


def test_rubber_law_needs_a_rubber_thickness(tmp_path):
    """With beta = 0 the rubber law (40) is the phase plane law (23): asking for it is refused."""
    rig = load_rig(write(tmp_path, GOOD))
    with pytest.raises(RigError, match=r"model 'rubber' needs \[plant\] rubber_thickness > 0"):
        rig.make_model("rubber")
    with pytest.raises(RigError, match=r"rig\.toml: model 'rubber' needs"):
        load_rig(write(tmp_path, GOOD + '\n[model]\nbacklash = "rubber"\n'))
    with_beta = load_rig(write(tmp_path, GOOD.replace("half_gap = 0.05", "half_gap = 0.05\nrubber_thickness = 0.02")))
    model = with_beta.make_model("rubber")
    assert model.rubber_thickness == 0.02
    # the band carries torque where the phase plane law has none: in the band, before steel contact
    assert model.torque(0.045, 0.0) > 0.0
    assert with_beta.make_model("phase-plane").torque(0.045, 0.0) == 0.0


def test_rig_file_not_utf8_names_the_file(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_bytes(("# Tr\u00e4gheit\n" + GOOD).encode("latin-1"))
    with pytest.raises(RigError, match=r"rig\.toml: not a UTF-8 text file \(byte 0xe4 at offset 4\)") as info:
        load_rig(path)
    assert str(info.value).startswith(str(path))


@pytest.mark.parametrize("changes, mode", [
    (dict(stiffness=1e12), "1.64e+06 rad/s"),                # within its range, not with these inertias
    (dict(motor_inertia=1e-10), "7.68e+06 rad/s"),           # g cm^2 typed as kg m^2, say
    (dict(damping=1e12), "2.68e+12 1/s"),                    # the damper's rate c (1/J_m + 1/J_l)
])
def test_a_shaft_mode_no_drive_has_is_refused(changes, mode):
    """sqrt(k (1/J_m + 1/J_l)) or c (1/J_m + 1/J_l) above 1e5 1/s: the simulation would need billions of steps."""
    with pytest.raises(RigError, match=r"rig\.toml: \[plant\] motor_inertia, load_inertia, (stiffness|damping): ") as info:
        rig_from_dict({"plant": dict(PLANT, **changes)}, source="rig.toml")
    assert mode in str(info.value) and "is above 100000" in str(info.value)


def test_simulation_longer_than_the_step_budget_is_refused_before_allocating():
    from backlash_df import simulate
    from backlash_df.simulation import MAX_STEPS

    rig = rig_from_dict({"plant": PLANT, "controller": {"kp": 30.0, "ti": 0.5}})
    with pytest.raises(ValueError, match=r"t_end = 10000 s at dt = 0\.0001 s is 1e\+08 steps, more than 2e\+07"):
        simulate(rig, "phase-plane", t_end=1e4, dt=1e-4)
    assert MAX_STEPS * 1e-4 > 320.0  # the longest run the verdict and the verification ask for fits


def test_a_load_torque_twisting_the_shaft_by_more_than_a_turn_is_refused():
    data = {"plant": dict(PLANT), "load": {"torque": -1e9}}  # within its range, not on this shaft
    with pytest.raises(RigError, match=r"rig\.toml: \[load\] torque = -1e\+09 N m twists the shaft by "
                                       r"\|T\| / k \+ alpha = 1\.7e\+05 rad, more than a turn"):
        rig_from_dict(data, source="rig.toml")
    data["load"]["torque"] = -0.9 * 2 * 3.14159 * PLANT["stiffness"]  # just under a turn: accepted
    assert rig_from_dict(data).load.torque < 0
