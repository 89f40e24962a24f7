"""A diagnosis' reasons and warnings are records; the sentences are rendered from them.

Each record below renders to exactly the sentence the diagnosis printed before the
records existed: the sentences were copied from the output of ``backlash-df diagnose``
on the bundled records (friction, rubber, KUKA axis 1, EMPS) and, for the warnings
those records do not raise, from the earlier code's output on the same numbers.  The
second half runs diagnoses and checks that every record holds the diagnosis' own
numbers (the candidates' gains and t statistics, the fitted values and intervals, the
whole record's values on their bounds, the side trials' gains).
"""

import dataclasses
import json
from pathlib import Path

import pytest

from backlash_df import load_rig
from backlash_df.identify import diagnose, load_measurements
from backlash_df.identify.diagnose import BASELINE_MIN_FIT, EXTENDED_MIN_AHEAD_FIT, MIN_GAIN, MIN_T
from backlash_df.identify.reasons import (Absorbed, BoundValue, Check, Concern, Disagreement, FewSegments, Finding,
                                          InitialSpeed, OnBound, Reason, RecordNote, SideUndetermined, Step,
                                          Unexplained, UnphysicalInterval, WeakBaseline)
from backlash_df.render.diagnosis import reason_sentence, warning_sentence

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

_SHAFT = ("these values end on a bound of the range the fit allows, so the data do not determine them (values of the "
          "shaft a record cannot determine where it does not resolve the shaft's mode: the causes are then named from "
          "the rigid-body model, which does not use them; elsewhere, check them in the rig file): ")
_REST = ("; something outside the catalogue remains (a pose-dependent gravity torque or inertia, a feed-forward, a "
         "torque the record does not hold), and the named values absorb part of it")
_FEW = ("(fewer than 20): cluster-robust intervals over so few segments are too narrow, and so short a record may not "
        "show enough of the motion to tell effects apart; record longer")
_INTEGRATED = " (integrated from the speeds: record motor_angle and load_angle)"

WARNINGS = [  # (record, the sentence printed before the records)
    (OnBound(values=(BoundValue("motor_inertia", 791.6999999500702, "kg m^2", 426.29999999999995, 791.7),
                     BoundValue("load_inertia", 1197.2999999113863, "kg m^2", 644.6999999999999, 1197.3),
                     BoundValue("damping", 20499.999998687075, "N m s/rad", 0.0, 20500.0),
                     BoundValue("half_gap", 7.000000000961761e-06, "rad", 7e-06, 1.3000000000000001e-05)), plant=True),
     _SHAFT + "motor_inertia = 791.7 kg m^2 (range [426.3, 791.7]); load_inertia = 1197 kg m^2 (range [644.7, 1197]); "
     "damping = 2.05e+04 N m s/rad (range [0, 2.05e+04]); half_gap = 7e-06 rad (range [7e-06, 1.3e-05])"),
    (OnBound(structure="rigid_body", values=(BoundValue("inertia", 1988.9999999999998, "kg m^2", 1071.0, 1989.0),),
             plant=False),
     "this value ends on a bound of the range the fit allows, so the data do not determine it: inertia = 1989 kg m^2 "
     "(range [1071, 1989])"),
    (SideUndetermined(effect="coulomb_friction", side="motor", other_side="load", gain=0.9657569806214918,
                      other_gain=0.9658109258153081),
     "the side of coulomb_friction is not determined by the data: on its own it explains the validation data as well "
     "on the load side (gain 96.6 % against 96.6 %); the shaft is too stiff here to tell the sides apart"),
    (SideUndetermined(effect="coulomb_friction", side="load", other_side="motor", gain=0.9078723735508535,
                      other_gain=0.9069585215500554),
     "the side of coulomb_friction is not determined by the data: on its own it explains the validation data as well "
     "on the motor side (gain 90.7 % against 90.8 %); the shaft is too stiff here to tell the sides apart"),
    (Unexplained(speed="motor_speed", fit=50.17490609043321, horizon=0.4, minimum=75.0),
     "the named causes leave much of the data unexplained: with the named causes the model still predicts motor_speed "
     "0.4 s ahead only to 50.2 % (below 75 %)" + _REST),
    (UnphysicalInterval(name="damping", value=467.61041926561796, ci95=(-6661.735094830147, 7596.955933361382),
                        unit="N m s/rad"),
     "the 95 % interval of damping includes unphysical negative values (-6662 .. 7597 N m s/rad)"),
    (RecordNote(text="motor_speed taken from the motor_angle column (five-point central differences): its noise "
                     "0.001 rad/s against 0.05 rad/s"),
     "motor_speed taken from the motor_angle column (five-point central differences): its noise 0.001 rad/s against "
     "0.05 rad/s"),
    (WeakBaseline(speed="load_speed", fit=12.345, minimum=30.0),
     "the baseline explains too little of the validation data (k-step fit 12.3 % on a speed, below 30 %): no cause is "
     "named; check the rig file (inertias, stiffness, gear ratio, units) and the record"),
    (FewSegments(segments=6, samples=100, minimum=20), "the estimation part holds only 6 independent segments of 100 "
     "samples " + _FEW),
    (FewSegments(segments=12, samples=None, minimum=20), "the estimation part holds only 12 independent segments " + _FEW),
    (InitialSpeed(name="motor_speed0", fitted=2.5, measured=1.25),
     "the fitted initial motor speed 2.5 rad/s contradicts the measured 1.25 rad/s"),
    (Absorbed(kept="coulomb_friction@load", dropped="viscous_friction@load", kept_value=465.25, kept_ci95=(440.5, 490.0),
              kept_unit="N m", dropped_value=12.5, dropped_ci95=(10.25, 14.75), dropped_unit="N m s/rad",
              kept_alone=869.0),
     "coulomb_friction@load absorbs viscous_friction@load: fitted together on the estimation part they are 465.2 "
     "(440.5 .. 490) N m and 12.5 (10.25 .. 14.75) N m s/rad, but viscous_friction@load does not improve the "
     "validation part enough to be named, and without it coulomb_friction@load is 869 N m: this record does not tell "
     "the two apart (a longer record, or one whose speed covers a wider range, would)"),
    (Disagreement(effect="coulomb_friction", two_mass={"value": 2.0, "ci95": [1.5, 2.5], "unit": "N m"},
                  rigid_body={"value": 4.5, "ci95": [4.25, 4.75], "unit": "N m"}),
     "coulomb_friction: the rigid-body model gives 4.5 (4.25 .. 4.75) N m, the two-mass model 2 (1.5 .. 2.5) N m: they "
     "disagree beyond their 95 % intervals, so no value is named; the record does not determine it"),
]


