"""tune: the fastest loop certified not to hunt (issue 20).

The bandwidth is checked against python-control's frequency response of the contact
loop assembled here from blocks; the answer against a brute-force grid search done
here (independent bandwidth, certification by long simulations from the standard
disturbance set); bad input is one line.
"""

import dataclasses
import itertools
import math

import control as ct
import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
from backlash_df.cli import main
from backlash_df.disturbances import TWIST, Disturbance, shaft_mode, standard_disturbances
from backlash_df.tuning import certify, contact_bandwidth
from conftest import EXAMPLES, example_rig

LAG = example_rig("motor_lag_feedback")
CASCADE = dataclasses.replace(LAG, controller=dataclasses.replace(LAG.controller, kp=150.0, structure="cascade",
                                                                  kv=5.0))
DAMPED = dataclasses.replace(LAG, plant=dataclasses.replace(LAG.plant, damping=30.0),
                             controller=dataclasses.replace(LAG.controller, ti=0.2, torque_lag=0.004))
#: The tunes checked against a brute-force grid: the range's end (motor_feedback), a sharp
#: boundary inside the range (motor_lag_feedback: hunting 1 % above the answer), a stiffer
#: damped shaft behind a slower torque loop (the DF's boundary inside the range).
CASES = {"motor_feedback": (example_rig("motor_feedback"), {"kp": (1.0, 1000.0)}),
         "motor_lag_feedback": (LAG, {"kp": (20.0, 400.0)}),
         "damped": (DAMPED, {"kp": (20.0, 400.0)})}


def blocks_bandwidth(rig):
    """omega_b from python-control blocks: the loop with the shaft k + c s, reference to load speed (or angle).

    Speed loop: J_m s w_m = T_m - T - d_m w_m, J_l s w_l = T - d_l w_l, T = (k + c s) (w_m - w_l) / s,
    T_m = lag * PI (w_ref - F y); a cascade: w_ref = kv (r - p), the output the load angle.  The
    viscous frictions d_m, d_l are the rig's; its dry friction is not in the bandwidth (the contract).
    """
    plant, ctl, friction = rig.plant, rig.controller, rig.friction
    law = rig.make_model()
    s = ct.tf("s")
    pi = ctl.kp * (1 + 1 / (ctl.ti * s))
    speed_filter = 1 / (ctl.speed_filter * s + 1)
    torque_lag = 1 / (ctl.torque_lag * s + 1)
    shaft = (law.stiffness + law.damping * s) / s
    load_over_motor = shaft / (plant.load_inertia * s + friction.viscous_load + shaft)  # w_l / w_m
    motor = 1 / (plant.motor_inertia * s + friction.viscous_motor + shaft * (1 - load_over_motor))  # w_m / T_m
    measured = 1 if ctl.feedback == "motor" else load_over_motor
    speed_loop = ct.feedback(torque_lag * pi * motor, speed_filter * measured)  # w_ref -> w_m
    if ctl.cascade:
        position = (1 if ctl.position_feedback == "motor" else load_over_motor) / s  # p / w_m
        closed = ct.feedback(ctl.kv * speed_loop, position) * load_over_motor / s  # r -> theta_l
    else:
        closed = speed_loop * load_over_motor  # r -> w_l
    omega = np.geomspace(1e-3, 1e4, 20000)
    first = int(np.argmax(np.abs(closed(1j * omega)) <= 1 / math.sqrt(2)))
    omega = np.linspace(omega[first - 1], omega[first], 2000)  # to 1e-7 relative
    return float(omega[np.argmax(np.abs(closed(1j * omega)) <= 1 / math.sqrt(2))])


#: load_feedback with viscous friction on both sides and Coulomb friction on the load (not in the bandwidth).
RUBBING = example_rig("load_feedback").with_values(viscous_motor=0.5, viscous_load=2.0, coulomb_load=100.0)


