"""Friction in the closed loop: stick and slip in the simulation, against references written here.

The reference is independent of the package: the cascade (P position loop around a PI
or P speed loop) of a two-mass drive with a dead-zone shaft and load friction, written
out as its equations and integrated as a hybrid automaton by scipy's DOP853 at tight
tolerances, with its own stick logic (a sliding load that reaches zero speed sticks if
the shaft torque is within the static level ``F_c + F_s``, else reverses; a stuck load
breaks away where the shaft torque leaves the static level), each event located by
``solve_ivp``.  Olsson and Astrom's analysis of friction-generated limit cycles says
what to expect: with integral action, Coulomb friction alone lets the loop creep to rest,
a breakaway excess over it makes the loop hunt by stick-slip; a P loop rests anywhere
inside its dead band.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import backlash_df as bd
from backlash_df.config import rig_from_dict
from conftest import EXAMPLES

EXAMPLE = EXAMPLES / "motor_lag_feedback.toml"

PLANT = {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 0.0, "half_gap": 0.002}
CASCADE = {"structure": "cascade", "kp": 30.0, "ti": 0.2, "feedback": "motor", "kv": 20.0, "position_feedback": "load"}
STICK_SLIP = {"coulomb_load": 20.0, "breakaway_load": 20.0, "stribeck_speed": 0.01}


def _rig(friction, **controller):
    return rig_from_dict({"plant": PLANT, "controller": dict(CASCADE, **controller), "friction": friction,
                          "model": {"backlash": "dead-zone"}})


def reference_run(rig, x0, t_end, rtol=1e-11):
    """The cascade of ``rig`` integrated by DOP853 with its own stick logic (module docs).

    State ``[theta_m, w_m, theta_l, w_l, I]`` (rad, rad/s, rad, rad/s, rad); returns the
    dense solution ``t -> state`` and the break-away times.
    """
    plant, ctl, friction = rig.plant, rig.controller, rig.friction
    jm, jl, k, alpha = plant.motor_inertia, plant.load_inertia, plant.stiffness, plant.half_gap
    fc, fs, ws, dl = friction.coulomb_load, friction.breakaway_load, friction.stribeck_speed, friction.viscous_load
    ki = ctl.kp / ctl.ti if math.isfinite(ctl.ti) else 0.0
    static = fc + fs

    def shaft(x):
        theta = x[0] - x[2]
        return k * (theta - alpha) if theta > alpha else (k * (theta + alpha) if theta < -alpha else 0.0)

    def field(direction):
        def rates(t, x):
            error = ctl.kv * (0.0 - x[2]) - x[1]
            torque = shaft(x)
            sliding = fc + (fs * math.exp(-(x[3] / ws) ** 2) if fs else 0.0)
            load = 0.0 if direction == 0 else (torque - dl * x[3] - direction * sliding) / jl
            return [x[1], (ctl.kp * error + ki * x[4] - torque) / jm, x[3], load, error]
        return rates

    def reversal(t, x):
        return x[3]

    def breakaway(t, x):
        return abs(shaft(x)) - static

    reversal.terminal = breakaway.terminal = True
    breakaway.direction = 1.0

    def held_or_sliding(x):
        torque = shaft(x)
        return 0 if abs(torque) <= static else (1 if torque > 0.0 else -1)

    t, x = 0.0, np.array(x0, dtype=float)
    direction = int(np.sign(x[3])) if x[3] != 0.0 else held_or_sliding(x)
    pieces, breakaways = [], []
    while t < t_end:
        reversal.direction = -float(direction)
        event = breakaway if direction == 0 else reversal
        sol = solve_ivp(field(direction), (t, t_end), x, method="DOP853", rtol=rtol, atol=rtol * 1e-3,
                        events=[event], dense_output=True)
        pieces.append((t, sol.t[-1], sol.sol))
        t, x = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:
            if direction == 0:
                breakaways.append(t)
                direction = 1 if shaft(x) > 0.0 else -1
            else:
                x[3] = 0.0
                direction = held_or_sliding(x)

    def at(times):
        return np.array([next(s(tt) for a, b, s in pieces if a <= tt <= b) for tt in times])
    return at, np.array(breakaways)


def _ours(rig, x0, t_end, dt):
    """The package's run from the reference's state ``x0``, its states in the reference's order."""
    theta_m, w_m, theta_l, w_l, integral = x0
    result = bd.simulate(rig, t_end=t_end, dt=dt, initial={"theta_d": theta_m - theta_l, "motor_speed": w_m,
                                                          "load_speed": w_l, "load_angle": theta_l,
                                                          "integrator": integral})
    s = result.states
    theta_l = s[:, 3]
    return result, np.column_stack([s[:, 0] + theta_l, s[:, 1], theta_l, s[:, 2], s[:, 4]])


