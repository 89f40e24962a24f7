"""From measured data to named causes: calibrate, select effects, report the gain and its uncertainty.

The record is split in time: the first 5 % are dropped (initial transient), the
*estimation part* runs to 60 %, the *validation part* is the last 40 %, seen
by no fit of the search (only by the final one, below).  Every fit is a k-step
prediction-error fit (:func:`~.calibrate.calibrate`: segments of ``horizon`` seconds, each started
from the data's state), which does not drift on closed-loop data.  Every score
is a prediction error on the validation part, scaled per speed by its standard
deviation, in two modes: the k-step prediction (segments of ``horizon``), where
fast effects (delay, rubber) show, and the *ahead* prediction, where each block
of ``horizon`` seconds is predicted from the data's state
:data:`VALIDATION_HORIZON` (0.4 s) before its end, where slow effects
(friction) show at their size while no prediction runs long enough to drift.

**Forward selection** over the catalogue (:mod:`.effects`): starting from the
nominal structure, every remaining candidate is fitted on top of the current set
(from the current values, its parameter at the null value); the candidate with
the largest validation gain is added if it passes the significance rule, and
the search repeats.  Candidates that passed the rule in a step but lost to a
larger gain (*runners-up*) are kept aside.  **Backward elimination** then fits
the set with the runners-up, refits it without each member and drops a member
that fails the rule against the rest (first one whose interval in the joint
fit includes its null value), until every member passes: two nearly collinear
effects (Coulomb and viscous friction under a sine speed) are told apart by the
joint fit, not by which happened to win a forward step.  A member the joint fit
supported (its value passing rule 3 below, the size rule) but the validation part did not,
whose removal moves a kept member's value out of its joint interval, is
*absorbed* by it: the diagnosis warns and says so (:func:`_absorption`).

Significance rule (stated, fixed), for adding an effect to a set:

1. *gain*: the validation RSS falls by at least :data:`MIN_GAIN` (5 %) of the
   current set's, in the mode (k-step or ahead) that also passes rule 2;
2. *evidence with correlated residuals*: over the validation blocks (the k-step
   blocks, whose residuals are correlated inside and nearly independent
   between), the per-block log RSS ratio ``ln(RSS_current / RSS_new)`` has a t
   statistic of at least :data:`MIN_T` (2);
3. *size*: the parameter's 95 % interval (cluster-robust, Student t) excludes
   the null value, a delay is at least one sample, and a torque effect
   (friction at the RMS speed, offset) is at least :data:`MIN_TORQUE_SHARE`
   (1 %) of the record's RMS motor torque; rubber is at least
   :data:`MIN_RUBBER_SHARE` (10 %) of the half gap (a thinner layer is within
   the mismatch between the exact model (14) and the static law (23) the fit
   uses) and wider than the twist's uncertainty (:attr:`_Search.twist_uncertainty`).

The answer is a set of causes ordered by their gain against the rest.  Before
naming any, the baseline must explain the data: with a validation fit below
:data:`BASELINE_MIN_FIT` % on a speed the diagnosis says so and names none.
The final set's values are refined by a free run where it does not drift
(:func:`~.calibrate.refine`), kept where they predict the validation part at
least as well; a member whose refined interval includes its null value is
dropped.  Once the validation part has chosen and scored the set, it is
calibrated anew on the *whole record* after the transient, estimation and
validation part together, by a k-step fit (:meth:`_Search.whole_record`):
the values and 95 % intervals the causes report come from all the data; every
fit percentage stays the estimation part's model scored on the validation part.

**Speeds.**  Where an angle column measures a speed more finely than its speed column and the two agree
(:func:`~.signals.encoder_speeds`: a fine encoder beside a noisy speed sensor), the fits take the
encoder's speed, and a warning names the column and both noises.

**Two structures.**  The selection runs twice (:class:`Stage`): for the
two-mass drive over the whole catalogue, and for the *rigid body* it contains
(:mod:`.predictors`, ``structure="rigid_body"``: one inertia, no shaft) over
:data:`RIGID_BODY_EFFECTS`.  Where the record does not resolve the shaft's mode
(:func:`~.signals.shaft_resolution`: its frequency above the band in which
the motor speed rises above its noise, as on a stiff robot gear), the causes
are named from the rigid-body stage, and the two-mass stage, which then starts
its segments on the rigid body's state where no angles are recorded, is the
cross-check: an effect both name whose 95 % intervals do not overlap is named
without a value, and the diagnosis says why (:func:`stage_disagreements`).  Elsewhere
the two-mass stage names the causes and the rigid-body stage is reported beside
it (a rigid body cannot express the shaft there).  A cause whose parameter ends
on a bound of the range the fit allows is named without a value too
(:attr:`Cause.on_bound`): the data ask for more than the range gives.

**Threads.**  With an ``executor`` (a :class:`concurrent.futures.ThreadPoolExecutor`: the
kernels release the GIL), the independent fits of a step run side by side on it (a selection
step's screenings, full refits and backward checks, the friction speeds' trials, the whole
record's), each fit then in its own thread alone; a step with one fit lends the executor to
that fit's forward-difference Jacobian columns (:func:`~.calibrate.calibrate`).  Either the
fits or one fit's columns, never both: no task on the executor submits to it, which on a
bounded pool could wait forever.  The numbers do not depend on the executor.
"""

import dataclasses
import functools
import itertools
import math

import numpy as np

from .._json import json_ready
from ..checkpoint import step_counter
from ..config import RANGES, rig_from_dict, rig_to_toml
from ..plotting import ResultPlot, axes_or_new, legend_beside
from ..render.diagnosis import (cause_sentence, cause_summary, diagnosis_report, diagnosis_sentence,
                                diagnosis_sentences, prediction_mode_text, reason_sentence, shown_value, skew_sentence,
                                value_text, warning_sentence)
from .._threads import single_threaded_blas
from .calibrate import calibrate, refine
from .effects import COULOMB_GRID, EFFECT_NAMES, STRIBECK_GRID, get_effect, peak_speed, smoothing_speeds
from .predictors import DEFAULT_HORIZON, PLANT_PARAMETERS, RIGID_PARAMETERS, predict, segment_bounds
from .reasons import (Absorbed, BoundValue, Check, Disagreement, FewSegments, Finding, InitialSpeed, OnBound, Reason,
                      RecordNote, SideUndetermined, Step, Unexplained, UnphysicalInterval, WeakBaseline)
from .residuals import residual_analysis
from .signals import data_states, encoder_speeds, shaft_resolution, speed_noise

__all__ = ["CandidateResult", "Cause", "Stage", "Diagnosis", "DiagnosedRig", "diagnose", "check_speed_units", "check_excitation",
           "MIN_GAIN",
           "MIN_T", "BASELINE_MIN_FIT", "VALIDATION_HORIZON", "MIN_TORQUE_SHARE", "MIN_RUBBER_SHARE",
           "EXTENDED_MIN_AHEAD_FIT", "MIN_SEGMENTS", "RIGID_BODY_EFFECTS", "MIN_SKEW_SHARE",
           "stage_disagreements"]

#: Smallest relative decrease of the validation RSS of an accepted effect.
MIN_GAIN = 0.05
#: Smallest t statistic of the per-block validation RSS decrease.
MIN_T = 2.0
#: Smallest torque of a named torque effect (friction at the RMS speed, offset) as a share of the
#: record's RMS motor torque: smaller effects are model mismatch, not a cause to act on.
MIN_TORQUE_SHARE = 0.01
#: Smallest rubber thickness beta named, as a share of the half gap alpha.
MIN_RUBBER_SHARE = 0.1
#: Smallest validation fit (%, k-step, every speed) of the baseline for naming a cause.
BASELINE_MIN_FIT = 30.0
#: Smallest validation fit (%, :data:`VALIDATION_HORIZON` ahead, every speed) of the extended model below
#: which the diagnosis warns that the named causes leave much of the data unexplained.  Where the
#: catalogue holds the truth (66 synthetic 4 s records of benchmarks/bench_diagnose.py: seeds 2000-2002
#: of its 11 effect sets, with and without angle columns) and on KUKA axis 1 the extended model
#: reaches at least 81.9 %; on KUKA axes 2 and 3, whose pose-dependent gravity torque no catalogue
#: effect expresses, 38 % to 69 %.
EXTENDED_MIN_AHEAD_FIT = 75.0
#: Fewest k-step segments in the estimation part without a warning: cluster-robust (sandwich)
#: intervals over few clusters are too narrow (on 2 s records, 11 segments, the sweep's exact-set
#: rate falls from 100 % to 94 % with angle columns, from 95.5 % to 80 % without; a 0.6 s record
#: gave Coulomb friction 41 % high, its interval excluding the truth).
MIN_SEGMENTS = 20
#: Prediction horizon (s) of the validation scores: each block of the validation part is predicted
#: from the data's state this long before its end (slow effects such as friction show over it).
VALIDATION_HORIZON = 0.4
#: Smallest share of the measured twist's spread (std) that the twist of an encoder skew (skew times the RMS load
#: speed) must reach to be held at its fitted value; a smaller skew is held at zero.  Fitted with the nominal
#: structure, a skew absorbs missing effects (on a synthetic record with friction and encoders read at the same
#: instant, 0.13 ms with an interval excluding zero: 1.3 % of the twist's spread, a viscous torque); the KUKA
#: record's link encoder, 2.65 ms late, explains 86 % of it.
MIN_SKEW_SHARE = 0.1
#: Candidates of a forward step refitted in full after the screening.
MAX_REFITS = 3
#: Optimiser iterations of a candidate fitted on top of the current set.
NESTED_NFEV = 40
#: Catalogue keys the rigid-body stage selects from: friction of the one body (keyed on the load side, where
#: the rigid-body model puts friction of either side), the torque offset and the actuator delay.
RIGID_BODY_EFFECTS = ("coulomb_friction@load", "viscous_friction@load", "breakaway_friction@load", "torque_offset",
                      "actuator_delay")