@pytest.mark.parametrize("name", ["motor_feedback", "load_feedback", "motor_lag_feedback", "cascade", "friction"])
def test_bandwidth_is_the_contact_loops_minus_3_db_on_the_load(name):
    rig = {"cascade": CASCADE, "friction": RUBBING}.get(name) or example_rig(name)
    assert contact_bandwidth(rig) == pytest.approx(blocks_bandwidth(rig), rel=1e-4)


def test_an_unstable_contact_loop_has_no_bandwidth():
    rig = example_rig("load_feedback")
    stiff = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, kp=3000.0))
    assert math.isnan(contact_bandwidth(stiff))


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(("args", "words"), [
    (["--vary", "kp", "10,1"], ["kp", "0 < low < high"]),
    (["--vary", "kp", "0,10"], ["kp", "0 < low < high"]),
    (["--vary", "kp", "1,x"], ["LOW,HIGH"]),
    (["--vary", "stiffness", "1,10"], ["'stiffness'", "kp, ti, speed_filter, kv"]),
    (["--vary", "kv", "1,10"], ["kv", 'structure = "cascade"']),
    (["--vary", "kp", "1,10", "--tolerance", "-0.1"], ["--tolerance"]),
    (["--vary", "kp", "1,10", "--vary", "kp", "2,20"], ["kp given twice"]),
    (["--vary", "kp", "1,10", "--gain-margin", "0.9"], ["gain margin", ">= 1"]),
    (["--vary", "kp", "1,10", "--gain-margin", "nan"], ["gain margin", ">= 1"]),
])
def test_bad_ranges_are_one_line(args, words):
    result = CliRunner().invoke(main, ["tune", str(EXAMPLES / "motor_feedback.toml"), *args])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:"), result.output
    for word in words:
        assert word in lines[0]


def test_a_value_that_does_not_vary_is_refused():
    rig = example_rig("motor_feedback")
    p_only = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, ti=math.inf))
    with pytest.raises(ValueError, match="ti does not vary"):
        bd.tune(p_only, {"ti": (0.1, 1.0)})
    with pytest.raises(ValueError, match="one or two"):
        bd.tune(rig, {"kp": (1.0, 2.0), "ti": (0.1, 1.0), "speed_filter": (1e-3, 1e-2)})
    with pytest.raises(ValueError, match="tolerance"):
        bd.tune(rig, {"kp": (1.0, 2.0)}, tolerance=math.nan)


# --------------------------------------------------------------------------- the answer against brute force


@pytest.fixture(scope="module")
def tunings():
    """Each case's tuning, computed once."""
    return {}


def tuned(tunings, case):
    if case not in tunings:
        rig, vary = CASES[case]
        tunings[case] = bd.tune(rig, vary, gain_margin=1)
    return tunings[case]


def motion(rig, disturbance, t_end):
    """The later half of a simulation against the earlier: largest |w_m - w_l| (rad/s) over (t_end/4, t_end/2]
    and over (t_end/2, t_end], the number of times the shaft comes into contact (|theta_d| reaches alpha
    from inside the gap) in the later half, and, with dry friction, the later half's break-aways (a side
    leaving its stick) and the share of it with every rubbing side stuck (0 and 0.0 without)."""
    run = bd.simulate(rig, t_end=t_end, initial=disturbance.initial())
    names = run.state_names
    relative = np.abs(run.states[:, names.index("motor_speed")] - run.states[:, names.index("load_speed")])
    earlier, later = (run.time > 0.25 * t_end) & (run.time <= 0.5 * t_end), run.time > 0.5 * t_end
    contact = np.abs(run.states[later, names.index("theta_d")]) >= rig.plant.half_gap
    modes = np.zeros((int(np.sum(later)), 0)) if run.friction_mode is None else run.friction_mode[later]
    stuck = modes == 0
    return (float(np.max(relative[earlier])), float(np.max(relative[later])), int(np.sum(contact[1:] & ~contact[:-1])),
            int(np.sum(stuck[:-1] & ~stuck[1:])), float(np.mean(np.all(stuck, axis=1))) if stuck.shape[1] else 0.0)


