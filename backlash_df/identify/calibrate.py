"""Prediction and calibration: the drive model driven by the measured torques.

The model is the open-loop two-mass drive of the paper (eq. 42) with the
catalogue's effects (:mod:`.effects`)::

    J_m dw_m/dt = T_m(t - tau) + T_0 - T(theta_d, dtheta_d) - F_m(w_m)
    J_l dw_l/dt = T_l(t) + T(theta_d, dtheta_d) - F_l(w_l)
    dtheta_d/dt = w_m - w_l
    F_s(w) = d_s w + (F_c,s + F_b,s exp(-(w / w_s)^2)) tanh(w / eps)

with the rig's torque law ``T`` (the rubber law (40) when ``rubber_thickness``
is positive; the exact model (14) is predicted with its static form, the phase
plane law (23)), the measured commanded torque ``T_m`` and the known load
torque ``T_l``.  All effect parameters are zero in the nominal structure.  The
smoothing speed ``eps`` and the Stribeck speed ``w_s`` are the values
``coulomb_smoothing`` and ``stribeck_speed`` where given (a diagnosis chooses them,
held in the fit), else 1 % and 5 % of the record's largest speed (:mod:`.effects`).

The **rigid-body model** (``structure="rigid_body"``) is the limit of a shaft
infinitely stiff without play: one inertia ``J = J_m + J_l`` (fitted as
``inertia``) turning at one speed ``w``, predicted for both measured speeds::

    J dw/dt = T_m(t - tau) + T_0 + T_l(t) - F_m(w) - F_l(w)

started at each segment from the momentum-weighted data speed
``(J_m w_m + J_l w_l) / (J_m + J_l)`` (the rig file's inertias).

**Encoder skew.**  Where the twist is measured (both angle columns), the load
encoder may be read later than the motor encoder by ``encoder_skew`` (s; the
link encoder of the KUKA record, ``examples/kuka``, about 3 ms): the measured
twist then holds ``encoder_skew w_l`` besides the elastic twist, so the
segments start from ``theta_d0 + twist - encoder_skew w_l``, with the skew
fitted along (within two samples either way).

**Prediction modes** (as MATLAB's ``compare``).  A *k-step prediction* cuts the
record into segments of ``horizon`` samples; each segment is simulated from the
state the data give at its first sample (:func:`data_states`: the smoothed
measured speeds, and theta_d = the measured twist, or the integral of
``w_m - w_l`` without angle columns, plus one fitted offset ``theta_d0``), so no
prediction runs longer than the horizon: an observer-based k-step predictor.
Without angle columns on a shaft whose mode the record does not resolve
(:func:`shaft_resolution`: a stiff gear), the integrated twist drifts by more
than the shaft ever twists; each segment then starts *quasi-statically*: both
speeds at the momentum-weighted data speed and the twist whose shaft torque
gives both inertias the same acceleration (the state of the rigid body the
model contains, its fast mode not excited), with no offset fitted.  On
closed-loop data of a position-controlled axis any unmodelled torque piles up as
speed in a long simulation; the k-step prediction cannot drift.  A *free run*
is one segment over the whole window.

**Calibration** fits the plant values of the rig file (data-sheet values, a few
per cent off), the offset ``theta_d0`` and the effect parameters by bounded
nonlinear least squares (:func:`scipy.optimize.least_squares`, trust region
reflective) of the k-step prediction error on an estimation window.  It is a
multiple-shooting fit (:class:`Shooting`) of the two-mass model: each
segment's initial speeds are corrected too, with the data's state as a
measurement of them, so that the noise of that state does not bias the values
(errors in the variables), and, where the twist is integrated from the speeds,
the twist's drift as the random walk it is (quasi-static starts take no
corrections).  Intervals
come from a cluster-robust ("sandwich") covariance over the segments,
``(J^T J)^-1 (sum_g J_g^T r_g r_g^T J_g) (J^T J)^-1 G / (G - 1)`` with a
Student t quantile of ``G - 1`` degrees of freedom: residuals correlated within
a segment, as they are, do not make the interval overconfident.

The kernel is compiled (numba, fixed-step RK4 with ``substeps`` steps a sample,
inputs interpolated linearly) and runs every segment in one call.

**Jacobians.**  A k-step fit of the two-mass model takes its Jacobian from
forward sensitivities (:mod:`.sensitivity`, :func:`sensitivity_jacobian`): one
run of the kernel with the derivatives riding along gives every column, the
multiple-shooting corrections' included, where forward differences took one run
a value.  It is the derivative of the discrete prediction with its modes held,
which differences of a small step reproduce (to 1e-6, the tests); a free run
(:func:`refine`) keeps forward differences (:func:`parallel_jacobian`): over a
whole window the contacts' switching times move with the values, which a held
mode's derivative does not see and differences do, and so does the rigid body.
"""

import dataclasses
import functools
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._jit import inline as _inline
from .._jit import jit_unchecked as _jit_unchecked
from .._json import json_ready
from ..models import LAW_CODES, PHASE_PLANE, RUBBER, held_mode, mode_torque
from ..plotting import ResultPlot, axes_or_new, legend_beside
from .effects import get_effect, smoothing_speeds
from .sensitivity import DELAY, segment_sensitivities

__all__ = [
    "FitParameter",
    "Calibration",
    "Replay",
    "PLANT_PARAMETERS",
    "MODEL_PARAMETERS",
    "RIGID_PARAMETERS",
    "STRUCTURES",
    "nominal_values",
    "data_states",
    "predict",
    "replay",
    "calibrate",
    "refine",
    "fit_percent",
    "information_criterion",
    "smoothed_speeds",
    "speed_noise",
    "angle_rate",
    "encoder_speeds",
    "ENCODER_SPEED_GAIN",
    "ENCODER_SPEED_AGREEMENT",
    "ShaftResolution",
    "shaft_resolution",
    "RESOLVED_SNR",
    "integrated_displacement",
    "TwoMassModel",
    "RigidBodyModel",
    "Shooting",
    "parallel_jacobian",
    "sensitivity_jacobian",
    "cluster_robust_stderr",
]

#: Plant values of the rig file that calibration adjusts.
PLANT_PARAMETERS = ("motor_inertia", "load_inertia", "stiffness", "damping", "half_gap")
#: Every value the prediction model reads, in the kernel's order (effects zero by default).
MODEL_PARAMETERS = PLANT_PARAMETERS + (
    "rubber_thickness", "coulomb_friction_motor", "coulomb_friction_load", "viscous_friction_motor",
    "viscous_friction_load", "breakaway_friction_motor", "breakaway_friction_load", "torque_offset",
)
#: Plant value the rigid-body model (``structure="rigid_body"``) fits: the whole drive's inertia.
RIGID_PARAMETERS = ("inertia",)
#: Model structures: the two-mass drive with its shaft, and the rigid body it contains.
STRUCTURES = ("two_mass", "rigid_body")
_UNITS = {"motor_inertia": "kg m^2", "load_inertia": "kg m^2", "stiffness": "N m/rad", "damping": "N m s/rad",
          "half_gap": "rad", "theta_d0": "rad", "inertia": "kg m^2", "encoder_skew": "s"}
_MAX_SKEW_SAMPLES = 2.0  # encoder skew fitted within +-2 samples
#: Smallest norm of a fit's scaled start vector: a fit whose free values all start at their null (an effect alone
#: on the rigid body, plant values held) starts this far inside, else trf's first step has zero length.
_MIN_START_NORM = 0.01
_RELATIVE_RANGE = 0.3  # data-sheet values are trusted to +-30 %
_SUBSTEPS = 2  # RK4 steps per sample
_THETA_GRID_POINTS = 33  # starting theta_d0 searched on a grid over its range
#: Noise of a smoothed speed (:func:`smoothed_speeds`, Savitzky-Golay 11 points, order 2) as a share of
#: the raw speed's: ``sqrt(h_0)`` with ``h_0 = 89 / 429`` the filter's centre weight.
SMOOTHED_NOISE_SHARE = math.sqrt(89.0 / 429.0)
DEFAULT_HORIZON = 0.1  # s, length of the k-step segments
#: Smallest free-run fit (%) of the k-step solution on every speed for the free-run refinement.
FREE_RUN_MIN = 50.0
#: An encoder's speed replaces a speed column only where it is at least this many times less noisy
#: (:func:`encoder_speeds`).
ENCODER_SPEED_GAIN = 4.0
#: ... and where column and encoder speed differ by at most this many times their noises combined.
ENCODER_SPEED_AGREEMENT = 1.1
#: Power ratio of the motor speed's spectrum over its noise floor below which a frequency is not resolved
#: by the record (:func:`shaft_resolution`; 10 dB).
RESOLVED_SNR = 10.0


