"""Prediction, generator and calibration checked against independent simulations and closed forms."""

import dataclasses
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from backlash_df import load_rig, rig_from_dict
from backlash_df.identify import (calibrate, fit_percent, get_effect, load_measurements, measurements_from_arrays,
                                  predict, replay, synthesize)
from backlash_df.identify.calibrate import Shooting, cluster_robust_stderr, parallel_jacobian
from backlash_df.identify.predictors import TwoMassModel, nominal_values, segment_bounds
from backlash_df.identify.signals import angle_rate, encoder_speeds, integrated_displacement, shaft_resolution
from backlash_df.identify.effects import smoothing_speeds
from backlash_df.identify.synthetic import Experiment

PLANT = {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 3.0, "half_gap": 0.02}
CONTROLLER = {"kp": 20.0, "ti": 0.3, "feedback": "motor", "speed_filter": 0.002}
QUIET = Experiment(noise=0.0)


def _rig(law="phase-plane"):
    return rig_from_dict({"plant": PLANT, "controller": CONTROLLER, "model": {"backlash": law}})


def _true_values(record):
    plant = record.true_plant
    values = {name: getattr(plant, name) for name in PLANT} | {"theta_d0": record.initial_state["theta_d0"]}
    for key, size in record.effects.items():
        values[get_effect(key).value_key] = size
    return values | {"rubber_thickness": plant.rubber_thickness}


@pytest.mark.parametrize("effects", [{}, {"coulomb_friction@motor": 5.0}, {"viscous_friction@load": 1.5,
                                     "coulomb_friction@load": 4.0}, {"torque_offset": -6.0},
                                     {"actuator_delay": 0.004}, {"rubber": 0.015}])
def test_free_run_reproduces_the_closed_loop_rig(effects):
    """The generator runs plant + PI loop at 1/5 of the sample step with the exact model (14);
    the prediction runs the open-loop plant from the recorded torque on the sample grid
    with the static law.  With the true values the two agree to the integration error,
    and the same run without the hidden effects is clearly worse."""
    record = synthesize(_rig(), effects, seed=3, duration=1.0, experiment=QUIET)
    law = "phase-plane"  # a positive rubber_thickness among the values selects the rubber law (40)
    values = _true_values(record)
    with_effects = replay(record.measurements, _rig(law), values)
    # 90 % with Coulomb friction: the fitted law is smoothed over 10 times the rig's speed
    # band, and over a 1 s free run its small torque difference piles up as speed; 95 %
    # otherwise (the rig's exact model (14) and dead time against the static law and the
    # interpolated torque)
    coulomb = any(key.startswith("coulomb") for key in effects)
    assert min(with_effects.fit_percent().values()) > (90.0 if coulomb else 95.0)
    if effects:
        without = replay(record.measurements, _rig(law), values | {get_effect(key).value_key: 0.0 for key in effects})
        assert np.linalg.norm(without.residual) > 3.0 * np.linalg.norm(with_effects.residual)


def test_k_step_calibration_recovers_its_own_model():
    """Data made by the model itself (free run, no noise) along a synthetic rig's trajectory,
    values up to 8 % off the data sheet, two effects: the k-step fit returns the truth."""
    rig = _rig()
    record = synthesize(rig, {"coulomb_friction@load": 4.0, "viscous_friction@motor": 0.8}, seed=4, duration=1.5,
                        experiment=QUIET, datasheet_error=0.08)
    truth = _true_values(record)
    simulated = replay(record.measurements, rig, truth).simulated
    data = dataclasses.replace(record.measurements, motor_speed=simulated[:, 0], load_speed=simulated[:, 1])
    fit = calibrate(data, rig, ("coulomb_friction@load", "viscous_friction@motor"), window=(0, 900), polish=False)
    for name in list(PLANT) + ["coulomb_friction_load", "viscous_friction_motor"]:
        # damping, the least visible value, to 5 %
        assert fit.parameters[name].value == pytest.approx(truth[name], rel=0.05 if name == "damping" else 0.01), name
    assert 0.0 < fit.parameters["coulomb_friction_load"].stderr < 0.01 * 4.0  # noise-free: a narrow interval
    assert "coulomb_friction_load" in fit.fit_report()
    # k-step prediction of the fitted model: as good as the data allow
    assert min(predict(data, rig, fit.values, window=(900, data.n_samples)).fit_percent().values()) > 99.0