def settles(rig, t_end=80.0):
    """Every standard disturbance dies out in a simulation of ``t_end`` (s).

    The later half's motion is negligible or below 0.8 of the earlier half's, or it
    touches a flank at most 8 times and, not growing, drifts or, stuck, creeps: a free
    load drifting across the gap, losing speed only at its rare impacts (its speed
    decaying like 1/t), is not hunting; nor is a loop with dry friction stuck at least
    half the later half and breaking away at most 8 times there: integral action creeping
    to rest winds the shaft up ever more slowly as the error shrinks, each slide ending
    nearer the rest and the next further off, so that one half of the run may hold a
    slide and the other none.  A cycle of the loop, a backlash or a stick-slip one
    (periods of a second or two here), touches a flank or breaks away dozens to
    hundreds of times.
    """
    scale = rig.plant.half_gap * shaft_mode(rig)
    for disturbance in standard_disturbances(rig):
        earlier, later, contacts, breakaways, stuck = motion(rig, disturbance, t_end)
        dying = later < 1e-6 * scale or later < 0.8 * earlier
        drifting = contacts <= 8 and later <= earlier  # NaN (diverged) is neither
        creeping = contacts <= 8 and breakaways <= 8 and stuck >= 0.5 and math.isfinite(later)
        if not (dying or drifting or creeping):
            return False
    return True


def test_settles_judges_dry_friction_as_the_loop_moves():
    """The PI cascade of tests/test_friction_loop.py: with a breakaway friction it hunts by stick-slip (a break-away
    every 0.8 s); with Coulomb friction alone it creeps to rest, each slide ending 6 times nearer the rest than the
    last and the next ever later (at 1, 13 and 86 s from a twist of -0.04 rad: the later half of 80 s holds none,
    the motor crossing the gap once toward the next), which the earlier half's quieter wind-up must not make
    hunting."""
    from test_friction_loop import STICK_SLIP, _rig

    assert not settles(_rig(STICK_SLIP), t_end=20.0)
    creeping = _rig({"coulomb_load": 20.0})
    earlier, later, contacts, breakaways, stuck = motion(creeping, Disturbance(TWIST, -0.04), 80.0)
    assert later > earlier and contacts == 1 and breakaways == 0 and stuck == 1.0
    assert settles(creeping)


def shared(case):
    """The xdist group of the tests that share ``case``'s tuning (:func:`tunings`): one worker computes it once,
    while the other cases' groups run on the other worker."""
    return pytest.mark.xdist_group(f"tune-{case}")


@pytest.mark.xdist_group("grouping-check")
def test_the_suite_s_xdist_groups_hold(request):
    """Under ``--dist loadgroup`` a grouped test's id carries its group: the mark that keeps each shared
    tuning on one worker is in effect (pytest 9.2 with pytest-xdist 3.8 drops it without a word,
    pytest-dev/pytest-xdist#1386)."""
    if not getattr(request.config.option, "loadgroup", False):  # set on pytest-xdist's workers
        pytest.skip("not run by pytest-xdist with --dist loadgroup")
    assert request.node.nodeid.endswith("@grouping-check")


@pytest.mark.parametrize("case", [pytest.param(case, marks=shared(case)) for case in CASES])
def test_the_tuning_settles_and_every_faster_tuning_of_a_fine_grid_hunts(tunings, case):
    """Within 2 % of a brute-force grid's best: none of its points of a larger bandwidth settles in long simulations."""
    tuning = tuned(tunings, case)
    rig, vary = CASES[case]
    (name, (low, high)), = vary.items()
    assert tuning.feasible
    best = rig.with_values(**{name: tuning.best.values[0]})
    assert tuning.best.bandwidth == pytest.approx(blocks_bandwidth(best), rel=1e-3)
    assert settles(best)
    grid = np.geomspace(low, high, int(math.ceil(math.log(high / low) / math.log(1.02))) + 1)  # 2 % apart
    faster = [rig.with_values(**{name: value}) for value in grid]
    faster = [r for r in faster if blocks_bandwidth(r) > tuning.best.bandwidth / 0.98]
    assert not any(settles(r, t_end=40.0) for r in faster)
    tolerance = [p.tolerance for p in tuning.front]  # the front: monotone, from the certified tuning
    bandwidth = [p.bandwidth for p in tuning.front]
    assert tuning.front[0].tolerance == 0.0 and tuning.front[0].values == tuning.best.values
    assert tolerance == sorted(tolerance) and bandwidth == sorted(bandwidth) and len(set(bandwidth)) == len(bandwidth)