def _gain(value, mode):
    return Finding(Check.GAIN, value >= MIN_GAIN, value, MIN_GAIN, "1", mode=mode)


def _t(value, mode):
    return Finding(Check.T_STATISTIC, value >= MIN_T, value, MIN_T, "1", mode=mode)


_RUBBER = (_gain(-0.002860972801770556, "k-step"), _t(-6.413088177419827, "k-step"),
           Finding(Check.INTERVAL, True, 1.4334886697394509e-06, 0.0, "rad", ci95=(1.43e-06, 1.44e-06)),
           Finding(Check.RUBBER_SHARE, False, 1.4334886697394509e-06, 0.002, "rad", share=0.1, reference=0.02),
           Finding(Check.RUBBER_TWIST, False, 1.4334886697394509e-06, 0.0047971327906442835, "rad",
                   twist_measured=False))
_COULOMB = (_gain(-0.05926985882776714, "k-step"), _t(-0.5133220692325718, "k-step"),
            Finding(Check.INTERVAL, False, 0.40468463641186386, 0.0, "N m", ci95=(-0.0152, 0.8245)),
            Finding(Check.TORQUE, False, 0.40468463641186386, 0.5599788956464633, "N m", share=0.01,
                    reference=55.99788956464633, shown=0.40468463641186386))
_TORQUE_ZERO = Finding(Check.TORQUE, False, 4.451e-10, 0.56, "N m", share=0.01, reference=56.0, shown=0.0)
_DELAY = (_gain(0.04595284324039994, "ahead"), _t(1.5571263146474497, "ahead"),
          Finding(Check.INTERVAL, False, 2.592698481126798e-05, 0.0, "s", ci95=(-9.68e-06, 6.15e-05)),
          Finding(Check.DELAY, False, 2.592698481126798e-05, 0.001, "s"))
_PASSED = (_gain(0.899, "k-step"), _t(372.0, "k-step"), Finding(Check.INTERVAL, True, 4.125, 0.0, "N m", ci95=(4.0, 4.25)),
           Finding(Check.TORQUE, True, 4.125, 0.56, "N m", share=0.01, reference=56.0, shown=4.125))