def test_shooting_jacobian_equals_column_by_column_differences():
    """The Jacobian of the segments' speed corrections, computed one evaluation per speed for all
    segments, equals the forward differences taken one correction at a time (a correction moves
    its own segment only); the prior's rows are the identity times their weight."""
    rig = _rig()
    record = synthesize(rig, {"torque_offset": 3.0}, seed=4, duration=0.6, encoder_counts=2**20)
    model = TwoMassModel(record.measurements, rig)
    starts, stops = segment_bounds(30, 530, 100)
    measured = record.measurements.speeds[30:530]
    shooting = Shooting(record.measurements, starts, stops, residual_rms=0.3)
    values = nominal_values(rig) | _true_values(record)

    def residual(x):  # x: the offset (N m), then the corrections
        states, _ = model.run(values | {"torque_offset": x[0]}, starts, stops, shooting.corrections(x[1:]))
        data = (measured - model.speeds_of(states[30:530])).ravel(order="F")
        return np.concatenate([data, shooting.penalty(x[1:])])

    x = np.concatenate([[2.5], np.random.default_rng(1).normal(size=shooting.size)])
    with ThreadPoolExecutor(2) as pool:
        jacobian = parallel_jacobian(residual, 1, shooting, np.full(x.size, np.inf), executor=pool)(x).toarray()
    f0 = residual(x)
    for i in range(x.size):
        step = 1e-6 * max(1.0, abs(x[i]))
        shifted = x.copy()
        shifted[i] += step
        np.testing.assert_allclose(jacobian[:, i], (residual(shifted) - f0) / step, rtol=1e-6, atol=1e-9)
    prior = jacobian[measured.size:, 1:]
    assert np.count_nonzero(prior) == shooting.size and np.allclose(np.diag(prior), 0.3)
    assert not np.any(jacobian[measured.size:, 0])


@pytest.mark.parametrize("seed", [1, 2])
def test_multiple_shooting_does_not_bias_an_offset_on_noisy_speeds(seed):
    """Segments started from the noisy data's state bias a k-step fit (errors in the variables:
    5.0 N m came out 4.84 N m, its interval 4.74..4.95 excluding the truth, on speeds with
    0.05 rad/s of noise); with the segments' speeds corrected the interval holds the truth."""
    rig = _rig()
    record = synthesize(rig, {"torque_offset": 5.0}, seed=seed, duration=2.0, encoder_counts=2**20,
                        experiment=Experiment(noise=0.05))
    n = record.measurements.n_samples
    fit = calibrate(record.measurements, rig, ("torque_offset",), window=(int(0.05 * n), n), polish=False)
    offset = fit.parameters["torque_offset"]
    low, high = offset.ci95
    assert low <= 5.0 <= high
    assert offset.value == pytest.approx(5.0, rel=0.03)
    assert fit.shooting_segments == fit.n_clusters and "multiple shooting" in fit.fit_report()
    speeds_only = dataclasses.replace(record.measurements, motor_angle=None, load_angle=None)
    no_angles = calibrate(speeds_only, rig, (), window=(0, 300), polish=False)
    assert no_angles.shooting_segments == no_angles.n_clusters and "twist_drift" in no_angles.values
    assert "twist_drift" not in fit.values  # a measured twist does not drift


@pytest.mark.parametrize("seed", [2000, 2001])
def test_integrated_twist_drift_is_fitted(seed):
    """Without angle columns the twist is the integral of the noisy relative speed: a random walk
    (seed 2001: 1.07 mrad RMS off the encoders' twist over the estimation part, after the offset).
    The fitted drift brings it to the encoders' twist of the same record (2^20 counts) to within one
    step of the random walk over a segment (0.28 mrad)."""
    rig = _rig()
    record = synthesize(rig, "viscous_friction@load", seed=seed, duration=4.0, encoder_counts=2**20)
    speeds_only = dataclasses.replace(record.measurements, motor_angle=None, load_angle=None)
    n = speeds_only.n_samples
    window = slice(int(0.05 * n), int(0.6 * n))
    fit = calibrate(speeds_only, rig, (), window=(window.start, window.stop), polish=False)
    integrated = integrated_displacement(speeds_only) + fit.values["theta_d0"]
    corrected = integrated + np.interp(np.arange(n), *fit.values["twist_drift"])

    def error(twist):
        gap = (twist - record.measurements.twist)[window]
        return float(np.sqrt(np.mean((gap - gap.mean()) ** 2)))

    assert error(corrected) < 2.8e-4
    assert error(corrected) < error(integrated)