def fit_percent(measured, simulated):
    """Fit percentage as MATLAB's ``compare``: ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)``.

    100 is a perfect fit, 0 is no better than the mean, negative is worse; NaN
    for a constant signal (nothing to fit).

    Examples
    --------
    >>> y = np.array([0.0, 1.0, 2.0, 3.0])
    >>> fit_percent(y, y)
    100.0
    >>> fit_percent(y, np.full(4, y.mean()))
    0.0
    """
    measured = np.asarray(measured, dtype=float)
    error = np.linalg.norm(measured - np.asarray(simulated, dtype=float))
    spread = np.linalg.norm(measured - measured.mean())
    return float(100.0 * (1.0 - error / spread)) if spread > 0.0 else float("nan")


# --------------------------------------------------------------------------- compiled prediction kernel


@_inline
def _friction(w, viscous, coulomb, breakaway, eps, w_s):
    """``F(w)`` of the module docs, N m; without Coulomb or breakaway friction no tanh, without breakaway
    friction no exp is evaluated (the same number: they are multiplied by zero; ``w_s > 0``)."""
    if coulomb == 0.0 and breakaway == 0.0:
        return viscous * w
    if breakaway == 0.0:
        return viscous * w + coulomb * math.tanh(w / eps)
    return viscous * w + (coulomb + breakaway * math.exp(-(w / w_s) ** 2)) * math.tanh(w / eps)


@_inline
def _rates(x, wm, wl, tm, tl, law, mode, p, eps, w_s):
    """Right-hand side of the model (module docs) at theta_d = ``x`` and speeds ``wm, wl`` (rad, rad/s):
    ``(dtheta_d/dt, dw_m/dt, dw_l/dt, shaft torque in N m)``; ``p``: the first 13 values of :func:`_segments`."""
    v = wm - wl
    m = held_mode(law, mode, x, v, p[2], p[3], p[4], p[5])
    torque = mode_torque(law, m, x, v, p[2], p[3], p[4], p[5])
    return (v, (tm + p[12] - torque - _friction(wm, p[8], p[6], p[10], eps, w_s)) / p[0],
            (tl + torque - _friction(wl, p[9], p[7], p[11], eps, w_s)) / p[1], torque)


@_jit_unchecked
def _segments(law, p, eps, w_s, tm, tl, starts, stops, z0, substeps, states, torque):
    """Simulate each segment ``starts[i]:stops[i]`` from state ``z0[i]`` (RK4, inputs interpolated).

    The state is held in scalars, the values ``p`` in a tuple (not reference-counted) and
    :func:`_rates` is inlined: no array is passed inside the step loop (numba
    reference-counts an array passed to an inlined helper that calls compiled functions:
    2 of every 9 ns of a step before).
    numpy's error model (7 % faster): its divisors, the inertias, the sample interval
    and the smoothing speeds, are positive (the fit's bounds, the record's checks).
    """
    last = tm.shape[0] - 1
    values = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12])
    for s in range(starts.shape[0]):
        x, wm, wl = z0[s, 0], z0[s, 1], z0[s, 2]
        mode = held_mode(law, np.int64(0), x, wm - wl, p[2], p[3], p[4], p[5])
        for i in range(starts[s], stops[s]):
            states[i, 0], states[i, 1], states[i, 2] = x, wm, wl
            a0, a1, a2, torque[i] = _rates(x, wm, wl, tm[i], tl[i], law, mode, values, eps, w_s)
            if i == last:
                continue
            d_tm, d_tl = tm[i + 1] - tm[i], tl[i + 1] - tl[i]
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                h = (f1 - f0) * p[13]
                fm = 0.5 * (f0 + f1)
                tmm, tlm = tm[i] + fm * d_tm, tl[i] + fm * d_tl
                if q > 0:  # the first stage of the sample's first step is the rate its torque came with
                    a0, a1, a2, _ = _rates(x, wm, wl, tm[i] + f0 * d_tm, tl[i] + f0 * d_tl, law, mode, values, eps,
                                           w_s)
                b0, b1, b2, _ = _rates(x + 0.5 * h * a0, wm + 0.5 * h * a1, wl + 0.5 * h * a2, tmm, tlm, law, mode,
                                       values, eps, w_s)
                c0, c1, c2, _ = _rates(x + 0.5 * h * b0, wm + 0.5 * h * b1, wl + 0.5 * h * b2, tmm, tlm, law, mode,
                                       values, eps, w_s)
                d0, d1, d2, _ = _rates(x + h * c0, wm + h * c1, wl + h * c2, tm[i] + f1 * d_tm, tl[i] + f1 * d_tl, law,
                                       mode, values, eps, w_s)
                x += h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                wm += h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
                wl += h / 6.0 * (a2 + 2.0 * b2 + 2.0 * c2 + d2)
                mode = held_mode(law, mode, x, wm - wl, p[2], p[3], p[4], p[5])


@_inline
def _rigid_rate(w, tm, tl, p, eps, w_s):
    """``dw/dt`` of the rigid body; ``p`` = (inertia, Coulomb, viscous, breakaway, offset), N m and N m s/rad."""
    return (tm + tl + p[4] - _friction(w, p[2], p[1], p[3], eps, w_s)) / p[0]


@_jit_unchecked
def _rigid_segments(p, eps, w_s, dt, tm, tl, starts, stops, w0, substeps, speed):
    """Simulate the rigid body over each segment ``starts[i]:stops[i]`` from ``w0[i]`` (RK4, inputs interpolated)."""
    last = tm.shape[0] - 1
    for s in range(starts.shape[0]):
        w = w0[s]
        for i in range(starts[s], stops[s]):
            speed[i] = w
            if i == last:
                continue
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                fm = 0.5 * (f0 + f1)
                h = (f1 - f0) * dt
                tm0, tl0 = tm[i] + f0 * (tm[i + 1] - tm[i]), tl[i] + f0 * (tl[i + 1] - tl[i])
                tmm, tlm = tm[i] + fm * (tm[i + 1] - tm[i]), tl[i] + fm * (tl[i + 1] - tl[i])
                tm1, tl1 = tm[i] + f1 * (tm[i + 1] - tm[i]), tl[i] + f1 * (tl[i + 1] - tl[i])
                k1 = _rigid_rate(w, tm0, tl0, p, eps, w_s)
                k2 = _rigid_rate(w + 0.5 * h * k1, tmm, tlm, p, eps, w_s)
                k3 = _rigid_rate(w + 0.5 * h * k2, tmm, tlm, p, eps, w_s)
                k4 = _rigid_rate(w + h * k3, tm1, tl1, p, eps, w_s)
                w += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


# --------------------------------------------------------------------------- data, replay, prediction


@dataclasses.dataclass(frozen=True)
class FitParameter:
    """A fitted (or fixed) parameter with its uncertainty.

    Attributes
    ----------
    name, unit : str
    value : float
        Best-fit value.
    stderr : float
        Standard error, cluster-robust (NaN when not estimable).
    nominal : float
        The rig file's value for plant parameters, the null value for effects.
    lower, upper : float
        Bounds of the fit.
    quantile : float
        Multiplier of ``stderr`` giving the 95 % interval (Student t, G - 1 dof).
    interval : tuple of float, optional
        The 95 % interval when it is not ``value -+ quantile stderr`` (see :func:`refine`).
    """

    name: str
    value: float
    stderr: float
    nominal: float
    lower: float
    upper: float
    unit: str = ""
    quantile: float = 1.959963984540054
    interval: tuple | None = None

    @property
    def ci95(self):
        """95 % confidence interval, ``value -+ t stderr`` unless given as ``interval``."""
        if self.interval is not None:
            return self.interval
        return (self.value - self.quantile * self.stderr, self.value + self.quantile * self.stderr)

    @property
    def on_bound(self):
        """True if the value ends within 0.1 % of the range at a bound of the fit."""
        tolerance = 1e-3 * (self.upper - self.lower)
        return bool(self.value - self.lower <= tolerance or self.upper - self.value <= tolerance)

    def to_dict(self):
        """JSON-ready ``{"value", "ci95", "stderr", "unit", "start", "bounds"}``."""
        low, high = self.ci95
        return {"value": self.value, "ci95": [low, high], "stderr": self.stderr, "unit": self.unit,
                "start": self.nominal, "bounds": [self.lower, self.upper]}

    def __repr__(self):
        low, high = self.ci95
        return f"<FitParameter {self.name} = {self.value:.6g} +/- {self.stderr:.3g} {self.unit} (95 % CI {low:.4g}..{high:.4g})>"