def _breakaways(result):
    stuck = result.friction_mode[:, 0] == 0
    return result.time[1:][stuck[:-1] & ~stuck[1:]]


def test_stick_slip_hunting_against_the_reference_converges_at_fourth_order():
    rig = _rig(STICK_SLIP)
    x0 = [0.0, 0.0, 0.01, 0.0, 0.0]
    at, reference_breakaways = reference_run(rig, x0, 4.0)
    times = np.array([1.0, 2.5, 4.0])
    errors = []
    for dt in (4e-4, 2e-4, 1e-4):
        result, states = _ours(rig, x0, 4.0, dt)
        errors.append(np.abs(states[np.round(times / dt).astype(int)] - at(times)).max())
        ours = _breakaways(result)
        assert ours.size == reference_breakaways.size >= 4
        assert np.abs(ours - reference_breakaways).max() <= dt  # each break-away found within its step
    assert errors[-1] < 5e-9
    assert errors[0] / errors[1] > 10.0 and errors[1] / errors[2] > 10.0  # RK4: 16 a halving


def test_the_load_rests_at_zero_speed_while_stuck_and_holds_within_the_static_level():
    result = bd.simulate(_rig(STICK_SLIP), t_end=4.0, initial={"load_angle": 0.01})
    stuck = result.friction_mode[:, 0] == 0
    assert stuck.any() and (~stuck).any()
    assert np.all(result.state("load_speed")[stuck] == 0.0)
    assert np.abs(result.torque[stuck]).max() <= STICK_SLIP["coulomb_load"] + STICK_SLIP["breakaway_load"] + 1e-9


def test_breakaway_friction_hunts_and_coulomb_friction_alone_creeps_to_rest():
    """Olsson and Astrom: the PI cascade hunts by stick-slip only with a breakaway excess over Coulomb friction."""
    hunting = bd.simulate(_rig(STICK_SLIP), t_end=20.0, initial={"load_angle": 0.01})
    periods = np.diff(_breakaways(hunting))
    assert periods.size > 10
    np.testing.assert_allclose(periods[-4:], periods[-1], rtol=1e-3)  # a steady cycle, one break-away a half period
    assert np.ptp(hunting.state("load_angle")[-10000:]) > 0.04  # the load hunts over +-0.03 rad
    creeping = bd.simulate(_rig({"coulomb_load": 20.0}), t_end=20.0, initial={"load_angle": 0.01})
    stuck = creeping.friction_mode[:, 0] == 0
    ends = np.flatnonzero(stuck[1:] & ~stuck[:-1]) + 1  # where each slide ends
    rests = np.abs(creeping.state("load_angle")[ends])
    assert rests.size >= 2 and np.all(np.diff(rests) < 0.0)  # each slide ends nearer the target
    assert np.all(stuck[-20000:]) and rests[-1] < 0.05 * 0.01  # and the loop creeps, no cycle


@pytest.mark.parametrize("start", [0.01, -0.03, 0.2, -0.5])
def test_a_p_cascade_rests_anywhere_inside_its_dead_band(start):
    """With a P speed controller the rest is ``|kp kv theta_l| <= F_c + F_s``: a band, not a point."""
    rig = _rig(STICK_SLIP, ti=math.inf)
    band = (STICK_SLIP["coulomb_load"] + STICK_SLIP["breakaway_load"]) / (rig.controller.kp * rig.controller.kv)
    result = bd.simulate(rig, t_end=4.0, initial={"load_angle": start})
    rest = result.state("load_angle")[-1]
    assert np.all(result.friction_mode[-5000:, 0] == 0)
    assert abs(rest) <= band
    if abs(start) < 0.75 * band:  # inside the band the shaft's wind-up never reaches the static level
        assert rest == start
    else:
        assert abs(rest) > 0.2 * band  # it stops where the slide ends, not at the target


def test_viscous_friction_changes_the_backlash_cycle_as_the_reference_does():
    """A backlash cycle with viscous friction on the load: the run against the reference, and the cycle shrunk."""
    wide = dict(PLANT, half_gap=0.02)

    def rig(viscous):
        return rig_from_dict({"plant": wide, "controller": dict(CASCADE, kv=40.0, ti=0.1),
                              "friction": {"viscous_load": viscous}, "model": {"backlash": "dead-zone"}})

    x0 = [0.0, 0.0, 0.05, 0.0, 0.0]
    at, _ = reference_run(rig(30.0), x0, 3.0)
    _, states = _ours(rig(30.0), x0, 3.0, 1e-4)
    times = np.array([1.0, 3.0])
    np.testing.assert_allclose(states[np.round(times / 1e-4).astype(int)], at(times), atol=1e-8)
    spans = [np.ptp(bd.simulate(rig(viscous), t_end=20.0, initial={"load_angle": 0.05}).state("load_angle")[-20000:])
             for viscous in (0.0, 30.0)]
    assert spans[0] > 0.01 and spans[1] < 0.8 * spans[0]