def test_rigid_body_prediction_against_closed_form_and_solve_ivp():
    """The rigid-body model J dw/dt = T_m + T_0 - F(w): under a torque ramp a t with viscous friction
    alone, w(t) = (a/d)(t - J/d) + (w_0 + a J/d^2) exp(-d t/J); with the catalogue's Coulomb and
    breakaway friction, a sine torque and an offset, solve_ivp (DOP853, rtol 1e-11) of the same law."""
    from scipy.integrate import solve_ivp

    rig = _rig()
    inertia, damping, slope, w0 = 6.0, 1.5, 4.0, 0.3
    t = np.arange(2001) * 1e-3
    exact = slope / damping * (t - inertia / damping) + (w0 + slope * inertia / damping**2) * np.exp(
        -damping * t / inertia)
    ramp = measurements_from_arrays(time=t, motor_torque=slope * t, motor_speed=exact, load_speed=exact)
    values = nominal_values(rig) | {"inertia": inertia, "viscous_friction_load": damping}
    free = predict(ramp, rig, values, horizon=None, structure="rigid_body")
    np.testing.assert_allclose(free.simulated[:, 0], exact, atol=1e-7)

    torque = 20.0 * np.sin(2 * np.pi * 0.7 * t) + 3.0 * np.sin(2 * np.pi * 5.3 * t)
    rough = measurements_from_arrays(time=t, motor_torque=torque, motor_speed=np.sin(2 * np.pi * 0.7 * t),
                                     load_speed=np.sin(2 * np.pi * 0.7 * t))
    eps, w_s = smoothing_speeds(rough)
    coulomb, breakaway, offset = 1.2, 2.0, 0.4
    values = nominal_values(rig) | {"inertia": inertia, "coulomb_friction_motor": coulomb, "viscous_friction_load": 0.3,
                                    "breakaway_friction_load": breakaway, "torque_offset": offset}

    def rate(time, w):
        friction = 0.3 * w + (coulomb + breakaway * np.exp(-(w / w_s) ** 2)) * np.tanh(w / eps)
        return (np.interp(time, t, torque) + offset - friction) / inertia

    model = predict(rough, rig, values, horizon=None, structure="rigid_body")
    start = model.simulated[0, 0]
    reference = solve_ivp(rate, (0.0, t[-1]), [start], t_eval=t, method="DOP853", rtol=1e-11, atol=1e-13,
                          max_step=1e-3)
    np.testing.assert_allclose(model.simulated[:, 0], reference.y[0], atol=2e-6)
    np.testing.assert_array_equal(model.simulated[:, 0], model.simulated[:, 1])  # one body, one speed

    # the speeds a diagnosis chooses, given as values: a sharper smoothing and a narrower Stribeck bump
    eps, w_s = 0.2 * eps, 0.5 * w_s
    chosen = predict(rough, rig, values | {"coulomb_smoothing": eps, "stribeck_speed": w_s}, horizon=None,
                     structure="rigid_body")
    reference = solve_ivp(rate, (0.0, t[-1]), [chosen.simulated[0, 0]], t_eval=t, method="DOP853", rtol=1e-11,
                          atol=1e-13, max_step=1e-3)
    np.testing.assert_allclose(chosen.simulated[:, 0], reference.y[0], atol=2e-6)
    assert np.max(np.abs(chosen.simulated[:, 0] - model.simulated[:, 0])) > 1e-3


KUKA = Path(__file__).resolve().parent.parent / "examples" / "kuka"


def _kuka_speeds_only():
    rig = load_rig(KUKA / "kuka_rig.toml")
    record = load_measurements(KUKA / "kuka_axis1.csv", gear_ratio=rig.plant.gear_ratio)
    return rig, dataclasses.replace(record, motor_angle=None, load_angle=None)


def test_shaft_resolution_of_a_stiff_gear_and_a_lab_rig():
    """The KUKA gear's mode (sqrt(k (1/J_m + 1/J_l)), 112 rad/s = 17.8 Hz) lies above the band in which
    its motor speed stands above the noise (the speeds move below about 2 Hz); a shaft 100 times softer
    (1.78 Hz) lies inside it.  The synthetic rig's multisine reaches 29.3 Hz on the motor, so its band
    holds that line, and its 20 Hz mode."""
    rig, record = _kuka_speeds_only()
    kuka = shaft_resolution(record, rig)
    assert kuka.mode_frequency == pytest.approx(np.sqrt(4.58e6 * (1 / 609 + 1 / 921)) / (2 * np.pi))
    assert 2.0 < kuka.resolved_frequency < kuka.mode_frequency and not kuka.resolved
    soft = dataclasses.replace(rig, plant=dataclasses.replace(rig.plant, stiffness=rig.plant.stiffness / 100))
    assert shaft_resolution(record, soft).resolved
    lab = shaft_resolution(synthesize(_rig(), "none", seed=3, duration=2.0).measurements, _rig())
    assert lab.resolved and lab.resolved_frequency >= 29.0


