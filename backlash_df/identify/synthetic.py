"""Measurement files from a simulated rig that is NOT the model being fitted.

The rig is a speed-controlled two-mass drive with backlash, simulated at a finer
step than the record's (``oversample`` sub-steps a sample):

* the shaft follows the exact model (1), (14) with its own limited integrator
  for theta_b (the rubber law (40) when the hidden effect is ``rubber``);
* a PI speed controller (rig file ``[controller]``: kp, ti, feedback) on the
  measured speed through a first-order filter, noise included;
* the reference is a slow sine (the speed reverses, so friction changes sign),
  an injected multisine test torque on the motor and a known smoothed square
  load torque make the shaft torque reverse: both contact sides are crossed;
* the true plant is the rig file's with data-sheet errors: each of inertias,
  stiffness, damping and half gap off by a uniform random amount within
  ``+-datasheet_error``;
* white sensor noise on both speeds; the recorded ``motor_torque`` is the
  commanded torque (controller output plus test signal), exact;
* hidden effects (none, one or several), of random size unless given:
  Coulomb friction on either side (smoothed 10 times more sharply than the
  fitted model's; one side at a time), breakaway (Stribeck) friction on top
  of it or alone (on the same side; Stribeck speed 5 % of the reference's
  amplitude, where the fitted model takes 5 % of the record's largest speed),
  viscous friction on either side, a constant torque offset added to the
  applied torque (not to the recorded one), an actuator dead time, rubber in
  the coupling.

The simulation is the compiled kernel of :mod:`backlash_df.simulation` with the
controller states in the linear part.
"""

import dataclasses
import math

import numpy as np

from ..config import Plant
from ..models import make_model
from ..simulation import simulate_linear
from ..system import LinearPart
from .effects import COULOMB_SMOOTHING, STRIBECK_SPEED, get_effect
from .measurements import measurements_from_arrays

__all__ = ["Experiment", "SyntheticRecord", "synthesize"]


@dataclasses.dataclass(frozen=True)
class Experiment:
    """The excitation of a synthetic record (SI units).

    Attributes
    ----------
    speed_amplitude : float
        Amplitude of the sine speed reference, rad/s.
    speed_frequency : float
        Its frequency, Hz.
    test_amplitude : float
        Amplitude of each sine of the injected multisine test torque, N m.
    test_frequencies : tuple of float
        Frequencies of the multisine, Hz (random phases).
    load_torque : float
        Amplitude of the smoothed square load torque, N m.
    load_period : float
        Its period, s.
    noise : float
        Standard deviation of the white speed-sensor noise, rad/s.
    warmup : float
        Simulated time before the record starts, s (the record starts mid-motion).
    """

    speed_amplitude: float = 3.0
    speed_frequency: float = 0.5
    test_amplitude: float = 6.0
    test_frequencies: tuple = (1.7, 3.1, 5.3, 8.9, 13.7, 21.1, 29.3)
    load_torque: float = 60.0
    load_period: float = 0.45
    noise: float = 0.02
    warmup: float = 0.3


@dataclasses.dataclass(frozen=True)
class SyntheticRecord:
    """A synthetic measurement record with the truth behind it.

    Attributes
    ----------
    measurements : Measurements
        What a measurement file would hold.
    effects : dict
        The hidden effects: catalogue key -> size in the effect's unit (empty: none).
    true_plant : Plant
        The plant actually simulated (data-sheet errors applied).
    seed : int
    initial_state : dict
        The rig's state at the first sample: ``theta_d0`` (rad), ``motor_speed0``,
        ``load_speed0`` (rad/s, noise-free) and the exact model's ``theta_b0`` (rad).
    """

    measurements: object
    effects: dict
    true_plant: Plant
    seed: int
    initial_state: dict

    @property
    def cause(self):
        """The first hidden effect's key (``none`` without one)."""
        return next(iter(self.effects), "none")

    @property
    def size(self):
        """The first hidden effect's size (0 without one)."""
        return next(iter(self.effects.values()), 0.0)