@dataclasses.dataclass(frozen=True)
class Replay:
    """Simulated speeds of the model driven by the measured torques.

    Attributes
    ----------
    time : ndarray
        Sample instants, s (the record's, over the simulated window).
    simulated, measured : ndarray
        Simulated and measured speeds, shape (N, number of measured speeds), rad/s.
    names : tuple of str
        Names of the speed columns.
    theta_d, torque : ndarray
        Simulated displacement theta_d (rad) and shaft torque (N m).
    mode : str
        ``free run`` or ``k-step (k = ...)``.
    """

    time: np.ndarray
    simulated: np.ndarray
    measured: np.ndarray
    names: tuple
    theta_d: np.ndarray
    torque: np.ndarray
    mode: str = "free run"

    @property
    def residual(self):
        """Measured minus simulated speeds, rad/s."""
        return self.measured - self.simulated

    @property
    def load_speed(self):
        """Simulated load speed (the last column), rad/s."""
        return self.simulated[:, -1]

    def fit_percent(self, start=0, stop=None):
        """Fit percentage of each speed on samples ``start:stop`` (of this replay), as a dict."""
        window = slice(start, stop)
        return {name: fit_percent(self.measured[window, j], self.simulated[window, j])
                for j, name in enumerate(self.names)}

    def rms(self, start=0, stop=None):
        """RMS of each speed's residual on samples ``start:stop`` (rad/s), as a dict."""
        window = slice(start, stop)
        return {name: float(np.sqrt(np.mean(self.residual[window, j] ** 2))) for j, name in enumerate(self.names)}

    def __repr__(self):
        fits = ", ".join(f"{name} {value:.1f} %" for name, value in self.fit_percent().items())
        return f"<Replay {self.mode}: {self.time.size} samples, fit {fits}>"

    def to_dict(self):
        """JSON-ready: mode, fit percentages, and the simulated and measured speeds (s, rad/s)."""
        return json_ready({"mode": self.mode, "names": list(self.names), "fit_percent": self.fit_percent(),
                           "time": self.time, "simulated": self.simulated, "measured": self.measured,
                           "theta_d": self.theta_d, "torque": self.torque})

    def plot(self, ax=None, label=None):
        """Measured against simulated speeds, one panel per speed.

        Returns
        -------
        ResultPlot
            One panel per speed; the legend beside the first.
        """
        figure, axes = axes_or_new(ax, (len(self.names), 1), sharex=True, figsize=(9.5, 2.2 * len(self.names)),
                                   layout="constrained")
        for j, name in enumerate(self.names):
            axes[j].plot(self.time, self.measured[:, j], color="0.6", lw=1.0, label="measured")
            axes[j].plot(self.time, self.simulated[:, j], lw=1.0, label=label or self.mode)
            axes[j].set_ylabel(f"{name} (rad/s)")
        legend_beside(axes[0])
        axes[-1].set_xlabel("time (s)")
        return ResultPlot(figure, axes)


def nominal_values(rig):
    """The rig file's plant values as a dictionary of the model's parameters (effects, skew and offset at zero;
    ``inertia``, the rigid body's, ``J_m + J_l``)."""
    plant = rig.plant
    values = dict.fromkeys(MODEL_PARAMETERS, 0.0) | {"actuator_delay": 0.0, "theta_d0": 0.0, "encoder_skew": 0.0,
                                                     "inertia": float(plant.motor_inertia + plant.load_inertia)}
    return values | {name: float(getattr(plant, name)) for name in PLANT_PARAMETERS + ("rubber_thickness",)}


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


def _law_code(rig_law, values):
    if values.get("rubber_thickness", 0.0) > 0.0 or rig_law == "rubber":
        return RUBBER
    code = LAW_CODES[rig_law]
    return PHASE_PLANE if rig_law == "exact" else code