# --------------------------------------------------------------------------- the friction's describing function

@pytest.mark.parametrize("amplitude", [1e-3, 0.05, 0.3, 7.0])
def test_the_friction_describing_function_against_its_closed_form_and_quadrature(amplitude):
    from scipy.integrate import quad

    from backlash_df.describing import friction_describing_function

    coulomb, breakaway, stribeck = 2.0, 5.0, 0.1
    assert friction_describing_function(amplitude, coulomb) == pytest.approx(4.0 * coulomb / (math.pi * amplitude),
                                                                               rel=1e-15)

    def first_harmonic(phi):  # b1 of the friction along w = A sin(phi), over the half period where w > 0
        w = amplitude * math.sin(phi)
        return (coulomb + breakaway * math.exp(-(w / stribeck) ** 2)) * math.sin(phi)

    b1 = 2.0 / math.pi * quad(first_harmonic, 0.0, math.pi, epsabs=0.0, epsrel=1e-13, limit=200)[0]
    assert friction_describing_function(amplitude, coulomb, breakaway, stribeck) == pytest.approx(b1 / amplitude,
                                                                                                  rel=1e-10)


def _lag_rig(**friction):
    return bd.load_rig(EXAMPLE).with_values(**friction)


@pytest.mark.parametrize("friction", [{"coulomb_load": 50.0},
                                      {"coulomb_motor": 30.0, "breakaway_motor": 20.0, "stribeck_speed": 2.0}],
                         ids=["coulomb on the load", "breakaway on the motor"])
def test_the_slaved_friction_damper_is_its_own_describing_function(friction):
    """Substituted back: the damper d at (A, w) is N_f of the side's speed amplitude in the loop with d, the loop
    written out here (Coulomb friction's damper is a closed form, a breakaway's bisected)."""
    from backlash_df.describing import friction_describing_function
    from backlash_df.slaving import FrictionSlaving

    rig = _lag_rig(**friction)
    part = bd.drive_loop(rig, dry_friction=True).linear_part()
    slaving = FrictionSlaving(part)
    amplitude, omega = np.array([0.06, 0.15, 0.4]), np.array([200.0, 256.0, 300.0])
    damping = slaving.gain(amplitude, omega)
    f = rig.friction
    side = "load" if f.coulomb_load else "motor"
    (speed,) = slaving.speed_amplitudes(amplitude, omega).values()
    assert not slaving.sticks(amplitude, omega).any()
    np.testing.assert_allclose(damping, friction_describing_function(
        speed, getattr(f, f"coulomb_{side}"), getattr(f, f"breakaway_{side}"), f.stribeck_speed or 1.0), rtol=1e-12)
    # the side's speed amplitude and G from the loop written out: z = (jw I - A')^-1 b, A' with the damper d / J
    i = part.state_names.index(f"{side}_speed")
    inertia = getattr(rig.plant, f"{side}_inertia")
    for a, w, d, s, g in zip(amplitude, omega, damping, speed, slaving(omega, amplitude)):
        a_mat = part.A.copy()
        a_mat[i, i] -= d / inertia
        z = np.linalg.solve(1j * w * np.eye(part.n_states) - a_mat, part.b)
        assert s == pytest.approx(a * abs(z[i] / (part.c_x @ z)), rel=1e-12)
        assert g == pytest.approx(-(part.c_x @ z), rel=1e-12)


def test_coulomb_friction_shrinks_the_backlash_cycle_as_the_simulation_does():
    """The DF with the friction's damper moves the stable cycle as the simulation started on it does."""
    plain, rubbing = (bd.predict_limit_cycles(_lag_rig(**friction)) for friction in ({}, {"coulomb_load": 50.0}))
    verified = [bd.verify_limit_cycles(rig, prediction) for rig, prediction in
                ((_lag_rig(), plain), (_lag_rig(coulomb_load=50.0), rubbing))]
    (stable_plain,), (stable_rubbing,) = plain.stable_cycles, rubbing.stable_cycles
    assert stable_rubbing.amplitude < stable_plain.amplitude  # the friction damps the cycle
    assert verified[1].simulation.amplitude < verified[0].simulation.amplitude  # so does the simulation
    assert abs(stable_rubbing.amplitude / verified[1].simulation.amplitude - 1.0) < 0.08  # as the DF's usual error
    assert stable_rubbing.friction_amplitude["load"] > 0.1
    assert "friction_amplitude" in stable_rubbing.to_dict() and "friction_amplitude" not in stable_plain.to_dict()


