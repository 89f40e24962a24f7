"""Why a diagnosis decided as it did, as data: each candidate's checks and the warnings as records.

A candidate of the search (:class:`~.diagnose.CandidateResult`) carries a
:class:`Reason`: the step of the search that judged it (:class:`Step`) and its
:class:`Finding` records, one per rule of the significance rule it was judged by
(:class:`Check`: the gain and the t statistic always, the size rule's checks where
they fail), each with the number judged and the limit it had to reach.  A diagnosis'
warnings (:attr:`~.diagnose.Diagnosis.warning_records`) are records, one type per
concern (:class:`Concern`: :class:`RecordNote`, :class:`WeakBaseline`, ...), each
with its ``rule`` (the concern), its ``structure`` (the stage whose values it
concerns, ``"two_mass"`` or ``"rigid_body"``; None for a :class:`Disagreement`
between the two) and the numbers its sentence states; ``to_dict()`` gives
``{"rule", "structure", ...}``.

The sentences a person reads (``CandidateResult.reason``, ``Diagnosis.warnings``)
are rendered from these records in :mod:`backlash_df.render.diagnosis`
(:func:`~backlash_df.render.diagnosis.reason_text`,
:func:`~backlash_df.render.diagnosis.warning_text`); a test of a decision checks
the records' rules and numbers, not words.  Units: a gain is a fraction (1), a t
statistic has none, fit percentages are %, torques N m, rubber thickness rad, a
delay and a horizon s, speeds rad/s; a parameter's value carries its own ``unit``.
"""

import dataclasses
import enum
import typing

from .._json import json_ready

__all__ = ["Check", "Step", "Finding", "Reason", "Concern", "RecordNote", "WeakBaseline", "Unexplained",
           "FewSegments", "UnphysicalInterval", "BoundValue", "OnBound", "InitialSpeed", "Absorbed",
           "SideUndetermined", "Disagreement"]


class Check(enum.StrEnum):
    """A rule of the significance rule a candidate is judged by (:mod:`.diagnose`, rules 1 to 3)."""

    GAIN = "gain"  # rule 1: the validation RSS falls by at least MIN_GAIN
    T_STATISTIC = "t statistic"  # rule 2: the per-block log RSS ratio's t at least MIN_T
    INTERVAL = "interval"  # rule 3: the 95 % interval excludes the null value
    DELAY = "delay"  # rule 3: a delay at least one sample
    TORQUE = "torque"  # rule 3: a torque effect at least MIN_TORQUE_SHARE of the RMS motor torque
    RUBBER_SHARE = "rubber share"  # rule 3: rubber at least MIN_RUBBER_SHARE of the half gap
    RUBBER_TWIST = "rubber twist"  # rule 3: rubber wider than the twist's uncertainty


class Step(enum.StrEnum):
    """The step of the search that judged a candidate."""

    REFERENCE = "reference"  # the nominal structure, judged by nothing
    SCREENING = "screening"  # a forward step's screening fit (plant values held)
    FORWARD = "forward"  # a forward step's full fit
    BACKWARD = "backward check"  # a member judged against the rest (backward elimination)
    REFINEMENT = "refinement"  # a member whose refined value fails the size rule: dropped


@dataclasses.dataclass(frozen=True)
class Finding:
    """One rule applied to a candidate: what was judged, against what, and whether it passed.

    Attributes
    ----------
    rule : Check
    passed : bool
    value : float
        The number judged, in ``unit``: the gain (fraction), the t statistic, the fitted value
        (``interval``, ``delay``, ``rubber share``, ``rubber twist``) or the effect's typical torque at
        its fitted value (``torque``: friction at the RMS speed, an offset).
    limit : float
        What it had to reach, in ``unit``: ``value >= limit`` (gain, t, torque, rubber share, delay: one
        sample), ``value > limit`` (rubber twist: the twist's uncertainty); for ``interval`` the null value
        the interval must exclude.
    unit : str
        ``"1"`` for the gain and the t statistic.
    mode : str
        ``gain`` and ``t statistic``: the prediction they were taken in, ``"k-step"`` or ``"ahead"``;
        ``""`` otherwise.
    ci95 : tuple of float or None
        ``interval``: the 95 % interval ``(low, high)``, ``unit``.
    share, reference : float or None
        ``torque`` and ``rubber share``: ``limit = share * reference``, the reference the record's RMS
        motor torque (N m) or the rig's half gap (rad).
    shown : float or None
        ``torque``: the torque as the sentence prints it, N m: 0 where the fitted value is one the data
        cannot tell from 0 (:func:`~backlash_df.render.diagnosis.parameter_resolution`).
    twist_measured : bool or None
        ``rubber twist``: whether the twist's uncertainty is the encoders' step (angle columns given)
        rather than the drift of the twist integrated from the speeds.
    """

    rule: Check
    passed: bool
    value: float
    limit: float
    unit: str
    mode: str = ""
    ci95: tuple | None = None
    share: float | None = None
    reference: float | None = None
    shown: float | None = None
    twist_measured: bool | None = None

    def to_dict(self):
        """``{"rule", "passed", "value", "limit", "unit"}`` and the fields the rule uses."""
        entry = {name: value for name, value in dataclasses.asdict(self).items()
                 if value is not None and not (name == "mode" and value == "")}
        return json_ready(entry | {"rule": str(self.rule)})