def segment_bounds(start, stop, horizon):
    """``(starts, stops)`` of segments of ``horizon`` samples covering ``start:stop`` (None: one segment)."""
    if horizon is None or horizon >= stop - start:
        return np.array([start]), np.array([stop])
    starts = np.arange(start, stop, horizon)
    if stop - starts[-1] < max(horizon // 2, 2) and starts.size > 1:
        starts = starts[:-1]
    return starts, np.append(starts[1:], stop)


class TwoMassModel:
    """The two-mass model of a record, ready to predict any window with any values (the kernel's inputs cached).

    :func:`predict` and :func:`calibrate` build one per record; it is public so that
    a test can run the very model a fit runs (:meth:`run`).

    Parameters
    ----------
    measurements : Measurements
        The record.
    rig : Rig
        Plant and torque law.

    Attributes
    ----------
    quasi_static : bool
        Segments start on the rigid body's state (module docs): no angle columns and the
        shaft's mode not resolved (:func:`shaft_resolution`).
    drifting : bool
        The twist is integrated from both speeds, its drift fitted (:class:`Shooting`).
    """

    structure = "two_mass"

    def __init__(self, measurements, rig):
        self.measurements = measurements
        self.rig = rig
        self.eps, self.w_s = smoothing_speeds(measurements)
        self.speeds = smoothed_speeds(measurements)
        self.twist = measured_twist(measurements)
        self.load_torque = np.ascontiguousarray(measurements.load_torque_or_zero, dtype=float)
        self.t_rel = measurements.time - measurements.time[0]
        self.twist_measured = getattr(measurements, "twist", None) is not None
        #: segments start on the rigid body's state (module docs): no angles, the shaft's mode not resolved
        self.quasi_static = not self.twist_measured and not shaft_resolution(measurements, rig).resolved
        #: the twist integrated from both speeds, whose drift the k-step fits correct (:class:`Shooting`)
        self.drifting = not self.twist_measured and not self.quasi_static and measurements.load_speed is not None

    def motor_torque(self, delay):
        """Commanded motor torque delayed by the actuator dead time (N m), on the record's grid."""
        torque = self.measurements.motor_torque
        return np.ascontiguousarray(torque if delay <= 0.0 else np.interp(self.t_rel - delay, self.t_rel, torque))

    def coulomb_smoothing(self, values):
        """The friction law's smoothing speed ``eps`` (rad/s): ``values["coulomb_smoothing"]`` where a diagnosis
        chose it, else the catalogue's (:data:`~.effects.COULOMB_SMOOTHING` of the record's largest speed)."""
        return float(values.get("coulomb_smoothing", self.eps))

    def stribeck_speed(self, values):
        """The breakaway friction's Stribeck speed ``w_s`` (rad/s): ``values["stribeck_speed"]`` where a
        diagnosis chose it, else the catalogue's (:data:`~.effects.STRIBECK_SPEED` of the record's largest
        speed)."""
        return float(values.get("stribeck_speed", self.w_s))

    def run(self, values, starts, stops, corrections=None):
        """Simulate segments from the data's states (plus ``corrections``, shape (segments, 3), the
        multiple-shooting corrections of :class:`Shooting`); (states, torque) on the whole record's
        grid (rows outside the segments are zero)."""
        p = self.kernel_values(values)
        n = self.measurements.n_samples
        states = np.zeros((n, 3))
        torque = np.zeros(n)
        _segments(_law_code(self.rig.model, values), p, self.coulomb_smoothing(values), self.stribeck_speed(values),
                  self.motor_torque(values.get("actuator_delay", 0.0)), self.load_torque,
                  starts.astype(np.int64), stops.astype(np.int64), self.initial_states(values, p, starts, corrections),
                  _SUBSTEPS, states, torque)
        return states, torque

    def kernel_values(self, values):
        """The kernel's vector: :data:`MODEL_PARAMETERS` of ``values`` (the rubber band at most the gap,
        ``beta <= 2 alpha``) and the sample interval."""
        p = np.array([float(values[name]) for name in MODEL_PARAMETERS] + [self.measurements.dt])
        p[5] = min(p[5], 2.0 * p[4])
        return p

    def initial_states(self, values, p, starts, corrections=None):
        """The segments' initial states (segments, 3): the data's (module docs), quasi-static or from the
        twist, plus ``corrections``; a free run's fitted initial speeds."""
        if self.quasi_static:
            z0 = self._quasi_static_states(values, p, starts)
        else:
            twist = values["theta_d0"] + self.twist[starts] - values.get("encoder_skew", 0.0) * self.speeds[starts, -1]
            if self.drifting and "twist_drift" in values:  # the fitted drift, its last value beyond its knots
                twist = twist + np.interp(starts, *values["twist_drift"])
            z0 = np.column_stack([twist, self.speeds[starts, 0], self.speeds[starts, -1]])
        if corrections is not None:
            z0 += corrections
        for column, name in ((1, "motor_speed0"), (2, "load_speed0")):
            if name in values:  # fitted initial speeds of a free run
                z0[0, column] = values[name]
        return np.ascontiguousarray(z0)

    def speed_sensitivities(self, values, starts, stops, names, corrections=None, steps=None, initial=()):
        """Derivatives of the predicted speeds by ``values[names]`` and by the segments' ``initial`` states.

        Forward sensitivities (:mod:`.sensitivity`): one run gives every column.
        A value that moves the initial states does so through
        :meth:`initial_states`: linearly (the twist offset, the encoder skew, a
        free run's initial speeds), or, from a quasi-static start, every value,
        differentiated by forward differences of ``steps`` (default
        :data:`_INITIAL_STATE_STEP` ``max(1, |value|)``; no simulation).

        Parameters
        ----------
        values : dict
        starts, stops : ndarray of int
            Segments.
        names : sequence of str
            Values to differentiate by.
        corrections : ndarray, optional
            As :meth:`run`.
        steps : sequence of float, optional
            Forward-difference step of each of ``names`` for quasi-static initial states.
        initial : sequence of int
            Initial states (0 theta_d, 1 w_m, 2 w_l) to differentiate by, each segment's own.

        Returns
        -------
        by_values : ndarray, shape (n, speeds, len(names))
            ``d(speeds)/d(values[names])`` on the record's grid (zero outside the segments).
        by_initial : ndarray, shape (n, speeds, len(initial))
            ``d(speeds)/d(initial state)`` of the row's segment.
        """
        p = self.kernel_values(values)
        starts, stops = starts.astype(np.int64), stops.astype(np.int64)
        z0 = self.initial_states(values, p, starts, corrections)
        if steps is None:
            steps = [_INITIAL_STATE_STEP * max(1.0, abs(float(values[name]))) for name in names]
        shifts = {}  # d z0 / d value of the values that move the initial states
        for name, step in zip(names, steps):
            if self.quasi_static and name == "actuator_delay":  # through the motor torque, piecewise linear
                shifts[name] = self._quasi_static_by_delay(values, p, starts)
            elif self.quasi_static:
                moved = values | {name: float(values[name]) + step}
                shifts[name] = (self.initial_states(moved, self.kernel_values(moved), starts, corrections) - z0) / step
            elif name in _INITIAL_STATE_VALUES:  # linear: theta_d0 + twist - skew w_l, a free run's speeds
                shifts[name] = np.zeros_like(z0)
                if name == "theta_d0":
                    shifts[name][:, 0] = 1.0
                elif name == "encoder_skew":
                    shifts[name][:, 0] = -self.speeds[starts, -1]
                else:
                    shifts[name][0, 1 if name == "motor_speed0" else 2] = 1.0
        requested = len(initial)
        moved = {int(r) for shift in shifts.values() for r in np.flatnonzero(np.any(shift, axis=0))}
        initial = list(initial) + sorted(moved - set(initial))
        clipped = float(values["rubber_thickness"]) > 2.0 * float(values["half_gap"])  # beta = 2 alpha
        codes = {name: DELAY if name == "actuator_delay" else MODEL_PARAMETERS.index(name)
                 for name in names if name in MODEL_PARAMETERS or name == "actuator_delay"}
        beta = MODEL_PARAMETERS.index("rubber_thickness")
        columns = sorted(set(codes.values()) | ({beta} if clipped and "half_gap" in names else set()))
        delay = values.get("actuator_delay", 0.0)
        n, speeds, width = self.measurements.n_samples, len(self.measurements.speed_names), len(columns) + len(initial)
        out = np.zeros((n, 2, width))
        segment_sensitivities(_law_code(self.rig.model, values), p, self.coulomb_smoothing(values),
                              self.stribeck_speed(values), self.motor_torque(delay),
                              self.motor_torque_rate(delay) if DELAY in columns else self.load_torque,
                              self.load_torque, starts, stops, z0, _SUBSTEPS, np.array(columns, dtype=np.int64),
                              np.array(initial, dtype=np.int64), np.zeros((11, width)), out)
        by_state = out[:, :speeds, len(columns):]
        segment = np.repeat(np.arange(starts.size), stops - starts)
        by_values = np.zeros((n, speeds, len(names)))
        for j, name in enumerate(names):
            if name in codes and not (clipped and name == "rubber_thickness"):
                by_values[:, :, j] = out[:, :speeds, columns.index(codes[name])]
            if clipped and name == "half_gap":
                by_values[:, :, j] += 2.0 * out[:, :speeds, columns.index(beta)]
            if name in shifts:  # through the initial states
                rows = slice(starts[0], stops[-1])
                by_values[rows, :, j] += np.einsum("isk,ik->is", by_state[rows],
                                                   shifts[name][segment][:, initial])
        return by_values, by_state[:, :, :requested]

    def motor_torque_rate(self, delay):
        """Derivative of :meth:`motor_torque` by the delay (N m/s): minus the commanded torque's slope at
        ``t - delay``, the slope of the interval below a sample (a delay's forward step lands there), zero
        before the record."""
        torque = self.measurements.motor_torque
        slopes = np.concatenate([[0.0], np.diff(torque) / np.diff(self.t_rel)])
        return np.ascontiguousarray(-slopes[np.searchsorted(self.t_rel, self.t_rel - max(delay, 0.0), side="left")])

    def speeds_of(self, states):
        """Columns of ``states`` matching the measured speeds."""
        return states[:, 1:1 + len(self.measurements.speed_names)]

    def _quasi_static_states(self, values, p, starts):
        """Segment starts on the rigid body's state: both speeds at the momentum-weighted data speed ``w``, and
        the twist whose shaft torque ``T_s = (J_l (T_m + T_0 - F_m(w)) - J_m (T_l - F_l(w))) / (J_m + J_l)``
        accelerates both inertias alike, through the dead zone's inverse ``T_s / k + alpha tanh(T_s / (k alpha))``
        (the jump across the gap smoothed over the torque ``k alpha``)."""
        k, alpha = p[2], p[4]
        shaft = self._quasi_static_shaft_torque(values, p, starts)
        twist = shaft / k + alpha * np.tanh(shaft / max(k * alpha, 1e-12))
        w = self._momentum_speed(p, starts)
        return np.column_stack([twist, w, w])

    def _momentum_speed(self, p, starts):
        """The data's momentum-weighted speed ``(J_m w_m + J_l w_l) / (J_m + J_l)`` at ``starts`` (rad/s)."""
        return (p[0] * self.speeds[starts, 0] + p[1] * self.speeds[starts, -1]) / (p[0] + p[1])

    def _quasi_static_shaft_torque(self, values, p, starts):
        """``T_s`` of :meth:`_quasi_static_states` at ``starts`` (N m)."""
        jm, jl = p[0], p[1]
        w = self._momentum_speed(p, starts)
        eps, w_s = self.coulomb_smoothing(values), self.stribeck_speed(values)
        motor = (self.motor_torque(values.get("actuator_delay", 0.0))[starts] + p[12]
                 - _friction_of(w, p[8], p[6], p[10], eps, w_s))
        load = self.load_torque[starts] - _friction_of(w, p[9], p[7], p[11], eps, w_s)
        return (jl * motor - jm * load) / (jm + jl)

    def _quasi_static_by_delay(self, values, p, starts):
        """``d z0 / d(actuator delay)`` of :meth:`_quasi_static_states` (rad/s, 0, 0): the motor torque's
        rate (:meth:`motor_torque_rate`) through ``T_s`` and the inverse dead zone."""
        jm, jl, k, alpha = p[0], p[1], p[2], p[4]
        shaft = self._quasi_static_shaft_torque(values, p, starts)
        by_shaft = (2.0 - np.tanh(shaft / max(k * alpha, 1e-12)) ** 2) / k
        shift = np.zeros((starts.size, 3))
        shift[:, 0] = by_shaft * jl / (jm + jl) * self.motor_torque_rate(values.get("actuator_delay", 0.0))[starts]
        return shift


class RigidBodyModel(TwoMassModel):
    """The rigid-body model of a record (module docs): the same interface and parameters as
    :class:`TwoMassModel`, whose states it returns as ``(0, w, w)`` (no twist, one speed for both
    measured speeds, the momentum-weighted speed ``(J_m w_m + J_l w_l) / (J_m + J_l)`` of the data at a
    segment's start)."""

    structure = "rigid_body"

    def __init__(self, measurements, rig):
        super().__init__(measurements, rig)
        plant = rig.plant
        self.speed = np.ascontiguousarray((plant.motor_inertia * self.speeds[:, 0] + plant.load_inertia
                                           * self.speeds[:, -1]) / (plant.motor_inertia + plant.load_inertia))

    def run(self, values, starts, stops, corrections=None):
        """Simulate segments from the data's momentum-weighted speed; (states, torque) as :meth:`TwoMassModel.run`
        (the shaft torque is zero: the rigid body has no shaft)."""
        p = np.array([float(values["inertia"])] + [
            float(values[f"{name}_motor"] + values[f"{name}_load"])
            for name in ("coulomb_friction", "viscous_friction", "breakaway_friction")] + [float(values["torque_offset"])])
        w0 = self.speed[starts].copy()
        if "motor_speed0" in values:  # fitted initial speed of a free run
            w0[0] = values["motor_speed0"]
        n = self.measurements.n_samples
        speed = np.zeros(n)
        _rigid_segments(p, self.coulomb_smoothing(values), self.stribeck_speed(values), self.measurements.dt,
                        self.motor_torque(values.get("actuator_delay", 0.0)),
                        self.load_torque, starts.astype(np.int64), stops.astype(np.int64), w0, _SUBSTEPS, speed)
        states = np.zeros((n, 3))
        states[:, 1] = states[:, 2] = speed
        return states, np.zeros(n)


#: Relative step of the forward differences of a segment's quasi-static initial states by a value (an algebraic
#: function, no simulation: the square root of the double's resolution balances truncation and round-off).
_INITIAL_STATE_STEP = 1.5e-8
#: Values that move the initial states of a segment that does not start quasi-statically.
_INITIAL_STATE_VALUES = ("theta_d0", "encoder_skew", "motor_speed0", "load_speed0")


def _friction_of(w, viscous, coulomb, breakaway, eps, w_s):
    """The friction law of the kernel (:func:`_friction`) on an array of speeds, N m."""
    return viscous * w + (coulomb + breakaway * np.exp(-(w / w_s) ** 2)) * np.tanh(w / eps)


def _model_of(measurements, rig, structure):
    """The :class:`TwoMassModel` (``two_mass``) or :class:`RigidBodyModel` (``rigid_body``) of a record."""
    if structure not in STRUCTURES:
        raise ValueError(f"unknown model structure {structure!r}; one of {', '.join(STRUCTURES)}")
    return RigidBodyModel(measurements, rig) if structure == "rigid_body" else TwoMassModel(measurements, rig)


def _horizon_samples(measurements, horizon):
    return None if horizon is None else max(int(round(horizon / measurements.dt)), 5)


def predict(measurements, rig, values=None, window=None, horizon=DEFAULT_HORIZON, block=None, structure="two_mass"):
    """Speeds predicted by the model from the data: k-step or free run.

    Parameters
    ----------
    measurements : Measurements
    rig : Rig
        Torque law (``[model] backlash``) and data-sheet plant values.
    values : dict, optional
        Values overriding the rig's: any of :data:`MODEL_PARAMETERS`,
        ``actuator_delay`` (s) and ``theta_d0`` (rad, offset of theta_d).
    window : tuple of int, optional
        Samples ``(start, stop)`` (default: all).
    horizon : float or None
        Prediction horizon, s: segments of this length, each started from the
        data's state (:func:`data_states`); None for one free run over the window.
    block : float, optional
        With a ``block`` shorter than ``horizon`` (s), the window is cut into
        blocks of that length and each block is predicted by a segment started
        ``horizon`` before the block's end (earlier than the window if need be):
        every sample is predicted between ``horizon - block`` and ``horizon``
        ahead, as MATLAB's ``predict`` with k steps.
    structure : str
        ``two_mass`` (the drive with its shaft) or ``rigid_body`` (module docs).

    Returns
    -------
    Replay
    """
    values = nominal_values(rig) | dict(values or {})
    start, stop = window if window is not None else (0, measurements.n_samples)
    k = _horizon_samples(measurements, horizon)
    model = _model_of(measurements, rig, structure)
    kb = k if block is None or k is None else min(_horizon_samples(measurements, block), k)
    block_starts, block_stops = segment_bounds(start, stop, kb)
    lead = 0 if k is None else k - kb
    states = np.empty((stop - start, 3))
    torque = np.empty(stop - start)
    lanes = 1 if lead == 0 else -(-k // kb)
    for lane in range(lanes):  # segments of one lane do not overlap
        chosen = np.arange(lane, block_starts.size, lanes)
        lane_states, lane_torque = model.run(values, np.maximum(block_starts[chosen] - lead, 0), block_stops[chosen])
        for first, last in zip(block_starts[chosen], block_stops[chosen]):
            states[first - start:last - start] = lane_states[first:last]
            torque[first - start:last - start] = lane_torque[first:last]
    mode = "free run" if k is None or (lead == 0 and block_starts.size == 1) else (
        f"k-step (k = {k} samples, {k * measurements.dt:.3g} s)" if lead == 0 else
        f"{k - kb}..{k}-step ahead ({(k - kb) * measurements.dt:.3g}..{k * measurements.dt:.3g} s)")
    return Replay(time=measurements.time[start:stop], simulated=model.speeds_of(states),
                  measured=measurements.speeds[start:stop], names=measurements.speed_names,
                  theta_d=states[:, 0], torque=torque, mode=mode)


def replay(measurements, rig, values=None, n_samples=None):
    """Free-run simulation of the rig's model from the data's state at the first sample.

    ``values`` as in :func:`predict`; ``n_samples`` limits the run to the first
    samples.  Returns a :class:`Replay`.
    """
    stop = measurements.n_samples if n_samples is None else int(n_samples)
    return predict(measurements, rig, values, window=(0, stop), horizon=None)


# --------------------------------------------------------------------------- calibration


@dataclasses.dataclass(frozen=True, repr=False)
class Calibration:
    """Result of :func:`calibrate`: parameters with uncertainties and fit statistics.

    Attributes
    ----------
    effects : tuple of str
        Catalogue keys fitted along (empty for the nominal structure).
    parameters : dict
        Name -> :class:`FitParameter`: plant values, ``theta_d0`` and the effects'
        (keyed ``name_side`` for friction).
    values : dict
        Every model value, ready for :func:`predict`.
    window : tuple of int
        Samples ``start:stop`` whose residual was minimised.
    horizon : int or None
        Samples per k-step segment.
    n_residuals : int
        Number of scaled residuals (samples times measured speeds).
    n_clusters : int
        Segments the robust covariance is computed over.
    rss : float
        Residual sum of squares of the scaled residual at the optimum.
    aic, bic : float
        ``N ln(RSS / N) + 2 p`` and ``N ln(RSS / N) + p ln N`` on the estimation window.
    nfev : int
        Model runs of the optimiser (a forward-difference Jacobian's columns, a sensitivity Jacobian's one run,
        included).
    success : bool
    message : str
    shooting_segments : int
        Segments whose initial speeds were fitted too (multiple shooting, :class:`Shooting`; 0: none).
    structure : str
        ``two_mass`` or ``rigid_body`` (module docs).
    """

    effects: tuple
    parameters: dict
    values: dict
    window: tuple
    horizon: int | None
    n_residuals: int
    n_clusters: int
    rss: float
    aic: float
    bic: float
    nfev: int
    success: bool
    message: str
    shooting_segments: int = 0
    structure: str = "two_mass"

    @property
    def n_free(self):
        """Number of fitted parameters."""
        return len(self.parameters)

    def effect_parameter(self, key):
        """The :class:`FitParameter` of catalogue entry ``key``."""
        return self.parameters[get_effect(key).value_key]

    def fit_report(self):
        """A printable report of parameters, standard errors and statistics, lmfit style."""
        lines = [
            f"[[Calibration: {' + '.join(self.effects) or 'none'}]]"
            + (" (rigid-body model)" if self.structure == "rigid_body" else ""),
            f"    samples {self.window[0]}:{self.window[1]}, "
            + (f"k-step segments of {self.horizon} samples" if self.horizon else "free run")
            + f" ({self.n_clusters} blocks), residuals {self.n_residuals}, parameters {self.n_free}, "
            f"evaluations {self.nfev}"
            + (f", initial speeds of the {self.shooting_segments} segments fitted too (multiple shooting)"
               if self.shooting_segments else ""),
            f"    RSS {self.rss:.6g}, AIC {self.aic:.6g}, BIC {self.bic:.6g}, success {self.success}",
            "[[Variables]] (95 % CI cluster-robust over the segments; start = rig file)",
        ]
        for parameter in self.parameters.values():
            low, high = parameter.ci95
            lines.append(
                f"    {parameter.name:<26} {parameter.value:12.6g} +/- {parameter.stderr:<10.3g} "
                f"(95 % CI {low:.5g}..{high:.5g}, start {parameter.nominal:.5g}) {parameter.unit}"
            )
        return "\n".join(lines)

    def __repr__(self):
        return (f"<Calibration {' + '.join(self.effects) or 'none'}: RSS {self.rss:.4g}, "
                f"BIC {self.bic:.6g}, {self.n_free} parameters>")

    def to_dict(self):
        """JSON-ready: effects, parameters (:meth:`FitParameter.to_dict`) and the fit statistics."""
        return json_ready({
            "effects": list(self.effects),
            "parameters": {name: parameter.to_dict() for name, parameter in self.parameters.items()},
            "window": list(self.window), "horizon": self.horizon, "n_residuals": self.n_residuals,
            "n_clusters": self.n_clusters, "rss": self.rss, "aic": self.aic, "bic": self.bic, "nfev": self.nfev,
            "success": self.success, "message": self.message, "shooting_segments": self.shooting_segments,
        })


def _free_parameters(model, effects, values0, window, free_run):
    """(name, start, lower, upper, scale, nominal, unit) of the fitted parameters of ``model`` (:class:`TwoMassModel`
    or :class:`RigidBodyModel`).

    ``nominal`` is the rig file's value (plant), the null value (effects) or the
    data's value (initial speeds of a free run, fitted only then).
    """
    measurements, rig = model.measurements, model.rig
    nominal = nominal_values(rig)
    if model.structure == "rigid_body":
        rows = _rigid_rows(model, nominal, window, free_run)
    else:
        rows = _two_mass_rows(model, nominal, window, free_run)
    for key in effects:
        effect = get_effect(key)
        low, high = effect.bounds(rig, measurements)
        rows.append((effect.value_key, low, high, effect.scale(rig, measurements), effect.null, effect.unit))
    return [(name, float(np.clip(values0.get(name, nominal_), low, high)), low, high, scale, nominal_, unit)
            for name, low, high, scale, nominal_, unit in rows]


def _rigid_rows(model, nominal, window, free_run):
    """Rows of :func:`_free_parameters` for the rigid body: its inertia (+-30 %), a free run's initial speed."""
    measurements = model.measurements
    inertia = nominal["inertia"]
    rows = [("inertia", (1 - _RELATIVE_RANGE) * inertia, (1 + _RELATIVE_RANGE) * inertia, inertia, inertia,
             _UNITS["inertia"])]
    if free_run:
        speed_range = float(np.ptp(measurements.speeds)) + 1e-9
        measured = model.speed[window[0]]
        rows.append(("motor_speed0", measured - 0.2 * speed_range, measured + 0.2 * speed_range, 0.01 * speed_range,
                     float(measured), "rad/s"))
    return rows


def _two_mass_rows(model, nominal, window, free_run):
    """Rows of :func:`_free_parameters` for the two-mass drive: plant values, the twist offset (not for
    quasi-static starts), the encoder skew where the twist is measured (k-step fits: a free run's one initial
    twist cannot tell it from the offset), a free run's initial speeds."""
    measurements, rig = model.measurements, model.rig
    rows = []
    for name in PLANT_PARAMETERS:
        value = nominal[name]
        if name == "damping":
            scale = max(value, 1e-4 * nominal["stiffness"])
            rows.append((name, 0.0, 5.0 * scale, scale, value, _UNITS[name]))
        else:
            rows.append((name, (1 - _RELATIVE_RANGE) * value, (1 + _RELATIVE_RANGE) * value, value, value,
                         _UNITS[name]))
    if not model.quasi_static:
        centre, reach = theta_d0_range(measurements, rig)
        rows.append(("theta_d0", centre - reach, centre + reach, 0.25 * reach, centre, "rad"))
    if model.twist_measured and not free_run:  # a free run starts once: held
        skew = _MAX_SKEW_SAMPLES * measurements.dt
        rows.append(("encoder_skew", -skew, skew, 0.25 * measurements.dt, 0.0, _UNITS["encoder_skew"]))
    if free_run:
        speed_range = float(np.ptp(measurements.speeds)) + 1e-9
        data = data_states(measurements, 0.0, [window[0]])[0]
        for name, measured in zip(("motor_speed0", "load_speed0"), data[1:]):
            rows.append((name, measured - 0.2 * speed_range, measured + 0.2 * speed_range, 0.01 * speed_range,
                         float(measured), "rad/s"))
    return rows


def theta_d0_range(measurements, rig):
    """Centre and half width (rad) of the range of the twist offset ``theta_d0``.

    The half width is ``4 alpha`` plus twice the twist of the largest torque;
    the centre is 0, or minus the mean measured twist (the encoders' zeros are
    independent, so the measured twist holds up to an arbitrary constant).
    """
    plant = rig.plant
    reach = 4.0 * plant.half_gap + 2.0 * float(np.max(np.abs(measurements.motor_torque))) / plant.stiffness
    twist = getattr(measurements, "twist", None)
    return (0.0 if twist is None else -float(np.mean(twist))), reach


def cluster_robust_stderr(jacobian, residual, clusters, scales):
    """Cluster-robust standard errors (sandwich over segments) and the t quantile of G - 1 dof.

    Parameters
    ----------
    jacobian : ndarray, shape (n, p)
        Jacobian of the (scaled) residual in the scaled parameters.
    residual : ndarray, shape (n,)
        The residual at the solution.
    clusters : ndarray of int, shape (n,)
        Cluster (segment) of each row, ``0 .. G - 1``.
    scales : ndarray, shape (p,)
        Parameter scales: the errors are returned in the parameters' units.

    Returns
    -------
    stderr : ndarray, shape (p,)
        ``sqrt(diag(B M B))`` times ``scales``, ``B = (J^T J)^+`` and ``M = G/(G-1) sum_g s_g s_g^T``
        with ``s_g`` the sum of ``J_i r_i`` over the cluster's rows.
    quantile : float
        The 97.5 % quantile of Student's t with ``G - 1`` degrees of freedom.
    """
    from scipy.stats import t as student

    bread = np.linalg.pinv(jacobian.T @ jacobian)
    n_clusters = int(clusters.max()) + 1
    weighted = jacobian * residual[:, None]
    scores = np.column_stack([np.bincount(clusters, column, n_clusters) for column in weighted.T])
    meat = scores.T @ scores * n_clusters / max(n_clusters - 1, 1)
    cov = bread @ meat @ bread
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None)) * scales
    return stderr, float(student.ppf(0.975, max(n_clusters - 1, 1)))


