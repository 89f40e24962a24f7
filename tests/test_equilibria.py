"""Rest points of the loops: where the loop rests, whether it stays, how far a disturbance keeps it (issue 22).

Every rest is checked against the block diagram in closed form (the shaft on the flank
carrying the load, ``theta_d = -sign(T_l) alpha - T_l / k``, the integrator holding it,
``I = -T_l / k_i``), its local stability against the loop in contact, and its reach
against the simulation: a disturbance 3 % inside it keeps the law in the rest's mode for
the whole run, one 3 % beyond it leaves.
"""

import dataclasses
import math
import warnings

import numpy as np
import pytest

import backlash_df as bd
from backlash_df.disturbances import MOTOR_SPEED, TWIST, Disturbance
from backlash_df.equilibria import contact_shaft, linear_stability, loop_rests
from conftest import example_rig

LAW = "phase-plane"


def tuned(name, **controller):
    rig = example_rig(name)
    return dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, **controller))


LOOPS = {
    "speed loop": dict(),
    "cascade, load position, torque limit": dict(structure="cascade", kv=20.0, torque_limit=300.0),
    "cascade, motor position": dict(structure="cascade", kv=20.0, position_feedback="motor"),
    "speed loop, dead time": dict(delay=0.0005),
}


@pytest.mark.parametrize("loop", list(LOOPS))
def test_a_loaded_loop_rests_on_its_flank_in_closed_form(loop):
    rig = tuned("loaded_feedback", **LOOPS[loop])
    model = rig.make_model(LAW)
    (rest,), note = loop_rests(rig, model)
    plant, load, ctl = rig.plant, rig.load.torque, rig.controller
    assert note == "" and rest.side == -1 and rest.where == "on the left flank"
    assert rest.theta_d == pytest.approx(-plant.half_gap - load / plant.stiffness, rel=1e-12)
    assert rest.torque == pytest.approx(-load, rel=1e-12)
    state = rest.initial()
    assert state["integrator"] == pytest.approx(-load / ctl.ki, rel=1e-12)
    assert abs(state["motor_speed"]) < 1e-12 and abs(state["load_speed"]) < 1e-12
    if ctl.cascade:  # the measured position sits on its reference 0
        measured = state["load_angle"] + (state["theta_d"] if ctl.position_feedback == "motor" else 0.0)
        assert abs(measured) < 1e-12
    # local stability: the contact loop's poles (Pade order 8 for the dead time)
    contact = linear_stability(bd.drive_loop(rig).linear_part(), *contact_shaft(model))
    assert np.allclose(rest.stability.poles, contact.poles) and rest.stable
    # a rest stays: simulated from it, nothing moves
    run = bd.simulate(rig, LAW, t_end=2.0, initial=state)
    assert np.ptp(run.theta_d) < 1e-9 * plant.half_gap and np.all(run.mode == -2)


@pytest.mark.parametrize("loop", list(LOOPS))
def test_the_reach_is_where_the_simulated_motion_leaves_the_flank(loop):
    rig = tuned("loaded_feedback", **LOOPS[loop])
    (rest,), _ = loop_rests(rig, rig.make_model(LAW))
    assert {d.kind for d in rest.reach} == {TWIST, MOTOR_SPEED}
    for reach in rest.reach:
        assert reach.value != 0.0
        inside = bd.simulate(rig, LAW, t_end=6.0, initial=rest.initial(reach.scaled(0.97)))
        outside = bd.simulate(rig, LAW, t_end=6.0, initial=rest.initial(reach.scaled(1.03)))
        assert np.all(inside.mode == -2), reach
        assert np.any(outside.mode == 0), reach
    # a released twist towards the gap leaves contact when the shaft torque reaches 0: T_l / k
    twist = rest.reach_of(TWIST)
    assert abs(twist.value) == pytest.approx(rig.load.torque / rig.plant.stiffness, rel=1e-6)


def test_without_load_the_loop_rests_anywhere_in_the_gap():
    rig = example_rig("motor_feedback")
    (rest,), _ = loop_rests(rig, rig.make_model(LAW))
    assert rest.side == 0 and rest.continuum and rest.theta_d == 0.0
    assert np.all(rest.state == 0.0)
    assert rest.stability.status == "marginal" and not rest.stable  # the free load: a pole at s = 0
    # a twist inside the gap is a rest itself; the motor kick that reaches the flank is the reach
    assert TWIST in rest.still and rest.reach_of(TWIST).value == pytest.approx(rig.plant.half_gap)
    kick = rest.reach_of(MOTOR_SPEED)
    inside = bd.simulate(rig, LAW, t_end=6.0, initial=rest.initial(kick.scaled(0.97)))
    outside = bd.simulate(rig, LAW, t_end=6.0, initial=rest.initial(kick.scaled(1.03)))
    assert np.all(inside.mode == 0) and np.any(outside.mode != 0)