def random_effect_size(cause, rig, rng, experiment=Experiment()):
    """A random size of effect ``cause`` (catalogue key) inside the range the generator draws from.

    ``rubber``: beta in [0.5, 1.2] alpha.  ``coulomb_friction`` (either side):
    [4, 12] N m per 100 kg m^2/s^2 of reference torque ``J_tot w_ref 2 pi f_ref``,
    i.e. a few per cent of the torque moving the load; ``breakaway_friction``
    twice that (it acts only near zero speed).  ``viscous_friction``: the
    same torque at the reference's peak speed.  ``torque_offset``: the same range,
    either sign.  ``actuator_delay``: [1.5, 6] ms.
    """
    plant = rig.plant
    torque = (plant.motor_inertia + plant.load_inertia) * experiment.speed_amplitude * 2 * np.pi * experiment.speed_frequency
    name = get_effect(cause).name
    if name == "rubber":
        return float(rng.uniform(0.5, 1.2) * plant.half_gap)
    if name == "coulomb_friction":
        return float(rng.uniform(0.04, 0.12) * torque)
    if name == "breakaway_friction":
        return float(rng.uniform(0.08, 0.24) * torque)
    if name == "viscous_friction":
        return float(rng.uniform(0.04, 0.12) * torque / experiment.speed_amplitude)
    if name == "torque_offset":
        return float(rng.choice([-1.0, 1.0]) * rng.uniform(0.04, 0.12) * torque)
    if name == "actuator_delay":
        return float(rng.uniform(1.5e-3, 6e-3))
    raise ValueError(f"synthesize: the generator cannot hide {cause!r}")


def _perturbed_plant(plant, rng, error):
    changes = {name: getattr(plant, name) * (1.0 + rng.uniform(-error, error))
               for name in ("motor_inertia", "load_inertia", "stiffness", "damping", "half_gap")}
    return dataclasses.replace(plant, **changes)


def _signals(experiment, phases, time):
    """Reference (rad/s), test torque and load torque (N m) at ``time`` (s from the simulation start)."""
    reference = experiment.speed_amplitude * np.sin(2 * np.pi * experiment.speed_frequency * time)
    test = sum(experiment.test_amplitude * np.sin(2 * np.pi * f * time + p)
               for f, p in zip(experiment.test_frequencies, phases))
    square = np.tanh(8.0 * np.sin(2 * np.pi * time / experiment.load_period))
    return reference, test, experiment.load_torque * square


def _closed_loop(plant, controller, effects, friction_speed, stribeck_speed):
    """Linear part of plant + PI loop: states theta_d, w_m, w_l, filtered speed, integral.

    Inputs: reference now, reference and test torque as applied (delayed by the
    dead time), load torque, sensor noise of the fed-back speed.
    """
    jm, jl = plant.motor_inertia, plant.load_inertia
    kp, ki = controller.kp, controller.kp / controller.ti
    tf = max(controller.speed_filter, 1e-3)
    fb = 1 if controller.feedback == "motor" else 2
    rows = {"motor": 1, "load": 2}
    inertias = {"motor": jm, "load": jl}
    a = np.zeros((5, 5))
    a[0, 1], a[0, 2] = 1.0, -1.0
    a[3, fb], a[3, 3] = 1.0 / tf, -1.0 / tf
    a[4, 3] = -1.0
    friction = {"level": 0.0, "breakaway": 0.0, "row": np.zeros(5), "column": np.zeros(5)}
    for key, size in effects.items():
        effect = get_effect(key)
        if effect.name == "viscous_friction":
            a[rows[effect.side], rows[effect.side]] -= size / inertias[effect.side]
        if effect.name in ("coulomb_friction", "breakaway_friction"):
            friction["level" if effect.name == "coulomb_friction" else "breakaway"] = size
            friction["row"][rows[effect.side]] = 1.0
            friction["column"][rows[effect.side]] = 1.0 / inertias[effect.side]
    controller_row = np.array([0.0, 0.0, 0.0, -kp, ki])  # u = kp (r - w_f) + ki xi, state part
    motor_column = np.array([0.0, 1.0 / jm, 0.0, 0.0, 0.0])
    delay = effects.get("actuator_delay", 0.0)
    if delay == 0.0:
        a += np.outer(motor_column, controller_row)
    e = np.zeros((5, 5))
    e[4, 0] = 1.0  # integral of r - w_f
    e[1, 1] = kp / jm  # kp r(t - delay)
    e[1, 2] = 1.0 / jm  # test(t - delay) + torque offset
    e[2, 3] = 1.0 / jl  # load torque
    e[3, 4] = 1.0 / tf  # sensor noise of the fed-back speed
    system = LinearPart(
        A=a, b=np.array([0.0, -1.0 / jm, 1.0 / jl, 0.0, 0.0]), E=e,
        c_x=np.array([1.0, 0.0, 0.0, 0.0, 0.0]), c_v=np.array([0.0, 1.0, -1.0, 0.0, 0.0]),
        state_names=("theta_d", "motor_speed", "load_speed", "filtered_speed", "speed_error_integral"),
        input_names=("reference", "reference_applied", "test_applied", "load_torque", "noise"),
        delay=delay, d=controller_row if delay else None, e_d=motor_column if delay else None,
        friction=friction["level"], friction_speed=friction_speed, f=friction["row"], e_f=friction["column"],
        breakaway=friction["breakaway"], breakaway_speed=stribeck_speed,
    )
    return system, (kp, ki, fb)