_STRUCTURE_NAMES = {"two_mass": "two-mass model", "rigid_body": "rigid-body model"}


@dataclasses.dataclass(frozen=True, repr=False)
class CandidateResult:
    """One model (a set of effects) calibrated and scored on the validation part.

    Attributes
    ----------
    effects : tuple of str
        Catalogue keys of the set (empty: the nominal structure).
    calibration : Calibration
        Fit on the estimation part.
    prediction : Replay
        k-step prediction over the validation part.
    fit_percent : dict
        Validation fit per speed, k-step prediction (MATLAB ``compare``).
    ahead_fit_percent : dict
        Validation fit per speed, each block predicted :data:`VALIDATION_HORIZON` ahead.
    free_run_fit_percent : dict
        Validation fit per speed, free run from the data's state at the part's start.
    rss : tuple of float
        Validation RSS of the k-step and the ahead prediction, each speed scaled by its std.
    block_rss : tuple of ndarray
        The same per validation block.
    added : str or None
        The key this step added (None for the baseline).
    gain : float
        Relative validation RSS decrease against the set it was added to.
    t_statistic : float
        t statistic of the per-block RSS decrease.
    accepted : bool
    reason_record : Reason or None
        Why it was accepted or not: the step that judged it and the rules it was judged by
        (:class:`~.reasons.Reason`); None for a model no step judged (``baseline``, ``extended``).
    """

    effects: tuple
    calibration: object
    prediction: object
    fit_percent: dict
    ahead_fit_percent: dict
    free_run_fit_percent: dict
    rss: tuple
    block_rss: tuple
    added: str | None = None
    gain: float = 0.0
    t_statistic: float = 0.0
    accepted: bool = False
    reason_record: Reason | None = None

    @property
    def reason(self):
        """Why it was accepted or not, in words (:func:`~backlash_df.render.diagnosis.reason_sentence`); ""
        without a :attr:`reason_record`."""
        return "" if self.reason_record is None else reason_sentence(self.reason_record)

    @property
    def mean_fit_percent(self):
        """Mean of the validation k-step fit percentages of the measured speeds."""
        return float(np.mean(list(self.fit_percent.values())))

    @property
    def mean_ahead_fit_percent(self):
        """Mean of the validation fit percentages of the measured speeds predicted ``VALIDATION_HORIZON`` ahead."""
        return float(np.mean(list(self.ahead_fit_percent.values())))

    @property
    def parameter(self):
        """The added effect's FitParameter (None for the baseline)."""
        return self.calibration.effect_parameter(self.added) if self.added else None

    def to_dict(self):
        """JSON-ready summary."""
        parameter = self.parameter
        return {
            "effects": list(self.effects), "added": self.added,
            "fit_percent": self.mean_fit_percent, "fit_percent_per_signal": self.fit_percent,
            "ahead_fit_percent": self.ahead_fit_percent, "free_run_fit_percent": self.free_run_fit_percent,
            "gain": self.gain, "t_statistic": self.t_statistic,
            "parameter": _parameter_dict(parameter) if parameter else None,
            "accepted": self.accepted, "reason": self.reason,
            "reason_record": None if self.reason_record is None else self.reason_record.to_dict(),
        }

    def __repr__(self):
        fits = ", ".join(f"{name} {value:.1f} %" for name, value in self.fit_percent.items())
        return f"<CandidateResult {' + '.join(self.effects) or 'none'}: k-step fit {fits}, accepted={self.accepted}>"


def _parameter_dict(parameter):
    low, high = parameter.ci95
    return {"name": parameter.name, "value": parameter.value, "stderr": parameter.stderr, "ci95": [low, high],
            "unit": parameter.unit}


@dataclasses.dataclass(frozen=True, repr=False)
class Cause:
    """One named cause: an effect of the catalogue, its side and its fitted parameter.

    Attributes
    ----------
    effect : str
        Catalogue name (``"coulomb_friction"``, ``"rubber"``, ...).
    side : str or None
        ``"motor"`` or ``"load"`` for a friction, None where the effect has no side.
    parameters : dict of str to FitParameter
        The effect's fitted parameter(s), with value, 95 % interval and unit.
    gain : float
        Share of the validation RSS the effect removed when it was added (0 .. 1).
    structure : str
        The model whose value it is: ``"two_mass"`` or ``"rigid_body"`` (module docs, "Two structures").
    determined : bool
        False where the two structures disagree on its value beyond their 95 % intervals
        (:attr:`Diagnosis.disagreements`), or where its parameter ends on a bound of the range the fit allows
        (:attr:`on_bound`): the effect is named, its value is not.
    stribeck_speed : float or None
        For a breakaway friction, the Stribeck speed ``w_s`` (rad/s) its size goes with, chosen by the whole
        record's fit (:meth:`_Search.whole_record`); None for the other effects.
    """

    effect: str
    side: str | None
    parameters: dict
    gain: float
    structure: str = "two_mass"
    determined: bool = True
    stribeck_speed: float | None = None

    def __post_init__(self):
        if self.on_bound:  # a bound is not an estimate, whatever the caller says
            object.__setattr__(self, "determined", False)

    @property
    def key(self):
        """Catalogue key: ``effect@side``, or ``effect`` without a side."""
        return self.effect + (f"@{self.side}" if self.side else "")

    @property
    def on_bound(self):
        """True where the effect's parameter ends on a bound of the range the fit allows
        (:attr:`.calibrate.FitParameter.on_bound`): the data ask for a value beyond it, so the value is a bound,
        not an estimate, and its interval means nothing; such a cause is not :attr:`determined`."""
        return any(p.on_bound for p in self.parameters.values())

    def to_dict(self):
        """The ``causes`` entry of the ``diagnose`` JSON: effect, side, gain, ``{name: {"value", "ci95", "unit"}}``,
        structure, determined, on_bound, stribeck_speed."""
        return {"effect": self.effect, "side": self.side, "gain": self.gain,
                "parameters": {name: {"value": p.value, "ci95": list(p.ci95), "unit": p.unit}
                               for name, p in self.parameters.items()},
                "structure": self.structure, "determined": self.determined, "on_bound": self.on_bound,
                "stribeck_speed": self.stribeck_speed}

    def value_text(self, name):
        """Parameter ``name`` as printed: ``value unit (95 % CI low .. high)``; ``not determined`` for the value
        where the cause is not :attr:`determined`, and the fit's range for the interval where it is
        :attr:`on_bound` (:func:`~backlash_df.render.diagnosis.value_text`)."""
        return value_text(self, name)

    def summary(self):
        """``effect (side): value unit (95 % CI low .. high)`` (:meth:`value_text`), the side left out on the rigid
        body (one inertia; :func:`~backlash_df.render.diagnosis.cause_summary`)."""
        return cause_summary(self)

    def describe(self):
        """The cause in a sentence a person can act on (:meth:`.effects.Effect.describe`), or, where its value
        is not :attr:`determined`, that the drive has it but the record does not determine its size, and why
        (:func:`~backlash_df.render.diagnosis.cause_sentence`)."""
        parameter = self.parameters[self.effect]
        described = (get_effect(self.key).describe(parameter.value, *parameter.ci95,
                                                   rigid=self.structure == "rigid_body") if self.determined else None)
        return cause_sentence(self, described)

    def __repr__(self):
        values = ", ".join(f"{name} = {self.value_text(name)}" for name in self.parameters)
        return f"<Cause {self.key} ({_STRUCTURE_NAMES[self.structure]}): {values}; gain {100 * self.gain:.1f} %>"


def _model_dict(candidate):
    return candidate.to_dict() | {"parameters": candidate.calibration.to_dict()["parameters"]}


def _whole_dict(calibration):
    """The ``whole_record`` entry of the JSON: the calibrated set's effects and every value with its interval
    (those of :meth:`~.calibrate.Calibration.to_dict`)."""
    entry = calibration.to_dict()
    return {"effects": entry["effects"], "parameters": entry["parameters"]}