def test_a_load_feedback_loop_that_hunts_at_every_gain_is_infeasible_with_its_least_hunting_tuning():
    rig = example_rig("load_feedback")
    tuning = bd.tune(rig, {"kp": (5.0, 100.0)}, gain_margin=1)
    assert not tuning.feasible and not tuning.best.certified
    assert tuning.best.verdict.verdict in ("limit cycle", "bistable", "unstable")
    assert not settles(rig.with_values(kp=tuning.best.values[0]))
    screened = [c.amplitude for c in tuning.screen if math.isfinite(c.bandwidth)]
    assert tuning.to_dict()["feasible"] is False and min(screened) > 0.0


# --------------------------------------------------------------------------- checkpoints


class _Counted:
    """A stand-in for ``tuning._screen_cell`` that records its cells and raises Ctrl-C at call ``at``."""

    def __init__(self, original, at=None):
        self.original, self.at, self.cells = original, at, []

    def __call__(self, settings, values):
        self.cells.append(tuple(values))
        if len(self.cells) == self.at:
            raise KeyboardInterrupt
        return self.original(settings, values)


@shared("damped")
def test_an_interrupted_tune_resumes_to_the_same_answer_and_recomputes_no_finished_cell(tunings, tmp_path,
                                                                                       monkeypatch):
    import backlash_df.tuning as tuning_module
    from backlash_df.checkpoint import Checkpoint

    rig, vary = CASES["damped"]
    uninterrupted = tuned(tunings, "damped")
    path = tmp_path / "tune.checkpoint"
    interrupt = _Counted(tuning_module._screen_cell, at=5)
    monkeypatch.setattr(tuning_module, "_screen_cell", interrupt)
    with pytest.raises(KeyboardInterrupt):
        bd.tune(rig, vary, gain_margin=1, checkpoint=path)
    done = set(interrupt.cells[:4])
    counting = _Counted(interrupt.original)
    monkeypatch.setattr(tuning_module, "_screen_cell", counting)
    resumed = bd.tune(rig, vary, gain_margin=1, checkpoint=Checkpoint(path, resume=True))
    assert not done & set(counting.cells)
    first, second = uninterrupted.to_dict(), resumed.to_dict()
    first.pop("seconds"), second.pop("seconds")
    assert second == first


@shared("motor_lag_feedback")
def test_the_certificate_holds_under_refinement_at_a_sharp_boundary(tunings):
    """Half the simulation step and twice the shooting seeds: the answer is certified again, and the
    faster tuning that failed its certificate (1 % above, at the sharp boundary) fails again."""
    tuning = tuned(tunings, "motor_lag_feedback")
    rig, _ = CASES["motor_lag_feedback"]
    failed = [c for c in tuning.certificates if not c.certified and c.bandwidth > tuning.best.bandwidth]
    assert failed, "the case has a sharp boundary: a faster tuning failed its certificate"
    refined = certify(rig.with_values(kp=tuning.best.values[0]), refinement=2)
    assert refined.certified and refined.verdict.verdict == tuning.best.verdict.verdict == "no oscillation"
    assert not certify(rig.with_values(kp=failed[0].values[0]), refinement=2).certified


