"""Replay and calibration: the drive model driven by the measured torques.

The model is the open-loop two-mass drive of the paper (eq. 42)::

    J_m dw_m/dt = T_m(t - tau) - T(theta_d, dtheta_d) - F_m
    J_l dw_l/dt = T_l(t) + T(theta_d, dtheta_d) - d_l w_l - F_c tanh(w_l / eps)
    dtheta_d/dt = w_m - w_l

with the rig's torque law ``T`` (the rubber law (40) for the ``rubber``
candidate), the measured commanded torque ``T_m`` and the known load torque
``T_l``.  The effect parameters (``tau``, ``d_l``, ``F_c``, ``beta``) are zero in
the nominal structure.  Replay is a *free-run simulation* (no measured speed is
fed back) from an initial state ``(theta_d0, w_m0, w_l0)`` estimated from the
data, on the record's own grid (RK4 with located contact switches, see
:mod:`backlash_df.simulate`).

Calibration fits the plant values of the rig file (data-sheet values, a few per
cent off), the initial state and the effect parameter by bounded nonlinear least
squares (:func:`scipy.optimize.least_squares`, trust region reflective) on an
estimation part of the record.  Standard errors come from the Jacobian at the
optimum the lmfit way, ``cov = s^2 (J^T J)^-1`` with ``s^2 = RSS / (N - p)``,
inflated for the residual's autocorrelation (AR(1) effective sample size
``N (1 - rho_1) / (1 + rho_1)``): free-run residuals are far from white.
"""

import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.optimize import least_squares

from ..models import make_model
from ..simulate import simulate_linear, two_mass_system
from .effects import COULOMB_SMOOTHING_SPEED, get_effect

__all__ = [
    "FitParameter",
    "Calibration",
    "Replay",
    "PLANT_PARAMETERS",
    "STATE_PARAMETERS",
    "nominal_values",
    "estimate_initial_state",
    "replay",
    "calibrate",
    "fit_percent",
    "information_criterion",
    "data_state",
    "segment_replay",
    "smoothed_speeds",
    "integrated_displacement",
]

#: Plant values of the rig file that calibration adjusts.
PLANT_PARAMETERS = ("motor_inertia", "load_inertia", "stiffness", "damping", "half_gap")
#: Initial state fitted with them: theta_d (rad), motor and load speed (rad/s) at the first sample.
STATE_PARAMETERS = ("theta_d0", "motor_speed0", "load_speed0")
_UNITS = {
    "motor_inertia": "kg m^2", "load_inertia": "kg m^2", "stiffness": "N m/rad", "damping": "N m s/rad",
    "half_gap": "rad", "theta_d0": "rad", "motor_speed0": "rad/s", "load_speed0": "rad/s",
}
_RELATIVE_RANGE = 0.3  # data-sheet values are trusted to +-30 %
_Z95 = 1.959963984540054
_POLISH_NFEV = 30  # iterations of each free-run refinement step (it starts next to its optimum)
_POLISH_FRACTIONS = (0.25, 0.5, 1.0)  # growing windows of the free-run refinement
_THETA_GRID_POINTS = 33  # starting theta_d0 searched on a grid of step alpha / 4