@dataclasses.dataclass(frozen=True, repr=False)
class Stage:
    """The selection over one model structure (module docs, "Two structures").

    Attributes
    ----------
    structure : str
        ``two_mass`` or ``rigid_body``.
    causes : list of Cause
        The causes this structure names, by decreasing gain.
    baseline, extended : CandidateResult
        Its nominal structure and selected set, refined.
    candidates : list of CandidateResult
        Every model of this structure tried.
    warning_records : list
        What concerns this structure's values (weak baseline, values on bounds, absorbed effects), as records
        (:mod:`~.reasons`: one type per :class:`~.reasons.Concern`); :attr:`warnings` in words.
    absorbed : list of tuple
        ``(kept, dropped, warning)`` of the absorptions its backward elimination found (:func:`_absorption`), the
        warning an :class:`~.reasons.Absorbed` record.
    whole_record : Calibration
        The selected set calibrated anew on the whole record after the transient (:meth:`_Search.whole_record`):
        the causes' values.
    encoder_skew : FitParameter or None
        The two-mass stage's encoder skew (s) where the twist is measured, fitted with the baseline and held
        afterwards (at zero where its interval includes zero).
    """

    structure: str
    causes: list
    baseline: CandidateResult
    extended: CandidateResult
    candidates: list
    warning_records: list
    absorbed: list
    whole_record: object
    encoder_skew: object = None

    @property
    def warnings(self):
        """:attr:`warning_records` in words (:func:`~backlash_df.render.diagnosis.warning_sentence`)."""
        return [warning_sentence(caveat) for caveat in self.warning_records]

    @property
    def keys(self):
        """Catalogue keys of the named causes, in order."""
        return [cause.key for cause in self.causes]

    @property
    def weak_baseline(self):
        """Whether the baseline explains too little of the validation data to name a cause (k-step fit below
        :data:`BASELINE_MIN_FIT` % on a speed)."""
        return _weak(self.baseline)

    @property
    def unexplained(self):
        """Whether the named causes leave much of the data unexplained (the extended model's ahead fit below
        :data:`EXTENDED_MIN_AHEAD_FIT` % on a speed)."""
        return bool(self.causes) and not self.weak_baseline and _unexplained(self.extended)

    @property
    def nominal_values(self):
        """The structure's plant values (:data:`~.predictors.PLANT_PARAMETERS`, or
        :data:`~.predictors.RIGID_PARAMETERS` on the rigid body) as the whole record calibrates them."""
        names = RIGID_PARAMETERS if self.structure == "rigid_body" else PLANT_PARAMETERS
        return {name: self.whole_record.values[name] for name in names}

    def to_dict(self):
        """JSON-ready ``{"structure", "causes", "baseline", "extended", "whole_record", "candidates", "warnings",
        "warning_records"}``."""
        return json_ready({"structure": self.structure, "causes": [cause.to_dict() for cause in self.causes],
                           "baseline": _model_dict(self.baseline), "extended": _model_dict(self.extended),
                           "whole_record": _whole_dict(self.whole_record),
                           "candidates": [c.to_dict() for c in self.candidates], "warnings": self.warnings,
                           "warning_records": [caveat.to_dict() for caveat in self.warning_records]})

    def __repr__(self):
        return (f"<Stage {self.structure}: causes {', '.join(self.keys) or 'none'}; validation k-step fit "
                f"{self.baseline.mean_fit_percent:.1f} % -> {self.extended.mean_fit_percent:.1f} %>")