def _hidden_effects(cause, size, rig, rng, experiment):
    """The effects to hide as key -> size: from a key (``none``), a sequence of keys or a mapping."""
    if isinstance(cause, str):
        cause = {} if cause == "none" else {cause: size}
    elif not isinstance(cause, dict):
        cause = dict.fromkeys(cause)
    effects = {}
    for key, value in cause.items():
        effect = get_effect(key)
        effects[effect.key] = random_effect_size(effect.key, rig, rng, experiment) if value is None else float(value)
    sides = {get_effect(key).side for key in effects if key.startswith(("coulomb_friction", "breakaway_friction"))}
    if len(sides) > 1:
        raise ValueError("synthesize: Coulomb and breakaway friction on one side at a time")
    return effects


def _encoder_angles(states, dt, oversample, counts, rng, skew=0.0):
    """``motor_angle`` and ``load_angle`` (rad) at every ``oversample``-th row of the simulation's ``states``
    (step ``dt``), read by encoders of ``counts`` per revolution (none: {}), the load encoder ``skew`` seconds
    late (its angle interpolated linearly between steps).  The load angle is the trapezoid integral of the load
    speed at the simulation's step: at the record's, its error ``-(w dt)^2 / 12`` biased an encoder's speed (a
    gain 0.13 % low at the 20 Hz shaft mode)."""
    if counts is None:
        return {}
    from scipy.integrate import cumulative_trapezoid  # lazy: keeps `import backlash_df` quick

    load = cumulative_trapezoid(states[:, 2], dx=dt, initial=0.0)
    time = np.arange(load.size) * dt
    late = np.interp(time[::oversample] - skew, time, load)
    load, twist = load[::oversample], states[::oversample, 0]
    step = 2.0 * np.pi / counts
    zeros = rng.uniform(0.0, 2.0 * np.pi, 2)
    return {"motor_angle": np.floor((zeros[0] + load + twist) / step) * step,
            "load_angle": np.floor((zeros[1] + late) / step) * step}


