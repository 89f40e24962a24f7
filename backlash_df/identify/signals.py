"""Conditioning of a record's signals for the prediction: smoothed speeds, their noise, encoder speeds, the twist.

The predictions (:mod:`.predictors`) start every k-step segment from the state the
data give (:func:`data_states`): the measured speeds smoothed by a Savitzky-Golay
filter (:func:`smoothed_speeds`) and the twist theta_d, measured by the two encoders
or integrated from the speeds (:func:`measured_twist`).  The noise of a speed
(:func:`speed_noise`) weighs the multiple-shooting corrections of a fit; where an
encoder measures a speed more finely than its column, :func:`encoder_speeds` puts
the encoder's in its place; :func:`shaft_resolution` tells whether a record holds
motion at the shaft's mode at all.
"""

import dataclasses
import math

import numpy as np

__all__ = ["encoder_speeds", "ShaftResolution", "shaft_resolution", "RESOLVED_SNR"]

#: Noise of a smoothed speed (:func:`smoothed_speeds`, Savitzky-Golay 11 points, order 2) as a share of
#: the raw speed's: ``sqrt(h_0)`` with ``h_0 = 89 / 429`` the filter's centre weight.
SMOOTHED_NOISE_SHARE = math.sqrt(89.0 / 429.0)
#: An encoder's speed replaces a speed column only where it is at least this many times less noisy
#: (:func:`encoder_speeds`).
ENCODER_SPEED_GAIN = 4.0
#: ... and where column and encoder speed differ by at most this many times their noises combined.
ENCODER_SPEED_AGREEMENT = 1.1
#: Power ratio of the motor speed's spectrum over its noise floor below which a frequency is not resolved
#: by the record (:func:`shaft_resolution`; 10 dB).
RESOLVED_SNR = 10.0


def _smoothed(values, window=11):
    """``values`` (columns) smoothed by a Savitzky-Golay filter (order 2) along the samples."""
    from scipy.signal import savgol_filter  # lazy: scipy.signal takes a second to import

    n = values.shape[0]
    return savgol_filter(values, min(window, n - (1 - n % 2)), 2, axis=0)


def smoothed_speeds(measurements, window=11):
    """Measured speeds smoothed by a Savitzky-Golay filter (order 2), rad/s, shape (N, m)."""
    return _smoothed(measurements.speeds, window)


def _residual_noise(values):
    """Standard deviation of speed signals (columns, rad/s) about their smoothing."""
    return np.std(values - _smoothed(values), axis=0)


def speed_noise(measurements):
    """Standard deviation of each measured speed's noise (rad/s): measured minus smoothed."""
    return _residual_noise(measurements.speeds)


def _white_noise(values):
    """The white noise's standard deviation in speed signals (columns, rad/s): their difference from the
    smoothed signals (:func:`_residual_noise`) over the share ``sqrt(1 - h_0)`` of the noise that the smoothing
    leaves in it."""
    return _residual_noise(values) / math.sqrt(1.0 - SMOOTHED_NOISE_SHARE**2)


def angle_rate(angles, dt):
    """The speed an encoder's angle column measures: five-point central differences.

    ``(theta[i-2] - 8 theta[i-1] + 8 theta[i+1] - theta[i+2]) / (12 dt)``, truncation error
    ``dt^4 w'''' / 30`` (three points err by ``dt^2 w'' / 6``); second-order differences at the two
    samples of either end.

    Parameters
    ----------
    angles : ndarray
        Angle samples, rad, uniformly spaced.
    dt : float
        Sampling interval, s.

    Returns
    -------
    ndarray
        The speed at every sample, rad/s.
    """
    rate = np.gradient(angles, dt, edge_order=2)
    if angles.size >= 5:
        rate[2:-2] = (angles[:-4] - 8.0 * angles[1:-3] + 8.0 * angles[3:-1] - angles[4:]) / (12.0 * dt)
    return rate


def encoder_speeds(measurements):
    """The record with each speed column replaced by its encoder's speed where that is the finer measurement.

    An encoder's speed is the five-point central difference of its angle column (:func:`angle_rate`).  It
    replaces the speed column where both hold:

    * it is at least :data:`ENCODER_SPEED_GAIN` times less noisy (the estimate of each signal's white noise
      from the signal minus its smoothing, as :func:`shaft_resolution`'s): a fine encoder against a speed sensor or a
      coarse difference.  Where the motion's own content above the smoothing's band outweighs the noise,
      the estimate cannot tell them apart and the column is kept;
    * the two differ by their noises only, the standard deviation of column minus encoder speed at most
      :data:`ENCODER_SPEED_AGREEMENT` times ``sqrt(sigma_column^2 + sigma_encoder^2)``: a column that is
      filtered, or an encoder that is read late (``encoder_skew``), differs by a part proportional to the
      acceleration, and the column is kept.

    On the synthetic records of the benchmarks (2^20 counts per revolution at 1 kHz) the encoders' speeds
    are 12-15 times less noisy than the speed columns; on the KUKA record (``examples/kuka``) the motor
    encoder's is 2 times, the link encoder's noisier and late, so nothing is replaced there.

    Parameters
    ----------
    measurements : Measurements

    Returns
    -------
    Measurements
        The same record where no speed is replaced; otherwise a copy with the replaced columns and a line
        each in :attr:`~.measurements.Measurements.notes` naming the column and both noises.
    """
    changes, notes = {}, []
    for name, angle in (("motor_speed", "motor_angle"), ("load_speed", "load_angle")):
        column, angles = getattr(measurements, name), getattr(measurements, angle)
        if column is None or angles is None:
            continue
        derived = angle_rate(angles, measurements.dt)
        sigma_column, sigma_encoder = float(_white_noise(column)), float(_white_noise(derived))
        spread = float(np.std(column - derived))
        if (ENCODER_SPEED_GAIN * sigma_encoder <= sigma_column
                and spread <= ENCODER_SPEED_AGREEMENT * math.hypot(sigma_column, sigma_encoder)):
            changes[name] = derived
            notes.append(f"{name} taken from the {angle} column (five-point central differences): its noise "
                         f"{sigma_encoder:.2g} rad/s against {sigma_column:.2g} rad/s in the {name} column")
    if not changes:
        return measurements
    return dataclasses.replace(measurements, **changes, notes=measurements.notes + tuple(notes))


