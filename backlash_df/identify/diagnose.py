"""From measured data to a named cause: calibrate, compare candidates, report the gain.

The record is split in time: the first 5 % are dropped (initial transient), the
*estimation part* runs to 60 %, the *validation part* is the last 40 %, never
used by any fit.  Each catalogue candidate (:mod:`.effects`) is calibrated on
the estimation part (:func:`~.calibrate.calibrate`, each from the rig file's
values and, being an extension of the nominal structure, also from the
calibrated baseline with its parameter at the null value; the better fit of the
two is kept), then replayed by **free-run simulation** from the initial state
estimated from the data at the record's start, driven by the measured torques
only; every number of the verdict is computed on the validation part.

Significance rule (stated, fixed): a candidate is *accepted* when all hold

1. its validation BIC (``N ln(RSS/N) + p ln N``, lmfit's definition, on the
   scaled validation residual) is lower than the baseline's by more than
   :data:`BIC_MARGIN` (10: "very strong" evidence on the Kass-Raftery scale);
2. its validation residual sum of squares is at most :data:`RSS_RATIO` (0.5)
   times the baseline's: the extension must explain at least half of what the
   nominal structure leaves unexplained, not a sliver of model mismatch;
3. its parameter's 95 % confidence interval excludes the null value and the
   parameter is resolvable (an actuator delay of at least one sample).

The cause is the accepted candidate with the lowest validation BIC; with none
accepted it is ``none``: the nominal structure explains the data.
"""

import dataclasses
import json
import math

import numpy as np

from .calibrate import PLANT_PARAMETERS, calibrate, fit_percent, information_criterion, replay
from .effects import EFFECT_NAMES, get_effect
from .residuals import residual_analysis

__all__ = ["CandidateResult", "Diagnosis", "diagnose", "check_speed_units", "BIC_MARGIN", "RSS_RATIO"]

#: Validation BIC improvement a candidate must exceed.
BIC_MARGIN = 10.0
#: Largest validation RSS ratio (extended / baseline) of an accepted candidate.
RSS_RATIO = 0.5
#: Optimiser iterations of a candidate's free-run fit started from the baseline.
NESTED_NFEV = 30
PREDICTION_MODE = (
    "free-run simulation from the initial state estimated from the data at the record's start, "
    "driven by the measured torques; scored on the validation part only"
)


@dataclasses.dataclass(frozen=True, repr=False)
class CandidateResult:
    """One candidate's calibration and its score on the validation part.

    Attributes
    ----------
    cause : str
        Catalogue name.
    calibration : Calibration
        Fit on the estimation part.
    replay : Replay
        Free-run simulation over the whole record with the fitted values.
    validation : slice
        Samples of the validation part.
    fit_percent : dict
        Validation fit percentage per measured speed.
    rms : dict
        Validation residual RMS per measured speed, rad/s.
    rss : float
        Validation residual sum of squares, each speed scaled by its std.
    aic, bic : float
        Information criteria on the validation residual.
    accepted : bool
        Whether the significance rule accepts it (never for ``none``).
    reason : str
        Why it is accepted or not.
    """

    cause: str
    calibration: object
    replay: object
    validation: slice
    fit_percent: dict
    rms: dict
    rss: float
    aic: float
    bic: float
    accepted: bool = False
    reason: str = ""

    @property
    def mean_fit_percent(self):
        """Mean of the validation fit percentages of the measured speeds."""
        return float(np.mean(list(self.fit_percent.values())))

    @property
    def parameter(self):
        """The effect's FitParameter (None for ``none``)."""
        return self.calibration.effect_parameter

    def to_dict(self):
        """JSON-ready summary."""
        parameter = self.parameter
        return {
            "cause": self.cause,
            "fit_percent": self.mean_fit_percent,
            "fit_percent_per_signal": self.fit_percent,
            "rms": self.rms,
            "aic": self.aic,
            "bic": self.bic,
            "parameter": _parameter_dict(parameter) if parameter else None,
            "accepted": self.accepted,
            "reason": self.reason,
        }

    def __repr__(self):
        fits = ", ".join(f"{name} {value:.1f} %" for name, value in self.fit_percent.items())
        return f"<CandidateResult {self.cause}: fit {fits}, BIC {self.bic:.1f}, accepted={self.accepted}>"