@dataclasses.dataclass(frozen=True, repr=False)
class Reason:
    """Why a candidate was accepted or not: the step that judged it and the rules it was judged by.

    Attributes
    ----------
    step : Step
    findings : tuple of Finding
        The gain and the t statistic (each passed or not), then each check of the size rule that failed;
        after the refinement (``step`` ``refinement``) the failed size checks alone; none for the reference.
    """

    step: Step
    findings: tuple = ()

    @property
    def accepted(self):
        """Whether every rule passed (False for the reference and after the refinement)."""
        return self.step not in (Step.REFERENCE, Step.REFINEMENT) and all(f.passed for f in self.findings)

    def finding(self, rule):
        """The finding of ``rule`` (a :class:`Check`), None where there is none."""
        return next((finding for finding in self.findings if finding.rule == rule), None)

    def to_dict(self):
        """``{"step", "findings": [Finding.to_dict()]}``."""
        return {"step": str(self.step), "findings": [finding.to_dict() for finding in self.findings]}

    def __repr__(self):
        failed = ", ".join(str(finding.rule) for finding in self.findings if not finding.passed)
        return f"<Reason {self.step}: {'failed ' + failed if failed else 'accepted' if self.accepted else 'judged'}>"


class Concern(enum.StrEnum):
    """What a diagnosis' warning is about: each has its record type (:class:`RecordNote`, ...)."""

    RECORD = "record"  # a note of the record's loading or conditioning
    WEAK_BASELINE = "weak baseline"  # the baseline's k-step fit below BASELINE_MIN_FIT
    UNEXPLAINED = "unexplained"  # the extended model's ahead fit below EXTENDED_MIN_AHEAD_FIT
    FEW_SEGMENTS = "few segments"  # the estimation part holds fewer than MIN_SEGMENTS segments
    UNPHYSICAL_INTERVAL = "unphysical interval"  # a physical value's interval reaches below 0
    ON_BOUND = "on bound"  # values of the whole record's fit on a bound of their range
    INITIAL_SPEED = "initial speed"  # a fitted initial speed contradicts the measured one
    ABSORBED = "absorbed"  # a kept effect absorbs a dropped one
    SIDE = "side"  # a friction's side not determined
    DISAGREEMENT = "disagreement"  # the two structures disagree on an effect beyond their intervals


@dataclasses.dataclass(frozen=True, kw_only=True)
class Caveat:
    """A warning of a diagnosis as data; one subclass per :class:`Concern` (its :attr:`rule`).

    Attributes
    ----------
    structure : str or None
        The stage whose values it concerns, ``"two_mass"`` or ``"rigid_body"``; None for a disagreement
        between the two.
    """

    rule: typing.ClassVar[Concern]
    structure: str | None = "two_mass"

    def to_dict(self):
        """``{"rule", "structure", ...}``: the concern and its numbers (the subclass' fields)."""
        return json_ready({"rule": str(self.rule), **dataclasses.asdict(self)})


@dataclasses.dataclass(frozen=True, kw_only=True)
class RecordNote(Caveat):
    """A note the record carries from its loading or conditioning (:attr:`~.measurements.Measurements.notes`:
    decimation, an unknown column, a speed taken from an angle column), as it states it: ``text``."""

    rule: typing.ClassVar[Concern] = Concern.RECORD
    text: str


