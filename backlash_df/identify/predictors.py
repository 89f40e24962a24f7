"""Prediction: the drive model driven by the measured torques, k-step or free run.

The model is the open-loop two-mass drive of the paper (eq. 42) with the
catalogue's effects (:mod:`.effects`)::

    J_m dw_m/dt = T_m(t - tau) + T_0 - T(theta_d, dtheta_d) - F_m(w_m)
    J_l dw_l/dt = T_l(t) + T(theta_d, dtheta_d) - F_l(w_l)
    dtheta_d/dt = w_m - w_l
    F_s(w) = d_s w + (F_c,s + F_b,s exp(-(w / w_s)^2)) tanh(w / eps)

with the rig's torque law ``T`` (the rubber law (40) when ``rubber_thickness``
is positive; the exact model (14) is predicted with its static form, the phase
plane law (23)), the measured commanded torque ``T_m``, the known load
torque ``T_l`` and the friction law ``F_s`` of :mod:`backlash_df.friction` on each
side.  All effect parameters are zero in the nominal structure.  The
smoothing speed ``eps`` and the Stribeck speed ``w_s`` are the values
``coulomb_smoothing`` and ``stribeck_speed`` where given (a diagnosis chooses them,
held in the fit), else 1 % and 5 % of the record's largest speed (:mod:`.effects`).

The **rigid-body model** (``structure="rigid_body"``) is the limit of a shaft
infinitely stiff without play: one inertia ``J = J_m + J_l`` (fitted as
``inertia``) turning at one speed ``w``, predicted for both measured speeds::

    J dw/dt = T_m(t - tau) + T_0 + T_l(t) - F_m(w) - F_l(w)

started at each segment from the momentum-weighted data speed
``(J_m w_m + J_l w_l) / (J_m + J_l)`` (the rig file's inertias).  Both models
hold the same :class:`RecordInputs` of a record (its torques on the kernel's grid,
its smoothed speeds, the friction law's speeds) and run the same interface
(:meth:`TwoMassModel.run`, :meth:`RigidBodyModel.run`).

**Encoder skew.**  Where the twist is measured (both angle columns), the load
encoder may be read later than the motor encoder by ``encoder_skew`` (s; the
link encoder of the KUKA record, ``examples/kuka``, about 3 ms): the measured
twist then holds ``encoder_skew w_l`` besides the elastic twist, so the
segments start from ``theta_d0 + twist - encoder_skew w_l``, with the skew
fitted along (within two samples either way).

**Prediction modes** (as MATLAB's ``compare``).  A *k-step prediction* cuts the
record into segments of ``horizon`` samples; each segment is simulated from the
state the data give at its first sample (:func:`~.signals.data_states`: the smoothed
measured speeds, and theta_d = the measured twist, or the integral of
``w_m - w_l`` without angle columns, plus one fitted offset ``theta_d0``), so no
prediction runs longer than the horizon: an observer-based k-step predictor.
Without angle columns on a shaft whose mode the record does not resolve
(:func:`~.signals.shaft_resolution`: a stiff gear), the integrated twist drifts by more
than the shaft ever twists; each segment then starts *quasi-statically*: both
speeds at the momentum-weighted data speed and the twist whose shaft torque
gives both inertias the same acceleration (the state of the rigid body the
model contains, its fast mode not excited), with no offset fitted.  On
closed-loop data of a position-controlled axis any unmodelled torque piles up as
speed in a long simulation; the k-step prediction cannot drift.  A *free run*
is one segment over the whole window.

The kernels are compiled (numba, fixed-step RK4 with ``substeps`` steps a sample,
inputs interpolated linearly) and run every segment in one call.  The two-mass
model's derivatives by its values come from forward sensitivities riding along
one run (:meth:`TwoMassModel.speed_sensitivities`): the derivative of the discrete
prediction with its modes held, which differences of a small step reproduce.
"""

import dataclasses

import numpy as np