def first_harmonic(rig, disturbance, t_end=60.0):
    """The first-harmonic amplitude of theta_d (rad) over the last 10 s of a simulation: the dominant frequency
    from a zero-padded FFT, then a least-squares fit of a sine and a cosine there."""
    run = bd.simulate(rig, t_end=t_end, initial=disturbance.initial())
    late = run.time > t_end - 10.0
    time, twist = run.time[late], run.theta_d[late] - np.mean(run.theta_d[late])
    spectrum = np.abs(np.fft.rfft(twist, 8 * twist.size))
    omega = 2 * np.pi * np.fft.rfftfreq(8 * twist.size, time[1] - time[0])[np.argmax(spectrum)]
    basis = np.column_stack([np.cos(omega * time), np.sin(omega * time)])
    return float(np.hypot(*np.linalg.lstsq(basis, twist, rcond=None)[0]))


@shared("motor_lag_feedback")
def test_a_tolerance_buys_bandwidth_and_the_loop_hunts_within_it(tunings):
    """With tolerance A the answer is faster than the certified one, and simulations from the standard set end
    on cycles whose first harmonic of theta_d is within A (the test's own Fourier fit)."""
    rig, vary = CASES["motor_lag_feedback"]
    tolerance = 0.35
    strict = tuned(tunings, "motor_lag_feedback")
    loose = bd.tune(rig, vary, tolerance=tolerance, gain_margin=1)
    assert loose.feasible and loose.best.bandwidth > strict.best.bandwidth
    assert 0.0 < loose.best.amplitude <= tolerance
    answer = rig.with_values(kp=loose.best.values[0])
    amplitudes = [first_harmonic(answer, disturbance) for disturbance in standard_disturbances(answer)]
    assert max(amplitudes) <= 1.02 * tolerance
    assert max(amplitudes) == pytest.approx(loose.best.amplitude, rel=0.05)


# --------------------------------------------------------------------------- bounds, plateaus, least hunting, margin


def test_a_plateau_is_left_at_its_knee_and_a_bound_is_flagged():
    """kp 5..1e5 on motor_feedback: the bandwidth gains < 1 % over the last factor of 2 below 1e5; the answer is
    the smallest certified kp within 1 % of the plateau (python-control's bandwidth: within 1 % at the answer; a
    factor 1.02 lower outside it, or a certificate failed there), flagged; kp 1..100 ends on the bound, still
    climbing, and says so."""
    rig = example_rig("motor_feedback")
    tuning = bd.tune(rig, {"kp": (5.0, 1e5)}, gain_margin=1)
    top = blocks_bandwidth(rig.with_values(kp=1e5))
    assert blocks_bandwidth(rig.with_values(kp=5e4)) > top / 1.01  # the plateau, independently
    kp = tuning.best.values[0]
    assert tuning.feasible and tuning.best.certified and kp < 5e3
    assert blocks_bandwidth(rig.with_values(kp=kp)) >= 0.99 * top * (1 - 1e-4)
    knee = blocks_bandwidth(rig.with_values(kp=kp / 1.02)) < 0.99 * top  # the smallest within 1 % ...
    failed = [c.values[0] for c in tuning.certificates if not c.certified and kp / 1.35 <= c.values[0] < kp]
    assert knee or failed  # ... or the smaller ones within 1 % fail their certificate (4 bisections: 1.35)
    assert tuning.plateau["kp"]["reached_at"] == kp and tuning.plateau["kp"]["bandwidth"] == pytest.approx(top, 1e-3)
    assert tuning.on_bound == () and tuning.to_dict()["best"]["plateau"]["kp"]["reached_at"] == kp
    assert any(line.startswith("plateau:") for line in tuning.sentences())
    bound = bd.tune(rig, {"kp": (1.0, 100.0)}, gain_margin=1)
    assert bound.best.values == (100.0,) and bound.on_bound == ("kp",) and not bound.plateau
    assert bound.to_dict()["best"]["on_bound"] == ["kp"] and any("on a bound" in line for line in bound.sentences())


#: The brief's drive where nothing is certified: a light motor on a soft shaft, load feedback.
HUNTING = example_rig("load_feedback").with_values(motor_inertia=0.02, load_inertia=0.5, stiffness=2000.0,
                                                   damping=0.5, half_gap=0.01)