def _theta_d0_by_grid(model, values, starts, stops, measured, weights):
    """Starting ``theta_d0`` (rad): the best of a grid over its range (:func:`theta_d0_range`).

    The prediction error is far from convex in theta_d0: a start on the wrong
    side of the gap leads the fit into a local minimum with the half gap at a
    bound, so the fit starts from the global minimum of this 1-D cut.
    """

    def cost(theta_d0):
        states, _ = model.run(values | {"theta_d0": theta_d0}, starts, stops)
        return float(np.sum(((measured - model.speeds_of(states[starts[0]:stops[-1]])) * weights) ** 2))

    centre, reach = theta_d0_range(model.measurements, model.rig)
    grid = centre + np.linspace(-reach, reach, _THETA_GRID_POINTS)
    return float(grid[int(np.argmin([cost(theta) for theta in grid]))])


def calibrate(measurements, rig, effects=(), window=None, start_values=None, horizon=DEFAULT_HORIZON, workers=1,
              max_nfev=None, polish=True, fixed=(), structure="two_mass"):
    """Fit plant values, the twist offset and the effects' parameters to a record.

    Parameters
    ----------
    measurements : Measurements
    rig : Rig
        Torque law and data-sheet values (the start and the +-30 % bounds of
        inertias, stiffness and half gap; damping in ``[0, 5 c]``).
    effects : sequence of str
        Catalogue keys (:data:`~backlash_df.identify.EFFECT_NAMES`) fitted along;
        a single string is one effect.
    window : tuple of int, optional
        Samples ``(start, stop)`` whose residual is minimised (default: all).
    start_values : dict, optional
        Starting values (for example a previous calibration's ``values``); without
        ``theta_d0`` its start is the best point of a grid.
    horizon : float or None
        Length (s) of the k-step segments (module docs); None: one free run.
    workers : int
        Threads computing forward-difference Jacobian columns (the free runs, the rigid body; the
        kernel releases the GIL).
    max_nfev : int, optional
        Limit of optimiser iterations.
    polish : bool
        After the k-step fit, refine by a free run over the window (half of it,
        then all of it, each from the previous solution), with the initial
        speeds fitted too -- but only when the free run of the k-step solution
        does not drift (fit at least :data:`FREE_RUN_MIN` % on every speed).
        The initial state of a short segment is only as good as the noisy data
        at its start, which biases slow effects (friction) a little; a free
        run has no such error, and shows a slow effect at full size.
    fixed : sequence of str
        Names of values kept at their start (for example
        :data:`PLANT_PARAMETERS`, to screen a candidate effect quickly).
    structure : str
        ``two_mass`` (plant values of the rig file, twist offset, and the
        encoder skew where the twist is measured) or ``rigid_body`` (its
        ``inertia``, module docs).

    Returns
    -------
    Calibration

    Notes
    -----
    The residual is ``(y_j - y_hat_j) / std(y_j)`` per measured speed ``j``
    stacked, so that each speed weighs as in its fit percentage.
    """
    with single_threaded_blas():
        return _calibrate(measurements, rig, effects, window, start_values, horizon, workers, max_nfev, polish, fixed,
                          structure)


