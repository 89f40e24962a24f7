"""Calibration: the drive model's values fitted to a record, with intervals.

:func:`calibrate` fits the plant values of the rig file (data-sheet values, a few
per cent off), the offset ``theta_d0`` and the effect parameters by bounded
nonlinear least squares (:func:`scipy.optimize.least_squares`, trust region
reflective) of the k-step prediction error (:func:`~.predictors.predict`, whose
module describes the models) on an estimation window.  It is a
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

**Jacobians.**  A k-step fit of the two-mass model takes its Jacobian from
forward sensitivities (:meth:`~.predictors.TwoMassModel.speed_sensitivities`,
:func:`sensitivity_jacobian`): one run of the kernel with the derivatives riding
along gives every column, the multiple-shooting corrections' included, where
forward differences took one run a value.  It is the derivative of the discrete
prediction with its modes held, which differences of a small step reproduce (to
1e-6, the tests); a free run (:func:`refine`) keeps forward differences
(:func:`parallel_jacobian`): over a whole window the contacts' switching times
move with the values, which a held mode's derivative does not see and
differences do, and so does the rigid body.

**Threads.**  With an ``executor`` (a :class:`concurrent.futures.ThreadPoolExecutor`:
the kernels release the GIL), the forward-difference Jacobian's columns run on
it; the numbers do not depend on it.
"""

import dataclasses
import functools
import math
from typing import NamedTuple

import numpy as np

from .._json import json_ready
from .._threads import single_threaded_blas
from .effects import get_effect
from .predictors import (DEFAULT_HORIZON, INITIAL_STATE_STEP, PLANT_PARAMETERS, horizon_samples, nominal_values,
                         predict, prediction_model, segment_bounds)
from .signals import SMOOTHED_NOISE_SHARE, data_states, speed_noise

__all__ = ["FitParameter", "Calibration", "calibrate", "refine", "FREE_RUN_MIN"]

_UNITS = {"motor_inertia": "kg m^2", "load_inertia": "kg m^2", "stiffness": "N m/rad", "damping": "N m s/rad",
          "half_gap": "rad", "theta_d0": "rad", "inertia": "kg m^2", "encoder_skew": "s"}
_MAX_SKEW_SAMPLES = 2.0  # encoder skew fitted within +-2 samples
#: Smallest norm of a fit's scaled start vector: a fit whose free values all start at their null (an effect alone
#: on the rigid body, plant values held) starts this far inside, else trf's first step has zero length.
_MIN_START_NORM = 0.01
_RELATIVE_RANGE = 0.3  # data-sheet values are trusted to +-30 %
_THETA_GRID_POINTS = 33  # starting theta_d0 searched on a grid over its range
#: Smallest free-run fit (%) of the k-step solution on every speed for the free-run refinement.
FREE_RUN_MIN = 50.0


class _FitRow(NamedTuple):
    """A fitted value: its name, start, bounds and scale in the fit, its nominal value (the rig file's, the
    effect's null, the data's) and its unit."""

    name: str
    start: float
    lower: float
    upper: float
    scale: float
    nominal: float
    unit: str


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
        Every model value, ready for :func:`~.predictors.predict`.
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
        ``two_mass`` or ``rigid_body`` (:mod:`.predictors`).
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


def _row(name, lower, upper, scale, nominal, unit):
    """A :class:`_FitRow` that starts at its nominal value (:func:`_free_parameters` moves the start)."""
    return _FitRow(name, nominal, lower, upper, scale, nominal, unit)