def _sine_record(skew=0.0, counts=2**20, noise=0.02, fast=0.02):
    """4 s at 1 kHz of the motion theta(t) = sin(2 pi 3 t) + fast sin(2 pi 17 t) rad on both sides: speed
    columns of the closed-form derivative plus white noise, angle columns read by encoders of ``counts``
    per revolution, the load encoder ``skew`` seconds late."""
    time = np.arange(4001) * 1e-3
    angle = lambda t: np.sin(6 * np.pi * t) + fast * np.sin(34 * np.pi * t)  # noqa: E731
    speed = 6 * np.pi * np.cos(6 * np.pi * time) + fast * 34 * np.pi * np.cos(34 * np.pi * time)
    step, rng = 2 * np.pi / counts, np.random.default_rng(0)
    record = measurements_from_arrays(
        time=time, motor_torque=np.sin(5 * time), motor_speed=speed + rng.normal(0, noise, time.size),
        load_speed=speed + rng.normal(0, noise, time.size), motor_angle=np.floor(angle(time) / step) * step,
        load_angle=np.floor(angle(time - skew) / step) * step)
    return record, speed


def test_encoder_speeds_replace_noisy_columns_by_the_closed_form_derivative():
    """A 2^20-count encoder at 1 kHz measures the speed to about 2e-3 rad/s; beside speed columns with
    0.02 rad/s of noise both columns are replaced, and the replacement is the closed-form derivative to
    the encoder's resolution.  The rest of the record is the same, and its notes say what was replaced."""
    record, speed = _sine_record()
    finer = encoder_speeds(record)
    for name in ("motor_speed", "load_speed"):
        error = getattr(finer, name) - speed
        assert np.sqrt(np.mean(error**2)) < 2.5e-3 and np.abs(error).max() < 0.01
        assert np.sqrt(np.mean((getattr(record, name) - speed) ** 2)) > 0.018  # the column's noise
    assert np.array_equal(finer.motor_torque, record.motor_torque) and np.array_equal(finer.twist, record.twist)
    assert [note.split(" taken from ")[0] for note in finer.notes] == ["motor_speed", "load_speed"]
    assert "against 0.02 rad/s in the load_speed column" in finer.notes[1]


def test_encoder_speeds_keep_columns_an_encoder_does_not_beat():
    """No replacement where the encoder is not four times finer (2^12 counts: 0.4 rad/s), where the column
    is as fine (noise 1e-4 rad/s), where the motion's own content above the smoothing outweighs the noise
    (a 17 Hz line of 21 rad/s: nothing tells noise from motion there), or, on the load side only, where the
    load encoder reads 1 ms late: its speed then differs from the column by 1 ms times the acceleration,
    not by the noises alone.  On the KUKA record the motor encoder is twice as fine as its column and the
    link encoder coarser: both columns kept."""
    for record in (_sine_record(counts=2**12)[0], _sine_record(noise=1e-4)[0], _sine_record(fast=0.2)[0]):
        assert encoder_speeds(record) is record
    late = encoder_speeds(_sine_record(skew=1e-3)[0])
    assert [note.split(" taken from ")[0] for note in late.notes] == ["motor_speed"]
    rig = load_rig(KUKA / "kuka_rig.toml")
    kuka = load_measurements(KUKA / "kuka_axis1.csv", gear_ratio=rig.plant.gear_ratio)
    assert encoder_speeds(kuka) is kuka


def test_generator_encoders_integrate_the_simulated_speed():
    """Encoders of 2^52 counts (no quantisation) on a noise-free record: the five-point speed of the angle
    columns is the simulated speed to 1e-5 rad/s RMS on the load side, 1e-4 on the motor side (whose angle
    adds the twist, sampled).  The generator integrates the load angle at the simulation's step; at the
    record's, the load's differed by 1e-4 rad/s RMS, and the diagnosis' clean speeds named rubber 0.2 %
    wide of the truth."""
    record = synthesize(_rig(), {"viscous_friction@load": 1.0}, seed=3, duration=2.0, encoder_counts=2**52,
                        experiment=QUIET).measurements
    for name, angle, bound in (("load_speed", "load_angle", 1e-5), ("motor_speed", "motor_angle", 1e-4)):
        error = (getattr(record, name) - angle_rate(getattr(record, angle), record.dt))[2:-2]
        assert np.sqrt(np.mean(error**2)) < bound