def integrated_displacement(measurements):
    """``int_0^t (w_m - w_l) dt`` from the measured speeds (rad): theta_d up to its offset."""
    from scipy.integrate import cumulative_trapezoid  # lazy: keeps `import backlash_df` quick

    if measurements.load_speed is None:
        return np.zeros(measurements.n_samples)
    relative = measurements.motor_speed - measurements.load_speed
    return cumulative_trapezoid(relative, dx=measurements.dt, initial=0.0)


def measured_twist(measurements):
    """The twist theta_d up to a constant (rad): measured (angle columns) or integrated from the speeds."""
    twist = getattr(measurements, "twist", None)
    return integrated_displacement(measurements) if twist is None else np.asarray(twist, dtype=float)


def data_states(measurements, theta_d0, samples):
    """States ``(theta_d, w_m, w_l)`` the data give at ``samples``, shape (len(samples), 3).

    Speeds are the smoothed measured speeds (the load speed equals the motor
    speed without a load-speed column); theta_d is ``theta_d0`` plus
    :func:`measured_twist`.
    """
    samples = np.asarray(samples, dtype=int)
    speeds = smoothed_speeds(measurements)
    return np.column_stack([theta_d0 + measured_twist(measurements)[samples], speeds[samples, 0],
                            speeds[samples, -1]])


@dataclasses.dataclass(frozen=True)
class ShaftResolution:
    """Whether a record resolves the shaft's mode (:func:`shaft_resolution`).

    Attributes
    ----------
    mode_frequency : float
        The shaft's natural frequency in contact, ``sqrt(k (1/J_m + 1/J_l)) / (2 pi)``, Hz, from the rig file.
    resolved_frequency : float
        The lowest frequency (Hz) at which the motor speed's spectrum falls below
        :data:`RESOLVED_SNR` times its noise floor: the record resolves motion below it.
    """

    mode_frequency: float
    resolved_frequency: float

    @property
    def resolved(self):
        """True when the mode lies inside the resolved band (the two-mass model's shaft shows in the record)."""
        return bool(self.mode_frequency <= self.resolved_frequency)

    def to_dict(self):
        """JSON-ready ``{"mode_frequency", "resolved_frequency", "resolved"}`` (Hz)."""
        return {"mode_frequency": self.mode_frequency, "resolved_frequency": self.resolved_frequency,
                "resolved": self.resolved}


def shaft_resolution(measurements, rig):
    """Does the record resolve the shaft's mode?  A :class:`ShaftResolution`.

    The motor speed's Welch spectrum (1 s Hann segments, 1 Hz bins) is compared
    with the floor of its white noise, ``2 sigma^2 / f_s`` with ``sigma`` the
    raw noise (:func:`speed_noise` over its share ``sqrt(1 - h_0)`` that the
    smoothing leaves in the difference).  Where the shaft's mode lies above the
    first frequency whose power falls below :data:`RESOLVED_SNR` times the floor,
    the speeds hold no motion at the mode: the shaft behaves as rigid in this
    record (KUKA axis 1: mode 17.8 Hz, resolved up to 9 Hz; the synthetic rig of
    the benchmarks: mode 20 Hz, resolved up to 35 Hz or more).
    """
    from scipy.signal import welch  # lazy: scipy.signal takes a second to import

    plant = rig.plant
    mode = math.sqrt(plant.stiffness * (1.0 / plant.motor_inertia + 1.0 / plant.load_inertia)) / (2.0 * math.pi)
    rate = 1.0 / measurements.dt
    noise = float(_white_noise(measurements.speeds)[0])
    frequency, power = welch(measurements.motor_speed, fs=rate, nperseg=min(measurements.n_samples, round(rate)))
    below = np.flatnonzero(power[1:] < RESOLVED_SNR * 2.0 * noise**2 / rate)
    return ShaftResolution(mode, float(frequency[1 + below[0]] if below.size else frequency[-1]))