def single_threaded_blas():
    """A context holding BLAS to one thread: the fits' matrices are small, and BLAS threads
    spinning on a busy machine cost several times the work itself (threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _calibrate(measurements, rig, effects, window, start_values, horizon, workers, max_nfev, polish, fixed,
               structure):
    effects = (effects,) if isinstance(effects, str) else tuple(effects)
    start, stop = window if window is not None else (0, measurements.n_samples)
    model = _model_of(measurements, rig, structure)
    values0 = nominal_values(rig) | {get_effect(key).value_key: get_effect(key).start(rig) for key in effects} \
        | dict(start_values or {})
    if structure == "two_mass" and not model.quasi_static and "theta_d0" not in (start_values or {}):
        k = _horizon_samples(measurements, horizon)
        starts, stops = segment_bounds(start, stop, k)
        measured = measurements.speeds[start:stop]
        weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
        values0["theta_d0"] = _theta_d0_by_grid(model, values0, starts, stops, measured, weights)
    result = _fit(model, effects, (start, stop), values0, horizon, workers, max_nfev, fixed)
    return refine(measurements, rig, result, workers, max_nfev, fixed) if polish and horizon is not None else result


def refine(measurements, rig, calibration, workers=1, max_nfev=None, fixed=()):
    """Refine a k-step calibration by a free run over its window, where the free run does not drift.

    The free run starts from the data's speeds at the window's start, fitted
    too; it is fitted over half the window, then over all of it, each from the
    previous solution.  Returned unchanged when the free run of ``calibration``
    fits less than :data:`FREE_RUN_MIN` % on a speed (closed-loop data drifts).

    The refined values' 95 % intervals are the union of the free run's and the
    k-step fit's: a free-run residual stays correlated over longer than any
    block the data allow, and the two modes' disagreement is model error the
    residual statistics of either do not see.
    """
    start, stop = calibration.window
    free = predict(measurements, rig, calibration.values, window=(start, stop), horizon=None,
                   structure=calibration.structure).fit_percent()
    if not min(free.values()) >= FREE_RUN_MIN:
        return calibration
    model = _model_of(measurements, rig, calibration.structure)
    result, values = calibration, calibration.values
    for fraction in (0.5, 1.0):
        last = start + max(int(round(fraction * (stop - start))), 10)
        result = _fit(model, calibration.effects, (start, last), values, None, workers, max_nfev, fixed)
        values = result.values
    parameters = dict(result.parameters)
    for name, parameter in calibration.parameters.items():  # intervals: the union of both modes'
        if name not in parameters:  # held in the free run (the encoder skew): the k-step fit's
            parameters[name] = parameter
            continue
        low, high = parameters[name].ci95
        parameters[name] = dataclasses.replace(parameters[name], interval=(min(low, parameter.ci95[0]),
                                                                           max(high, parameter.ci95[1])))
    return dataclasses.replace(result, parameters=parameters)


class Shooting:
    """Multiple shooting: corrections of the k-step segments' initial speeds (and of the integrated twist's
    drift), fitted with the model.

    The data's state at a segment's start (:func:`data_states`) is noisy, and a
    fit that starts every segment from it is biased (errors in the variables: a
    torque offset came out 2 % large on speeds with 0.02 rad/s of noise).  So
    each measured speed's initial value is corrected per segment, penalised as a
    measurement of it: ``c / (SMOOTHED_NOISE_SHARE sigma)`` with ``sigma`` the
    speed's noise (:func:`speed_noise`).  The penalty rows are scaled by
    ``residual_rms``, the RMS of the data's (scaled) residual of the fit without
    corrections: where model error, not sensor noise, makes the residual (a real
    drive), the corrections may not absorb it.  A correction moves one segment
    only, so the Jacobian columns of one speed across all segments cost one
    evaluation.

    With ``drift`` (the twist integrated from the speeds, :attr:`TwoMassModel.drifting`)
    the twist at each segment's start is corrected too, as a random walk: the
    integral of the speeds' white noise, whose step over a segment of ``k``
    samples has the standard deviation ``sigma_rw = dt sqrt(k (sigma_m^2 +
    sigma_l^2))`` (raw noise of each speed).  Its prior rows penalise each
    segment's drift against the previous one's (the first against zero: the
    offset ``theta_d0`` is fitted), scaled by ``residual_rms`` as the speeds'.
    The fitted drift is kept in the values (``twist_drift``: the segments' first
    samples and the drift there), so that a prediction beyond the window (the
    validation part) starts from its last value.

    Parameters
    ----------
    measurements : Measurements
        The record (its speeds' noise sets the prior's weights).
    starts, stops : ndarray of int
        The segments' first and one-past-last samples (:func:`segment_bounds`).
    residual_rms : float
        RMS of the data's scaled residual without corrections (the prior rows' scale).
    drift : bool
        Correct the integrated twist's drift too (random walk).
    """

    def __init__(self, measurements, starts, stops, residual_rms, drift=False):
        noise = np.maximum(speed_noise(measurements), 1e-9 * (float(np.ptp(measurements.speeds)) + 1.0))
        self.n_segments = starts.size
        self.states = ([0] if drift else []) + [1 + j for j in range(len(measurements.speed_names))]  # w_m (, w_l)
        raw = noise / math.sqrt(1.0 - SMOOTHED_NOISE_SHARE**2)  # the speeds' noise before smoothing
        step = measurements.dt * math.sqrt(float(np.median(stops - starts)) * float(np.sum(raw**2)))
        self.scales = ([step] if drift else []) + list(SMOOTHED_NOISE_SHARE * noise)
        self.drift = drift
        self.size = len(self.states) * self.n_segments
        self.weight = residual_rms
        # the segment of each data row (the measured speeds stacked), and of each correction
        self.segment_of_row = np.tile(np.repeat(np.arange(starts.size), stops - starts), len(measurements.speed_names))
        self.segment_of_correction = np.tile(np.arange(starts.size), len(self.states))
        self._pattern = None  # (values, indices, indptr) of :meth:`jacobian`'s CSR matrix

    @property
    def scale(self):
        """Scale of each correction in the fit's vector (rad/s)."""
        return np.repeat(self.scales, self.n_segments)

    def corrections(self, x):
        """The (segments, 3) state corrections of the scaled vector ``x``."""
        z = np.zeros((self.n_segments, 3))
        for b, state in enumerate(self.states):
            z[:, state] = x[b * self.n_segments:(b + 1) * self.n_segments] * self.scales[b]
        return z

    def penalty(self, x):
        """The prior's rows: each speed correction against the smoothed speed's noise, each drift step
        against the random walk's."""
        return self.weight * (self.prior_matrix @ x)

    @functools.cached_property
    def prior_matrix(self):
        """The prior's rows as a sparse matrix on the corrections' vector (identity; first differences for
        the drift), built once."""
        from scipy import sparse

        g = self.n_segments
        walk = sparse.identity(g) - sparse.eye(g, k=-1)
        blocks = [walk if state == 0 else sparse.identity(g) for state in self.states]
        return sparse.block_diag(blocks, format="csr")

    def drift_values(self, x, starts, base=None):
        """``twist_drift`` (knots, drift in rad) of the scaled vector ``x``, on top of a ``base`` drift."""
        drift = x[:self.n_segments] * self.scales[0]
        if base is not None:
            drift = drift + np.interp(starts, *base)
        return np.asarray(starts, dtype=float), drift

    def jacobian(self, by_values, by_corrections):
        """The fit's Jacobian (CSR) from its data rows' derivatives: by the values (rows, values) and by
        their own segment's corrections (rows, :attr:`states`), then the prior's rows, exact."""
        from scipy import sparse

        rows, g = by_values.shape
        if self._pattern is None or self._pattern[0] != g:
            width = g + len(self.states)
            own = g + self.n_segments * np.arange(len(self.states)) + self.segment_of_row[:, None]
            columns = np.hstack([np.broadcast_to(np.arange(g), (rows, g)), own]).ravel()
            prior = self.prior_matrix
            self._pattern = (g, np.concatenate([columns, g + prior.indices]),
                             np.concatenate([width * np.arange(rows + 1), rows * width + prior.indptr[1:]]))
        _, indices, indptr = self._pattern
        data = np.concatenate([np.hstack([by_values, by_corrections]).ravel(), self.weight * self.prior_matrix.data])
        return sparse.csr_matrix((data, indices, indptr), shape=(rows + self.size, g + self.size))

    def blocks(self):
        """Index ranges (in the corrections' vector) of each speed's corrections."""
        return [np.arange(b * self.n_segments, (b + 1) * self.n_segments) for b in range(len(self.states))]