def test_quasi_static_starts_tend_to_the_rigid_body_as_the_shaft_stiffens():
    """Without angle columns on a shaft the record does not resolve, every segment starts on the rigid
    body's state; the two-mass k-step prediction then differs from the rigid body's only by the shaft's
    own motion, which shrinks as the shaft stiffens (0.3 k to 10 k, the damping c scaled along so that the
    shaft's c / k stays; the contained rigid body is the limit)."""
    rig, record = _kuka_speeds_only()
    values = nominal_values(rig) | {"coulomb_friction_load": 450.0, "viscous_friction_load": 1700.0}
    rigid = predict(record, rig, values, structure="rigid_body").simulated
    gaps = []
    for factor in (0.3, 1.0, 3.0, 10.0):
        plant = dataclasses.replace(rig.plant, stiffness=factor * rig.plant.stiffness,
                                    damping=factor * rig.plant.damping)
        assert TwoMassModel(record, dataclasses.replace(rig, plant=plant)).quasi_static
        two_mass = predict(record, dataclasses.replace(rig, plant=plant),
                           values | {"stiffness": plant.stiffness, "damping": plant.damping}).simulated
        gaps.append(float(np.sqrt(np.mean((two_mass - rigid) ** 2))))
    assert gaps[1] < 0.2 * float(np.sqrt(np.mean((record.speeds - rigid) ** 2)))  # the rig file's shaft
    assert gaps[3] < gaps[2] < gaps[1] < gaps[0]


def test_cluster_robust_standard_error_of_a_mean():
    """For the mean (J = ones) the sandwich is sqrt(G/(G-1) sum_g (sum_i r_gi)^2) / N: residuals
    equal inside a cluster give sqrt(m) times the i.i.d. standard error."""
    rng = np.random.default_rng(0)
    groups, size = 40, 25
    residual = np.repeat(rng.normal(size=groups), size)
    clusters = np.repeat(np.arange(groups), size)
    stderr, quantile = cluster_robust_stderr(np.ones((residual.size, 1)), residual, clusters, np.ones(1))
    sums = residual.reshape(groups, size).sum(axis=1)
    assert stderr[0] == pytest.approx(np.sqrt(groups / (groups - 1) * np.sum(sums**2)) / residual.size)
    assert quantile == pytest.approx(2.0227, abs=1e-3)  # Student t, 39 dof


def test_fit_percent_closed_forms():
    y = np.sin(np.linspace(0.0, 6.0, 300)) + 0.3
    assert fit_percent(y, y) == pytest.approx(100.0)
    assert fit_percent(y, np.full_like(y, y.mean())) == pytest.approx(0.0)
    # y_hat = y + c (y - mean): ||y - y_hat|| = |c| ||y - mean||, so fit = 100 (1 - |c|)
    assert fit_percent(y, y + 0.25 * (y - y.mean())) == pytest.approx(75.0)


def test_generator_is_reproducible_and_hides_the_given_sizes():
    rig = _rig()
    a = synthesize(rig, ["viscous_friction@motor", "torque_offset"], seed=9, duration=0.5)
    b = synthesize(rig, ["viscous_friction@motor", "torque_offset"], seed=9, duration=0.5)
    np.testing.assert_array_equal(a.measurements.motor_speed, b.measurements.motor_speed)
    assert set(a.effects) == {"viscous_friction@motor", "torque_offset"} and a.effects["viscous_friction@motor"] > 0
    for name in PLANT:  # data-sheet errors within +-4 %
        assert abs(getattr(a.true_plant, name) / PLANT[name] - 1.0) <= 0.04
    quiet = synthesize(rig, "none", seed=2, duration=1.0, experiment=Experiment(noise=0.0))
    noisy = synthesize(rig, "none", seed=2, duration=1.0, experiment=Experiment(noise=0.02))
    difference = noisy.measurements.load_speed - quiet.measurements.load_speed
    assert np.std(difference) == pytest.approx(0.02, rel=0.25)
    with pytest.raises(ValueError, match="one side at a time"):
        synthesize(rig, ["coulomb_friction@load", "breakaway_friction@motor"], seed=1, duration=0.5)
    with pytest.raises(ValueError, match="encoder_counts = 0: give the encoder's counts per revolution"):
        synthesize(rig, "none", seed=1, duration=0.5, encoder_counts=0)  # was a ZeroDivisionError
    limited = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, torque_limit=50.0))
    with pytest.raises(ValueError, match="runs a PI speed loop; the rig's torque_limit is not modelled"):
        synthesize(limited, "none", seed=1, duration=0.5)  # was simulated without its limit
    stiction = synthesize(rig, {"coulomb_friction@load": 3.0, "breakaway_friction@load": 6.0}, seed=1, duration=0.5)
    assert stiction.effects == {"coulomb_friction@load": 3.0, "breakaway_friction@load": 6.0}