from .._json import json_ready
from ..friction import friction
from .._laws import LAW_CODES, PHASE_PLANE, RUBBER
from ..plotting import ResultPlot, axes_or_new, legend_beside
from ._kernels import (BREAKAWAY_LOAD, BREAKAWAY_MOTOR, COULOMB_LOAD, COULOMB_MOTOR, DELAY, HALF_GAP, KERNEL_VALUES,
                       LOAD_INERTIA, MOTOR_INERTIA, RIGID_BREAKAWAY, RIGID_COULOMB, RIGID_INERTIA, RIGID_OFFSET,
                       RIGID_VISCOUS, RUBBER_THICKNESS, STIFFNESS, TORQUE_OFFSET, VISCOUS_LOAD, VISCOUS_MOTOR,
                       rigid_segments, segment_sensitivities, two_mass_segments)
from .effects import smoothing_speeds
from .signals import measured_twist, shaft_resolution, smoothed_speeds

__all__ = ["PLANT_PARAMETERS", "MODEL_PARAMETERS", "RIGID_PARAMETERS", "STRUCTURES", "DEFAULT_HORIZON",
           "nominal_values", "TwoMassModel", "RigidBodyModel", "Replay", "predict", "replay", "fit_percent"]

#: Plant values of the rig file that calibration adjusts.
PLANT_PARAMETERS = ("motor_inertia", "load_inertia", "stiffness", "damping", "half_gap")
#: Every value the prediction model reads, in the two-mass kernel's order (effects zero by default).
MODEL_PARAMETERS = KERNEL_VALUES
#: Plant value the rigid-body model (``structure="rigid_body"``) fits: the whole drive's inertia.
RIGID_PARAMETERS = ("inertia",)
#: Model structures: the two-mass drive with its shaft, and the rigid body it contains.
STRUCTURES = ("two_mass", "rigid_body")
#: Length of the k-step segments, s.
DEFAULT_HORIZON = 0.1
#: Relative step of the forward differences of a segment's quasi-static initial states by a value (an algebraic
#: function, no simulation: the square root of the double's resolution balances truncation and round-off).
INITIAL_STATE_STEP = 1.5e-8
#: Values that move the initial states of a segment that does not start quasi-statically.
_INITIAL_STATE_VALUES = ("theta_d0", "encoder_skew", "motor_speed0", "load_speed0")
_SUBSTEPS = 2  # RK4 steps per sample


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


def nominal_values(rig):
    """The rig file's plant values as a dictionary of the model's parameters (effects, skew and offset at zero;
    ``inertia``, the rigid body's, ``J_m + J_l``)."""
    plant = rig.plant
    values = dict.fromkeys(MODEL_PARAMETERS, 0.0) | {"actuator_delay": 0.0, "theta_d0": 0.0, "encoder_skew": 0.0,
                                                     "inertia": float(plant.motor_inertia + plant.load_inertia)}
    return values | {name: float(getattr(plant, name)) for name in PLANT_PARAMETERS + ("rubber_thickness",)}