@dataclasses.dataclass(frozen=True, repr=False)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    causes : list of Cause
        The named causes, by decreasing gain (empty: the nominal structure explains the data);
        :attr:`Cause.structure` says which stage's value it is (:attr:`structure`), :attr:`Cause.determined`
        is False where the two stages disagree beyond their intervals (:attr:`disagreements`).
    sentence : str
        The causes in sentences a person can act on (:func:`~backlash_df.render.diagnosis.diagnosis_sentence`).
    baseline, extended : CandidateResult
        The two-mass model's nominal structure and selected set, refined (``polish``).
    candidates : list of CandidateResult
        Every two-mass model tried, in the order of the search.
    warning_records : list
        What a person must know before trusting the numbers, as records (:mod:`~.reasons`, one type per
        :class:`~.reasons.Concern`): the
        two-mass stage's, then, where the rigid body names the causes, its stage's and the
        :attr:`disagreements`; :attr:`warnings` in words.
    residuals_baseline, residuals_extended : ResidualAnalysis
        Residual analysis of the two k-step predictions on the validation part.
    measurements, rig
        The record as fitted (a speed column replaced by its encoder's speed where that is finer,
        :func:`~.signals.encoder_speeds`, which the warnings then name) and the rig.
    estimation, validation : slice
        Sample ranges of the two parts.
    whole_record : Calibration
        The two-mass model's selected set calibrated anew on the whole record after the transient
        (:attr:`Stage.whole_record`): the values :attr:`causes` names where the two-mass model is the answer.
    structure : str
        Whose values :attr:`causes` names: ``two_mass``, or ``rigid_body`` where the record does not
        resolve the shaft's mode (:attr:`shaft`).
    shaft : ShaftResolution
        The shaft's mode frequency against the band the record resolves.
    two_mass_causes : list of Cause
        The causes the two-mass stage names (the same as :attr:`causes` when it is the answer).
    rigid_body : Stage
        The rigid-body stage.
    disagreements : list of dict
        :func:`stage_disagreements` of the rigid-body stage against the two-mass stage where the rigid-body
        stage is the answer (empty otherwise).
    encoder_skew : FitParameter or None
        How much later the load encoder is read than the motor encoder (s), fitted with the two-mass
        baseline where both angle columns are given (:attr:`Stage.encoder_skew`); None without them.
    """

    causes: list
    sentence: str
    baseline: CandidateResult
    extended: CandidateResult
    candidates: list
    warning_records: list
    residuals_baseline: object
    residuals_extended: object
    measurements: object
    rig: object
    estimation: slice
    validation: slice
    whole_record: object
    structure: str = "two_mass"
    shaft: object = None
    two_mass_causes: list = ()
    rigid_body: Stage | None = None
    disagreements: list = ()
    encoder_skew: object = None

    @property
    def cause(self):
        """The first cause's effect name, ``none`` when there is none."""
        return self.causes[0].effect if self.causes else "none"

    @property
    def warnings(self):
        """:attr:`warning_records` in words, a rigid-body stage's named so
        (:func:`~backlash_df.render.diagnosis.warning_sentence`)."""
        return [warning_sentence(caveat, stage_named=True) for caveat in self.warning_records]

    @property
    def prediction_mode(self):
        """How the fit numbers were computed (:func:`~backlash_df.render.diagnosis.prediction_mode_text`)."""
        return prediction_mode_text(self.baseline.prediction.mode)

    def __repr__(self):
        names = ", ".join(c.key for c in self.causes) or "none"
        stage = self.rigid_body if self.structure == "rigid_body" else self
        return (f"<Diagnosis causes ({_STRUCTURE_NAMES[self.structure]}): {names}; validation k-step fit "
                f"{stage.baseline.mean_fit_percent:.1f} % -> {stage.extended.mean_fit_percent:.1f} %>")

    def to_dict(self):
        """The JSON document of ``backlash-df diagnose --json`` (contract page)."""
        time = self.measurements.time
        return json_ready({
            "cause": self.cause,
            "causes": [cause.to_dict() for cause in self.causes],
            "sentence": self.sentence,
            "warnings": self.warnings,
            "warning_records": [caveat.to_dict() for caveat in self.warning_records],
            "prediction": self.prediction_mode,
            "rule": RULE,
            "estimation": {"start": float(time[self.estimation.start]), "stop": float(time[self.estimation.stop - 1])},
            "validation": {"start": float(time[self.validation.start]), "stop": float(time[-1])},
            "baseline": _model_dict(self.baseline),
            "extended": _model_dict(self.extended),
            "whole_record": _whole_dict(self.whole_record),
            "candidates": [candidate.to_dict() for candidate in self.candidates],
            "structure": self.structure,
            "shaft": self.shaft.to_dict() if self.shaft else None,
            "two_mass_causes": [cause.to_dict() for cause in self.two_mass_causes],
            "rigid_body": self.rigid_body.to_dict() if self.rigid_body else None,
            "disagreements": list(self.disagreements),
            "encoder_skew": self._skew_dict(),
        })

    def _skew_dict(self):
        """The encoder skew's fit (``FitParameter.to_dict``) and ``held``, the value every later fit used."""
        if self.encoder_skew is None:
            return None
        return self.encoder_skew.to_dict() | {"held": self.baseline.calibration.values.get("encoder_skew", 0.0)}

    def skew_sentence(self):
        """The encoder skew in words, "" without angle columns
        (:func:`~backlash_df.render.diagnosis.skew_sentence`)."""
        skew = self.encoder_skew
        return "" if skew is None else skew_sentence(skew, _skew_shown(skew, self.measurements), MIN_SKEW_SHARE)

    def sentences(self):
        """The lines ``backlash-df diagnose`` prints: the cause, each named value, what each model names,
        :attr:`sentence`, the encoder skew, the validation fits, the warnings
        (:func:`~backlash_df.render.diagnosis.diagnosis_sentences`)."""
        return diagnosis_sentences(self)

    def plot(self, ax=None):
        """Measured against the k-step predictions (validation part) of the two-mass baseline and extended model,
        and of the rigid-body model where it names causes, one panel per speed.

        Returns
        -------
        ResultPlot
            One panel per speed; the legend beside the first.
        """
        names = self.measurements.speed_names
        figure, axes = axes_or_new(ax, (len(names), 1), sharex=True, figsize=(9.5, 2.4 * len(names)),
                                   layout="constrained")
        base, ext = self.baseline.prediction, self.extended.prediction
        for j, name in enumerate(names):
            axes[j].plot(base.time, base.measured[:, j], color="0.55", lw=1.2, label="measured")
            axes[j].plot(base.time, base.simulated[:, j], lw=1.0, label="baseline (none)")
            if self.extended.effects:
                axes[j].plot(ext.time, ext.simulated[:, j], lw=1.0, ls="--",
                             label=f"extended ({' + '.join(self.extended.effects)})")
            if self.rigid_body is not None and self.rigid_body.extended.effects:
                rigid = self.rigid_body.extended.prediction
                axes[j].plot(rigid.time, rigid.simulated[:, j], lw=1.0, ls=":",
                             label=f"rigid body ({' + '.join(self.rigid_body.extended.effects)})")
            axes[j].set_ylabel(f"{name} (rad/s)")
        legend_beside(axes[0])
        axes[-1].set_xlabel(f"time (s), validation part, {base.mode}")
        return ResultPlot(figure, axes)

    def rig_out(self):
        """The diagnosed model as a rig file: the rig, the 95 % intervals, what it leaves out
        (:class:`DiagnosedRig`; ``backlash-df diagnose --rig-out``).

        The input rig's ``[controller]`` and ``[model]``; the plant values as the whole
        record calibrates them (:attr:`whole_record`; on the rigid body, whose one
        inertia is all the record determines, both inertias scaled to it in the rig's
        ratio and the shaft's values the rig's); each named cause at its rig key
        (``coulomb_friction@load`` -> ``[friction] coulomb_load``, ``breakaway_friction``
        with the Stribeck speed the diagnosis chose, ``torque_offset`` -> ``[load]
        torque_offset``, ``rubber`` -> ``[plant] rubber_thickness`` and the law
        ``rubber``, the diagnosis' law); and an ``[uncertainty]`` box for every value
        with a 95 % interval, widened to hold the value and clipped to the key's
        range.  Every value is on the load side, as the diagnosis fits them.  A cause
        with no rig key (an ``actuator_delay`` the rig's ``[controller] delay`` does
        not match) or without a determined value is :attr:`DiagnosedRig.dropped`.
        """
        return _diagnosed_rig(self)

    def diagnosed_rig(self):
        """The diagnosed model as a :class:`~backlash_df.config.Rig` (:meth:`rig_out`'s ``rig``)."""
        return self.rig_out().rig

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML report: verdict, warnings, overlays, residuals, search, parameters.

        Parameters
        ----------
        title : str
            Page title (default "Diagnosis of" and the record's source).
        rig_text : str
            The rig file's text, shown as it is (not shown when empty).

        See Also
        --------
        backlash_df.render.diagnosis.diagnosis_report
        """
        residuals = (("baseline", self.residuals_baseline), ("extended", self.residuals_extended))
        return diagnosis_report(self, self.plot().figure,
                                {label: analysis.plot(title=f"Residuals of the {label} model").figure
                                 for label, analysis in residuals},
                                rule=RULE, horizon=VALIDATION_HORIZON, title=title, rig_text=rig_text)


@dataclasses.dataclass(frozen=True, repr=False)
class DiagnosedRig:
    """The diagnosed model as a rig file (:meth:`Diagnosis.rig_out`).

    Attributes
    ----------
    rig : Rig
        The diagnosed rig, its ``[uncertainty]`` the 95 % boxes.
    intervals : dict of str to tuple
        Rig key -> the 95 % interval ``(low, high)`` the diagnosis gives its value (before
        the box is widened to hold the value and clipped to the key's range).
    dropped : list of str
        The named causes the rig does not hold, each in a sentence: no rig key, or no
        determined value.
    notes : list of str
        How the rig was made where it is not the plain calibration (the rigid body's
        inertias, a value kept from the input rig, the law changed to ``rubber``).
    """

    rig: object
    intervals: dict
    dropped: list
    notes: list

    def to_toml(self):
        """The rig file's text: each estimated value with ``# 95 %: [low, high]``, the dropped causes and the
        notes in the comment at its head (:func:`~backlash_df.config.rig_to_toml`)."""
        header = [f"The rig {self.rig.source}."]
        header += [f"dropped: {note}" for note in self.dropped] + [f"note: {note}" for note in self.notes]
        comments = {key: f"95 %: [{low:.6g}, {high:.6g}]" for key, (low, high) in self.intervals.items()}
        return rig_to_toml(self.rig, comments=comments, header="\n".join(header))

    def __repr__(self):
        return (f"<DiagnosedRig {self.rig.source}: {len(self.intervals)} values with intervals, "
                f"{len(self.dropped)} dropped>")


#: Where a named cause goes in the rig file: effect -> (table, key; a friction's key takes ``_side``).
_RIG_KEYS = {"coulomb_friction": ("friction", "coulomb"), "viscous_friction": ("friction", "viscous"),
             "breakaway_friction": ("friction", "breakaway"), "torque_offset": ("load", "torque_offset"),
             "rubber": ("plant", "rubber_thickness")}


def _diagnosed_rig(diagnosis):
    """:meth:`Diagnosis.rig_out`."""
    rig = diagnosis.rig
    data = rig.to_dict()
    estimated, dropped, notes = {}, [], []  # rig key -> (table, value, (low, high))
    if diagnosis.structure == "rigid_body":
        inertia = diagnosis.rigid_body.whole_record.parameters["inertia"]
        scale = 1.0 / (rig.plant.motor_inertia + rig.plant.load_inertia)
        if inertia.on_bound:
            notes.append(f"the record does not resolve the shaft's mode, and the rigid-body model's inertia ended on "
                         f"a bound of the range it was allowed ({inertia.value:.6g} kg m^2): every plant value stays "
                         f"the rig's")
        else:
            for name in ("motor_inertia", "load_inertia"):
                share = getattr(rig.plant, name) * scale
                estimated[name] = ("plant", share * inertia.value, tuple(share * end for end in inertia.ci95))
            notes.append(f"the record does not resolve the shaft's mode: the rigid-body model's inertia "
                         f"{inertia.value:.6g} kg m^2 is split between motor and load in the rig's ratio, and "
                         f"stiffness, damping and half gap stay the rig's")
    else:
        for name in PLANT_PARAMETERS:
            parameter = diagnosis.whole_record.parameters[name]
            if parameter.on_bound:
                notes.append(f"[plant] {name} stays the rig's {getattr(rig.plant, name):g}: its fit ended on a bound "
                             f"of the range it was allowed ({parameter.value:.6g} {parameter.unit})")
            else:
                estimated[name] = ("plant", parameter.value, parameter.ci95)
    for cause in diagnosis.causes:
        parameter = cause.parameters[cause.effect]
        low, high = parameter.ci95
        shown = f"{parameter.value:.6g} {parameter.unit} (95 %: [{low:.6g}, {high:.6g}])"
        if not cause.determined:
            dropped.append(f"{cause.key}: named, but the record does not determine its value")
        elif cause.effect not in _RIG_KEYS:  # the actuator delay
            delay = rig.controller.delay if rig.controller is not None else 0.0
            if low <= delay <= high:
                notes.append(f"{cause.key} = {shown} agrees with the rig's [controller] delay = {delay:g} s")
            else:
                dropped.append(f"{cause.key} = {shown}: no rig key holds a delay of the applied torque; the rig's "
                               f"[controller] delay (dead time on every measured signal) is {delay:g} s")
        else:
            table, key = _RIG_KEYS[cause.effect]
            key = f"{key}_{cause.side}" if table == "friction" else key
            estimated[key] = (table, parameter.value, parameter.ci95)
            if cause.effect == "breakaway_friction":
                data["friction"]["stribeck_speed"] = cause.stribeck_speed
            if cause.effect == "rubber" and rig.model != "rubber":
                data["model"]["backlash"] = "rubber"
                notes.append(f"[model] backlash is \"rubber\" (the rig's was \"{rig.model}\"): the diagnosis "
                             f"fitted the rubber law (40)")
    if diagnosis.structure == "rigid_body" and any(cause.effect.endswith("_friction") for cause in diagnosis.causes):
        notes.append("the rigid-body model's friction acts on the one body, motor and load side together: it is "
                     "written on the load side")
    intervals = {}
    for key, (table, value, (low, high)) in estimated.items():
        data[table][key] = value
        if math.isfinite(low) and math.isfinite(high):
            intervals[key] = (low, high)
            lowest, highest, _ = RANGES[key]
            if key == "rubber_thickness":
                highest = min(highest, 2.0 * data["plant"]["half_gap"])
            data["uncertainty"][key] = [max(min(low, value), lowest), min(max(high, value), highest)]
    source = f"{rig.source} diagnosed from {diagnosis.measurements.source}"
    return DiagnosedRig(rig_from_dict(data, source=source), intervals, dropped, notes)


RULE = (f"an effect is added (forward selection, then backward elimination) if the validation RSS falls by at "
        f"least {100 * MIN_GAIN:g} % and the per-block log RSS ratio has t >= {MIN_T:g} over the validation blocks "
        f"(k-step or {VALIDATION_HORIZON:g} s ahead), and "
        f"its 95 % CI (cluster-robust over segments) excludes the null value (a delay at least one sample, a torque "
        f"effect at least {100 * MIN_TORQUE_SHARE:g} % of the RMS motor torque, rubber at least "
        f"{100 * MIN_RUBBER_SHARE:g} % of the half gap and wider than the twist's uncertainty); "
        f"no cause is named when the baseline's validation fit is below {BASELINE_MIN_FIT:g} % on a speed")


def _skew_shown(skew, measurements):
    """Whether the record shows the encoder skew ``skew`` (FitParameter, s): its 95 % interval excludes zero and
    the twist it explains, ``|skew|`` times the RMS load speed, is at least :data:`MIN_SKEW_SHARE` of the
    measured twist's standard deviation."""
    low, high = skew.ci95
    speed = float(np.sqrt(np.mean(measurements.speeds[:, -1] ** 2)))
    return bool((low > 0.0 or high < 0.0)
                and abs(skew.value) * speed >= MIN_SKEW_SHARE * float(np.std(measurements.twist)))


def check_speed_units(measurements, rig):
    """Refuse speeds that the rig's inertias and the torques say are not rad/s.

    The momentum balance of the whole drive, ``J_m w_m + J_l w_l`` against the
    impulse ``int (T_m + T_l) dt``, is regressed (with a linear trend for
    friction); a slope far from 1 (above 4, as rpm gives 30/pi = 9.55) means
    the speeds are not in rad/s.
    """
    from scipy.integrate import cumulative_trapezoid  # lazy: keeps `import backlash_df` quick

    plant = rig.plant
    load_speed = measurements.load_speed if measurements.load_speed is not None else measurements.motor_speed
    momentum = plant.motor_inertia * measurements.motor_speed + plant.load_inertia * load_speed
    torque = measurements.motor_torque + measurements.load_torque_or_zero
    impulse = cumulative_trapezoid(torque, dx=measurements.dt, initial=0.0)
    t = measurements.time - measurements.time[0]
    design = np.column_stack([impulse, t, np.ones_like(t)])
    slope = float(np.linalg.lstsq(design, momentum - momentum[0], rcond=None)[0][0])
    if slope > 4.0:
        raise ValueError(
            f"{measurements.source}: the speeds change {slope:.3g} times faster than the torques and the rig's "
            f"inertias allow: speeds must be in rad/s (if they are in rpm, multiply by pi/30)"
        )


def check_excitation(measurements, part=slice(None), label="the record"):
    """Refuse a record (or a ``part`` of it) whose torque or speeds do not move: nothing to fit or score."""
    for name in ("motor_torque",) + measurements.speed_names:
        values = getattr(measurements, name)[part]
        if not np.ptp(values) > 1e-9 * max(float(np.max(np.abs(values))), 1.0):
            raise ValueError(f"{measurements.source}: {name} is constant ({values[0]:.6g}) in {label}: there is no "
                             f"excitation to diagnose; record the drive while it moves")


#: The friction law's speeds a diagnosis chooses (:meth:`_Search.fit`): value key, the effect that needs it, the
#: grid of fractions of the record's largest speed.
_CHOSEN_SPEEDS = (("coulomb_smoothing", "coulomb_friction", COULOMB_GRID),
                  ("stribeck_speed", "breakaway_friction", STRIBECK_GRID))
_SPEED_KEYS = frozenset(value_key for value_key, *_ in _CHOSEN_SPEEDS)


def _without_speeds(values):
    """``values`` without the friction law's chosen speeds (:data:`_CHOSEN_SPEEDS`): a fit from them chooses
    the speeds again (:meth:`_Search.fit`)."""
    return {key: value for key, value in values.items() if key not in _SPEED_KEYS}


#: A breakaway bump is told from the Coulomb smoothing only where its Stribeck speed is at least this many times
#: the smoothing speed: a narrower bump fills in the step the smoothing rounds off (:meth:`_Search.fit`).
MIN_BUMP_WIDTH = 3.0


def _distinct_bump(values, smoothing):
    """Whether the Stribeck speed among ``values`` is at least :data:`MIN_BUMP_WIDTH` times the smoothing speed
    (``smoothing``, the catalogue's, where ``values`` give none); True without a Stribeck speed."""
    if "stribeck_speed" not in values:
        return True
    return values["stribeck_speed"] >= MIN_BUMP_WIDTH * values.get("coulomb_smoothing", smoothing)


class _Search:
    """Scores models of one structure (``two_mass`` or ``rigid_body``) on the validation part; the state of one
    stage of a diagnosis."""

    def __init__(self, measurements, rig, estimation, validation, horizon, executor, progress, structure="two_mass"):
        self.measurements, self.rig, self.structure = measurements, rig, structure
        self.estimation, self.validation = estimation, validation
        self.horizon, self.executor, self.progress = horizon, executor, progress
        self.weights = 1.0 / np.maximum(measurements.speeds[validation].std(axis=0), 1e-12)
        self.torque_rms = float(np.sqrt(np.mean(measurements.motor_torque**2)))
        self.baseline = None  # the nominal structure's CandidateResult, once fitted
        self.held = ()  # values held at their start in every fit after the baseline (the encoder skew)
        self.encoder_skew = None  # the baseline's FitParameter of the encoder skew, where the twist is measured
        self.absorbed = []  # (kept key, dropped key, warning) of the backward elimination (:func:`_absorption`)

    def polish(self, candidate):
        """``candidate`` refined by a free run (:func:`~.calibrate.refine`), scored; the refinement is kept only
        where it predicts the validation part at least as well (k-step plus ahead RSS): a free run sees slow
        effects at full size, a k-step fit sees fast ones (delay, rubber) better."""
        refined = self.score(candidate.effects, refine(self.measurements, self.rig, candidate.calibration,
                                                       executor=self.executor))
        self.progress()
        return refined if sum(refined.rss) <= sum(candidate.rss) else candidate

    def whole_record(self, candidate):
        """``candidate``'s set calibrated anew on the whole record after the transient (the estimation and the
        validation part together), from its values, by a k-step fit (:meth:`fit`).  The validation part chose
        the set and scored it; the values a diagnosis names come from all the data, with intervals about 1.3
        times narrower.  The friction law's speeds are chosen again among the same grids, now by the whole
        record's residual: where the estimation part holds few slow reversals its residual does not tell them
        apart, and on the whole record a smoothing wider than the drive's moves viscous friction into Coulomb
        friction.

        No free run refines it: a refinement is kept only where the validation part confirms it
        (:meth:`polish`), for a free run as long as the estimation part; one over the whole record runs longer
        than any that was checked (a free run of closed-loop data drifts the more the longer it runs), and no
        data are left to check it.  On KUKA axis 1 such a free run raised the Coulomb friction by 9 % and lowered
        the viscous friction by 8 %, away from a least-squares fit of the same samples."""
        values = _without_speeds(candidate.calibration.values)
        trials = self._side_by_side(
            lambda start, executor: calibrate(self.measurements, self.rig, candidate.effects,
                                              window=(self.estimation.start, self.measurements.n_samples),
                                              start_values=start, horizon=self.horizon, executor=executor,
                                              polish=False, fixed=self.held, structure=self.structure),
            self._speed_choices(candidate.effects, values), self.executor)
        calibration = min(trials, key=lambda trial: trial.rss)
        self.progress()
        return calibration

    @functools.cached_property
    def twist_uncertainty(self):
        """Uncertainty (rad) of the twist the segments start from.

        With angle columns, the encoders' step (the smallest nonzero change of
        the measured twist); without, the drift of the twist integrated from the
        noisy speeds over the record, three standard deviations of the random
        walk ``sigma sqrt(2 N) dt`` (sigma: the speeds' noise, measured minus
        smoothed).
        """
        twist = self.measurements.twist
        if twist is not None:
            steps = np.abs(np.diff(twist))
            return float(np.min(steps[steps > 0])) if np.any(steps > 0) else 0.0
        noise = float(np.mean(speed_noise(self.measurements)))
        return 3.0 * noise * math.sqrt(2.0 * self.measurements.n_samples) * self.measurements.dt

    def size_findings(self, key, parameter):
        """Rule 3, the size rule, applied to the fitted ``parameter`` of effect ``key``: a :class:`~.reasons.Finding`
        for each of its checks that applies to the effect (the interval always; the delay, the torque or the
        rubber's two where the effect is one)."""
        effect = get_effect(key)
        value, unit = parameter.value, parameter.unit
        findings = [Finding(Check.INTERVAL, not _includes_null(parameter, key), value, effect.null, unit,
                            ci95=tuple(parameter.ci95))]
        if effect.name == "actuator_delay":
            findings.append(Finding(Check.DELAY, not value < self.measurements.dt, value, self.measurements.dt, "s"))
        torque = self.effect_torque(effect, value)
        if torque is not None:
            limit = MIN_TORQUE_SHARE * self.torque_rms
            shown = self.effect_torque(effect, shown_value(parameter))  # a value the data cannot tell from 0 is 0
            findings.append(Finding(Check.TORQUE, bool(torque >= limit), torque, limit, "N m", share=MIN_TORQUE_SHARE,
                                    reference=self.torque_rms, shown=shown))
        if effect.name == "rubber":
            half_gap = self.rig.plant.half_gap
            findings.append(Finding(Check.RUBBER_SHARE, bool(value >= MIN_RUBBER_SHARE * half_gap), value,
                                    MIN_RUBBER_SHARE * half_gap, "rad", share=MIN_RUBBER_SHARE, reference=half_gap))
            findings.append(Finding(Check.RUBBER_TWIST, bool(value > self.twist_uncertainty), value,
                                    self.twist_uncertainty, "rad", twist_measured=self.measurements.twist is not None))
        return findings

    def size_failures(self, key, parameter):
        """The checks of rule 3, the size rule, the fitted ``parameter`` of effect ``key`` fails (empty: it
        passes; :meth:`size_findings`)."""
        return [finding for finding in self.size_findings(key, parameter) if not finding.passed]

    def effect_torque(self, effect, value):
        """Typical torque (N m) of a torque effect of size ``value`` (None for rubber and delay)."""
        if effect.name in ("coulomb_friction", "breakaway_friction", "torque_offset"):
            return abs(value)
        if effect.name == "viscous_friction":
            speed = self.measurements.motor_speed if effect.side == "motor" else self.measurements.speeds[:, -1]
            return value * float(np.sqrt(np.mean(speed**2)))
        return None

    def fit(self, effects, start_values=None, polish=False, screen=False, alone=False):
        """The scored fit of ``effects`` (:func:`~.calibrate.calibrate`; ``screen``: plant values held), on the
        search's executor (:meth:`_side_by_side`) unless ``alone``: a fit that runs on the executor itself, as one of
        several side by side, runs wholly in its own thread.

        The friction law's speeds are chosen, not assumed (:data:`_CHOSEN_SPEEDS`): the smoothing speed of a
        Coulomb friction among :data:`~.effects.COULOMB_GRID`, the Stribeck speed of a breakaway friction among
        :data:`~.effects.STRIBECK_GRID` (at least :data:`MIN_BUMP_WIDTH` times the smoothing speed).  Where a
        friction of the set has no speed among the start values, the set is fitted at every combination of the
        missing speeds, and the fit with the least estimation residual is returned, its speeds carried in the
        values and held by the fits that start from them (the full refit of a forward step and the whole-record
        fit choose them again, :func:`_without_speeds`).  The validation part is not looked at."""
        nested = bool(start_values)
        trials = self._side_by_side(lambda values, executor: self._fit(effects, values or None, polish, screen,
                                                                       executor, nested),
                                    self._speed_choices(effects, start_values), None if alone else self.executor)
        return min(trials, key=lambda trial: trial.calibration.rss)

    def _speed_choices(self, effects, start_values):
        """``start_values`` with each combination of the friction law's speeds it lacks for ``effects``
        (:data:`_CHOSEN_SPEEDS`, a Stribeck speed at least :data:`MIN_BUMP_WIDTH` times the smoothing speed); the
        start values alone where none is missing."""
        start_values = dict(start_values or {})
        names = {get_effect(key).name for key in effects}
        missing = [(value_key, grid) for value_key, name, grid in _CHOSEN_SPEEDS
                   if name in names and value_key not in start_values]
        if not missing:
            return [start_values]
        peak, (smoothing, _) = peak_speed(self.measurements), smoothing_speeds(self.measurements)
        combinations = [start_values | dict(speeds) for speeds in itertools.product(
            *[[(key, share * peak) for share in grid] for key, grid in missing])]
        return [values for values in combinations if _distinct_bump(values, smoothing)]

    def _fit(self, effects, start_values, polish, screen, executor, nested):
        calibration = calibrate(self.measurements, self.rig, effects, window=(self.estimation.start,
                                self.estimation.stop), start_values=start_values, horizon=self.horizon,
                                executor=executor, max_nfev=NESTED_NFEV if nested else None,
                                polish=polish,
                                fixed=(PLANT_PARAMETERS + RIGID_PARAMETERS if screen else ()) + self.held,
                                structure=self.structure)
        self.progress()
        return self.score(effects, calibration)

    def fits(self, jobs, screen=False):
        """:meth:`fit` of every ``(effects, start_values)`` of ``jobs``, in order, the fits side by side on the
        search's executor (:meth:`_side_by_side`): the same results as one by one, since a fit's numbers do not
        depend on its threads, and near the threads' count times faster (the kernel releases the GIL; a single
        fit's Jacobian leaves the optimiser's own steps serial)."""
        return self._side_by_side(lambda job, executor: self.fit(*job, screen=screen, alone=executor is None), jobs,
                                  self.executor)

    @staticmethod
    def _side_by_side(run, jobs, executor):
        """``run(job, executor)`` of every job, in order: side by side on ``executor``, each job then alone in its
        thread (``run(job, None)``), or, with one job or without an executor, in this thread with the executor
        for the job's own use.  A task on the executor never submits to it (module docs: Threads)."""
        if executor is None or len(jobs) <= 1:
            return [run(job, executor) for job in jobs]
        return list(executor.map(lambda job: run(job, None), jobs))

    def settle_skew(self, baseline):
        """The baseline with the encoder skew settled as a property of the record: fitted with the nominal
        structure, then held in every later fit -- at its value where the record shows it (:func:`_skew_shown`),
        else at zero (the baseline refitted so), so that a skew the record does not show moves no other value."""
        skew = baseline.calibration.parameters.get("encoder_skew")
        if skew is None:
            return baseline
        self.encoder_skew, self.held = skew, ("encoder_skew",)
        return baseline if _skew_shown(skew, self.measurements) else self.fit(())

    def score(self, effects, calibration, **fields):
        n = self.measurements.n_samples
        window = (self.validation.start, n)
        run = functools.partial(predict, self.measurements, self.rig, calibration.values, window=window,
                                structure=self.structure)
        short = run(horizon=self.horizon)
        ahead = run(horizon=VALIDATION_HORIZON, block=self.horizon)
        free = run(horizon=None)
        rss, blocks = [], []
        for prediction in (short, ahead):
            scaled = ((prediction.residual * self.weights) ** 2).sum(axis=1)
            starts, _ = segment_bounds(0, scaled.size, calibration.horizon or scaled.size)
            rss.append(float(scaled.sum()))
            blocks.append(np.add.reduceat(scaled, starts))
        return CandidateResult(effects=tuple(effects), calibration=calibration, prediction=short,
                               fit_percent=short.fit_percent(), ahead_fit_percent=ahead.fit_percent(),
                               free_run_fit_percent=free.fit_percent(), rss=tuple(rss), block_rss=tuple(blocks),
                               **fields)

    def judge(self, candidate, current, added):
        """Apply the significance rule to ``candidate`` = ``current`` + ``added``.

        Gain and t are taken in the mode (k-step or ahead) that passes, the larger gain if both do.
        """
        parameter = candidate.calibration.effect_parameter(added)
        tests = []
        for label, new, old, new_blocks, old_blocks in zip(("k-step", "ahead"), candidate.rss, current.rss,
                                                           candidate.block_rss, current.block_rss):
            gain = 1.0 - new / old if old > 0 else 0.0
            ratio = np.log(old_blocks / new_blocks)
            spread = float(np.std(ratio, ddof=1)) if ratio.size > 1 else 0.0
            t_stat = float(np.mean(ratio) / (spread / math.sqrt(ratio.size))) if spread > 0 else 0.0
            tests.append((gain, t_stat, label))
        passing = [test for test in tests if test[0] >= MIN_GAIN and test[1] >= MIN_T]
        gain, t_stat, label = max(passing or tests)
        findings = [Finding(Check.GAIN, bool(gain >= MIN_GAIN), gain, MIN_GAIN, "1", mode=label),
                    Finding(Check.T_STATISTIC, bool(t_stat >= MIN_T), t_stat, MIN_T, "1", mode=label),
                    *self.size_findings(added, parameter)]
        reason = Reason(Step.FORWARD, tuple(findings))
        return dataclasses.replace(candidate, added=added, gain=gain, t_statistic=t_stat, accepted=reason.accepted,
                                   reason_record=reason)


def _forward(search, baseline, keys, tried):
    """Forward selection from ``baseline``; returns the accepted steps in order and the runners-up.

    Every remaining candidate is *screened* by a fit of the effects' parameters
    and the twist offset only (plant values held at the current set's); the
    :data:`MAX_REFITS` with the largest screening gains (at least
    :data:`MIN_GAIN`) are refitted in full, and the one with the largest gain
    that passes the rule is added (so that, for example, the side of a
    friction is chosen by full fits).  The full refits choose the friction
    law's speeds again (:meth:`_Search.fit`): a screening fit's plant values
    belong to the set without the candidate, and a Coulomb smoothing chosen so
    before the rubber was in the set came out at 1 % of the largest speed,
    where the set with rubber chooses 0.3 %: a rounded step that a breakaway
    bump then filled in.  The *runners-up* are the keys whose full fit passed
    the rule in some step but were not added: two nearly collinear effects
    (Coulomb and viscous friction on a record whose speed is mostly a sine)
    pass in the same step with close gains, and the data may say which one it
    is only when both are fitted together (:func:`_backward`).
    """
    current, steps, runners = baseline, [], []
    while True:
        added = [key for key in keys if key not in current.effects]
        screens = search.fits([(current.effects + (key,), current.calibration.values
                                | {get_effect(key).value_key: get_effect(key).start(search.rig)}) for key in added],
                              screen=True)
        screened = [search.judge(fit, current, key) for fit, key in zip(screens, added)]
        tried += [_stepped(trial, Step.SCREENING) for trial in screened]
        promising = sorted((t for t in screened if t.gain >= MIN_GAIN), key=lambda t: -t.gain)[:MAX_REFITS]
        fulls = search.fits([(trial.effects, _without_speeds(trial.calibration.values)) for trial in promising])
        refits = [search.judge(full, current, trial.added) for full, trial in zip(fulls, promising)]
        tried += refits
        passing = [full for full in refits if full.accepted]
        if not passing:
            return steps, [key for key in dict.fromkeys(runners) if key not in current.effects]
        current = max(passing, key=lambda full: full.gain)
        steps.append(current)
        runners += [full.added for full in passing if full is not current]


def _backward(search, steps, runners, tried):
    """Backward elimination over the selected set and the runners-up.

    Starts from the last forward step, with the runners-up fitted along; while
    a member fails the rule against the rest (refit without it, then judged as
    adding it back), a failing member is dropped: first one whose interval in
    the joint fit includes its null value, else the one with the smallest gain
    (the estimation part may tell two collinear effects apart where the short
    validation part cannot).  Returns the
    final model (None without effects) and each member's ``(key, gain)``
    against the rest (its forward gain when it is the only one).
    """
    if not steps:
        return None, []
    final = steps[-1]
    if runners:
        start = final.calibration.values | {get_effect(key).value_key: get_effect(key).start(search.rig)
                                            for key in runners}
        final = search.fit(final.effects + tuple(runners), start)
    alone = steps[0].added if len(steps) == 1 and not runners else None
    while len(final.effects) > 1:
        withouts = search.fits([(tuple(k for k in final.effects if k != key),
                                 final.calibration.values | {get_effect(key).value_key: 0.0}) for key in final.effects])
        checks = [(search.judge(final, without, key), without) for key, without in zip(final.effects, withouts)]
        tried += [_stepped(check, Step.BACKWARD) for check, _ in checks]
        failing = [(not _includes_null(final.calibration.effect_parameter(check.added), check.added), check.gain,
                    without) for check, without in checks if not (check.accepted or _separated(search, check, without))]
        if not failing:
            return final, [(check.added, check.gain) for check, _ in checks]
        without = min(failing, key=lambda item: item[:2])[2]
        search.absorbed += _absorption(search, final, without)
        final = without
    if final.effects[0] == alone:
        return final, [(alone, steps[0].gain)]
    return _judged_alone(search, final, tried)


def _separated(search, check, reduced):
    """Whether a member that fails the rule against the rest (``check``, ``reduced`` the set without it) is kept
    because the estimation part separates it: it fails the block t test only (its validation gain is at least
    :data:`MIN_GAIN` and its size passes rule 3), and without it another member would absorb it
    (:func:`_absorption`).  The t test weighs every block alike, so a block where the drive stands still (nothing
    to predict) counts as much as one of motion; on KUKA axis 1 viscous friction lowers the validation RSS by 43 %
    over Coulomb friction alone, t -0.5, and without it Coulomb friction is 869 N m, not its joint 465 N m."""
    if check.accepted or not check.gain >= MIN_GAIN or search.size_failures(check.added, check.parameter):
        return False
    return bool(_absorption(search, check, reduced))


def _stepped(candidate, step):
    """``candidate`` with its reason's step ``step`` (a screening, a backward check)."""
    return dataclasses.replace(candidate, reason_record=dataclasses.replace(candidate.reason_record, step=step))


def _absorption(search, joint, reduced):
    """``(kept, dropped, warning)`` for a member dropped from ``joint`` (leaving ``reduced``) whose joint
    value passes the size rule (rule 3: its interval excludes its null value, and it is large enough to be
    named), where another member's value in ``reduced`` leaves its joint interval: the kept effect absorbs
    the dropped one (collinear effects, such as Coulomb and viscous friction on a record whose speed
    magnitude varies little), and its value is not its own.  A joint value too small to be named absorbs
    nothing: fitted from clean speeds, a partner of 0.05 % of the RMS torque may exclude zero and move a
    kept value by a share of a per cent, beyond its narrow interval."""
    dropped = next(key for key in joint.effects if key not in reduced.effects)
    parameter = joint.calibration.effect_parameter(dropped)
    if search.size_failures(dropped, parameter):
        return []
    notes = []
    for key in reduced.effects:
        before, after = joint.calibration.effect_parameter(key), reduced.calibration.effect_parameter(key)
        low, high = before.ci95
        if not low <= after.value <= high:
            notes.append((key, dropped, Absorbed(
                structure=search.structure, kept=key, dropped=dropped, kept_value=before.value, kept_ci95=(low, high),
                kept_unit=before.unit, dropped_value=parameter.value, dropped_ci95=tuple(parameter.ci95),
                dropped_unit=parameter.unit, kept_alone=after.value)))
    return notes


def _judged_alone(search, model, tried):
    """A one-effect ``model`` judged against the nominal structure: ``(model, [(key, gain)])`` or ``(None, [])``."""
    check = search.judge(model, search.baseline, model.effects[0])
    tried.append(_stepped(check, Step.BACKWARD))
    return (model, [(check.added, check.gain)]) if check.accepted else (None, [])


def _polished(search, chosen, order, tried):
    """The selected set refined (:meth:`_Search.polish`), every member's refined interval excluding its null value.

    A member whose refined value fails rule 3 (:meth:`_Search.size_failures`:
    its 95 % interval includes the null value, or it is too small) is dropped
    (its evidence came from the k-step fit alone) and the rest is refitted,
    judged and refined again.  Returns the refined model (None when no effect
    is left) and the ``(key, gain)`` of its members.
    """
    while True:
        refined = search.polish(chosen)
        checked = {key: search.size_findings(key, refined.calibration.effect_parameter(key)) for key in chosen.effects}
        weak = {key: findings for key, findings in checked.items() if not all(f.passed for f in findings)}
        if not weak:
            return refined, order
        for key, findings in weak.items():
            tried.append(dataclasses.replace(refined, added=key, accepted=False,
                                             reason_record=Reason(Step.REFINEMENT, tuple(findings))))
        rest = tuple(key for key in chosen.effects if key not in weak)
        if not rest:
            return None, []
        chosen = search.fit(rest, chosen.calibration.values | {get_effect(key).value_key: 0.0 for key in weak})
        order = [(key, gain) for key, gain in order if key in rest]
        if len(rest) == 1:
            chosen, order = _judged_alone(search, chosen, tried)
            if chosen is None:
                return None, []


def _includes_null(parameter, key):
    low, high = parameter.ci95
    return not (low > get_effect(key).null or high < get_effect(key).null)


def _causes(whole, order, structure):
    """The causes of one stage (``structure``): each effect of the set with its parameter of the whole-record
    calibration ``whole`` (:meth:`_Search.whole_record`), by decreasing gain."""
    causes = []
    for key, gain in sorted(order, key=lambda item: -item[1]):
        effect = get_effect(key)
        parameter = whole.effect_parameter(key)
        stribeck = whole.values.get("stribeck_speed") if effect.name == "breakaway_friction" else None
        causes.append(Cause(effect.name, effect.side, {effect.parameter: parameter}, gain, structure,
                            stribeck_speed=stribeck))
    return causes


def _side_notes(keys, tried):
    """A :class:`~.reasons.SideUndetermined` for each named friction whose other side explained the data as well
    on its own (within 1 %)."""
    alone = {trial.effects[0]: trial.gain for trial in tried if len(trial.effects) == 1 and trial.added}
    notes = []
    for key in keys:
        effect = get_effect(key)
        other = f"{effect.name}@{'motor' if effect.side == 'load' else 'load'}" if effect.side else None
        if other in alone and key in alone and abs(alone[other] - alone[key]) < 0.01:
            notes.append(SideUndetermined(effect=effect.name, side=effect.side, other_side=other.split("@")[1],
                                          gain=alone[key], other_gain=alone[other]))
    return notes


def _weak(baseline):
    """Whether a baseline explains too little to name a cause: its k-step fit below :data:`BASELINE_MIN_FIT` %
    on a speed."""
    return not min(baseline.fit_percent.values()) >= BASELINE_MIN_FIT


def _unexplained(extended):
    """Whether an extended model leaves much of the data unexplained: its ahead fit below
    :data:`EXTENDED_MIN_AHEAD_FIT` % on a speed."""
    return not min(extended.ahead_fit_percent.values()) >= EXTENDED_MIN_AHEAD_FIT


def _warnings(measurements, baseline, extended, whole, keys, structure="two_mass"):
    """The warning records (:mod:`.reasons`) of a stage: loading notes (decimation), a weak baseline or extended
    model, a short record, values of the whole-record calibration ``whole`` on a bound, unphysical intervals,
    initial states; for the rigid-body stage only what concerns its own values."""
    two_mass = structure == "two_mass"
    notes = [RecordNote(structure=structure, text=note) for note in measurements.notes] if two_mass else []
    if _weak(baseline):
        name, worst = min(baseline.fit_percent.items(), key=lambda item: item[1])
        notes.append(WeakBaseline(structure=structure, speed=name, fit=worst, minimum=BASELINE_MIN_FIT))
    elif keys and _unexplained(extended):
        name, fit = min(extended.ahead_fit_percent.items(), key=lambda item: item[1])
        notes.append(Unexplained(structure=structure, speed=name, fit=fit, horizon=VALIDATION_HORIZON,
                                 minimum=EXTENDED_MIN_AHEAD_FIT))
    segments = baseline.calibration.n_clusters
    if two_mass and segments < MIN_SEGMENTS:
        notes.append(FewSegments(structure=structure, segments=segments, samples=baseline.calibration.horizon,
                                 minimum=MIN_SEGMENTS))
    parameters = whole.parameters
    physical = PLANT_PARAMETERS + RIGID_PARAMETERS + tuple(get_effect(k).value_key for k in keys
                                                           if not get_effect(k).signed)
    bounded = []
    for name, parameter in parameters.items():
        low, _ = parameter.ci95
        if parameter.on_bound and name not in ("motor_speed0", "load_speed0"):
            bounded.append(BoundValue(name, parameter.value, parameter.unit, parameter.lower, parameter.upper))
        elif name in physical and low < 0.0 <= parameter.value:
            notes.append(UnphysicalInterval(structure=structure, name=name, value=parameter.value,
                                            ci95=tuple(parameter.ci95), unit=parameter.unit))
    if bounded:
        plant = any(name in PLANT_PARAMETERS and parameters[name].on_bound for name in parameters)
        notes.append(OnBound(structure=structure, values=tuple(bounded), plant=plant))
    return notes + (_initial_state_notes(measurements, whole) if two_mass else [])


def _initial_state_notes(measurements, calibration):
    """An :class:`~.reasons.InitialSpeed` for each fitted initial speed of a free run that contradicts the measured
    one (5 noise std)."""
    parameters = calibration.parameters
    measured = data_states(measurements, 0.0, [calibration.window[0]])[0]
    noise = speed_noise(measurements)
    notes = []
    for column, name in ((1, "motor_speed0"), (2, "load_speed0")):
        if name in parameters:
            gap = parameters[name].value - measured[column]
            if abs(gap) > 5.0 * noise[min(column - 1, noise.size - 1)] + 1e-9:
                notes.append(InitialSpeed(name=name, fitted=parameters[name].value, measured=float(measured[column])))
    return notes


def stage_disagreements(answer, other):
    """The effects two stages both name with disjoint 95 % intervals.

    A friction ``other`` names on both sides is compared as their sum (on a stiff
    shaft they act as one), its interval the sum of the ends.

    Parameters
    ----------
    answer, other : Stage
        The stage whose causes are named and the one that cross-checks it (anything with ``structure``,
        ``"two_mass"`` or ``"rigid_body"``, and ``causes``, a list of :class:`Cause`).

    Returns
    -------
    list of dict
        ``{"effect", "two_mass", "rigid_body", "note"}``, each structure's entry ``{"value", "ci95", "unit"}``,
        ``note`` both fits in a sentence (the diagnosis' warning, rendered from a :class:`~.reasons.Disagreement`).
    """
    found = []
    for cause in answer.causes:
        name = cause.effect
        theirs = [c.parameters[name] for c in other.causes if c.effect == name]
        if not theirs:
            continue
        mine = cause.parameters[name]
        summed = {"value": sum(p.value for p in theirs), "unit": mine.unit,
                  "ci95": [sum(p.ci95[0] for p in theirs), sum(p.ci95[1] for p in theirs)]}
        if mine.ci95[1] < summed["ci95"][0] or summed["ci95"][1] < mine.ci95[0]:
            found.append({"effect": name, answer.structure: {"value": mine.value, "ci95": list(mine.ci95),
                                                             "unit": mine.unit},
                          other.structure: summed})
            found[-1]["note"] = warning_sentence(_disagreement(found[-1]))
    return found


def _disagreement(entry):
    """A :func:`stage_disagreements` entry as a :class:`~.reasons.Disagreement` record."""
    return Disagreement(effect=entry["effect"], two_mass=entry["two_mass"], rigid_body=entry["rigid_body"])


def _select(search, keys):
    """One stage of a diagnosis over ``keys`` (module docs): the nominal structure calibrated, forward selection,
    backward elimination and the free-run refinement, unless the baseline explains too little; a :class:`Stage`."""
    baseline = search.settle_skew(search.fit(()))
    tried = [dataclasses.replace(baseline, reason_record=Reason(Step.REFERENCE))]
    weak = _weak(baseline)
    search.baseline = baseline
    chosen, order = (None, []) if weak else _backward(search, *_forward(search, baseline, keys, tried), tried)
    base_final = search.polish(baseline)
    extended = base_final
    if chosen is not None:
        extended, order = _polished(search, chosen, order, tried)
        extended = extended or base_final
    whole = search.whole_record(extended)
    named = [key for key, _ in order]
    absorbed = [note for note in search.absorbed if note[0] in named]  # not an absorber dropped later
    warnings = (_warnings(search.measurements, base_final, extended, whole, named, search.structure)
                + [warning for *_, warning in absorbed]
                + (_side_notes(named, tried) if search.structure == "two_mass" else []))
    return Stage(search.structure, _causes(whole, order, search.structure), base_final, extended, tried, warnings,
                 absorbed, whole, search.encoder_skew)


def _cross_check_keys(rigid, keys):
    """The two-mass stage's candidates where it cross-checks the rigid body (a shaft the record does not
    resolve): the effects the rigid-body stage names, friction on either side, among ``keys``."""
    names = {cause.effect for cause in rigid.causes}
    return [key for key in keys if get_effect(key).name in names]


def _rigid_keys(keys):
    """The rigid-body stage's candidates among ``keys``: :data:`RIGID_BODY_EFFECTS` whose effect is asked for
    (friction of either side)."""
    names = {get_effect(key).name for key in keys}
    return [key for key in RIGID_BODY_EFFECTS if get_effect(key).name in names]


def diagnose(measurements, rig, *, candidates=None, estimation_fraction=0.6, transient_fraction=0.05,
             horizon=DEFAULT_HORIZON, executor=None, progress=None):
    """Name the physical causes of what the rig's model gets wrong in a record.

    Parameters
    ----------
    measurements : Measurements
        The record (:func:`~.measurements.load_measurements`).
    rig : Rig
        Data-sheet plant and torque law (``[model] backlash``).
    candidates : sequence of str, optional
        Catalogue keys to try (default: the whole catalogue; a friction name
        alone is its load side).
    estimation_fraction : float
        End of the estimation part as a fraction of the record (0.6).
    transient_fraction : float
        Initial part dropped from the fit (0.05).
    horizon : float
        Length (s) of the k-step segments.
    executor : concurrent.futures.Executor, optional
        Runs the independent fits of a step side by side (the screenings, the full refits, the backward
        checks, the friction speeds' trials), or a step's lone fit's forward-difference Jacobian columns,
        never both at once (module docs: Threads); a :class:`~concurrent.futures.ThreadPoolExecutor`, the
        kernels release the GIL.  None: every fit in this thread.  The result does not depend on it.  Do
        not call :func:`diagnose` from a task of the same bounded pool.
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol), stage ``"fits"``, after every
        fit (from the fits' threads, one at a time); ``total`` None: the search decides how many.

    Returns
    -------
    Diagnosis

    Raises
    ------
    ValueError
        Unknown candidate, a record without excitation, speeds that are not
        rad/s, fractions out of range.
    """
    with single_threaded_blas():
        return _diagnose(measurements, rig, candidates, estimation_fraction, transient_fraction, horizon, executor,
                         progress)


def _diagnose(measurements, rig, candidates, estimation_fraction, transient_fraction, horizon, executor, progress):
    keys = [get_effect(key).key for key in (candidates if candidates is not None else EFFECT_NAMES) if key != "none"]
    if not 0.0 <= transient_fraction < estimation_fraction < 1.0:
        raise ValueError("need 0 <= transient_fraction < estimation_fraction < 1")
    measurements.check_gear_ratio(rig.plant.gear_ratio, where=rig.source)
    if rig.friction.any or rig.load.torque_offset != 0.0:
        raise ValueError(f"{rig.source}: has [friction] or [load] torque_offset; a diagnosis names what a rig without "
                         f"them lacks: diagnose with them removed (for a diagnosed rig, with the rig it came from)")
    check_excitation(measurements)
    check_speed_units(measurements, rig)
    n = measurements.n_samples
    estimation = slice(int(round(transient_fraction * n)), int(round(estimation_fraction * n)))
    validation = slice(estimation.stop, n)
    check_excitation(measurements, validation, f"the validation part (the last {100 * (1 - estimation_fraction):g} %)")
    measurements = encoder_speeds(measurements)
    search = functools.partial(_Search, measurements, rig, estimation, validation, horizon, executor,
                               step_counter(progress, "fits"))
    rigid = _select(search("rigid_body"), _rigid_keys(keys))
    shaft = shaft_resolution(measurements, rig)
    two_mass = _select(search("two_mass"), keys if shaft.resolved else _cross_check_keys(rigid, keys))
    answer = two_mass if shaft.resolved else rigid
    disagreements = [] if shaft.resolved else stage_disagreements(rigid, two_mass)
    undetermined = {disagreement["effect"] for disagreement in disagreements}
    causes = [dataclasses.replace(cause, determined=cause.determined and cause.effect not in undetermined)
              for cause in answer.causes]
    warnings = list(two_mass.warning_records)
    if answer is rigid:
        warnings += rigid.warning_records + [_disagreement(disagreement) for disagreement in disagreements]

    def analysis(candidate):
        p = candidate.prediction
        return residual_analysis(p.time, p.residual, measurements.motor_torque[validation], p.theta_d, p.torque,
                                 p.load_speed, p.names)

    return Diagnosis(
        causes=causes, sentence=diagnosis_sentence(answer, causes, shaft, measurements, VALIDATION_HORIZON),
        baseline=two_mass.baseline,
        extended=two_mass.extended, candidates=two_mass.candidates, warning_records=warnings,
        residuals_baseline=analysis(two_mass.baseline), residuals_extended=analysis(two_mass.extended),
        measurements=measurements, rig=rig, estimation=estimation, validation=validation, structure=answer.structure,
        shaft=shaft, two_mass_causes=two_mass.causes, rigid_body=rigid, disagreements=disagreements,
        encoder_skew=two_mass.encoder_skew, whole_record=two_mass.whole_record,
    )