@dataclasses.dataclass(frozen=True, kw_only=True)
class WeakBaseline(Caveat):
    """The baseline explains too little to name a cause: its k-step validation fit ``fit`` (%) on ``speed``,
    the worst, below ``minimum`` (%, :data:`~.diagnose.BASELINE_MIN_FIT`)."""

    rule: typing.ClassVar[Concern] = Concern.WEAK_BASELINE
    speed: str
    fit: float
    minimum: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class Unexplained(Caveat):
    """The named causes leave much of the data unexplained: the extended model predicts ``speed`` ``horizon``
    (s) ahead only to ``fit`` (%), below ``minimum`` (%, :data:`~.diagnose.EXTENDED_MIN_AHEAD_FIT`)."""

    rule: typing.ClassVar[Concern] = Concern.UNEXPLAINED
    speed: str
    fit: float
    horizon: float
    minimum: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class FewSegments(Caveat):
    """The estimation part holds only ``segments`` independent k-step segments of ``samples`` samples each
    (None: one free run), fewer than ``minimum`` (:data:`~.diagnose.MIN_SEGMENTS`)."""

    rule: typing.ClassVar[Concern] = Concern.FEW_SEGMENTS
    segments: int
    samples: int | None
    minimum: int


@dataclasses.dataclass(frozen=True, kw_only=True)
class UnphysicalInterval(Caveat):
    """The 95 % interval ``ci95`` of the physical value ``name`` (fitted ``value``, ``unit``) reaches below 0."""

    rule: typing.ClassVar[Concern] = Concern.UNPHYSICAL_INTERVAL
    name: str
    value: float
    ci95: tuple
    unit: str


@dataclasses.dataclass(frozen=True)
class BoundValue:
    """A value ``name`` fitted to ``value`` (``unit``) on a bound of its range ``[lower, upper]``."""

    name: str
    value: float
    unit: str
    lower: float
    upper: float


@dataclasses.dataclass(frozen=True, kw_only=True, repr=False)
class OnBound(Caveat):
    """Values of the whole record's fit that end on a bound of the range the fit allows (``values``, tuple of
    :class:`BoundValue`): the data do not determine them.  ``plant``: some are plant values (a shaft the record
    may not resolve)."""

    rule: typing.ClassVar[Concern] = Concern.ON_BOUND
    values: tuple
    plant: bool

    def __repr__(self):
        return f"<OnBound ({self.structure}): {', '.join(value.name for value in self.values)}>"


@dataclasses.dataclass(frozen=True, kw_only=True)
class InitialSpeed(Caveat):
    """A free run's fitted initial speed ``name`` (``motor_speed0`` or ``load_speed0``), ``fitted`` rad/s,
    contradicts the ``measured`` one (rad/s) by more than 5 noise standard deviations."""

    rule: typing.ClassVar[Concern] = Concern.INITIAL_SPEED
    name: str
    fitted: float
    measured: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class Absorbed(Caveat):
    """Effect ``kept`` absorbs effect ``dropped``: fitted together on the estimation part they are
    ``kept_value`` (95 % ``kept_ci95``, ``kept_unit``) and ``dropped_value`` (``dropped_ci95``,
    ``dropped_unit``); without ``dropped``, ``kept`` is ``kept_alone`` (``kept_unit``), outside its joint
    interval."""

    rule: typing.ClassVar[Concern] = Concern.ABSORBED
    kept: str
    dropped: str
    kept_value: float
    kept_ci95: tuple
    kept_unit: str
    dropped_value: float
    dropped_ci95: tuple
    dropped_unit: str
    kept_alone: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class SideUndetermined(Caveat):
    """The side of friction ``effect`` named on ``side`` is not determined: on its own it explains the
    validation data as well on ``other_side`` (gain ``other_gain`` against ``gain``, fractions, within 0.01)."""

    rule: typing.ClassVar[Concern] = Concern.SIDE
    effect: str
    side: str
    other_side: str
    gain: float
    other_gain: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class Disagreement(Caveat):
    """The two structures fit ``effect`` with disjoint 95 % intervals (:func:`~.diagnose.stage_disagreements`):
    ``two_mass`` and ``rigid_body``, each ``{"value", "ci95", "unit"}`` (a two-mass friction on both sides as
    their sum)."""

    rule: typing.ClassVar[Concern] = Concern.DISAGREEMENT
    structure: str | None = None
    effect: str
    two_mass: dict
    rigid_body: dict