def test_a_solution_where_the_friction_holds_the_side_is_void_not_a_cycle():
    """The small unstable backlash cycle (238 rad/s) barely moves the load: with a breakaway friction the damper has
    no fixed point there, so the solution is void (no later stage takes it as the separating cycle)."""
    plain = bd.predict_limit_cycles(_lag_rig())
    prediction = bd.predict_limit_cycles(_lag_rig(coulomb_load=5.0, breakaway_load=5.0, stribeck_speed=0.05))
    (void,) = prediction.void_cycles
    assert void.amplitude == pytest.approx(plain.cycles[0].amplitude, rel=1e-3) and not plain.cycles[0].stable
    assert [c.stable for c in prediction.cycles] == [True]
    assert "void_cycles" in prediction.to_dict() and "1 void" in repr(prediction)


def test_what_the_friction_df_does_not_solve_is_left_to_the_simulations():
    prediction = bd.predict_limit_cycles(_lag_rig(coulomb_load=5.0, coulomb_motor=5.0).with_values(torque_limit=300.0))
    assert prediction.cycles == () and "dry friction on both sides and a torque limit" in prediction.note
    limited = bd.predict_limit_cycles(_lag_rig(coulomb_load=5.0).with_values(torque_limit=300.0, torque=10.0))
    assert limited.cycles == () and "a load torque with a torque limit" in limited.note


# --------------------------------------------------------------------------- the friction DF on both sides

def test_on_both_sides_each_damper_is_its_own_describing_function_and_the_pair_shrinks_the_cycle_as_the_orbit():
    """Substituted back at the predicted stable cycle of the lag rig with Coulomb friction on both sides (5 N m on the
    motor, 50 N m on the load), the loop written out here with the dampers 4 F_c / (pi A_w) on both speeds: each
    side's speed amplitude is its A_w and 1 + G N(A, w) = 0.  Against the exact orbit seeded from it: within the
    DF's usual error (12 % in A, 1 % in w), and the motor's friction shrinks the cycle in both."""
    rig = _lag_rig(coulomb_load=50.0, coulomb_motor=5.0)
    prediction = bd.predict_limit_cycles(rig)
    assert prediction.note == ""
    (cycle,) = prediction.stable_cycles
    a, w, speeds = cycle.amplitude, cycle.omega, cycle.friction_amplitude
    assert set(speeds) == {"motor", "load"}
    part = bd.drive_loop(rig, dry_friction=True).linear_part()
    a_mat = part.A.copy()
    for side, level in (("motor", 5.0), ("load", 50.0)):
        i = part.state_names.index(f"{side}_speed")
        a_mat[i, i] -= 4.0 * level / (math.pi * speeds[side]) / getattr(rig.plant, f"{side}_inertia")
    z = np.linalg.solve(1j * w * np.eye(part.n_states) - a_mat, part.b)
    theta = part.c_x @ z
    for side in ("motor", "load"):
        assert a * abs(z[part.state_names.index(f"{side}_speed")] / theta) == pytest.approx(speeds[side], rel=1e-9)
    assert abs(1.0 - theta * complex(bd.describing_function(rig.make_model(), a, w))) < 1e-8
    orbit = bd.periodic_orbit(rig, seed=cycle)
    assert orbit.residual < 1e-10 and orbit.stable
    assert a == pytest.approx(orbit.amplitude, rel=0.12) and w == pytest.approx(orbit.omega, rel=0.01)
    (load_only,) = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0)).stable_cycles
    load_orbit = bd.periodic_orbit(_lag_rig(coulomb_load=50.0), seed=load_only)
    assert a < load_only.amplitude and orbit.amplitude < load_orbit.amplitude


def test_a_vanishing_motor_friction_leaves_the_load_friction_df_as_it_was():
    (one,) = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0)).stable_cycles
    (pair,) = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0, coulomb_motor=1e-9)).stable_cycles
    assert pair.amplitude == pytest.approx(one.amplitude, rel=1e-8) and pair.omega == pytest.approx(one.omega, rel=1e-8)
    assert pair.friction_amplitude["load"] == pytest.approx(one.friction_amplitude["load"], rel=1e-8)


# --------------------------------------------------------------------------- the friction DF with a torque limit

def _saturation_gain(command, limit):
    """N_sat(U), the closed form written here."""
    r = min(limit / command, 1.0)
    return 2.0 / math.pi * (math.asin(r) + r * math.sqrt(1.0 - r * r))