REASONS = [  # (record, the sentence printed before the records)
    (Reason(Step.REFERENCE), "the nominal structure (reference)"),
    (Reason(Step.SCREENING, _RUBBER),
     "screening: gain -0.3 % (k-step) below 5 %; t -6.4 (k-step) below 2; beta 1.43e-06 rad is below 10 % of the half "
     "gap 0.02 rad; beta 1.43e-06 rad is within the twist's uncertainty 0.0048 rad" + _INTEGRATED),
    (Reason(Step.SCREENING, _COULOMB), "screening: gain -5.9 % (k-step) below 5 %; t -0.5 (k-step) below 2; 95 % CI "
     "includes 0; its torque 0.405 N m is below 1 % of the record's RMS torque 56 N m"),
    (Reason(Step.SCREENING, _DELAY), "screening: gain 4.6 % (ahead) below 5 %; t 1.6 (ahead) below 2; 95 % CI includes "
     "0; delay shorter than one sample"),
    (Reason(Step.SCREENING, (_gain(0.8344724928658709, "ahead"), _t(1.9790602775881492, "ahead"))),
     "screening: t 1.98 (ahead) below 2"),
    (Reason(Step.FORWARD, _PASSED), "gain 89.9 % (k-step), t 372.0, CI excludes 0"),
    (Reason(Step.BACKWARD, _PASSED), "backward check: gain 89.9 % (k-step), t 372.0, CI excludes 0"),
    (Reason(Step.BACKWARD, (_gain(0.0, "ahead"), _t(0.6, "ahead"), _COULOMB[2], _TORQUE_ZERO)),
     "backward check: gain 0.0 % (ahead) below 5 %; t 0.6 (ahead) below 2; 95 % CI includes 0; its torque 0 N m is "
     "below 1 % of the record's RMS torque 56 N m"),
    (Reason(Step.REFINEMENT, _DELAY[2:]), "after the free-run refinement: 95 % CI includes 0; delay shorter than one "
     "sample; dropped"),
    (Reason(Step.REFINEMENT, _RUBBER[2:]), "after the free-run refinement: beta 1.43e-06 rad is below 10 % of the half "
     "gap 0.02 rad; beta 1.43e-06 rad is within the twist's uncertainty 0.0048 rad" + _INTEGRATED + "; dropped"),
    (Reason(Step.FORWARD, _RUBBER[:3] + (dataclasses.replace(_RUBBER[4], twist_measured=True),)),
     "gain -0.3 % (k-step) below 5 %; t -6.4 (k-step) below 2; beta 1.43e-06 rad is within the twist's uncertainty "
     "0.0048 rad"),
]


@pytest.mark.parametrize("record, sentence", WARNINGS, ids=[f"{r.rule}-{i}" for i, (r, _) in enumerate(WARNINGS)])
def test_each_warning_renders_to_the_sentence_printed_before(record, sentence):
    assert warning_sentence(record) == sentence
    named = warning_sentence(record, stage_named=True)
    assert named == (f"rigid-body model: {sentence}" if record.structure == "rigid_body" else sentence)


@pytest.mark.parametrize("record, sentence", REASONS, ids=[f"{r.step}-{i}" for i, (r, _) in enumerate(REASONS)])
def test_each_reason_renders_to_the_sentence_printed_before(record, sentence):
    assert reason_sentence(record) == sentence


def test_every_concern_and_check_has_a_sentence():
    assert {record.rule for record, _ in WARNINGS} == set(Concern)
    assert {finding.rule for record, _ in REASONS for finding in record.findings} == set(Check)


def test_records_as_json_hold_the_rule_and_the_numbers():
    side, _ = WARNINGS[2]
    assert side.to_dict() == {"rule": "side", "structure": "two_mass", "effect": "coulomb_friction", "side": "motor",
                              "other_side": "load", "gain": 0.9657569806214918, "other_gain": 0.9658109258153081}
    reason, _ = REASONS[3]
    entry = json.loads(json.dumps(reason.to_dict()))
    assert entry["step"] == "screening"
    assert entry["findings"][3] == {"rule": "delay", "passed": False, "value": 2.592698481126798e-05, "limit": 0.001,
                                    "unit": "s"}
    assert entry["findings"][2]["ci95"] == [-9.68e-06, 6.15e-05] and "mode" not in entry["findings"][2]


# --------------------------------------------------------------------------- the records hold the diagnosis' numbers


@pytest.fixture(scope="module")
def kuka():
    """KUKA axis 1: the rigid body names the causes; values on bounds, friction sides not determined."""
    rig = load_rig(EXAMPLES / "kuka" / "kuka_rig.toml")
    return diagnose(load_measurements(EXAMPLES / "kuka" / "kuka_axis1.csv", gear_ratio=rig.plant.gear_ratio), rig)