HUNTING_VARY = {"kp": (0.1, 100.0), "ti": (0.01, 2.0)}


@pytest.fixture(scope="module")
def least(tunings):
    if "hunting" not in tunings:
        tunings["hunting"] = bd.tune(HUNTING, HUNTING_VARY, gain_margin=1)
    return tunings["hunting"]


@shared("hunting")
def test_without_a_certified_tuning_the_answer_is_the_least_simulated_hunting(least):
    """The answer's amplitude is the smallest of every simulated one (front included), and the words fit."""
    assert not least.feasible
    assert least.best.values == least.simulated[0][0] and least.best.amplitude == least.simulated[0][1]
    assert least.best.amplitude == min(amplitude for _, amplitude in least.simulated)
    assert least.best.amplitude <= min(p.amplitude for p in least.front) * (1 + 1e-12)
    assert least.sentences()[0].startswith("no tuning certified; least hunting:")
    from backlash_df.render.tuning import range_caption
    assert "no tuning certified; the least hunting" in range_caption(least)


def harmonic(run, start, end):
    """The first-harmonic amplitude of theta_d (rad) over ``start < t <= end`` of ``run`` (as
    :func:`first_harmonic`: the FFT's dominant frequency, then a least-squares sine and cosine there)."""
    window = (run.time > start) & (run.time <= end)
    time, twist = run.time[window], run.theta_d[window] - np.mean(run.theta_d[window])
    spectrum = np.abs(np.fft.rfft(twist, 8 * twist.size))
    omega = 2 * np.pi * np.fft.rfftfreq(8 * twist.size, time[1] - time[0])[np.argmax(spectrum)]
    basis = np.column_stack([np.cos(omega * time), np.sin(omega * time)])
    return float(np.hypot(*np.linalg.lstsq(basis, twist, rcond=None)[0]))


def steady_harmonic(rig, disturbance):
    """The first harmonic of theta_d the run from ``disturbance`` settles to: the last 10 s of 40 s where they
    agree with the 10 s before to 2 %, else of 160 s (a slow loop's cycle still growing or shrinking at 40 s)."""
    for t_end in (40.0, 160.0):
        run = bd.simulate(rig, t_end=t_end, initial=disturbance.initial())
        last, before = harmonic(run, t_end - 10.0, t_end), harmonic(run, t_end - 20.0, t_end - 10.0)
        if abs(last - before) <= 0.02 * last:
            break
    return last


@pytest.mark.slow
@shared("hunting")
def test_the_least_hunting_answer_is_within_10_percent_of_a_12_by_12_grid_s_least(least):
    """A 12 x 12 log grid over the range, each tuning simulated from the standard disturbances: its hunting the
    largest first harmonic of theta_d they end on (:func:`steady_harmonic`): the answer's own is within 10 %
    of the grid's smallest."""
    rig = HUNTING

    def hunting(kp, ti):
        tuned = rig.with_values(kp=kp, ti=ti)
        return max(steady_harmonic(tuned, d) for d in standard_disturbances(tuned))

    grid = [hunting(kp, ti) for kp in np.geomspace(0.1, 100.0, 12) for ti in np.geomspace(0.01, 2.0, 12)]
    answer = hunting(*least.best.values)
    assert answer <= 1.1 * min(grid)


def test_the_answer_holds_its_gain_margin_in_the_test_s_own_simulations(tunings):
    """Default margin 1.25 on motor_lag_feedback: slower than the margin-free answer (1 % from hunting), and
    kp x 1.25 and kp / 1.25 settle from every standard disturbance (the test's simulations)."""
    rig, vary = CASES["motor_lag_feedback"]
    tuning = bd.tune(rig, vary)
    assert tuning.gain_margin["requested"] == 1.25 and tuning.gain_margin["achieved"]["kp"] >= 1.25
    kp = tuning.best.values[0]
    assert tuning.feasible and kp < tuned(tunings, "motor_lag_feedback").best.values[0] / 1.2
    for factor in (1.25, 1 / 1.25):
        assert settles(rig.with_values(kp=kp * factor))
    assert tuning.to_dict()["best"]["gain_margin"]["requested"] == 1.25