def test_with_a_torque_limit_the_friction_damper_and_the_saturation_gain_are_their_own_describing_functions():
    """Substituted back at the predicted saturated cycle of the lag rig (Coulomb friction 50 N m on the load, torque
    limit 3000 N m), the loop written out here with the command through the gain N_s = N_sat(U) and the damper d =
    4 F_c / (pi A_w): the command's amplitude is U, the load's speed amplitude A_w, and 1 + G N(A, w) = 0.  The
    simulation settles on the cycle within the DF's usual error (5 % in A, 1 % in w)."""
    rig = _lag_rig(coulomb_load=50.0).with_values(torque_limit=3000.0)
    prediction = bd.predict_limit_cycles(rig)
    assert prediction.note == ""
    (cycle,) = prediction.stable_cycles
    assert cycle.saturated and cycle.command_amplitude > 3000.0 and cycle.friction_amplitude["load"] > 0.0
    a, w = cycle.amplitude, cycle.omega
    part = bd.drive_loop(rig, dry_friction=True).linear_part()
    assert part.n_delayed == 0  # the command row is over the states alone
    n_s = _saturation_gain(cycle.command_amplitude, 3000.0)
    damping = 4.0 * 50.0 / (math.pi * cycle.friction_amplitude["load"])
    i = part.state_names.index("load_speed")
    row = part.command.row[:part.n_states]
    a_mat = part.A - (1.0 - n_s) * np.outer(part.command.column, row)  # the command through N_s
    a_mat[i, i] -= damping / rig.plant.load_inertia
    z = np.linalg.solve(1j * w * np.eye(part.n_states) - a_mat, part.b)
    theta = part.c_x @ z
    assert a * abs((row @ z) / theta) == pytest.approx(cycle.command_amplitude, rel=1e-9)
    assert a * abs(z[i] / theta) == pytest.approx(cycle.friction_amplitude["load"], rel=1e-9)
    n = complex(bd.describing_function(rig.make_model(), a, w))
    assert abs(1.0 - theta * n) < 1e-8  # G = -theta per unit T
    verified = bd.verify_limit_cycles(rig, prediction)
    (simulated,) = [c.simulated for c in verified.stable_cycles]
    assert simulated.found and simulated.saturation > 0.0
    assert simulated.amplitude == pytest.approx(a, rel=0.05) and simulated.omega == pytest.approx(w, rel=0.01)


def test_a_torque_limit_never_reached_leaves_the_friction_df_as_it_was():
    """The limit far above the command: the same cycles as without a limit, to round-off of the two algebras, each
    unsaturated; the void solution stays void."""
    free = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0))
    limited = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0).with_values(torque_limit=1e7))
    assert len(limited.cycles) == len(free.cycles) == 1 and len(limited.void_cycles) == len(free.void_cycles) == 1
    for ours, theirs in zip(limited.cycles + limited.void_cycles, free.cycles + free.void_cycles):
        assert not ours.saturated and ours.stable is theirs.stable
        assert ours.amplitude == pytest.approx(theirs.amplitude, rel=1e-10)
        assert ours.omega == pytest.approx(theirs.omega, rel=1e-10)
    assert limited.cycles[0].friction_amplitude["load"] == pytest.approx(free.cycles[0].friction_amplitude["load"],
                                                                      rel=1e-9)


# --------------------------------------------------------------------------- the verdict with friction

@pytest.mark.parametrize("friction, ti, outcome", [
    (STICK_SLIP, 0.2, "bistable"),  # small disturbances leave the load stuck at its rest; beyond, stick-slip
    ({"coulomb_load": 20.0}, 0.2, "no oscillation"),  # creeps to rest
    (STICK_SLIP, math.inf, "no oscillation"),  # rests in its dead band
], ids=["stick-slip", "creep", "dead band"])
def test_the_verdict_with_dry_friction(friction, ti, outcome):
    rig = _rig(friction, ti=ti)
    prediction = bd.predict_limit_cycles(rig)
    verdict = bd.judge_loop(rig, prediction)
    assert verdict.verdict == outcome
    if outcome == "bistable":
        hunting = bd.simulate(rig, t_end=20.0, initial={"load_angle": 0.01})
        period = 2.0 * np.diff(_breakaways(hunting))[-1]  # two break-aways a period
        assert verdict.cycle.omega == pytest.approx(2.0 * math.pi / period, rel=1e-2)
        assert verdict.df_agrees is False  # the DF sees no stick-slip cycle, and the verdict says so


# --------------------------------------------------------------------------- tuning with dry friction