def test_load_feedback_in_the_gap_lets_the_motor_coast_into_contact():
    # the controller sees the load, which the open gear leaves at rest: any motor kick drifts to a flank
    rig = example_rig("load_feedback")
    (rest,), _ = loop_rests(rig, rig.make_model(LAW))
    assert rest.reach_of(MOTOR_SPEED).value == 0.0
    kick = 0.05  # rad/s: the motor coasts at it, theta_d = kick t reaches alpha after 1 s
    run = bd.simulate(rig, LAW, t_end=2.0, initial=rest.initial(Disturbance(MOTOR_SPEED, kick)))
    assert np.any(run.mode != 0)
    first = np.argmax(run.mode != 0)  # the first contact
    assert np.allclose(run.theta_d[:first], kick * run.time[:first], rtol=1e-9, atol=1e-12)
    assert run.time[first] == pytest.approx(rig.plant.half_gap / kick, rel=1e-3)


def test_a_torque_limit_below_the_load_leaves_no_rest():
    rig = tuned("loaded_feedback", torque_limit=50.0)
    rests, note = loop_rests(rig, rig.make_model(LAW))
    assert rests == () and "50 N m" in note and "100 N m" in note
    verdict = bd.judge_loop(rig, bd.predict_limit_cycles(rig, LAW))
    assert verdict.verdict == "unstable" and "cannot hold the load" in verdict.reason
    # and indeed: the drive runs away, its speed growing without bound
    run = bd.simulate(rig, LAW, t_end=2.0)
    assert run.state("load_speed")[-1] > 1.9 * run.state("load_speed")[len(run.time) // 2] > 0.0


def test_rest_to_dict_names_its_units():
    rig = example_rig("loaded_feedback")
    (rest,), _ = loop_rests(rig, rig.make_model(LAW))
    data = rest.to_dict()
    assert data["where"] == "on the left flank" and data["stable"] is True
    assert {d["kind"]: d["unit"] for d in data["reach"]} == {"twist": "rad", "motor speed": "rad/s"}
    assert math.isclose(data["state"]["theta_d"], rest.theta_d)


def test_without_a_load_the_only_rest_is_the_gap_with_its_edges():
    # a corpus rig (bench_verdicts 'loaded' #10) whose round-off of 1e-19 N m once put "stable rests" on both flanks
    # at theta_d = +-alpha (the ends of the gap's continuum): the verdict read the loop as bistable, its every
    # disturbance that reaches contact hunts
    rig = bd.rig_from_dict({
        "plant": {"motor_inertia": 0.36592355071641774, "load_inertia": 2.6954891158217382,
                  "stiffness": 3514.9772667458333, "damping": 1.0, "half_gap": 0.07878621604874039},
        "controller": {"feedback": "load", "kp": 5.35119566230324, "ti": 0.17258957586472257,
                       "delay": 0.00025348830396057997},
        "model": {"backlash": LAW}})
    (rest,), note = loop_rests(rig, rig.make_model(LAW))
    assert note == "" and rest.continuum and rest.where == "in the gap" and rest.theta_d == 0.0
    assert rest.reach_of(TWIST).value == pytest.approx(rig.plant.half_gap, rel=1e-12)  # the continuum ends at the flank


def test_a_rest_whose_loop_grows_fast_has_no_reach_and_warns_nothing():
    # drives corpus rig #161, rounded: a high-gain, torque-limited speed loop whose gap mode grows at
    # about 337 1/s; over the flow's horizon its matrix powers overflow, which reads as "does not settle"
    rig = bd.rig_from_dict({
        "plant": {"motor_inertia": 0.74, "load_inertia": 3.16, "stiffness": 4029.0, "damping": 3.0,
                  "half_gap": 0.054},
        "controller": {"feedback": "motor", "kp": 4341.0, "ti": 0.645, "speed_filter": 0.002,
                       "torque_lag": 0.0019, "delay": 0.00043, "torque_limit": 488.4}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning reaches the user
        (rest,), _ = loop_rests(rig, rig.make_model(LAW))
    assert rest.stability.status == "unstable" and rest.stability.max_real > 300.0
    assert all(d.value == 0.0 for d in rest.reach)