def synthesize(rig, cause="none", size=None, seed=0, duration=2.0, sample_rate=1000.0, oversample=5,
               experiment=Experiment(), datasheet_error=0.04, encoder_counts=None, encoder_skew=0.0):
    """Simulate a measurement record of ``rig`` with hidden effects.

    Parameters
    ----------
    rig : Rig
        Data-sheet plant and PI controller (``[controller]`` required).
    cause : str, sequence of str or dict
        Hidden effects: a catalogue key (``none`` for no effect; a friction name
        alone is its load side), several keys, or a mapping key -> size (None:
        random).
    size : float, optional
        The size of a single ``cause`` (rad, N m, N m s/rad or s); random if
        omitted (:func:`random_effect_size`).
    seed : int
        Seed of every random draw (data-sheet errors, sizes, phases, noise).
    duration, sample_rate : float
        Length of the record (s) and its sampling rate (Hz).
    oversample : int
        Simulation sub-steps per sample (the rig runs at a finer step than the fit).
    experiment : Experiment
        Excitation and noise.
    datasheet_error : float
        Relative range of the data-sheet errors (0.04: each value within +-4 %).
    encoder_counts : int, optional
        With a count per revolution (at least 1; None: no angle columns), the record carries encoder angles
        ``motor_angle`` and ``load_angle`` (rad): the true angles rounded down to
        the encoder's step ``2 pi / encoder_counts``, each from its own random zero.
    encoder_skew : float
        How much later (s) the load encoder is read than the motor encoder: its
        angle is the load's angle ``encoder_skew`` earlier (as the link encoder of
        the KUKA record, about 3 ms).

    Returns
    -------
    SyntheticRecord

    Examples
    --------
    >>> from backlash_df import rig_from_dict
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.02}, "controller": {"kp": 20.0, "ti": 0.3, "feedback": "motor"}})
    >>> record = synthesize(rig, {"coulomb_friction@load": 5.0, "viscous_friction@load": 1.0}, seed=1, duration=0.5)
    >>> record.measurements.n_samples, record.cause, record.effects["viscous_friction@load"]
    (501, 'coulomb_friction@load', 1.0)
    """
    if encoder_counts is not None and not encoder_counts >= 1:
        raise ValueError(f"synthesize: encoder_counts = {encoder_counts!r}: give the encoder's counts per revolution "
                         f"(at least 1), or None for a record without angle columns")
    controller = rig.require_controller()
    unmodelled = [what for what, present in (
        ('structure = "cascade"', controller.cascade), ("torque_limit", controller.torque_limit > 0.0),
        ("a speed or position controller of the user's own",
         controller.speed_controller is not None or controller.position_controller is not None)) if present]
    if unmodelled:
        raise ValueError(f"synthesize: the record generator runs a PI speed loop; the rig's {unmodelled[0]} is not "
                         "modelled in it (give a rig whose [controller] is a PI speed loop)")
    rng = np.random.default_rng(seed)
    plant = _perturbed_plant(rig.plant, rng, datasheet_error)
    effects = _hidden_effects(cause, size, rig, rng, experiment)
    if "rubber" in effects:
        plant = dataclasses.replace(plant, rubber_thickness=effects["rubber"])
    friction_speed = 0.1 * COULOMB_SMOOTHING * experiment.speed_amplitude
    system, (kp, ki, fb) = _closed_loop(plant, controller, effects, friction_speed,
                                        STRIBECK_SPEED * experiment.speed_amplitude)
    model = make_model("rubber" if "rubber" in effects else "exact", **plant.shaft)

    dt_fine = 1.0 / (sample_rate * oversample)
    n_warm = int(round(experiment.warmup * sample_rate))
    n_record = int(round(duration * sample_rate)) + 1
    n_samples = n_warm + n_record
    time = np.arange((n_samples - 1) * oversample + 1) * dt_fine
    phases = rng.uniform(0.0, 2.0 * np.pi, len(experiment.test_frequencies))
    delay = effects.get("actuator_delay", 0.0)
    reference, test, load_torque = _signals(experiment, phases, time)
    reference_applied, test_applied, _ = _signals(experiment, phases, np.maximum(time - delay, 0.0))
    test_applied = test_applied + effects.get("torque_offset", 0.0)
    noise = rng.normal(0.0, experiment.noise, (n_samples, 2))
    sample_time = time[::oversample]
    fed_back_noise = np.interp(time, sample_time, noise[:, fb - 1])
    inputs = np.column_stack([reference, reference_applied, test_applied, load_torque, fed_back_noise])
    result = simulate_linear(system, model, time[-1], dt_fine, inputs=inputs)

    record = slice(n_warm * oversample, None, oversample)
    states = result.states[record]
    commanded = kp * (reference[record] - states[:, 3]) + ki * states[:, 4] + test[record]
    label = "+".join(effects) or "none"
    measurements = measurements_from_arrays(
        time=sample_time[n_warm:] - sample_time[n_warm],
        motor_torque=commanded,
        motor_speed=states[:, 1] + noise[n_warm:, 0],
        load_speed=states[:, 2] + noise[n_warm:, 1],
        load_torque=load_torque[record],
        source=f"synthetic({label}, seed={seed})",
        **_encoder_angles(result.states[n_warm * oversample:], dt_fine, oversample, encoder_counts, rng, encoder_skew),
    )
    first = n_warm * oversample
    initial_state = {"theta_d0": float(result.states[first, 0]), "motor_speed0": float(result.states[first, 1]),
                     "load_speed0": float(result.states[first, 2]),
                     "theta_b0": float(result.theta_b[first]) if "rubber" not in effects else math.nan}
    return SyntheticRecord(measurements=measurements, effects=effects, true_plant=plant, seed=seed,
                           initial_state=initial_state)