def _fit(model, effects, window, values0, horizon, workers, max_nfev, fixed=()):
    """One bounded least-squares fit of the prediction error over ``window``; a :class:`Calibration`.

    A k-step fit of the two-mass model corrects every segment's initial speeds
    (:class:`Shooting`), and without angle columns the integrated twist's drift,
    from the solution without corrections; the corrections are nuisance
    parameters, not reported, but their uncertainty is in every reported interval
    (the sandwich is over all fitted values).  Quasi-static starts (a shaft the
    record does not resolve) take no corrections.
    """
    from scipy.optimize import least_squares  # lazy: keeps `import backlash_df` quick

    measurements = model.measurements
    start, stop = window
    k = _horizon_samples(measurements, horizon)
    starts, stops = segment_bounds(start, stop, k)
    measured = measurements.speeds[start:stop]
    weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
    rows = [row for row in _free_parameters(model, effects, values0, window, horizon is None) if row[0] not in fixed]
    names = [row[0] for row in rows]
    g = len(names)
    scales = np.array([row[4] for row in rows])
    lower = np.array([row[2] for row in rows]) / scales
    upper = np.array([row[3] for row in rows]) / scales
    base = {key: value for key, value in values0.items() if key not in ("motor_speed0", "load_speed0")}
    shooting = None

    def values_of(x):
        return base | dict(zip(names, x[:g] * scales[:g]))

    def residual(x):
        corrections = shooting.corrections(x[g:]) if shooting else None
        states, _ = model.run(values_of(x), starts, stops, corrections)
        data = ((measured - model.speeds_of(states[start:stop])) * weights).ravel(order="F")
        return np.concatenate([data, shooting.penalty(x[g:])]) if shooting else data

    residual = _keeping_the_last(residual)
    x0 = np.array([row[1] for row in rows]) / scales
    if not np.linalg.norm(x0) > _MIN_START_NORM:  # trf's first trust radius is ||x0||: every value at its null
        x0 = np.clip(x0 + _MIN_START_NORM, lower, upper)
    # from the data's states first; from that solution the corrections converge in a few steps

    sensitivities = model.structure == "two_mass" and k is not None  # not a free run (module docs)

    def jacobian(shooting, upper):
        if sensitivities:
            return sensitivity_jacobian(model, names, values_of, scales, window, starts, stops, weights, shooting)
        return parallel_jacobian(residual, g, shooting, upper, workers)

    runs_a_jacobian = 1 if sensitivities else g
    solution = least_squares(residual, x0, bounds=(lower, upper), jac=jacobian(None, upper), method="trf",
                             max_nfev=max_nfev)
    nfev = int(solution.nfev) + int(solution.njev or 0) * runs_a_jacobian
    jacobian_at_solution = solution.jac
    blocks = segment_bounds(start, stop, k or _horizon_samples(measurements, DEFAULT_HORIZON))
    clusters = np.tile(np.repeat(np.arange(blocks[0].size), blocks[1] - blocks[0]), measured.shape[1])
    if k is not None and model.structure == "two_mass" and not model.quasi_static:
        shooting = Shooting(measurements, starts, stops, math.sqrt(float(np.mean(solution.fun**2))), model.drifting)
        free = np.full(shooting.size, np.inf)
        upper = np.concatenate([upper, free])
        solution = least_squares(residual, np.concatenate([solution.x, np.zeros(shooting.size)]),
                                 jac=jacobian(shooting, upper),
                                 bounds=(np.concatenate([lower, -free]), upper), method="trf", x_scale="jac",
                                 max_nfev=max_nfev, tr_solver="lsmr")
        nfev += int(solution.nfev) + int(solution.njev or 0)
        jacobian_at_solution = solution.jac.toarray()
        clusters = np.concatenate([clusters, shooting.segment_of_correction])  # a prior row per correction
        scales = np.concatenate([scales, shooting.scale])
    stderr, quantile = cluster_robust_stderr(jacobian_at_solution, solution.fun, clusters, scales)
    parameters = {
        name: FitParameter(name, float(value), float(err), float(row[5]), float(row[2]), float(row[3]), row[6],
                           quantile)
        for name, value, err, row in zip(names, solution.x[:g] * scales[:g], stderr, rows)
    }
    n = measured.size
    rss = float(solution.fun[:n] @ solution.fun[:n])
    values = {key: value for key, value in values_of(solution.x).items() if key not in ("motor_speed0", "load_speed0")}
    if shooting is not None and shooting.drift:
        values["twist_drift"] = shooting.drift_values(solution.x[g:], starts, base.get("twist_drift"))
    return Calibration(
        effects=tuple(effects), parameters=parameters, values=values, window=(start, stop), horizon=k,
        n_residuals=n, n_clusters=int(blocks[0].size), rss=rss,
        aic=information_criterion(rss, n, len(names), "aic"), bic=information_criterion(rss, n, len(names), "bic"),
        nfev=nfev, success=bool(solution.success), message=str(solution.message),
        shooting_segments=shooting.n_segments if shooting else 0, structure=model.structure,
    )