def _check_candidates(candidates):
    for candidate in candidates:
        reason = candidate.reason_record
        assert reason.accepted == candidate.accepted
        assert candidate.to_dict()["reason_record"] == reason.to_dict()
        if reason.step == Step.REFERENCE:
            assert candidate.added is None and reason.findings == ()
            continue
        parameter = candidate.calibration.effect_parameter(candidate.added)
        interval = reason.finding(Check.INTERVAL)
        if interval is not None:
            assert (interval.value, interval.ci95, interval.unit) == (parameter.value, tuple(parameter.ci95),
                                                                      parameter.unit)
            assert interval.passed == (not parameter.ci95[0] <= 0.0 <= parameter.ci95[1])
        if reason.step == Step.REFINEMENT:
            assert reason.finding(Check.GAIN) is None and not all(f.passed for f in reason.findings)
            continue
        gain, t = reason.finding(Check.GAIN), reason.finding(Check.T_STATISTIC)
        assert (gain.value, t.value) == (candidate.gain, candidate.t_statistic)
        assert gain.passed == (candidate.gain >= MIN_GAIN) and t.passed == (candidate.t_statistic >= MIN_T)
        assert gain.mode == t.mode and gain.mode in ("k-step", "ahead")


def test_the_candidates_records_hold_their_gain_t_and_fitted_value(kuka):
    _check_candidates(kuka.candidates)
    _check_candidates(kuka.rigid_body.candidates)
    assert {reason.step for c in kuka.candidates for reason in [c.reason_record]} >= {
        Step.REFERENCE, Step.SCREENING, Step.FORWARD, Step.BACKWARD}


def test_the_warnings_records_hold_the_diagnosis_values(kuka):
    records = kuka.warning_records
    assert kuka.warnings == [warning_sentence(r, stage_named=True) for r in records]
    assert kuka.to_dict()["warning_records"] == [r.to_dict() for r in records]
    assert kuka.rigid_body.to_dict()["warning_records"] == [r.to_dict() for r in kuka.rigid_body.warning_records]
    bounds = {(r.structure, v.name): v for r in records if r.rule == Concern.ON_BOUND for v in r.values}
    for structure, whole in (("two_mass", kuka.whole_record), ("rigid_body", kuka.rigid_body.whole_record)):
        on_bound = {name: p for name, p in whole.parameters.items() if p.on_bound and not name.endswith("speed0")}
        assert on_bound and {name for s, name in bounds if s == structure} == set(on_bound)
        for name, p in on_bound.items():
            v = bounds[structure, name]
            assert (v.value, v.unit, v.lower, v.upper) == (p.value, p.unit, p.lower, p.upper)
    alone = {c.effects[0]: c.gain for c in kuka.candidates if len(c.effects) == 1 and c.added}
    sides = [r for r in records if r.rule == Concern.SIDE]
    assert sides
    for r in sides:
        assert r.gain == alone[f"{r.effect}@{r.side}"] and r.other_gain == alone[f"{r.effect}@{r.other_side}"]
        assert abs(r.gain - r.other_gain) < 0.01
    rigid = [r for r in records if r.structure == "rigid_body"]
    assert rigid == list(kuka.rigid_body.warning_records)
    assert all(w.startswith("rigid-body model: ") for w, r in zip(kuka.warnings, records) if r in rigid)
    assert not any(w.startswith("rigid-body model: ") for w in kuka.rigid_body.warnings)


def test_an_unexplained_record_holds_the_worst_ahead_fit():
    rig = load_rig(EXAMPLES / "emps" / "emps_rig.toml")
    result = diagnose(load_measurements(EXAMPLES / "emps" / "emps_record.csv", gear_ratio=rig.plant.gear_ratio), rig)
    _check_candidates(result.candidates)
    unexplained = {r.structure: r for r in result.warning_records if r.rule == Concern.UNEXPLAINED}
    for structure, stage in (("two_mass", result), ("rigid_body", result.rigid_body)):
        speed, fit = min(stage.extended.ahead_fit_percent.items(), key=lambda item: item[1])
        assert fit < EXTENDED_MIN_AHEAD_FIT
        record = unexplained[structure]
        assert (record.speed, record.fit, record.minimum) == (speed, fit, EXTENDED_MIN_AHEAD_FIT)
    unphysical = [r for r in result.warning_records if r.rule == Concern.UNPHYSICAL_INTERVAL]
    assert unphysical
    for r in unphysical:
        p = result.whole_record.parameters[r.name]
        assert (r.value, r.ci95, r.unit) == (p.value, tuple(p.ci95), p.unit) and r.ci95[0] < 0.0 <= r.value
    assert BASELINE_MIN_FIT <= min(result.baseline.fit_percent.values())  # no weak-baseline record, rightly
    assert not any(r.rule == Concern.WEAK_BASELINE for r in result.warning_records)