class _CountedCertify:
    """A stand-in for ``tuning.certify`` that records its tunings' values and raises Ctrl-C at call ``at``."""

    def __init__(self, original, at=None):
        self.original, self.at, self.calls = original, at, []

    def __call__(self, rig, *args, **kwargs):
        self.calls.append(rig.controller.kp)
        if len(self.calls) == self.at:
            raise KeyboardInterrupt
        return self.original(rig, *args, **kwargs)


def test_a_tune_interrupted_in_its_gain_margin_stage_resumes_to_the_same_answer(tmp_path, monkeypatch):
    """kp 1..100 on motor_feedback, the default margin: the answer (kp = 100) and its scaled tunings are
    certificates 1 to 3, the margin's probes follow; stopped at the 5th, resumed: none of the 4 done again,
    the same JSON as an uninterrupted tune."""
    import backlash_df.tuning as tuning_module
    from backlash_df.checkpoint import Checkpoint

    rig, vary = example_rig("motor_feedback"), {"kp": (1.0, 100.0)}
    stages = []
    uninterrupted = bd.tune(rig, vary, progress=lambda stage, done, total: stages.append(stage))
    assert "gain margin" in stages and uninterrupted.best.values == (100.0,)
    path = tmp_path / "tune.checkpoint"
    interrupt = _CountedCertify(tuning_module.certify, at=5)
    monkeypatch.setattr(tuning_module, "certify", interrupt)
    with pytest.raises(KeyboardInterrupt):
        bd.tune(rig, vary, checkpoint=path)
    counting = _CountedCertify(interrupt.original)
    monkeypatch.setattr(tuning_module, "certify", counting)
    resumed = bd.tune(rig, vary, checkpoint=Checkpoint(path, resume=True))
    assert not set(interrupt.calls[:4]) & set(counting.calls) and counting.calls
    first, second = uninterrupted.to_dict(), resumed.to_dict()
    first.pop("seconds"), second.pop("seconds")
    assert second == first


def test_the_front_s_amplitudes_are_the_exact_orbits_where_shooting_converges():
    """Each hunting front point's amplitude is the stable exact orbit the test shoots at that tuning, from the
    simulation the test runs there (the orbit within 1 % of the simulated cycle)."""
    rig = example_rig("motor_lag_feedback")
    tuning = bd.tune(rig, {"kp": (20.0, 400.0)}, gain_margin=1)
    hunting = [p for p in tuning.front if p.amplitude > 0.0]
    assert hunting
    exact = 0
    for point in hunting:
        tuned = rig.with_values(kp=point.values[0])
        prediction = bd.verify_limit_cycles(tuned, bd.predict_limit_cycles(tuned))
        simulated = max(c.simulated.amplitude for c in prediction.stable_cycles if c.simulated.found)
        orbits = [o for o in bd.exact_orbits(tuned, prediction) if o.stable]
        matching = [o.amplitude for o in orbits if abs(o.amplitude / simulated - 1) <= 0.01]
        if matching:
            exact += 1
            assert point.amplitude == pytest.approx(matching[0], rel=1e-6)
        assert point.amplitude == pytest.approx(simulated, rel=0.01)
    assert exact >= 1


def test_the_gain_margin_checks_the_most_aggressive_scaled_tuning_first():
    """The scaled tunings of a margin g, the gains up and the integral time down first (the likeliest to hunt), the
    gentlest last; every combination of {1/g, 1, g} but the tuning itself, once each."""
    import backlash_df.tuning as tuning_module

    factors = tuning_module._scalings(("kp", "ti"), 1.25)
    assert factors[0] == (1.25, 0.8) and factors[-1] == (0.8, 1.25)
    assert sorted(factors) == sorted(f for f in itertools.product((0.8, 1.0, 1.25), repeat=2) if f != (1.0, 1.0))
    assert tuning_module._scalings(("kp", "ti"), 1.0) == []
