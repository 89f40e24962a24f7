"""Replay, generator and calibration checked against independent simulations."""

import dataclasses

import numpy as np
import pytest

from backlash_df import rig_from_dict
from backlash_df.identify import calibrate, fit_percent, replay, synthesize
from backlash_df.identify.synthetic import Experiment

PLANT = {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 3.0, "half_gap": 0.02}
CONTROLLER = {"kp": 20.0, "ti": 0.3, "feedback": "motor", "speed_filter": 0.002}


def _rig(law="phase-plane"):
    return rig_from_dict({"plant": PLANT, "controller": CONTROLLER, "model": {"backlash": law}})


QUIET = Experiment(noise=0.0)


def _true_values(record):
    plant = record.true_plant
    return {name: getattr(plant, name) for name in PLANT}


@pytest.mark.parametrize(
    ("cause", "size", "law"),
    [("none", 0.0, "exact"), ("coulomb_friction", 5.0, "exact"), ("viscous_friction", 1.5, "exact"),
     ("actuator_delay", 0.004, "exact"), ("rubber", 0.015, "rubber")],
)
def test_open_loop_replay_reproduces_closed_loop_rig(cause, size, law):
    """The generator runs plant + PI loop at 1/5 of the sample step; the replay runs
    the open-loop plant from the recorded commanded torque on the sample grid.
    With the true values and the true law the two must agree (different state
    spaces, steps and interpolation: agreement to the integration error)."""
    record = synthesize(_rig(), cause, size=size, seed=3, duration=1.0, experiment=QUIET)
    m = record.measurements
    values = _true_values(record)
    parameter = {"none": None, "rubber": "rubber_thickness"}.get(cause, cause)
    if parameter:
        values[parameter] = size
    values |= record.initial_state
    with_effect = replay(m, _rig(law), values)
    # 97 %: the fitted Coulomb law is 10 times smoother than the rig's, and the rig's
    # torque reacts within a sample to events that the replay sees interpolated
    assert min(with_effect.fit_percent().values()) > 97.0
    if parameter:  # the same replay without the hidden effect is clearly worse
        without = replay(m, _rig(law), values | {parameter: 0.0})
        worse = np.linalg.norm(without.residual) / np.linalg.norm(with_effect.residual)
        assert worse > 3.0


def test_calibration_recovers_parameters_of_its_own_model():
    """Data made by the replay model itself (no noise), along the trajectory of a
    synthetic rig whose values are up to 8 % off the data sheet: calibration
    from the data sheet must return the true values."""
    rig = _rig()
    record = synthesize(rig, "coulomb_friction", size=4.0, seed=4, duration=1.5, experiment=QUIET,
                        datasheet_error=0.08)
    truth = _true_values(record) | {"coulomb_friction": 4.0}
    measured = record.measurements
    simulated = replay(measured, rig, truth | record.initial_state).simulated
    data = dataclasses.replace(measured, motor_speed=simulated[:, 0], load_speed=simulated[:, 1])
    fit = calibrate(data, rig, "coulomb_friction", window=(0, int(0.6 * data.n_samples)))
    for name, value in truth.items():
        assert fit.parameters[name].value == pytest.approx(value, rel=0.01), name
    assert "coulomb_friction" in fit.fit_report()


def test_fit_percent_closed_forms():
    y = np.sin(np.linspace(0.0, 6.0, 300)) + 0.3
    assert fit_percent(y, y) == pytest.approx(100.0)
    assert fit_percent(y, np.full_like(y, y.mean())) == pytest.approx(0.0)
    # y_hat = y + c (y - mean): ||y - y_hat|| = |c| ||y - mean||, so fit = 100 (1 - |c|)
    assert fit_percent(y, y + 0.25 * (y - y.mean())) == pytest.approx(75.0)


def test_generator_is_reproducible_and_hides_the_given_size():
    rig = _rig()
    a = synthesize(rig, "viscous_friction", seed=9, duration=0.5)
    b = synthesize(rig, "viscous_friction", seed=9, duration=0.5)
    np.testing.assert_array_equal(a.measurements.motor_speed, b.measurements.motor_speed)
    assert 0.0 < a.size
    for name in PLANT:  # data-sheet errors within +-4 %
        assert abs(getattr(a.true_plant, name) / PLANT[name] - 1.0) <= 0.04
    # noise: the record minus the noise-free record of the same seed has the stated std
    quiet = synthesize(rig, "none", seed=2, duration=1.0, experiment=Experiment(noise=0.0))
    noisy = synthesize(rig, "none", seed=2, duration=1.0, experiment=Experiment(noise=0.02))
    difference = noisy.measurements.load_speed - quiet.measurements.load_speed
    assert np.std(difference) == pytest.approx(0.02, rel=0.25)