@pytest.mark.parametrize("ti, certified", [(0.2, False), (5.0, True)])
def test_a_certificate_with_dry_friction_rests_on_the_df_and_the_probes(ti, certified):
    """The stick-slip cascade hunts with fast integral action and settles with slow: the certificate says which, and
    that no exact orbit was sought."""
    from backlash_df.tuning import certify

    certificate = certify(_rig(STICK_SLIP, ti=ti))
    assert certificate.certified is certified
    assert certificate.verdict.orbits == () and "Stribeck decay is not affine" in certificate.verdict.orbit_note
    if not certified:
        assert certificate.verdict.verdict == "bistable" and certificate.amplitude > 0.005


@pytest.mark.slow
def test_tune_with_dry_friction_says_what_its_certificate_rests_on():
    tuned = bd.tune(_rig(STICK_SLIP), {"ti": (0.05, 5.0)}, gain_margin=1.0)
    assert tuned.feasible and tuned.values()["ti"] > 0.2
    assert any(line.startswith("dry friction: its breakaway is not affine") for line in tuned.sentences())


def test_tune_with_friction_and_a_torque_limit_says_its_certificate_has_no_exact_orbit():
    """The friction DF with the saturation screens and certifies; the exact orbits refuse the loop, and the
    tuning's sentence says the certificate rests on the describing functions and the probes alone."""
    tuned = bd.tune(_lag_rig(coulomb_load=50.0).with_values(torque_limit=3000.0), {"kp": (20.0, 400.0)},
                    gain_margin=1.0)
    assert tuned.feasible and tuned.best.verdict.orbits == () and "torque limit" in tuned.best.verdict.orbit_note
    assert ("dry friction: the exact orbits do not model it with a torque limit, so each certificate rests on the "
            "describing functions (the friction's and the saturation's included)") in "\n".join(tuned.sentences())


def test_tune_where_the_friction_df_does_not_apply_says_why_nothing_is_certified():
    """With friction on both sides and a torque limit the friction's DF is not solved (each prediction's note): no
    certificate, one verdict of the fastest tuning, and the first line says why (it crashed on an empty search
    before)."""
    tuned = bd.tune(_rig(dict(STICK_SLIP, coulomb_motor=1.0), ti=math.inf, torque_limit=100.0), {"kv": (5.0, 20.0)},
                    gain_margin=1.0)
    assert not tuned.feasible and tuned.values()["kv"] == 20.0
    assert tuned.sentences()[0].startswith("no tuning certified: a certificate needs the describing function, and "
                                           "here the describing function of dry friction")


def test_the_verdict_reports_the_dead_band_against_its_closed_form():
    """A P cascade rests anywhere within ``(F_c + F_s) / (kp kv)`` of its reference; with integral action the position
    rests on it and the twist spans ``(F_c + F_s) / k`` beyond the gap."""
    static = STICK_SLIP["coulomb_load"] + STICK_SLIP["breakaway_load"]
    p_loop = _rig(STICK_SLIP, ti=math.inf)
    band = bd.judge_loop(p_loop, bd.predict_limit_cycles(p_loop)).rest_band
    half = static / (CASCADE["kp"] * CASCADE["kv"])
    np.testing.assert_allclose(band["load_angle"], (-half, half), rtol=1e-12)
    pi_loop = _rig(STICK_SLIP)
    verdict = bd.judge_loop(pi_loop, bd.predict_limit_cycles(pi_loop))
    alpha, k = PLANT["half_gap"], PLANT["stiffness"]
    assert "load_angle" not in verdict.rest_band
    np.testing.assert_allclose(verdict.rest_band["theta_d"], (-alpha - static / k, alpha + static / k), rtol=1e-12)
    assert verdict.to_dict()["rest_band"]["theta_d"] == list(verdict.rest_band["theta_d"])
    plain = _rig({}, ti=math.inf)
    assert bd.judge_loop(plain, bd.predict_limit_cycles(plain)).rest_band == {}


# --------------------------------------------------------------------------- design maps with dry friction

def _first_harmonic(at, start, end, samples=4000):
    """A1 of theta_d (rad) and w (rad/s) of the reference's run over one period ``[start, end]``."""
    times = np.linspace(start, end, samples + 1)[:-1]
    states = at(times)
    theta_d, omega = states[:, 0] - states[:, 2], 2.0 * math.pi / (end - start)
    return 2.0 * math.hypot(np.mean(theta_d * np.sin(omega * times)), np.mean(theta_d * np.cos(omega * times))), omega


