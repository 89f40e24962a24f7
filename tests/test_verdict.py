"""Verdicts per loop: unstable loops are never called safe, bistability is said, DF/simulation conflicts flagged.

The rigs are the examples and the issue's cases: ``motor_lag_feedback.toml`` with a
dead time of 0.5 ms and ``load_feedback.toml`` with kp = 3000 (both unstable with the
gear in contact), ``motor_lag_feedback.toml`` as it is (bistable), ``load_feedback.toml``
(limit cycle), ``motor_feedback.toml`` (no oscillation) and ``load_feedback.toml`` with
kp = 10, ti = 1 s (nearly tangent loci: the DF is 23 % off in amplitude, 32 % in w; the verdict
follows the simulations and flags the DF).
"""

import dataclasses
import math
import warnings

import control as ct
import numpy as np
import pytest

from backlash_df import load_rig, simulate
from backlash_df.limit_cycles import predict_limit_cycles, verify_limit_cycles
from backlash_df.loops import drive_loop
from backlash_df.simulation import measure_limit_cycle
from backlash_df.verdict import VERDICTS, judge_loop, linear_stability
from conftest import EXAMPLES



def tuned(case, **controller):
    rig = load_rig(EXAMPLES / f"{case}.toml")
    return dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, **controller))


RIGS = {
    "delayed": lambda: tuned("motor_lag_feedback", delay=0.0005),
    "stiff": lambda: tuned("load_feedback", kp=3000.0),
    "bistable": lambda: tuned("motor_lag_feedback"),
    "cycle": lambda: tuned("load_feedback"),
    "calm": lambda: tuned("motor_feedback"),
    "tangent": lambda: tuned("load_feedback", kp=10.0, ti=1.0),
}
_CACHE = {}


def judged(name):
    """(rig, verdict) for a named rig, computed once; no RuntimeWarning may escape."""
    if name not in _CACHE:
        rig = RIGS[name]()
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            verdict = judge_loop(rig, verify_limit_cycles(rig, predict_limit_cycles(rig, "phase-plane")))
        _CACHE[name] = rig, verdict
    return _CACHE[name]


def exact_characteristic(part, stiffness, damping, s):
    """det(s I - A - b (k c_x + c c_v) - e_d d e^{-s tau}) / prod |s - eig|: the delay kept exact."""
    closed = part.A + np.outer(part.b, stiffness * part.c_x + damping * part.c_v)
    matrix = s * np.eye(len(part.b)) - closed - np.exp(-s * part.delay) * (part.e_d @ part.d)
    return np.linalg.det(matrix) / np.prod(np.abs(s) + np.abs(np.linalg.eigvals(closed)))


@pytest.mark.parametrize("name", ["delayed", "stiff"])
def test_loop_unstable_in_contact_is_called_unstable(name):
    verdict = judged(name)[1]
    assert verdict.verdict == "unstable", verdict
    assert not verdict.contact_loop.stable and verdict.contact_loop.max_real > 1.0
    # whatever the DF says (here: no stable cycle), every kicked run is named as diverged, none as rest or cycle
    assert {probe.outcome for probe in verdict.probes} == {"diverged"}
    assert all(probe.measured.verdict == "diverged" and not probe.measured.found for probe in verdict.probes)
    assert "unstable" in verdict.reason


@pytest.mark.parametrize("name", ["delayed", "stiff"])
def test_rightmost_contact_pole_solves_the_exact_delay_equation(name):
    # the Pade model's rightmost pole is a root of the characteristic equation with e^{-s tau} exact
    rig, verdict = judged(name)
    part = drive_loop(rig).linear_part()
    pole = verdict.contact_loop.poles[0]
    model = rig.make_model("phase-plane")
    assert abs(exact_characteristic(part, model.stiffness, model.damping, pole)) < 1e-9
    off = abs(exact_characteristic(part, model.stiffness, model.damping, pole + 1.0))
    assert off > 1e3 * abs(exact_characteristic(part, model.stiffness, model.damping, pole))