def _free_parameters(model, effects, values0, window, free_run):
    """The :class:`_FitRow` of each fitted parameter of ``model`` (:class:`~.predictors.TwoMassModel` or
    :class:`~.predictors.RigidBodyModel`), started at ``values0`` within its bounds.

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
        rows.append(_row(effect.value_key, low, high, effect.scale(rig, measurements), effect.null, effect.unit))
    return [row._replace(start=float(np.clip(values0.get(row.name, row.nominal), row.lower, row.upper)))
            for row in rows]


def _rigid_rows(model, nominal, window, free_run):
    """Rows of :func:`_free_parameters` for the rigid body: its inertia (+-30 %), a free run's initial speed."""
    measurements = model.measurements
    inertia = nominal["inertia"]
    rows = [_row("inertia", (1 - _RELATIVE_RANGE) * inertia, (1 + _RELATIVE_RANGE) * inertia, inertia, inertia,
                 _UNITS["inertia"])]
    if free_run:
        speed_range = float(np.ptp(measurements.speeds)) + 1e-9
        measured = model.speed[window[0]]
        rows.append(_row("motor_speed0", measured - 0.2 * speed_range, measured + 0.2 * speed_range,
                         0.01 * speed_range, float(measured), "rad/s"))
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
            rows.append(_row(name, 0.0, 5.0 * scale, scale, value, _UNITS[name]))
        else:
            rows.append(_row(name, (1 - _RELATIVE_RANGE) * value, (1 + _RELATIVE_RANGE) * value, value, value,
                             _UNITS[name]))
    if not model.quasi_static:
        centre, reach = theta_d0_range(measurements, rig)
        rows.append(_row("theta_d0", centre - reach, centre + reach, 0.25 * reach, centre, "rad"))
    if model.twist_measured and not free_run:  # a free run starts once: held
        skew = _MAX_SKEW_SAMPLES * measurements.dt
        rows.append(_row("encoder_skew", -skew, skew, 0.25 * measurements.dt, 0.0, _UNITS["encoder_skew"]))
    if free_run:
        speed_range = float(np.ptp(measurements.speeds)) + 1e-9
        data = data_states(measurements, 0.0, [window[0]])[0]
        for name, measured in zip(("motor_speed0", "load_speed0"), data[1:]):
            rows.append(_row(name, measured - 0.2 * speed_range, measured + 0.2 * speed_range, 0.01 * speed_range,
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


def calibrate(measurements, rig, effects=(), window=None, start_values=None, horizon=DEFAULT_HORIZON, *,
              executor=None, max_nfev=None, polish=True, fixed=(), structure="two_mass"):
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
        Length (s) of the k-step segments (:mod:`.predictors`); None: one free run.
    executor : concurrent.futures.Executor, optional
        Runs the forward-difference Jacobian's columns (the free runs, the rigid body); a
        :class:`~concurrent.futures.ThreadPoolExecutor` (the kernels release the GIL).  None: one after the
        other in this thread.  The numbers do not depend on it.  The fit submits to it from the calling
        thread only: do not call :func:`calibrate` from a task of the same bounded pool.
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
        :data:`~.predictors.PLANT_PARAMETERS`, to screen a candidate effect quickly).
    structure : str
        ``two_mass`` (plant values of the rig file, twist offset, and the
        encoder skew where the twist is measured) or ``rigid_body`` (its
        ``inertia``, :mod:`.predictors`).

    Returns
    -------
    Calibration

    Notes
    -----
    The residual is ``(y_j - y_hat_j) / std(y_j)`` per measured speed ``j``
    stacked, so that each speed weighs as in its fit percentage.
    """
    with single_threaded_blas():
        return _calibrate(measurements, rig, effects, window, start_values, horizon, executor, max_nfev, polish,
                          fixed, structure)


def _calibrate(measurements, rig, effects, window, start_values, horizon, executor, max_nfev, polish, fixed,
               structure):
    effects = (effects,) if isinstance(effects, str) else tuple(effects)
    start, stop = window if window is not None else (0, measurements.n_samples)
    model = prediction_model(measurements, rig, structure)
    values0 = nominal_values(rig) | {get_effect(key).value_key: get_effect(key).start(rig) for key in effects} \
        | dict(start_values or {})
    if structure == "two_mass" and not model.quasi_static and "theta_d0" not in (start_values or {}):
        k = horizon_samples(measurements, horizon)
        starts, stops = segment_bounds(start, stop, k)
        measured = measurements.speeds[start:stop]
        weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
        values0["theta_d0"] = _theta_d0_by_grid(model, values0, starts, stops, measured, weights)
    result = _fit(model, effects, (start, stop), values0, horizon, executor, max_nfev, fixed)
    if not polish or horizon is None:
        return result
    return refine(measurements, rig, result, executor=executor, max_nfev=max_nfev, fixed=fixed)


def refine(measurements, rig, calibration, *, executor=None, max_nfev=None, fixed=()):
    """Refine a k-step calibration by a free run over its window, where the free run does not drift.

    The free run starts from the data's speeds at the window's start, fitted
    too; it is fitted over half the window, then over all of it, each from the
    previous solution.  Returned unchanged when the free run of ``calibration``
    fits less than :data:`FREE_RUN_MIN` % on a speed (closed-loop data drifts).

    The refined values' 95 % intervals are the union of the free run's and the
    k-step fit's: a free-run residual stays correlated over longer than any
    block the data allow, and the two modes' disagreement is model error the
    residual statistics of either do not see.  ``executor``, ``max_nfev`` and ``fixed``
    as in :func:`calibrate`.
    """
    start, stop = calibration.window
    free = predict(measurements, rig, calibration.values, window=(start, stop), horizon=None,
                   structure=calibration.structure).fit_percent()
    if not min(free.values()) >= FREE_RUN_MIN:
        return calibration
    model = prediction_model(measurements, rig, calibration.structure)
    result, values = calibration, calibration.values
    for fraction in (0.5, 1.0):
        last = start + max(int(round(fraction * (stop - start))), 10)
        result = _fit(model, calibration.effects, (start, last), values, None, executor, max_nfev, fixed)
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

    The data's state at a segment's start (:func:`~.signals.data_states`) is noisy, and a
    fit that starts every segment from it is biased (errors in the variables: a
    torque offset came out 2 % large on speeds with 0.02 rad/s of noise).  So
    each measured speed's initial value is corrected per segment, penalised as a
    measurement of it: ``c / (SMOOTHED_NOISE_SHARE sigma)`` with ``sigma`` the
    speed's noise (:func:`~.signals.speed_noise`).  The penalty rows are scaled by
    ``residual_rms``, the RMS of the data's (scaled) residual of the fit without
    corrections: where model error, not sensor noise, makes the residual (a real
    drive), the corrections may not absorb it.  A correction moves one segment
    only, so the Jacobian columns of one speed across all segments cost one
    evaluation.

    With ``drift`` (the twist integrated from the speeds, :attr:`~.predictors.TwoMassModel.drifting`)
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
        The segments' first and one-past-last samples (:func:`~.predictors.segment_bounds`).
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


def _fit(model, effects, window, values0, horizon, executor, max_nfev, fixed=()):
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
    k = horizon_samples(measurements, horizon)
    starts, stops = segment_bounds(start, stop, k)
    measured = measurements.speeds[start:stop]
    weights = 1.0 / np.maximum(measured.std(axis=0), 1e-12)
    rows = [row for row in _free_parameters(model, effects, values0, window, horizon is None) if row.name not in fixed]
    names = [row.name for row in rows]
    g = len(names)
    scales = np.array([row.scale for row in rows])
    lower = np.array([row.lower for row in rows]) / scales
    upper = np.array([row.upper for row in rows]) / scales
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
    x0 = np.array([row.start for row in rows]) / scales
    if not np.linalg.norm(x0) > _MIN_START_NORM:  # trf's first trust radius is ||x0||: every value at its null
        x0 = np.clip(x0 + _MIN_START_NORM, lower, upper)
    # from the data's states first; from that solution the corrections converge in a few steps

    sensitivities = model.structure == "two_mass" and k is not None  # not a free run (module docs: Jacobians)

    def jacobian(shooting, upper):
        if sensitivities:
            return sensitivity_jacobian(model, names, values_of, scales, window, starts, stops, weights, shooting)
        return parallel_jacobian(residual, g, shooting, upper, executor=executor)

    runs_a_jacobian = 1 if sensitivities else g
    solution = least_squares(residual, x0, bounds=(lower, upper), jac=jacobian(None, upper), method="trf",
                             max_nfev=max_nfev)
    nfev = int(solution.nfev) + int(solution.njev or 0) * runs_a_jacobian
    jacobian_at_solution = solution.jac
    blocks = segment_bounds(start, stop, k or horizon_samples(measurements, DEFAULT_HORIZON))
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
        name: FitParameter(name, float(value), float(err), float(row.nominal), float(row.lower), float(row.upper),
                           row.unit, quantile)
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
                         rel_step=INITIAL_STATE_STEP):
    """Jacobian of a two-mass fit's residual from forward sensitivities: one run a Jacobian.

    The residual is :func:`_fit`'s: the data rows ``(measured - predicted) weights``
    over ``window``, speed after speed, then (with ``shooting``) the prior's rows.
    Its derivatives by the scaled values (``x[:len(names)]``, value ``x scales``)
    come from :meth:`~.predictors.TwoMassModel.speed_sensitivities`, those by the corrections
    from the same run's sensitivities to the segments' initial states (a
    correction moves its own segment only), the prior's rows exact.

    Parameters
    ----------
    model : ~.predictors.TwoMassModel
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
        value (:meth:`~.predictors.TwoMassModel.speed_sensitivities`), on the scaled value.

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


def parallel_jacobian(residual, n_global, shooting, upper, *, executor=None, rel_step=1e-6):
    """Forward-difference Jacobian whose columns may run side by side on an ``executor``.

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
    executor : concurrent.futures.Executor, optional
        Runs the columns' evaluations (a :class:`~concurrent.futures.ThreadPoolExecutor`: the kernels
        release the GIL); None: one after the other in this thread.
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

        if executor is None:
            differences = [difference(group) for group in groups]
        else:
            differences = list(executor.map(difference, groups))
        dense = np.column_stack([change / steps[group[0]] for group, change in zip(groups[:n_global], differences)])
        if shooting is None:
            return dense
        rows = shooting.segment_of_row.size
        by_correction = np.column_stack([change[:rows] / steps[group[shooting.segment_of_row]]
                                         for group, change in zip(groups[n_global:], differences[n_global:])])
        return shooting.jacobian(dense[:rows], by_correction)

    return jacobian