def _keeping_the_last(residual):
    """``residual`` that answers a call at the point of its previous call from memory.

    scipy's ``least_squares`` calls a callable Jacobian at the point whose residual it
    has just evaluated, without passing that residual on (:func:`parallel_jacobian`
    would simulate it again: a sixth of a diagnosis' simulations).  The point and its
    value are kept as one tuple, so that threads calling it side by side never pair a
    point with another's value.
    """
    last = [None]

    def remembered(x):
        kept = last[0]
        if kept is not None and np.array_equal(kept[0], x):
            return kept[1]
        value = residual(x)
        last[0] = (np.array(x, copy=True), value)
        return value

    return remembered


def sensitivity_jacobian(model, names, values_of, scales, window, starts, stops, weights, shooting=None,
                         rel_step=_INITIAL_STATE_STEP):
    """Jacobian of a two-mass fit's residual from forward sensitivities: one run a Jacobian.

    The residual is :func:`_fit`'s: the data rows ``(measured - predicted) weights``
    over ``window``, speed after speed, then (with ``shooting``) the prior's rows.
    Its derivatives by the scaled values (``x[:len(names)]``, value ``x scales``)
    come from :meth:`TwoMassModel.speed_sensitivities`, those by the corrections
    from the same run's sensitivities to the segments' initial states (a
    correction moves its own segment only), the prior's rows exact.

    Parameters
    ----------
    model : TwoMassModel
    names : sequence of str
        The fitted values, in ``x``'s order.
    values_of : callable
        ``x -> values`` of the model.
    scales : ndarray
        Scale of each of ``names``.
    window : tuple of int
        Samples ``(start, stop)`` of the data rows.
    starts, stops : ndarray of int
        The k-step segments.
    weights : ndarray
        Weight of each measured speed.
    shooting : Shooting, optional
        The corrections' layout.
    rel_step : float
        Relative step of the forward differences of quasi-static initial states by a
        value (:meth:`TwoMassModel.speed_sensitivities`), on the scaled value.

    Returns
    -------
    callable
        ``x -> J``, an ndarray, or a sparse matrix with ``shooting``.
    """
    start, stop = window
    g = len(names)

    def jacobian(x):
        corrections = shooting.corrections(x[g:]) if shooting else None
        steps = rel_step * np.maximum(1.0, np.abs(x[:g])) * scales[:g]
        by_values, by_state = model.speed_sensitivities(values_of(x), starts, stops, names, corrections, steps,
                                                        shooting.states if shooting else ())
        dense = _stacked_rows(by_values[start:stop], weights) * -scales[:g]
        if shooting is None:
            return dense
        return shooting.jacobian(dense, _stacked_rows(by_state[start:stop], weights) * -np.asarray(shooting.scales))

    return jacobian


def _stacked_rows(by_sample, weights):
    """``by_sample`` (samples, speeds, columns) as the residual's data rows (speed after speed), each speed's
    rows times its weight."""
    return (by_sample * weights[None, :, None]).transpose(1, 0, 2).reshape(-1, by_sample.shape[2])


def information_criterion(rss, n, n_free, kind="aic"):
    """AIC ``N ln(RSS/N) + 2 p`` or BIC ``N ln(RSS/N) + p ln N``, as lmfit computes them."""
    penalty = 2.0 * n_free if kind == "aic" else n_free * math.log(n)
    return float(n * math.log(max(rss, 1e-300) / n) + penalty)


def parallel_jacobian(residual, n_global, shooting, upper, workers, rel_step=1e-6):
    """Forward-difference Jacobian whose columns run in ``workers`` threads.

    The first ``n_global`` columns one evaluation each; with ``shooting``
    (:class:`Shooting`), each speed's corrections of all segments in one
    evaluation (a correction moves its own segment's rows only), returned as a
    sparse matrix with the prior's rows exact (the weight times
    :attr:`Shooting.prior_matrix`).

    Parameters
    ----------
    residual : callable
        ``residual(x)``: the data rows, then (with ``shooting``) the prior's rows.
    n_global : int
        Number of leading entries of ``x`` that are model values (the rest: the corrections).
    shooting : Shooting or None
        The corrections' layout.
    upper : ndarray
        Upper bounds of ``x``: a step that would cross one is taken backwards.
    workers : int
        Threads.
    rel_step : float
        Relative forward-difference step.

    Returns
    -------
    callable
        ``x -> J``, an ndarray, or a sparse matrix with ``shooting``.
    """

    groups = [np.array([i]) for i in range(n_global)]
    if shooting is not None:
        groups += [n_global + block for block in shooting.blocks()]

    def jacobian(x, f0=None):
        f0 = residual(x) if f0 is None else f0
        steps = rel_step * np.maximum(1.0, np.abs(x))
        steps = np.where(x + steps > upper, -steps, steps)

        def difference(group):
            shifted = x.copy()
            shifted[group] += steps[group]
            return residual(shifted) - f0

        if workers > 1:
            with ThreadPoolExecutor(workers) as pool:
                differences = list(pool.map(difference, groups))
        else:
            differences = [difference(group) for group in groups]
        dense = np.column_stack([change / steps[group[0]] for group, change in zip(groups[:n_global], differences)])
        if shooting is None:
            return dense
        rows = shooting.segment_of_row.size
        by_correction = np.column_stack([change[:rows] / steps[group[shooting.segment_of_row]]
                                         for group, change in zip(groups[n_global:], differences[n_global:])])
        return shooting.jacobian(dense[:rows], by_correction)

    return jacobian