def fit_percent(measured, simulated):
    """Fit percentage as MATLAB's ``compare``: ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)``.

    100 is a perfect fit, 0 is no better than the mean, negative is worse.

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


@dataclasses.dataclass(frozen=True)
class FitParameter:
    """A fitted (or fixed) parameter with its uncertainty.

    Attributes
    ----------
    name, unit : str
    value : float
        Best-fit value.
    stderr : float
        Standard error (NaN when not estimable).
    nominal : float
        Starting value (the rig file's value for plant parameters).
    lower, upper : float
        Bounds of the fit.
    """

    name: str
    value: float
    stderr: float
    nominal: float
    lower: float
    upper: float
    unit: str = ""

    @property
    def ci95(self):
        """95 % confidence interval ``value -+ 1.96 stderr`` (asymptotic, normal)."""
        return (self.value - _Z95 * self.stderr, self.value + _Z95 * self.stderr)

    def __repr__(self):
        low, high = self.ci95
        return f"<FitParameter {self.name} = {self.value:.6g} +/- {self.stderr:.3g} {self.unit} (95 % CI {low:.4g}..{high:.4g})>"


@dataclasses.dataclass(frozen=True)
class Replay:
    """Free-run simulation of the model from the measured torques.

    Attributes
    ----------
    time : ndarray
        Sample instants, s (the record's).
    simulated : ndarray
        Simulated speeds, shape (N, number of measured speeds), rad/s.
    measured : ndarray
        Measured speeds, same shape.
    names : tuple of str
        Names of the speed columns.
    result : SimulationResult
        The full simulation (states, theta_d, shaft torque, modes).
    """

    time: np.ndarray
    simulated: np.ndarray
    measured: np.ndarray
    names: tuple
    result: object

    @property
    def residual(self):
        """Measured minus simulated speeds, rad/s."""
        return self.measured - self.simulated

    def fit_percent(self, start=0, stop=None):
        """Fit percentage of each speed on samples ``start:stop``, as a dict."""
        window = slice(start, stop)
        return {
            name: fit_percent(self.measured[window, j], self.simulated[window, j])
            for j, name in enumerate(self.names)
        }

    def rms(self, start=0, stop=None):
        """RMS of each speed's residual on samples ``start:stop`` (rad/s), as a dict."""
        window = slice(start, stop)
        return {name: float(np.sqrt(np.mean(self.residual[window, j] ** 2))) for j, name in enumerate(self.names)}

    def plot(self, axes=None, label="simulated"):
        """Measured against simulated speeds; returns the axes (one per speed)."""
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(len(self.names), 1, sharex=True, figsize=(8, 2.2 * len(self.names)), squeeze=False)
            axes = axes[:, 0]
        for j, name in enumerate(self.names):
            axes[j].plot(self.time, self.measured[:, j], color="0.6", lw=1.0, label="measured")
            axes[j].plot(self.time, self.simulated[:, j], lw=1.0, label=label)
            axes[j].set_ylabel(f"{name} (rad/s)")
            axes[j].legend(loc="upper right", fontsize="small")
        axes[-1].set_xlabel("time (s)")
        return axes


def nominal_values(rig):
    """The rig file's plant values as a dictionary of the model's parameters."""
    plant = rig.plant
    return {name: float(getattr(plant, name)) for name in PLANT_PARAMETERS} | {
        "rubber_thickness": float(plant.rubber_thickness)
    }


def estimate_initial_state(measurements, values, window=20):
    """Initial state ``(theta_d0, w_m0, w_l0)`` estimated from the first samples.

    The speeds are the means of the first ``window`` samples (corrected to the
    first instant with their fitted slope).  The shaft torque follows from the
    load's momentum balance ``T = J_l dw_l/dt - T_l`` (or the motor's,
    ``T = T_m - J_m dw_m/dt``, without a load speed), and ``theta_d0`` from the
    torque law in contact, ``theta_d = +-alpha + T / k`` (0 inside the gap when T
    is below the noise).
    """
    window = min(window, measurements.n_samples)
    t = measurements.time[:window] - measurements.time[0]

    def start_and_slope(signal):
        slope, intercept = np.polyfit(t, signal[:window], 1)
        return float(intercept), float(slope)

    motor0, motor_slope = start_and_slope(measurements.motor_speed)
    if measurements.load_speed is not None:
        load0, load_slope = start_and_slope(measurements.load_speed)
        torque = values["load_inertia"] * load_slope - measurements.load_torque_or_zero[0]
    else:
        load0 = motor0
        torque = measurements.motor_torque[0] - values["motor_inertia"] * motor_slope
    alpha, k = values["half_gap"], values["stiffness"]
    theta0 = math.copysign(alpha, torque) + torque / k if abs(torque) > 1e-3 * k * alpha else 0.0
    return {"theta_d0": theta0, "motor_speed0": motor0, "load_speed0": load0}


def _law_for(rig_law, values):
    return "rubber" if values.get("rubber_thickness", 0.0) > 0.0 or rig_law == "rubber" else rig_law


def _drive_system(values):
    system = two_mass_system(values["motor_inertia"], values["load_inertia"], load_damping=values.get("viscous_friction", 0.0))
    friction = values.get("coulomb_friction", 0.0)
    if friction > 0.0:
        system = dataclasses.replace(
            system, friction=friction, friction_speed=COULOMB_SMOOTHING_SPEED,
            f=np.array([0.0, 0.0, 1.0]), e_f=np.array([0.0, 0.0, 1.0 / values["load_inertia"]]),
        )
    return system


def _applied_motor_torque(measurements, values):
    """Commanded motor torque delayed by the actuator dead time (N m), on the record's grid."""
    delay = values.get("actuator_delay", 0.0)
    if delay <= 0.0:
        return measurements.motor_torque
    t_rel = measurements.time - measurements.time[0]
    return np.interp(t_rel - delay, t_rel, measurements.motor_torque)


def _simulate(measurements, rig_law, values, start, stop, z0, motor_torque=None):
    """Free-run simulation over samples ``start:stop`` from state ``z0``; a SimulationResult."""
    motor_torque = _applied_motor_torque(measurements, values) if motor_torque is None else motor_torque
    inputs = np.column_stack([motor_torque[start:stop], measurements.load_torque_or_zero[start:stop]])
    law = _law_for(rig_law, values)
    beta = min(values.get("rubber_thickness", 0.0), 2.0 * values["half_gap"]) if law == "rubber" else 0.0
    model = make_model(law, stiffness=values["stiffness"], damping=values["damping"],
                       half_gap=values["half_gap"], rubber_thickness=beta)
    theta_b0 = values.get("theta_b0", math.nan) if start == 0 else math.nan
    if not abs(theta_b0) <= values["half_gap"]:  # unknown: the limited integrator's value at theta_d0
        theta_b0 = float(np.clip(z0[0], -values["half_gap"], values["half_gap"]))
    dt = measurements.dt
    return simulate_linear(_drive_system(values), model, (stop - start - 1) * dt, dt, inputs=inputs,
                           z0=np.asarray(z0, dtype=float), theta_b0=theta_b0)


def replay(measurements, rig, values=None, n_samples=None):
    """Free-run simulation of the rig's model driven by the measured torques.

    Parameters
    ----------
    measurements : Measurements
    rig : Rig
        Torque law (``[model] backlash``) and data-sheet plant values.
    values : dict, optional
        Parameter values overriding the rig's: any of :data:`PLANT_PARAMETERS`,
        :data:`STATE_PARAMETERS`, ``rubber_thickness`` (rad), ``coulomb_friction``
        (N m), ``viscous_friction`` (N m s/rad), ``actuator_delay`` (s), and for
        the exact law ``theta_b0`` (rad; default ``theta_d0`` clipped to the gap).  A missing
        initial state is estimated with :func:`estimate_initial_state`.
    n_samples : int, optional
        Simulate the first ``n_samples`` samples only (default: all).

    Returns
    -------
    Replay
    """
    values = nominal_values(rig) | dict(values or {})
    if not all(name in values for name in STATE_PARAMETERS):
        values = estimate_initial_state(measurements, values) | values
    n = measurements.n_samples if n_samples is None else int(n_samples)
    z0 = [values[name] for name in STATE_PARAMETERS]
    result = _simulate(measurements, rig.model, values, 0, n, z0)
    columns = {"motor_speed": 1, "load_speed": 2}
    simulated = np.column_stack([result.states[:, columns[name]] for name in measurements.speed_names])
    return Replay(
        time=measurements.time[:n], simulated=simulated, measured=measurements.speeds[:n],
        names=measurements.speed_names, result=result,
    )


@dataclasses.dataclass(frozen=True, repr=False)
class Calibration:
    """Result of :func:`calibrate`: parameters with uncertainties and fit statistics.

    Attributes
    ----------
    effect : str
        Catalogue entry fitted (``none`` for the nominal structure).
    parameters : dict
        Name -> :class:`FitParameter`, plant, initial state and the effect's.
    values : dict
        Name -> best-fit value, ready for :func:`replay`.
    window : tuple of int
        Samples ``start:stop`` whose residual was minimised.
    n_residuals : int
        Number of scaled residuals (samples times measured speeds).
    rss : float
        Residual sum of squares of the scaled residual at the optimum.
    aic, bic : float
        ``N ln(RSS / N) + 2 p`` and ``N ln(RSS / N) + p ln N`` on the estimation part.
    nfev : int
        Simulations run by the optimiser (Jacobian columns included).
    success : bool
    message : str
    """

    effect: str
    parameters: dict
    values: dict
    window: tuple
    n_residuals: int
    rss: float
    aic: float
    bic: float
    nfev: int
    success: bool
    message: str

    @property
    def n_free(self):
        """Number of fitted parameters."""
        return len(self.parameters)

    @property
    def effect_parameter(self):
        """The effect's :class:`FitParameter` (None for ``none``)."""
        name = get_effect(self.effect).parameter
        return self.parameters.get(name) if name else None

    def fit_report(self):
        """A printable report of parameters, standard errors and statistics, lmfit style."""
        lines = [
            f"[[Calibration: {self.effect}]]",
            f"    samples {self.window[0]}:{self.window[1]}, residuals {self.n_residuals}, "
            f"parameters {self.n_free}, simulations {self.nfev}, success {self.success}",
            f"    RSS {self.rss:.6g}, AIC {self.aic:.6g}, BIC {self.bic:.6g}",
            "[[Variables]]",
        ]
        for parameter in self.parameters.values():
            low, high = parameter.ci95
            lines.append(
                f"    {parameter.name:<18} {parameter.value:12.6g} +/- {parameter.stderr:<10.3g} "
                f"(95 % CI {low:.5g}..{high:.5g}, start {parameter.nominal:.5g}) {parameter.unit}"
            )
        return "\n".join(lines)

    def __repr__(self):
        return f"<Calibration {self.effect}: RSS {self.rss:.4g}, AIC {self.aic:.6g}, {self.n_free} parameters>"


def _free_parameters(measurements, rig, effect, start_values, segmented):
    """(name, start, lower, upper, scale, unit) of the fitted parameters."""
    nominal = nominal_values(rig)
    speed_range = float(np.ptp(measurements.speeds)) + 1.0
    rows = []
    for name in PLANT_PARAMETERS:
        value = nominal[name]
        if name == "damping":
            scale = max(value, 1e-4 * nominal["stiffness"])
            rows.append((name, start_values[name], 0.0, 5.0 * scale, scale))
        else:
            rows.append((name, start_values[name], (1 - _RELATIVE_RANGE) * value, (1 + _RELATIVE_RANGE) * value, value))
    alpha = nominal["half_gap"]
    rows.append(("theta_d0", start_values["theta_d0"], -4.0 * alpha, 4.0 * alpha, alpha))
    if not segmented:
        for name in ("motor_speed0", "load_speed0"):
            rows.append((name, start_values[name], start_values[name] - 0.2 * speed_range,
                         start_values[name] + 0.2 * speed_range, 0.01 * speed_range))
    if effect.parameter:
        low, high = effect.bounds(rig, measurements)
        start = start_values.get(effect.parameter, effect.initial(rig, measurements))
        rows.append((effect.parameter, start, low, high, effect.scale(rig, measurements)))
    return [(name, float(np.clip(start, low, high)), low, high, scale, _UNITS.get(name, effect.unit))
            for name, start, low, high, scale in rows]


def _stderr(jacobian, residual, n_free, scales):
    """Standard errors from the Jacobian, inflated for AR(1)-correlated residuals."""
    n = residual.size
    dof = max(n - n_free, 1)
    s2 = float(residual @ residual) / dof
    rho = float(np.clip(np.corrcoef(residual[:-1], residual[1:])[0, 1], 0.0, 0.999)) if n > 2 else 0.0
    inflation = (1.0 + rho) / (1.0 - rho)
    cov = np.linalg.pinv(jacobian.T @ jacobian) * s2 * inflation
    return np.sqrt(np.clip(np.diag(cov), 0.0, None)) * scales


def smoothed_speeds(measurements, window=11):
    """Measured speeds smoothed by a Savitzky-Golay filter (order 2), rad/s, shape (N, m)."""
    window = min(window, measurements.n_samples - (1 - measurements.n_samples % 2))
    from scipy.signal import savgol_filter  # lazy: scipy.signal takes a second to import

    return savgol_filter(measurements.speeds, window, 2, axis=0)


def integrated_displacement(measurements):
    """``int_0^t (w_m - w_l) dt`` from the measured speeds (rad): theta_d up to its offset."""
    relative = measurements.motor_speed - measurements.load_speed
    return np.concatenate([[0.0], np.cumsum(0.5 * (relative[1:] + relative[:-1]))]) * measurements.dt


def data_state(measurements, theta_d0, sample):
    """State ``(theta_d, w_m, w_l)`` at ``sample`` estimated from the data.

    Speeds are the smoothed measured speeds; theta_d is ``theta_d0`` (its value
    at the first sample) plus the integral of the measured ``w_m - w_l``.
    """
    speeds = smoothed_speeds(measurements)
    theta = theta_d0 + integrated_displacement(measurements)[sample]
    return np.array([theta, speeds[sample, 0], speeds[sample, -1]])


def _segment_bounds(start, stop, horizon):
    edges = list(range(start, stop, horizon))
    if len(edges) > 1 and stop - edges[-1] < horizon // 2:
        edges.pop()
    return list(zip(edges, edges[1:] + [stop]))


def segment_replay(measurements, rig, values, window, horizon=0.2):
    """Simulated speeds over ``window`` in segments of ``horizon`` s, each from the data's state.

    Each segment is a free-run simulation started from :func:`data_state` at its
    first sample (``values["theta_d0"]`` the offset of theta_d): a
    ``horizon``-long prediction, the k-step prediction mode of system
    identification with k = horizon / dt.  Needs the load speed.

    Returns
    -------
    ndarray
        Shape (stop - start, number of measured speeds), rad/s.
    """
    start, stop = window
    segments = _segment_bounds(start, stop, max(int(round(horizon / measurements.dt)), 10))
    speeds = smoothed_speeds(measurements)
    displacement = integrated_displacement(measurements)
    torque = _applied_motor_torque(measurements, values)
    pieces = []
    for first, last in segments:
        z0 = [values["theta_d0"] + displacement[first], speeds[first, 0], speeds[first, -1]]
        result = _simulate(measurements, rig.model, values, first, last, z0, torque)
        pieces.append(result.states[:, 1:3][:, : measurements.speeds.shape[1]])
    return np.concatenate(pieces)


def _theta_d0_by_grid(measurements, rig, values, window, horizon, points=_THETA_GRID_POINTS):
    """Starting ``theta_d0`` (rad): the best of a grid over ``[-4 alpha, 4 alpha]``.

    The cost is the residual sum of squares of the speeds over ``window``
    (segments of ``horizon`` s, or one free run when None) at the other
    ``values``.  It is far from convex in theta_d0: a start on the wrong side of
    the gap (the first samples' estimate of :func:`estimate_initial_state` is
    too noisy to tell) leads the fit into a local minimum with the half gap at
    its bound, so the fit starts from the global minimum of this 1-D cut.
    """
    start, stop = window
    measured = measurements.speeds[start:stop]
    weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
    alpha = values["half_gap"]

    def cost(theta_d0):
        trial = values | {"theta_d0": theta_d0}
        if horizon is None:
            simulated = replay(measurements, rig, trial, n_samples=stop).simulated[start:stop]
        else:
            simulated = segment_replay(measurements, rig, trial, window, horizon)
        return float(np.sum(((measured - simulated) * weights) ** 2))

    grid = np.linspace(-4.0 * alpha, 4.0 * alpha, points)
    return float(grid[int(np.argmin([cost(theta) for theta in grid]))])


def calibrate(measurements, rig, effect="none", window=None, start_values=None, horizon=0.2, polish=True,
              workers=1, max_nfev=None):
    """Fit plant values, initial state and one effect's parameter to a record.

    Parameters
    ----------
    measurements : Measurements
    rig : Rig
        Torque law and data-sheet values (the starting point and the +-30 % bounds
        of inertias, stiffness and half gap; damping in ``[0, 5 c]``).
    effect : str
        Catalogue entry (:data:`~backlash_df.identify.EFFECT_NAMES`) whose
        parameter is fitted along.
    window : tuple of int, optional
        Samples ``(start, stop)`` whose residual is minimised (default: all).
    start_values : dict, optional
        Starting values (for example a previous calibration's ``values``).
        Without ``theta_d0`` its start is the best point of a grid
        (:func:`_theta_d0_by_grid`).
    horizon : float or None
        Length (s) of the simulated segments.  With a measured load speed the
        window is cut into segments of ``horizon`` seconds, each simulated
        free-run from the state the data give at its start
        (:func:`data_state`, one fitted offset ``theta_d0`` for all): the
        rigid-body mode cannot drift for longer than a segment, which keeps the
        least-squares problem smooth enough to converge from data-sheet values.
        ``None`` (or no load speed): one free run from sample 0, with the
        initial speeds fitted too.
    polish : bool
        After the segmented fit, refine by free runs from sample 0 (output
        error, the prediction mode of the validation) over a quarter, half and
        all of the window, starting from the segmented solution
        (:func:`_polish`).  Effects that act slowly (friction) show their full
        size only over a long free run.
    workers : int
        Threads computing Jacobian columns (the simulation kernel releases the GIL).
    max_nfev : int, optional
        Limit of optimiser iterations.

    Returns
    -------
    Calibration

    Notes
    -----
    The residual is ``(y_j - y_hat_j) / std(y_j)`` per measured speed ``j``
    stacked, so that each speed weighs as in its fit percentage.
    """
    effect = get_effect(effect)
    start, stop = window if window is not None else (0, measurements.n_samples)
    segmented = horizon is not None and measurements.load_speed is not None
    values0 = nominal_values(rig) | dict(start_values or {})
    if not all(name in values0 for name in STATE_PARAMETERS):
        values0 = estimate_initial_state(measurements, values0) | values0
    if "theta_d0" not in (start_values or {}):
        values0["theta_d0"] = _theta_d0_by_grid(measurements, rig, values0, (start, stop), horizon if segmented else None)
    rows = _free_parameters(measurements, rig, effect, values0, segmented)
    names = [row[0] for row in rows]
    scales = np.array([row[4] for row in rows])
    lower = np.array([row[2] for row in rows]) / scales
    upper = np.array([row[3] for row in rows]) / scales
    x0 = np.array([row[1] for row in rows]) / scales
    measured = measurements.speeds[start:stop]
    weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
    fixed = {key: value for key, value in values0.items() if key not in names}
    if effect.name != "rubber":
        fixed["rubber_thickness"] = nominal_values(rig)["rubber_thickness"]
    def values_of(x):
        return fixed | dict(zip(names, x * scales))

    def simulated(x):
        values = values_of(x)
        if segmented:
            return segment_replay(measurements, rig, values, (start, stop), horizon)
        return replay(measurements, rig, values, n_samples=stop).simulated[start:stop]

    def residual(x):
        return ((measured - simulated(x)) * weights).ravel(order="F")

    jacobian = _parallel_jacobian(residual, lower, upper, workers)
    solution = least_squares(residual, x0, jac=jacobian, bounds=(lower, upper), method="trf", max_nfev=max_nfev)
    if segmented and polish:
        return _polish(measurements, rig, effect.name, (start, stop), values_of(solution.x), workers,
                       _POLISH_NFEV if max_nfev is None else max_nfev)
    stderr = _stderr(solution.jac, solution.fun, len(names), scales)
    best = solution.x * scales
    parameters = {
        name: FitParameter(name, float(value), float(err), float(row[1]), float(row[2]), float(row[3]), row[5])
        for name, value, err, row in zip(names, best, stderr, rows)
    }
    values = values_of(solution.x)
    if segmented:
        values |= dict(zip(STATE_PARAMETERS, data_state(measurements, values["theta_d0"], 0)))
    n = solution.fun.size
    rss = float(solution.fun @ solution.fun)
    return Calibration(
        effect=effect.name, parameters=parameters, values=values, window=(start, stop),
        n_residuals=n, rss=rss, aic=information_criterion(rss, n, len(names), "aic"),
        bic=information_criterion(rss, n, len(names), "bic"),
        nfev=int(solution.nfev) + int(solution.njev or 0) * (len(names) + 1), success=bool(solution.success),
        message=str(solution.message),
    )


def _polish(measurements, rig, effect, window, values, workers, max_nfev):
    """Free-run refinement of a segmented fit over growing windows (continuation).

    The free run starts at sample 0 from the data's state (:func:`data_state`),
    whose speeds are only as good as the smoothing at the record's edge; over
    the whole window the free-run cost is far from convex (the rigid-body mode
    integrates any initial-speed error), so the fit runs first on the first
    quarter of the window, then on half of it, then on all of it, each from the
    previous solution (:data:`_POLISH_FRACTIONS`).
    """
    start, stop = window
    values = values | dict(zip(STATE_PARAMETERS, data_state(measurements, values["theta_d0"], 0)))
    for fraction in _POLISH_FRACTIONS:
        last = start + max(int(round(fraction * (stop - start))), 10)
        result = calibrate(measurements, rig, effect, window=(start, last), start_values=values, horizon=None,
                           workers=workers, max_nfev=max_nfev)
        values = result.values
    return result


def information_criterion(rss, n, n_free, kind="aic"):
    """AIC ``N ln(RSS/N) + 2 p`` or BIC ``N ln(RSS/N) + p ln N``, as lmfit computes them."""
    penalty = 2.0 * n_free if kind == "aic" else n_free * math.log(n)
    return float(n * math.log(max(rss, 1e-300) / n) + penalty)


def _parallel_jacobian(residual, lower, upper, workers, rel_step=1e-5):
    """Forward-difference Jacobian whose columns run in ``workers`` threads."""

    def jacobian(x, f0=None):
        f0 = residual(x) if f0 is None else f0
        steps = rel_step * np.maximum(1.0, np.abs(x))
        steps = np.where(x + steps > upper, -steps, steps)

        def column(i):
            shifted = x.copy()
            shifted[i] += steps[i]
            return (residual(shifted) - f0) / steps[i]

        if workers > 1:
            with ThreadPoolExecutor(workers) as pool:
                columns = list(pool.map(column, range(x.size)))
        else:
            columns = [column(i) for i in range(x.size)]
        return np.column_stack(columns)

    return jacobian