def test_a_map_over_the_breakaway_friction_finds_the_stick_slip_cycle_of_the_reference():
    """Each cell's simulation starts, as ``verify_limit_cycles`` documents, from theta_d = 0 and the kick
    dtheta_d = 2 alpha w_hi / 3 (the motor and load speeds at +-kick/2, the rest zero; w_hi the scan's top): from
    there the reference hunts with a breakaway excess and creeps to rest without one (Olsson and Astrom).  The
    hunting cell's cycle is the reference's, its first harmonic over the last period, to 1e-4; the DF cannot see
    stick-slip, and the map's note says so."""
    from backlash_df.limit_cycles import default_ranges

    rig = _rig(STICK_SLIP)
    dmap = bd.design_map(rig, [0.0, STICK_SLIP["breakaway_load"]], [0.2], x="breakaway_load", y="ti")
    kick = 2.0 * PLANT["half_gap"] * default_ranges(rig)[1][1] / 3.0
    start = [0.0, kick / 2.0, 0.0, -kick / 2.0, 0.0]
    at, breakaways = reference_run(rig, start, 20.0)
    amplitude, _ = _first_harmonic(at, breakaways[-5], breakaways[-3])  # two break-aways a period
    _, creeping = reference_run(rig.with_values(breakaway_load=0.0), start, 20.0)
    assert creeping.size <= 2 and breakaways.size > 20
    assert dmap.sim_verdict["dead-zone"].tolist() == [["no oscillation"], ["limit cycle"]]
    assert dmap.sim_amplitude["dead-zone"][1, 0] == pytest.approx(amplitude, rel=1e-4)
    assert dmap.df_verdict["dead-zone"].tolist() == [["no oscillation"], ["no oscillation"]]
    assert dmap.notes and "cannot see stick-slip" in dmap.notes[0] and dmap.to_dict()["notes"] == list(dmap.notes)
    assert any(line.startswith("note: dry friction") for line in dmap.sentences())


def test_a_map_cell_the_friction_df_does_not_solve_is_undetermined_not_quiet(tmp_path):
    """With friction on both sides and a torque limit the friction DF is not applied (the prediction's note): its
    map cell says so, where a prediction with no cycles would have read "no oscillation"; without dry friction there
    is no note."""
    rig = _lag_rig(coulomb_load=5.0).with_values(torque_limit=1e7)
    dmap = bd.design_map(rig, [0.0, 5.0], [rig.controller.ti], x="coulomb_motor", y="ti", simulate=False)
    assert dmap.df_verdict[rig.model].tolist() == [["limit cycle"], ["undetermined"]]
    assert np.isfinite(dmap.df_amplitude[rig.model][0, 0]) and np.isnan(dmap.df_amplitude[rig.model][1, 0])
    plain = bd.design_map(_lag_rig(), [0.0], [rig.controller.ti], x="coulomb_load", y="ti", simulate=False)
    assert plain.notes == () and plain.to_dict()["notes"] == []
    swept = bd.design_map(_lag_rig(), [0.0, 5.0], [rig.controller.ti], x="coulomb_load", y="ti", simulate=False)
    assert swept.notes == dmap.notes != ()  # a swept friction value gives the cells that have it the note
    from click.testing import CliRunner
    from backlash_df.cli import main

    rig_file = tmp_path / "rubbing.toml"
    rig_file.write_text(rig.to_toml())
    result = CliRunner().invoke(main, ["map", str(rig_file), "--x", "coulomb_motor", "0,5", "--y", "ti",
                                       str(rig.controller.ti), "--no-simulate"])
    assert result.exit_code == 0, result.output
    assert "note: dry friction" in result.output


def test_under_a_load_torque_the_friction_df_solves_the_dc_balance_and_the_cycle_with_its_damper():
    """Substituted back, each part written out here, at the predicted stable cycle (A, w, b) of the lag rig with Coulomb
    friction on the load under a load torque of 100 N m: the bias is the DC balance (the shaft's mean torque, by
    quadrature of the law over the period, carries the load: a zero-mean speed gives the friction no mean), the damper
    d is N_f of the load's speed amplitude in the loop with d, and 1 + G_d N(A, w, b) = 0.  The simulation settles on
    the cycle within the DF's usual error (10 % in A, 1 % in w, 5 % in the bias)."""
    from backlash_df.describing import friction_describing_function

    rig = _lag_rig(coulomb_load=50.0).with_values(torque=100.0)
    prediction = bd.predict_limit_cycles(rig)
    assert prediction.note == "" and prediction.balanced
    (cycle,) = prediction.stable_cycles
    a, w, b = cycle.amplitude, cycle.omega, cycle.bias
    law = rig.make_model()
    phase = np.linspace(0.0, 2.0 * np.pi, 6_400_000, endpoint=False)  # the law jumps at release: error O(1/n)
    torque = law.torque(b + a * np.sin(phase), a * w * np.cos(phase))
    assert torque.mean() == pytest.approx(-100.0, rel=1e-6)  # the load torque carried (module contract's sign)
    n = 2.0 * (np.mean(torque * np.sin(phase)) + 1j * np.mean(torque * np.cos(phase))) / a  # (b1 + j a1) / A
    part = bd.drive_loop(rig, dry_friction=True).linear_part()
    i = part.state_names.index("load_speed")
    damping = friction_describing_function(cycle.friction_amplitude["load"], 50.0)  # the loop with this damper:
    a_mat = part.A.copy()
    a_mat[i, i] -= damping / rig.plant.load_inertia
    z = np.linalg.solve(1j * w * np.eye(part.n_states) - a_mat, part.b)
    assert cycle.friction_amplitude["load"] == pytest.approx(a * abs(z[i] / (part.c_x @ z)), rel=1e-9)
    assert abs(1.0 - (part.c_x @ z) * n) < 1e-6  # G = -c z, so 1 + G N = 1 - (c z) N
    verified = bd.verify_limit_cycles(rig, prediction)
    (simulated,) = [c.simulated for c in verified.stable_cycles]
    assert simulated.found
    assert simulated.amplitude == pytest.approx(a, rel=0.1) and simulated.omega == pytest.approx(w, rel=0.01)
    assert simulated.bias == pytest.approx(b, rel=0.05)