def test_contact_poles_match_python_control_feedback():
    # independent path: G(s) as a python-control transfer function, closed by the shaft k + c s
    rig, verdict = judged("stiff")
    model = rig.make_model("phase-plane")
    g = drive_loop(rig).transfer_function()
    closed = ct.feedback(g, ct.tf([model.damping, model.stiffness], [1.0]))
    expected = max(ct.poles(closed), key=lambda p: p.real)
    assert abs(verdict.contact_loop.poles[0].real - expected.real) < 1e-6 * abs(expected)
    assert abs(abs(verdict.contact_loop.poles[0].imag) - abs(expected.imag)) < 1e-6 * abs(expected)


def test_pade_order_converges_on_the_rightmost_pole():
    rig = RIGS["delayed"]()
    part = drive_loop(rig).linear_part()
    poles = [linear_stability(part, 5895.0, 10.0, pade_order=order).poles[0] for order in (4, 6, 8)]
    assert abs(poles[1] - poles[2]) < 1e-6 * abs(poles[2])
    assert abs(poles[0] - poles[2]) < 1e-3 * abs(poles[2])


def test_bistable_loop_names_the_separating_cycle():
    rig, verdict = judged("bistable")
    prediction = verdict.prediction
    assert verdict.verdict == "bistable", verdict
    assert verdict.contact_loop.stable
    # the separating cycle is the DF's unstable one: substitute it back into 1 + G N = 0
    unstable = [c for c in prediction.cycles if not c.stable]
    assert verdict.disturbance_source == "DF unstable cycle"
    assert verdict.disturbance_to_start == pytest.approx(unstable[0].amplitude, rel=1e-12)
    g = drive_loop(rig).frequency_response(unstable[0].omega)
    assert abs(1.0 + g * prediction.describing(unstable[0].amplitude, unstable[0].omega)) < 1e-8
    # rest holds for the small kicks, the cycle is reached from a larger one
    outcomes = [probe.outcome for probe in verdict.probes]
    assert outcomes[0] == "rest" and "cycle" in outcomes
    assert verdict.settles_up_to < min(p.disturbance for p in verdict.probes if p.outcome == "cycle")
    assert verdict.cycle.amplitude == pytest.approx(prediction.stable_cycles[0].amplitude, rel=0.1)


def test_limit_cycle_and_no_oscillation():
    _, hunting = judged("cycle")
    assert hunting.verdict == "limit cycle"
    assert {probe.outcome for probe in hunting.probes} == {"cycle"}
    assert hunting.cycle.amplitude == pytest.approx(hunting.prediction.stable_cycles[0].simulated.amplitude, rel=1e-3)
    rig, calm = judged("calm")
    assert calm.verdict == "no oscillation"
    assert calm.settles_up_to == pytest.approx(24.0 * rig.plant.half_gap)
    assert calm.df_agrees is True
    assert calm.contact_loop.stable and calm.open_loop.status == "marginal"  # free load: s = 0


def test_tangent_loci_follow_the_simulation_and_flag_the_df():
    verdict = judged("tangent")[1]
    prediction = verdict.prediction
    df = prediction.stable_cycles[0]
    assert abs(df.omega / verdict.cycle.omega - 1.0) > 0.2  # the DF misses the simulated frequency
    assert verdict.verdict == "limit cycle" and verdict.df_agrees is False
    assert "DF UNRELIABLE" in verdict.reason
    _, agreed = judged("cycle")
    assert agreed.df_agrees is True and "DF agrees" in agreed.reason


def test_every_verdict_is_one_of_the_five_and_serialises():
    for name in RIGS:
        _, verdict = judged(name)
        data = verdict.to_dict()
        assert data["verdict"] in VERDICTS
        assert isinstance(data["contact_loop"]["stable"], bool)
        assert all(len(pole) == 2 and all(math.isfinite(x) for x in pole) for pole in data["contact_loop"]["poles"])


def test_diverging_simulation_is_named_without_warnings():
    rig = RIGS["stiff"]()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = simulate(rig, "phase-plane", t_end=20.0, kick=1.0)  # overflows to inf / NaN near 8 s
        measured = measure_limit_cycle(result)
    assert not np.all(np.isfinite(result.theta_d))
    assert measured.verdict == "diverged" and not measured.found and measured.cycle_dict() is None
    # a run that stays finite but grows beyond the bound is diverged as well
    short = simulate(rig, "phase-plane", t_end=1.0, kick=1.0)
    assert np.all(np.isfinite(short.theta_d)) and np.abs(short.theta_d).max() > 1e3 * rig.plant.half_gap
    assert measure_limit_cycle(short).verdict == "diverged"