def _parameter_dict(parameter):
    low, high = parameter.ci95
    return {"name": parameter.name, "value": parameter.value, "stderr": parameter.stderr,
            "ci95": [low, high], "unit": parameter.unit}


def _finite(value):
    return value if isinstance(value, (int, str, bool)) or value is None or math.isfinite(value) else None


def _clean(obj):
    if isinstance(obj, dict):
        return {key: _clean(value) for key, value in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(value) for value in obj]
    if isinstance(obj, float):
        return _finite(obj)
    return obj


@dataclasses.dataclass(frozen=True, repr=False)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    cause : str
        The named cause (``none`` when the nominal structure explains the data).
    sentence : str
        The cause in one sentence a person can act on.
    baseline : CandidateResult
        The nominal structure calibrated.
    extended : CandidateResult
        The model extended by the cause (the baseline when the cause is ``none``).
    candidates : list of CandidateResult
        All candidates, ranked: accepted first, then by validation BIC.
    residuals_baseline, residuals_extended : ResidualAnalysis
        Residual analysis of the two on the validation part.
    measurements, rig
        The inputs.
    estimation, validation : slice
        Sample ranges of the two parts.
    """

    cause: str
    sentence: str
    baseline: CandidateResult
    extended: CandidateResult
    candidates: list
    residuals_baseline: object
    residuals_extended: object
    measurements: object
    rig: object
    estimation: slice
    validation: slice

    def __repr__(self):
        return (
            f"<Diagnosis cause={self.cause!r}: validation fit {self.baseline.mean_fit_percent:.1f} % -> "
            f"{self.extended.mean_fit_percent:.1f} % ({PREDICTION_MODE.split(' from')[0]})>"
        )

    def to_dict(self):
        """The JSON document of ``backlash-df diagnose --json`` (DESIGN.md)."""
        time = self.measurements.time
        extended = self.extended.to_dict() | {
            "parameters": {name: _parameter_dict(p) for name, p in self.extended.calibration.parameters.items()},
        }
        baseline = self.baseline.to_dict() | {
            "parameters": {name: _parameter_dict(p) for name, p in self.baseline.calibration.parameters.items()},
        }
        return _clean({
            "cause": self.cause,
            "sentence": self.sentence,
            "prediction": PREDICTION_MODE,
            "rule": f"accepted if validation BIC lower than the baseline's by more than {BIC_MARGIN:g}, "
                    f"validation RSS at most {RSS_RATIO:g} x the baseline's, and the parameter's 95 % CI "
                    f"excludes its null value (a delay at least one sample); cause = accepted candidate "
                    f"with the lowest validation BIC, else none",
            "estimation": {"start": float(time[self.estimation.start]), "stop": float(time[self.estimation.stop - 1])},
            "validation": {"start": float(time[self.validation.start]), "stop": float(time[-1])},
            "baseline": baseline,
            "extended": extended,
            "candidates": [candidate.to_dict() for candidate in self.candidates],
        })

    def to_json(self):
        """:meth:`to_dict` as indented JSON text."""
        return json.dumps(self.to_dict(), indent=2)

    def plot(self, axes=None):
        """Measured against baseline and extended free-run speeds (validation part); returns the axes."""
        import matplotlib.pyplot as plt

        names = self.measurements.speed_names
        if axes is None:
            _, axes = plt.subplots(len(names), 1, sharex=True, figsize=(9, 2.4 * len(names)), squeeze=False)
            axes = axes[:, 0]
        window = self.validation
        time = self.measurements.time[window]
        for j, name in enumerate(names):
            axes[j].plot(time, self.baseline.replay.measured[window, j], color="0.55", lw=1.2, label="measured")
            axes[j].plot(time, self.baseline.replay.simulated[window, j], lw=1.0, label="baseline (none)")
            if self.cause != "none":
                axes[j].plot(time, self.extended.replay.simulated[window, j], lw=1.0, ls="--",
                             label=f"extended ({self.cause})")
            axes[j].set_ylabel(f"{name} (rad/s)")
            axes[j].legend(loc="upper right", fontsize="small")
        axes[-1].set_xlabel("time (s), validation part")
        return axes

    def report_html(self):
        """A self-contained HTML report: verdict, overlays, residuals, ranking, parameters."""
        import matplotlib.pyplot as plt

        from ..report import figure_html, html_page, table_html

        fig, axes = plt.subplots(len(self.measurements.speed_names), 1, sharex=True, squeeze=False,
                                 figsize=(9, 2.4 * len(self.measurements.speed_names)))
        self.plot(axes[:, 0])
        overlay = figure_html(fig, "Validation part: measured speeds against the free-run simulations, "
                                   "before (baseline) and after (extended) the extension.")
        residual_figures = []
        for label, analysis in (("baseline", self.residuals_baseline), ("extended", self.residuals_extended)):
            fig = plt.figure(figsize=(10, 7))
            analysis.plot(fig)
            fig.suptitle(f"Residuals of the {label} model ({'none' if label == 'baseline' else self.cause})")
            residual_figures.append(figure_html(
                fig, f"{label}: residual over time, against theta_d and shaft torque, spectrum, "
                     f"autocorrelation and cross-correlation with the motor torque (99 % band grey)."))
        ranking = [[c.cause, f"{c.mean_fit_percent:.2f}", " / ".join(f"{v:.2f}" for v in c.fit_percent.values()),
                    " / ".join(f"{v:.3g}" for v in c.rms.values()), f"{c.bic - self.baseline.bic:.1f}",
                    _format_parameter(c.parameter), "yes" if c.accepted else "no", c.reason]
                   for c in self.candidates]
        ranking_table = table_html(
            ["cause", "fit % (mean)", "fit % per speed", "RMS rad/s per speed", "dBIC", "parameter (95 % CI)",
             "accepted", "why"], ranking, text_columns=(0, 5, 6, 7))
        parameter_rows = [[name, f"{p.nominal:.5g}", f"{p.value:.5g}", f"{p.stderr:.3g}",
                           f"{p.ci95[0]:.5g} .. {p.ci95[1]:.5g}", p.unit]
                          for name, p in self.extended.calibration.parameters.items()]
        parameters = table_html(["parameter", "start (rig file)", "fitted", "std. error", "95 % CI", "unit"],
                                parameter_rows, text_columns=(0, 5))
        summary = (f'<p class="summary"><b>Cause: {self.cause}.</b> {self.sentence}</p>'
                   f"<p>Prediction mode: {PREDICTION_MODE}. Validation fit (MATLAB compare): baseline "
                   f"{self.baseline.mean_fit_percent:.2f} %, extended {self.extended.mean_fit_percent:.2f} %.</p>")
        return html_page(f"Diagnosis of {self.measurements.source}", [
            ("", summary),
            ("Measured against simulated", overlay),
            ("Ranking of the candidate effects", ranking_table + f"<p>{self.to_dict()['rule']}.</p>"),
            ("What the simulation gets wrong", "\n".join(residual_figures)),
            (f"Calibrated parameters of the extended model ({self.cause})", parameters),
        ])


def _format_parameter(parameter):
    if parameter is None:
        return "-"
    low, high = parameter.ci95
    return f"{parameter.name} = {parameter.value:.4g} ({low:.4g} .. {high:.4g}) {parameter.unit}"


def check_speed_units(measurements, rig):
    """Refuse speeds that the rig's inertias and the torques say are not rad/s.

    The momentum balance of the whole drive, ``J_m w_m + J_l w_l`` against the
    impulse ``int (T_m + T_l) dt``, is regressed (with a linear trend for
    friction); a slope far from 1 (above 4, as rpm gives 30/pi = 9.55) means
    the speeds are not in rad/s.
    """
    plant = rig.plant
    load_speed = measurements.load_speed if measurements.load_speed is not None else measurements.motor_speed
    momentum = plant.motor_inertia * measurements.motor_speed + plant.load_inertia * load_speed
    torque = measurements.motor_torque + measurements.load_torque_or_zero
    impulse = np.concatenate([[0.0], np.cumsum(0.5 * (torque[1:] + torque[:-1]))]) * measurements.dt
    t = measurements.time - measurements.time[0]
    design = np.column_stack([impulse, t, np.ones_like(t)])
    slope = float(np.linalg.lstsq(design, momentum - momentum[0], rcond=None)[0][0])
    if slope > 4.0:
        raise ValueError(
            f"{measurements.source}: the speeds change {slope:.3g} times faster than the torques and the rig's "
            f"inertias allow: speeds must be in rad/s (if they are in rpm, multiply by pi/30)"
        )


def _score(cause, calibration, measurements, rig, validation, weights):
    simulation = replay(measurements, rig, calibration.values)
    residual = simulation.residual[validation] * weights
    rss = float(np.sum(residual**2))
    n = residual.size
    p = calibration.n_free
    return CandidateResult(
        cause=cause, calibration=calibration, replay=simulation, validation=validation,
        fit_percent={name: fit_percent(simulation.measured[validation, j], simulation.simulated[validation, j])
                     for j, name in enumerate(simulation.names)},
        rms={name: float(np.sqrt(np.mean(simulation.residual[validation, j] ** 2)))
             for j, name in enumerate(simulation.names)},
        rss=rss, aic=information_criterion(rss, n, p, "aic"), bic=information_criterion(rss, n, p, "bic"),
    )


def _judge(candidate, baseline, dt):
    """Apply the significance rule; returns the candidate with ``accepted`` and ``reason`` set."""
    parameter = candidate.parameter
    low, _ = parameter.ci95
    delta_bic = candidate.bic - baseline.bic
    ratio = candidate.rss / baseline.rss if baseline.rss > 0 else 1.0
    failures = []
    if not delta_bic < -BIC_MARGIN:
        failures.append(f"dBIC {delta_bic:.1f} not below -{BIC_MARGIN:g}")
    if not ratio <= RSS_RATIO:
        failures.append(f"RSS ratio {ratio:.2f} above {RSS_RATIO:g}")
    if not low > get_effect(candidate.cause).null:
        failures.append("95 % CI includes the null value")
    if candidate.cause == "actuator_delay" and parameter.value < dt:
        failures.append("delay shorter than one sample")
    reason = "; ".join(failures) if failures else f"dBIC {delta_bic:.1f}, RSS ratio {ratio:.2f}, CI excludes 0"
    return dataclasses.replace(candidate, accepted=not failures, reason=reason)


def _sentence(cause, extended, baseline):
    gain = (f" Validation fit {baseline.mean_fit_percent:.1f} % -> {extended.mean_fit_percent:.1f} % "
            f"(free-run simulation).")
    effect = get_effect(cause)
    if cause == "none":
        values = extended.calibration.values
        return (effect.action + " Calibrated: " + ", ".join(f"{name} = {values[name]:.4g}" for name in PLANT_PARAMETERS)
                + f". Validation fit {baseline.mean_fit_percent:.1f} % (free-run simulation).")
    parameter = extended.parameter
    low, high = parameter.ci95
    text = effect.action.format(value=parameter.value, low=low, high=high, value_ms=1e3 * parameter.value,
                                low_ms=1e3 * low, high_ms=1e3 * high)
    return text + gain


def _calibrate_extension(measurements, rig, name, baseline, fit):
    """Calibration of candidate ``name`` from two starts; the one with the lower estimation RSS.

    The extension contains the nominal structure (its parameter at the null
    value), so besides the fit from the rig file's values it is also fitted by
    free run from the calibrated baseline with the parameter at its null value: its estimation RSS is then never
    above the baseline's, and a difference on the validation part is the
    effect's, not the optimiser's (the free-run cost has local minima).
    """
    effect = get_effect(name)
    fresh = calibrate(measurements, rig, name, **fit)
    nested = calibrate(measurements, rig, name, window=fit["window"], horizon=None, workers=fit["workers"],
                       start_values=baseline.values | {effect.parameter: effect.null}, max_nfev=NESTED_NFEV)
    return min((fresh, nested), key=lambda calibration: calibration.rss)


def diagnose(measurements, rig, candidates=None, estimation_fraction=0.6, transient_fraction=0.05, horizon=0.2,
             workers=1):
    """Name the physical cause of what the rig's model gets wrong in a record.

    Parameters
    ----------
    measurements : Measurements
        The record (:func:`~.measurements.load_measurements`).
    rig : Rig
        Data-sheet plant and torque law (``[model] backlash``).
    candidates : sequence of str, optional
        Catalogue names to try besides ``none`` (default: the whole catalogue).
    estimation_fraction : float
        End of the estimation part as a fraction of the record (0.6).
    transient_fraction : float
        Initial part dropped from the fit (0.05).
    horizon : float
        Segment length (s) of the calibration's simulations (see
        :func:`~.calibrate.calibrate`).
    workers : int
        Threads for the Jacobian columns.

    Returns
    -------
    Diagnosis

    Raises
    ------
    ValueError
        Unknown candidate name, speeds that are not rad/s, fractions out of range.
    """
    names = [name for name in (candidates if candidates is not None else EFFECT_NAMES) if name != "none"]
    for name in names:
        get_effect(name)
    if not 0.0 <= transient_fraction < estimation_fraction < 1.0:
        raise ValueError("need 0 <= transient_fraction < estimation_fraction < 1")
    check_speed_units(measurements, rig)
    n = measurements.n_samples
    estimation = slice(int(round(transient_fraction * n)), int(round(estimation_fraction * n)))
    validation = slice(estimation.stop, n)
    weights = 1.0 / np.maximum(measurements.speeds[validation].std(axis=0), 1e-12)
    fit = dict(window=(estimation.start, estimation.stop), horizon=horizon, workers=workers)

    base_calibration = calibrate(measurements, rig, "none", **fit)
    baseline = dataclasses.replace(_score("none", base_calibration, measurements, rig, validation, weights),
                                   reason="the nominal structure (reference)")
    results = []
    for name in names:
        calibration = _calibrate_extension(measurements, rig, name, base_calibration, fit)
        candidate = _score(name, calibration, measurements, rig, validation, weights)
        results.append(_judge(candidate, baseline, measurements.dt))
    accepted = sorted((c for c in results if c.accepted), key=lambda c: c.bic)
    cause = accepted[0].cause if accepted else "none"
    extended = accepted[0] if accepted else baseline
    ranked = accepted + sorted((c for c in results if not c.accepted), key=lambda c: c.bic)

    def analysis(candidate):
        result = candidate.replay.result
        return residual_analysis(
            measurements.time[validation], candidate.replay.residual[validation],
            measurements.motor_torque[validation], result.theta_d[validation], result.torque[validation],
            result.states[validation, 2], candidate.replay.names)

    return Diagnosis(
        cause=cause, sentence=_sentence(cause, extended, baseline), baseline=baseline, extended=extended,
        candidates=[baseline] + ranked, residuals_baseline=analysis(baseline), residuals_extended=analysis(extended),
        measurements=measurements, rig=rig, estimation=estimation, validation=validation,
    )