def segment_bounds(start, stop, horizon):
    """``(starts, stops)`` of segments of ``horizon`` samples covering ``start:stop`` (None: one segment)."""
    if horizon is None or horizon >= stop - start:
        return np.array([start]), np.array([stop])
    starts = np.arange(start, stop, horizon)
    if stop - starts[-1] < max(horizon // 2, 2) and starts.size > 1:
        starts = starts[:-1]
    return starts, np.append(starts[1:], stop)


def horizon_samples(measurements, horizon):
    """Samples of a k-step segment of ``horizon`` seconds in the record (at least 5; None: a free run)."""
    return None if horizon is None else max(int(round(horizon / measurements.dt)), 5)


def _law_code(rig_law, values):
    """The kernel's law code: the rubber law (40) where the values give a rubber band or the rig names it, the
    static phase plane law (23) for the exact model (14), else the rig's law."""
    if values.get("rubber_thickness", 0.0) > 0.0 or rig_law == "rubber":
        return RUBBER
    code = LAW_CODES[rig_law]
    return PHASE_PLANE if rig_law == "exact" else code


class RecordInputs:
    """What the two-mass and the rigid-body model take from a record, computed once.

    Parameters
    ----------
    measurements : Measurements
        The record.

    Attributes
    ----------
    speeds : ndarray, shape (N, speeds)
        The smoothed measured speeds (:func:`~.signals.smoothed_speeds`), rad/s: the segments' starts.
    load_torque : ndarray
        The known load torque (zero without the column), N m.
    t_rel : ndarray
        Time from the first sample, s.
    eps, w_s : float
        The catalogue's smoothing and Stribeck speeds of the record (:func:`~.effects.smoothing_speeds`), rad/s.
    """

    def __init__(self, measurements):
        self.measurements = measurements
        self.eps, self.w_s = smoothing_speeds(measurements)
        self.speeds = smoothed_speeds(measurements)
        self.load_torque = np.ascontiguousarray(measurements.load_torque_or_zero, dtype=float)
        self.t_rel = measurements.time - measurements.time[0]

    def motor_torque(self, delay):
        """Commanded motor torque delayed by the actuator dead time (N m), on the record's grid."""
        torque = self.measurements.motor_torque
        return np.ascontiguousarray(torque if delay <= 0.0 else np.interp(self.t_rel - delay, self.t_rel, torque))

    def motor_torque_rate(self, delay):
        """Derivative of :meth:`motor_torque` by the delay (N m/s): minus the commanded torque's slope at
        ``t - delay``, the slope of the interval below a sample (a delay's forward step lands there), zero
        before the record."""
        torque = self.measurements.motor_torque
        slopes = np.concatenate([[0.0], np.diff(torque) / np.diff(self.t_rel)])
        return np.ascontiguousarray(-slopes[np.searchsorted(self.t_rel, self.t_rel - max(delay, 0.0), side="left")])

    def friction_speeds(self, values):
        """The friction law's smoothing speed ``eps`` and Stribeck speed ``w_s`` (rad/s):
        ``values["coulomb_smoothing"]`` and ``values["stribeck_speed"]`` where a diagnosis chose them, else the
        catalogue's (:data:`~.effects.COULOMB_SMOOTHING` and :data:`~.effects.STRIBECK_SPEED` of the record's
        largest speed)."""
        return float(values.get("coulomb_smoothing", self.eps)), float(values.get("stribeck_speed", self.w_s))

    def speeds_of(self, states):
        """Columns of a model's ``states`` (N, 3) matching the measured speeds."""
        return states[:, 1:1 + len(self.measurements.speed_names)]


class TwoMassModel:
    """The two-mass model of a record, ready to predict any window with any values (the kernel's inputs cached).

    :func:`predict` and :func:`~.calibrate.calibrate` build one per record (:func:`prediction_model`); it is
    public so that a test can run the very model a fit runs (:meth:`run`).

    Parameters
    ----------
    measurements : Measurements
        The record.
    rig : Rig
        Plant and torque law.

    Attributes
    ----------
    inputs : RecordInputs
        The record's torques, smoothed speeds and friction speeds.
    quasi_static : bool
        Segments start on the rigid body's state (module docs): no angle columns and the
        shaft's mode not resolved (:func:`~.signals.shaft_resolution`).
    drifting : bool
        The twist is integrated from both speeds, its drift fitted (:class:`~.calibrate.Shooting`).
    """

    structure = "two_mass"

    def __init__(self, measurements, rig):
        self.measurements, self.rig = measurements, rig
        self.inputs = RecordInputs(measurements)
        self.twist = measured_twist(measurements)
        self.twist_measured = getattr(measurements, "twist", None) is not None
        self.quasi_static = not self.twist_measured and not shaft_resolution(measurements, rig).resolved
        self.drifting = not self.twist_measured and not self.quasi_static and measurements.load_speed is not None

    def run(self, values, starts, stops, corrections=None):
        """Simulate segments from the data's states (plus ``corrections``, shape (segments, 3), the
        multiple-shooting corrections of :class:`~.calibrate.Shooting`); (states, torque) on the whole
        record's grid (rows outside the segments are zero)."""
        p = self.kernel_values(values)
        n = self.measurements.n_samples
        states = np.zeros((n, 3))
        torque = np.zeros(n)
        two_mass_segments(_law_code(self.rig.model, values), p, *self.inputs.friction_speeds(values),
                          self.inputs.motor_torque(values.get("actuator_delay", 0.0)), self.inputs.load_torque,
                          starts.astype(np.int64), stops.astype(np.int64),
                          self.initial_states(values, p, starts, corrections), _SUBSTEPS, states, torque)
        return states, torque

    def speeds_of(self, states):
        """Columns of ``states`` matching the measured speeds."""
        return self.inputs.speeds_of(states)

    def kernel_values(self, values):
        """The kernel's vector: :data:`MODEL_PARAMETERS` of ``values`` (the rubber band at most the gap,
        ``beta <= 2 alpha``) and the sample interval."""
        p = np.array([float(values[name]) for name in MODEL_PARAMETERS] + [self.measurements.dt])
        p[RUBBER_THICKNESS] = min(p[RUBBER_THICKNESS], 2.0 * p[HALF_GAP])
        return p

    def initial_states(self, values, p, starts, corrections=None):
        """The segments' initial states (segments, 3): the data's (module docs), quasi-static or from the
        twist, plus ``corrections``; a free run's fitted initial speeds."""
        speeds = self.inputs.speeds
        if self.quasi_static:
            z0 = self._quasi_static_states(values, p, starts)
        else:
            twist = values["theta_d0"] + self.twist[starts] - values.get("encoder_skew", 0.0) * speeds[starts, -1]
            if self.drifting and "twist_drift" in values:  # the fitted drift, its last value beyond its knots
                twist = twist + np.interp(starts, *values["twist_drift"])
            z0 = np.column_stack([twist, speeds[starts, 0], speeds[starts, -1]])
        if corrections is not None:
            z0 += corrections
        for column, name in ((1, "motor_speed0"), (2, "load_speed0")):
            if name in values:  # fitted initial speeds of a free run
                z0[0, column] = values[name]
        return np.ascontiguousarray(z0)

    def speed_sensitivities(self, values, starts, stops, names, corrections=None, steps=None, initial=()):
        """Derivatives of the predicted speeds by ``values[names]`` and by the segments' ``initial`` states.

        Forward sensitivities (``_kernels.segment_sensitivities``): one run gives every column.
        A value that moves the initial states does so through
        :meth:`initial_states`: linearly (the twist offset, the encoder skew, a
        free run's initial speeds), or, from a quasi-static start, every value,
        differentiated by forward differences of ``steps`` (default
        :data:`INITIAL_STATE_STEP` ``max(1, |value|)``; no simulation).

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
            steps = [INITIAL_STATE_STEP * max(1.0, abs(float(values[name]))) for name in names]
        shifts = self._initial_shifts(values, p, starts, corrections, z0, names, steps)
        requested = len(initial)
        moved = {int(r) for shift in shifts.values() for r in np.flatnonzero(np.any(shift, axis=0))}
        initial = list(initial) + sorted(moved - set(initial))
        clipped = float(values["rubber_thickness"]) > 2.0 * float(values["half_gap"])  # beta = 2 alpha
        codes = {name: DELAY if name == "actuator_delay" else MODEL_PARAMETERS.index(name)
                 for name in names if name in MODEL_PARAMETERS or name == "actuator_delay"}
        columns = sorted(set(codes.values()) | ({RUBBER_THICKNESS} if clipped and "half_gap" in names else set()))
        delay = values.get("actuator_delay", 0.0)
        n, speeds, width = self.measurements.n_samples, len(self.measurements.speed_names), len(columns) + len(initial)
        out = np.zeros((n, 2, width))
        inputs = self.inputs
        segment_sensitivities(_law_code(self.rig.model, values), p, *inputs.friction_speeds(values),
                              inputs.motor_torque(delay),
                              inputs.motor_torque_rate(delay) if DELAY in columns else inputs.load_torque,
                              inputs.load_torque, starts, stops, z0, _SUBSTEPS, np.array(columns, dtype=np.int64),
                              np.array(initial, dtype=np.int64), np.zeros((11, width)), out)
        by_state = out[:, :speeds, len(columns):]
        segment = np.repeat(np.arange(starts.size), stops - starts)
        by_values = np.zeros((n, speeds, len(names)))
        for j, name in enumerate(names):
            if name in codes and not (clipped and name == "rubber_thickness"):
                by_values[:, :, j] = out[:, :speeds, columns.index(codes[name])]
            if clipped and name == "half_gap":
                by_values[:, :, j] += 2.0 * out[:, :speeds, columns.index(RUBBER_THICKNESS)]
            if name in shifts:  # through the initial states
                rows = slice(starts[0], stops[-1])
                by_values[rows, :, j] += np.einsum("isk,ik->is", by_state[rows],
                                                   shifts[name][segment][:, initial])
        return by_values, by_state[:, :, :requested]

    def _initial_shifts(self, values, p, starts, corrections, z0, names, steps):
        """``d z0 / d value`` (segments, 3) of each of ``names`` that moves the initial states ``z0``
        (:meth:`speed_sensitivities`)."""
        shifts = {}
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
                    shifts[name][:, 0] = -self.inputs.speeds[starts, -1]
                else:
                    shifts[name][0, 1 if name == "motor_speed0" else 2] = 1.0
        return shifts

    def _quasi_static_states(self, values, p, starts):
        """Segment starts on the rigid body's state: both speeds at the momentum-weighted data speed ``w``, and
        the twist whose shaft torque ``T_s = (J_l (T_m + T_0 - F_m(w)) - J_m (T_l - F_l(w))) / (J_m + J_l)``
        accelerates both inertias alike, through the dead zone's inverse ``T_s / k + alpha tanh(T_s / (k alpha))``
        (the jump across the gap smoothed over the torque ``k alpha``)."""
        k, alpha = p[STIFFNESS], p[HALF_GAP]
        shaft = self._quasi_static_shaft_torque(values, p, starts)
        twist = shaft / k + alpha * np.tanh(shaft / max(k * alpha, 1e-12))
        w = self._momentum_speed(p, starts)
        return np.column_stack([twist, w, w])

    def _momentum_speed(self, p, starts):
        """The data's momentum-weighted speed ``(J_m w_m + J_l w_l) / (J_m + J_l)`` at ``starts`` (rad/s)."""
        speeds = self.inputs.speeds
        return (p[MOTOR_INERTIA] * speeds[starts, 0] + p[LOAD_INERTIA] * speeds[starts, -1]) / (
            p[MOTOR_INERTIA] + p[LOAD_INERTIA])

    def _quasi_static_shaft_torque(self, values, p, starts):
        """``T_s`` of :meth:`_quasi_static_states` at ``starts`` (N m)."""
        jm, jl = p[MOTOR_INERTIA], p[LOAD_INERTIA]
        w = self._momentum_speed(p, starts)
        eps, w_s = self.inputs.friction_speeds(values)
        motor = (self.inputs.motor_torque(values.get("actuator_delay", 0.0))[starts] + p[TORQUE_OFFSET]
                 - friction(w, p[VISCOUS_MOTOR], p[COULOMB_MOTOR], p[BREAKAWAY_MOTOR], eps, w_s))
        load = self.inputs.load_torque[starts] - friction(w, p[VISCOUS_LOAD], p[COULOMB_LOAD], p[BREAKAWAY_LOAD], eps,
                                                          w_s)
        return (jl * motor - jm * load) / (jm + jl)

    def _quasi_static_by_delay(self, values, p, starts):
        """``d z0 / d(actuator delay)`` of :meth:`_quasi_static_states` (rad/s, 0, 0): the motor torque's
        rate (:meth:`RecordInputs.motor_torque_rate`) through ``T_s`` and the inverse dead zone."""
        jm, jl, k, alpha = p[MOTOR_INERTIA], p[LOAD_INERTIA], p[STIFFNESS], p[HALF_GAP]
        shaft = self._quasi_static_shaft_torque(values, p, starts)
        by_shaft = (2.0 - np.tanh(shaft / max(k * alpha, 1e-12)) ** 2) / k
        rate = self.inputs.motor_torque_rate(values.get("actuator_delay", 0.0))[starts]
        shift = np.zeros((starts.size, 3))
        shift[:, 0] = by_shaft * jl / (jm + jl) * rate
        return shift


class RigidBodyModel:
    """The rigid-body model of a record (module docs), with :class:`TwoMassModel`'s interface: it takes the same
    values (the inertia ``inertia``, and each friction of both sides summed) and returns its states as
    ``(0, w, w)`` (no twist, one speed for both measured speeds, started from the momentum-weighted speed
    ``(J_m w_m + J_l w_l) / (J_m + J_l)`` of the data at a segment's start).

    Parameters
    ----------
    measurements : Measurements
        The record.
    rig : Rig
        Plant (the inertias that weigh the starting speed).

    Attributes
    ----------
    inputs : RecordInputs
        The record's torques, smoothed speeds and friction speeds.
    speed : ndarray
        The data's momentum-weighted speed at every sample, rad/s.
    """

    structure = "rigid_body"

    def __init__(self, measurements, rig):
        self.measurements, self.rig = measurements, rig
        self.inputs = RecordInputs(measurements)
        plant, speeds = rig.plant, self.inputs.speeds
        self.speed = np.ascontiguousarray((plant.motor_inertia * speeds[:, 0] + plant.load_inertia * speeds[:, -1])
                                          / (plant.motor_inertia + plant.load_inertia))

    def run(self, values, starts, stops, corrections=None):
        """Simulate segments from the data's momentum-weighted speed; (states, torque) as :meth:`TwoMassModel.run`
        (the shaft torque is zero: the rigid body has no shaft; no corrections)."""
        p = np.empty(5)
        p[RIGID_INERTIA], p[RIGID_OFFSET] = float(values["inertia"]), float(values["torque_offset"])
        for index, name in ((RIGID_COULOMB, "coulomb_friction"), (RIGID_VISCOUS, "viscous_friction"),
                            (RIGID_BREAKAWAY, "breakaway_friction")):
            p[index] = float(values[f"{name}_motor"] + values[f"{name}_load"])
        w0 = self.speed[starts].copy()
        if "motor_speed0" in values:  # fitted initial speed of a free run
            w0[0] = values["motor_speed0"]
        n = self.measurements.n_samples
        speed = np.zeros(n)
        rigid_segments(p, *self.inputs.friction_speeds(values), self.measurements.dt,
                       self.inputs.motor_torque(values.get("actuator_delay", 0.0)), self.inputs.load_torque,
                       starts.astype(np.int64), stops.astype(np.int64), w0, _SUBSTEPS, speed)
        states = np.zeros((n, 3))
        states[:, 1] = states[:, 2] = speed
        return states, np.zeros(n)

    def speeds_of(self, states):
        """Columns of ``states`` matching the measured speeds."""
        return self.inputs.speeds_of(states)


def prediction_model(measurements, rig, structure="two_mass"):
    """The :class:`TwoMassModel` (``two_mass``) or :class:`RigidBodyModel` (``rigid_body``) of a record.

    Raises
    ------
    ValueError
        Unknown structure, naming :data:`STRUCTURES`.
    """
    if structure not in STRUCTURES:
        raise ValueError(f"unknown model structure {structure!r}; one of {', '.join(STRUCTURES)}")
    return RigidBodyModel(measurements, rig) if structure == "rigid_body" else TwoMassModel(measurements, rig)


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
        data's state (:func:`~.signals.data_states`); None for one free run over the window.
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
    k = horizon_samples(measurements, horizon)
    model = prediction_model(measurements, rig, structure)
    kb = k if block is None or k is None else min(horizon_samples(measurements, block), k)
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