def test_a_p_speed_loop_under_a_load_torque_leaves_its_friction_to_the_simulations():
    """A P speed loop under a load torque runs at a mean speed: the zero-mean friction DF does not hold, and the
    prediction says so; a cascade under the same load holds its mean speeds at zero and is solved."""
    p_loop = bd.predict_limit_cycles(_lag_rig(coulomb_load=50.0).with_values(torque=100.0, ti=math.inf))
    assert p_loop.cycles == () and "a load torque on a P speed loop" in p_loop.note
    cascade = _rig(STICK_SLIP).with_values(torque=5.0)
    assert bd.predict_limit_cycles(cascade).note == ""


# --------------------------------------------------------------------------- Coulomb friction in the exact kernel

def test_coulomb_friction_is_exact_in_the_piecewise_affine_kernel():
    """Coulomb friction alone keeps every mode affine (sliding: a constant torque; stuck: the speed held), so the
    exact-discretisation kernel steps it: against the DOP853 reference its states agree to round-off at any step
    (no step-size error: the runs at two steps agree to 1e-11 of the states' range, no chattering at the stick), each
    stick and break-away located."""
    rig = _rig({"coulomb_load": 20.0})
    x0 = [0.0, 0.0, 0.01, 0.0, 0.0]
    at, breakaways = reference_run(rig, x0, 4.0)
    times = np.array([0.5, 1.0, 2.5, 4.0])
    runs = []
    for dt in (4e-4, 1e-4):
        result, states = _ours(rig, x0, 4.0, dt)
        runs.append(states[np.round(times / dt).astype(int)])
        assert np.abs(runs[-1] - at(times)).max() < 1e-9
        ours = _breakaways(result)
        assert ours.size == breakaways.size >= 1 and np.abs(ours - breakaways).max() <= dt
        stuck = result.friction_mode[:, 0] == 0
        assert np.all(result.state("load_speed")[stuck] == 0.0)
        assert np.count_nonzero(np.diff(stuck.astype(int))) <= 2 * breakaways.size + 2  # no chattering at the stick
    assert np.abs(runs[0] - runs[1]).max() < 1e-11 * np.abs(runs[1]).max()


def test_the_exact_kernel_with_coulomb_friction_holds_under_a_load_torque_and_a_dead_time():
    """The holding friction includes the inputs and the delayed signals (rows over the kernel's augmented state):
    the lag rig with Coulomb friction on the load, a load torque and a dead time, the exact kernel against the RK4
    kernel (a negligible breakaway) as its step halves: the distance falls at second order at least (the kernels
    interpolate the delayed signals differently, to second order), to 1e-7 of the states' range."""
    rig = _lag_rig(coulomb_load=300.0).with_values(torque=100.0, delay=0.0005)
    smooth = rig.with_values(breakaway_load=1e-9, stribeck_speed=1.0)
    exact = bd.simulate(rig, t_end=0.3, dt=1e-5, kick=20.0)
    stuck = exact.friction_mode[:, 0] == 0
    assert stuck.any() and (~stuck).any()
    distances = []
    for dt in (4e-5, 2e-5):
        run = bd.simulate(smooth, t_end=0.3, dt=dt, kick=20.0)
        step = int(round(dt / 1e-5))
        distances.append(np.abs(run.states - exact.states[::step]).max() / np.abs(exact.states).max())
    assert distances[1] < 2e-7 and distances[0] / distances[1] > 4.0
