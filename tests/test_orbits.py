"""Exact periodic orbits by shooting: against time simulation, finite differences and Pade orders.

The references are independent of the shooting code: the project's exact-discretisation
simulation kernel (its own event location by bisection, no saltation matrices), finite
differences of the period map (events relocated, so they test the saltation matrices),
and convergence of the Pade approximant of a dead time with its order.
"""

import dataclasses
import functools
import json
import math

import numpy as np
import pytest

import backlash_df as bd
from backlash_df.orbits import (
    OrbitNotFound,
    PeriodicOrbit,
    exact_orbits,
    orbit_residual,
    orbit_state_names,
    periodic_orbit,
)
from backlash_df.simulation import measure_limit_cycle, simulate_linear, simulate_rig, simulated_limit_cycle
from conftest import EXAMPLES


@pytest.fixture(scope="module")
def load_rig():
    return bd.load_rig(EXAMPLES / "load_feedback.toml")


@pytest.fixture(scope="module")
def lag_rig():
    return bd.load_rig(EXAMPLES / "motor_lag_feedback.toml")


@pytest.fixture(scope="module")
def load_orbit(load_rig):
    return periodic_orbit(load_rig, "phase-plane", bd.predict_limit_cycles(load_rig).cycles[0])


@pytest.fixture(scope="module")
def lag_orbits(lag_rig):
    """The separating (unstable) and the stable cycle of the bistable motor-lag loop."""
    return exact_orbits(lag_rig, bd.predict_limit_cycles(lag_rig, "phase-plane"))


def _delay_rig(delay=0.0005):
    """The issue's near-critical tuning: motor feedback, c = 10, kp = 222, ti = 0.3 s, dead time."""
    return bd.rig_from_dict({
        "plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 10.0, "half_gap": 0.05},
        "controller": {"feedback": "motor", "kp": 222.0, "ti": 0.3, "speed_filter": 0.0076,
                       "torque_lag": 0.0015, "delay": delay},
    })


def _start(orbit, offset=None):
    """``initial=`` of simulate_rig: the orbit's section state (plus an offset), loop states only."""
    state = orbit.state if offset is None else orbit.state + offset
    return {name: value for name, value in zip(orbit.state_names, state) if not name.startswith(("pade", "theta_b"))}


def _simulate_from(rig, model, orbit, t_end, dt, offset=None):
    """The project's simulation kernel started on the orbit's section state (theta_b included)."""
    system = bd.drive_loop(rig).linear_part()
    state = orbit.state if offset is None else orbit.state + offset
    theta_b = state[-1] if orbit.state_names[-1] == "theta_b" else 0.0
    load = rig.load.torque
    return simulate_linear(system, rig.make_model(model), t_end, dt, z0=state[:system.A.shape[0]], theta_b0=theta_b,
                           inputs=lambda time: np.stack([0.0 * time, load + 0.0 * time], axis=1))


def _monodromy(rig, model, orbit):
    _, jacobian = orbit_residual(rig, model, np.append(orbit.state, orbit.period))
    return jacobian[:-1, :-1] + np.eye(orbit.state.size)


# --------------------------------------------------------------------------- against simulation


def test_load_feedback_orbit_matches_a_long_converged_simulation(load_rig, load_orbit):
    # started from the DF kick, 180 periods: the deviation decays as |mu|max^n = 0.926^n
    cycle = bd.predict_limit_cycles(load_rig).cycles[0]
    result = simulate_rig(load_rig, "phase-plane", t_end=12.0, dt=2e-5, kick=cycle.amplitude * cycle.omega)
    measured = measure_limit_cycle(result, periods=20, rtol=1e-6)
    assert measured.found
    assert measured.omega == pytest.approx(load_orbit.omega, rel=1e-6)
    assert measured.amplitude == pytest.approx(load_orbit.amplitude, rel=1e-5)
    assert measured.peak == pytest.approx(load_orbit.peak, rel=1e-5)
    assert abs(measured.bias) < 1e-6 and abs(load_orbit.bias) < 1e-12  # odd symmetry: centred in the gap
    assert load_orbit.stable and load_orbit.residual < 1e-10
    assert abs(load_orbit.multipliers[0] - 1.0) < 1e-8  # the trivial multiplier of an autonomous orbit
    # and the DF's first-harmonic error the issue quotes: about 10 % high
    assert cycle.amplitude / load_orbit.amplitude - 1.0 == pytest.approx(0.102, abs=0.005)


@pytest.mark.parametrize("model", ["phase-plane", "exact", "damped-dead-zone"])
def test_one_period_of_simulation_from_the_state_returns_to_it(load_rig, load_orbit, model):
    orbit = periodic_orbit(load_rig, model, load_orbit)
    steps = 4096  # the grid lands on T; the kernel is exact between events
    result = _simulate_from(load_rig, model, orbit, orbit.period, orbit.period / steps)
    loop_states = result.states.shape[1]
    scale = np.abs(result.states).max(axis=0)
    assert np.abs((result.states[-1] - orbit.state[:loop_states]) / scale).max() < 1e-9
    assert result.events == len(orbit.events)


def test_motor_lag_stable_orbit_is_the_simulated_cycle(lag_rig, lag_orbits):
    unstable, stable = lag_orbits
    assert stable.stable and not unstable.stable
    # started slightly off the orbit (|mu|max = 0.97 makes a start from rest slow to settle)
    result = _simulate_from(lag_rig, "phase-plane", stable, 300 * stable.period, stable.period / 1024,
                            1e-5 * stable.state)
    measured = measure_limit_cycle(result, periods=20, rtol=1e-6)
    assert measured.omega == pytest.approx(stable.omega, rel=1e-6)
    assert measured.amplitude == pytest.approx(stable.amplitude, rel=1e-5)


def test_near_tangent_loci_the_far_off_df_seed_still_finds_the_simulated_orbit(load_rig):
    # kp = 10, ti = 1 s: DF 0.0740 rad at 57.6 rad/s, the loop cycles at 0.0604 rad, 43.6 rad/s;
    # Newton from the DF seed alone fails, the seed relaxed by simulation converges
    rig = dataclasses.replace(load_rig, controller=dataclasses.replace(load_rig.controller, kp=10.0, ti=1.0))
    cycle = bd.predict_limit_cycles(rig, "phase-plane").cycles[0]
    orbit = periodic_orbit(rig, "phase-plane", cycle)
    measured, result = simulated_limit_cycle(rig, "phase-plane", t_end=20.0, kick=cycle.amplitude * cycle.omega)
    from_simulation = periodic_orbit(rig, "phase-plane", result)
    assert from_simulation.period == pytest.approx(orbit.period, rel=1e-9)
    assert measured.amplitude == pytest.approx(orbit.amplitude, rel=1e-3)  # default step and rtol
    assert orbit.stable and orbit.peak / orbit.amplitude > 1.1  # far from a sinusoid
    assert cycle.amplitude / orbit.amplitude - 1.0 == pytest.approx(0.226, abs=0.005)
    assert cycle.omega / orbit.omega - 1.0 == pytest.approx(0.322, abs=0.005)


def test_every_switch_lies_on_the_laws_boundary_to_round_off(load_orbit):
    # contact where theta_d = theta*(dtheta_d) (19), release where k (theta_d - alpha) + c dtheta_d = 0 (Theorem 1)
    k, c, alpha = 5895.0, 3.0, 0.05
    for time, before, after in load_orbit.events:
        i = np.nonzero(load_orbit.time == time)[0][-1]  # the sample stored at the switch
        x, v = load_orbit.theta_d[i], load_orbit.dtheta_d[i]
        side = after or before
        if after:
            assert abs(side * x - bd.theta_star(side * v, k, c, alpha)) < 1e-14
        else:
            assert abs(k * (side * x - alpha) + c * side * v) < 1e-11 * k * alpha


# --------------------------------------------------------------------------- Floquet stability


def _deviation_along(rig, model, orbit, periods, size, real=True):
    """Component along the dominant non-trivial Floquet mode, sampled once a period, of a perturbed run.

    ``real``: the dominant multiplier must be real (returned as a float); else a
    complex pair is allowed, the run starts along the real part of its mode and the
    component is complex.
    """
    values, right = np.linalg.eig(_monodromy(rig, model, orbit))
    order = np.argsort(-np.abs(values))
    dominant = next(i for i in order if abs(values[i] - 1.0) > 1e-6)
    mu = values[dominant]
    if real:
        assert abs(mu.imag) < 1e-12  # a real dominant multiplier on these rigs
    left = np.linalg.inv(right)[dominant]
    mode = right[:, dominant].real
    offset = size * mode / np.abs(mode).max() * np.abs(orbit.state).max()
    steps = 2048
    result = _simulate_from(rig, model, orbit, periods * orbit.period, orbit.period / steps, offset)
    returns = result.states[::steps] - orbit.state
    return (mu.real, returns @ left.real) if real else (mu, returns @ left)


def test_stable_orbit_perturbation_decays_at_the_floquet_rate(load_rig, load_orbit):
    # 1e-4 of the state's size: nonlinear effects ~1e-6, round-off of the deviation well below
    mu, deviation = _deviation_along(load_rig, "phase-plane", load_orbit, periods=12, size=1e-4)
    assert load_orbit.max_multiplier == pytest.approx(mu)
    rates = deviation[1:] / deviation[:-1]
    assert np.allclose(rates, mu, rtol=2e-5)
    assert mu < 1.0


def test_unstable_orbit_perturbation_grows_at_the_floquet_rate(lag_rig, lag_orbits):
    # the separating cycle barely enters contact (A = 1.06 alpha): a smaller kick keeps it linear
    unstable = lag_orbits[0]
    mu, deviation = _deviation_along(lag_rig, "phase-plane", unstable, periods=10, size=1e-6)
    assert mu == pytest.approx(unstable.max_multiplier) and mu > 1.0
    assert np.allclose(deviation[1:] / deviation[:-1], mu, rtol=1e-5)


def test_the_separating_orbit_divides_rest_from_the_stable_cycle(lag_rig, lag_orbits):
    # simulation cannot find the unstable orbit, but it sees both sides of it
    unstable, stable = lag_orbits
    bigger, smaller = _start(unstable, 0.02 * unstable.state), _start(unstable, -0.02 * unstable.state)
    outside, _ = simulated_limit_cycle(lag_rig, "phase-plane", t_end=4.0, initial=bigger)
    inside, _ = simulated_limit_cycle(lag_rig, "phase-plane", t_end=4.0, initial=smaller)
    assert inside.verdict == "no limit cycle"  # the loop settles
    assert outside.found and outside.amplitude == pytest.approx(stable.amplitude, rel=1e-3)


# --------------------------------------------------------------------------- the Jacobian


@pytest.mark.parametrize("model", ["phase-plane", "exact", "damped-dead-zone", "revised-dead-zone"])
def test_monodromy_matches_finite_differences_of_the_period_map(load_rig, load_orbit, model):
    orbit = periodic_orbit(load_rig, model, load_orbit)
    jacobian, error, scale = _jacobian_error(load_rig, model, orbit)
    assert error.max() < 1e-6 * (np.abs(jacobian) * scale).max()
    if model != "revised-dead-zone":  # (27) is continuous at its switches: saltation = identity
        # the check is sharp enough to see the saltation matrices: without them M is far off
        no_saltation = _flows_only(load_rig, model, orbit)
        assert (np.abs(no_saltation - jacobian[:-1, :-1]) * scale[:-1]).max() > 1e3 * error.max()


def _jacobian_error(rig, model, orbit):
    """The shooting Jacobian, its error against central differences (each column in units of its
    unknown's size) and those sizes."""
    def residual(unknowns):
        return orbit_residual(rig, model, unknowns, pade_order=orbit.pade_order or 6)

    unknowns = np.append(orbit.state, orbit.period)
    _, jacobian = residual(unknowns)
    scale = np.append(np.abs(orbit.state).max() * np.ones(orbit.state.size), orbit.period)
    numeric = np.empty_like(jacobian)
    for j, name in enumerate(orbit.state_names + ("period",)):
        h = 1e-6 * scale[j]
        plus, _ = residual(unknowns + h * np.eye(unknowns.size)[j])
        if name == "theta_b":  # on its stop in contact: theta_b < alpha would open the gap (one-sided)
            numeric[:, j] = (plus - residual(unknowns)[0]) / h
            continue
        minus, _ = residual(unknowns - h * np.eye(unknowns.size)[j])
        numeric[:, j] = (plus - minus) / (2.0 * h)
    return jacobian, np.abs(numeric - jacobian) * scale, scale


def _flows_only(rig, model, orbit):
    """M - I without the saltation matrices: what a naive product of mode flows gives.

    The mode sequence and durations come from the orbit's events (contacts and
    releases, and the torque command's switches, merged by time); each mode's state
    matrix from ``backlash_df._switching.mode_matrices`` (left contact, free, right
    contact) and, with a torque limit, ``_switching.command_matrices``
    (the loop has no dead time: its states, then theta_b for the exact model).
    """
    from scipy.linalg import expm

    from backlash_df._switching import COMMAND_MODES, command_matrices, mode_matrices

    law = rig.make_model(model)
    part = bd.drive_loop(rig).linear_part()
    n = orbit.state.size
    matrices = mode_matrices(part, law, law.law)
    per_mode = matrices[:, None] if part.command is None else command_matrices(part, matrices).per_mode
    switches = sorted([(t, 0, after) for t, _, after in orbit.events] +
                      [(t, 1, after) for t, _, after in orbit.command_events])
    mode = [orbit.events[0][1], orbit.command_events[0][1] if orbit.command_events else 0]
    times, modes = [0.0], [tuple(mode)]
    for time, kind, after in switches:
        mode[kind] = after
        if time > times[-1]:
            times.append(time)
            modes.append(tuple(mode))
        modes[-1] = tuple(mode)
    product = np.eye(n)
    for (side, command), start, stop in zip(modes, times, times[1:] + [orbit.period]):
        flow = per_mode[side + 1, COMMAND_MODES.index(command) if part.command is not None else 0][:n, :n]
        product = expm(flow * (stop - start)) @ product
    return product - np.eye(n)


# --------------------------------------------------------------------------- dead time


def test_dead_time_orbit_converges_with_the_pade_order_and_bounds_the_simulation():
    rig = _delay_rig()
    seed = (0.2109, 267.3)
    amplitudes = {order: periodic_orbit(rig, None, seed, pade_order=order).amplitude for order in (2, 4, 6)}
    assert abs(amplitudes[6] - amplitudes[4]) < 1e-9 * amplitudes[6]
    assert abs(amplitudes[4] - amplitudes[2]) > 100 * abs(amplitudes[6] - amplitudes[4])
    # the simulation's dead time at a fine step against this reference: the 1e-4
    measured, _ = simulated_limit_cycle(rig, None, t_end=20.0, dt=1.25e-5, kick=seed[0] * seed[1],
                                        periods=20, rtol=1e-5)
    assert measured.amplitude == pytest.approx(amplitudes[6], rel=1e-4)


def test_dead_time_states_are_named(lag_rig):
    rig = dataclasses.replace(lag_rig, controller=dataclasses.replace(lag_rig.controller, delay=1e-4))
    names = orbit_state_names(rig, "exact", pade_order=3)
    assert names[-4:] == ("pade_1", "pade_2", "pade_3", "theta_b")


# --------------------------------------------------------------------------- torque limit, cascade, user controllers


def _tuned(rig, load=0.0, **controller):
    """The rig with ``[controller]`` values changed and a constant load torque (N m)."""
    return dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, **controller),
                               load=dataclasses.replace(rig.load, torque=load))


def _user_pi(kp, ti, lag=0.0):
    """The PI ``kp (1 + 1 / (ti s))`` (and a first-order lag) as a user's python-control LTI."""
    import control as ct

    return ct.tf([kp * ti, kp], [ti, 0.0]) * ct.tf([1.0], [lag, 1.0])


#: Loops of examples/load_feedback.toml with a torque limit (kp = 3000: the contact loop is unstable and
#: the limit caps the growth), a slide along the limit (a fast integrator under a load torque), cascades
#: (kv = 20 1/s, both position feedbacks), a dead time on both measured signals, a user's PI (no clamp).
LIMITED = {
    "kp3000-limit50": {"kp": 3000.0, "torque_limit": 50.0},
    "kp3000-limit200": {"kp": 3000.0, "torque_limit": 200.0},
    "kp300-limit30": {"kp": 300.0, "torque_limit": 30.0},
    "sliding": {"kp": 100.0, "ti": 0.002, "torque_limit": 30.0, "load": 20.0},
    "cascade-motor": {"structure": "cascade", "kv": 20.0, "position_feedback": "motor"},
    "cascade-load-limit30": {"structure": "cascade", "kv": 20.0, "position_feedback": "load", "kp": 300.0,
                             "torque_limit": 30.0},
    "cascade-delay-limit30": {"structure": "cascade", "kv": 20.0, "position_feedback": "load", "kp": 300.0,
                              "torque_limit": 30.0, "delay": 0.0005},
}


@functools.cache
def _limited(name, model="phase-plane"):
    """(rig, orbit) of a loop of LIMITED (``"user-limit30"``: kp300-limit30 with the PI as a user's LTI),
    seeded by a simulation from a kick."""
    load_rig = bd.load_rig(EXAMPLES / "load_feedback.toml")
    if name == "user-limit30":
        rig = _tuned(load_rig, kp=300.0, torque_limit=30.0).with_controller(speed=_user_pi(300.0, 0.5))
    else:
        rig = _tuned(load_rig, **LIMITED[name])
    _, result = simulated_limit_cycle(rig, model, t_end=5.0, kick=1.0)
    return rig, periodic_orbit(rig, model, result)


def _last_periods(result, period, periods):
    """Samples of a run covering the last ``periods`` periods (the nearest whole number of steps)."""
    steps = round(periods * period / (result.time[1] - result.time[0]))
    return slice(result.time.size - 1 - steps, result.time.size)


@pytest.mark.parametrize("name", list(LIMITED))
def test_limited_and_cascade_orbits_match_a_long_converged_simulation(name):
    rig, orbit = _limited(name)
    assert orbit.stable and orbit.residual < 1e-10
    assert abs(orbit.multipliers[0] - 1.0) < 1e-8
    for dt in (2e-5, 1e-5):  # the step halved: both runs agree with the orbit
        measured, result = simulated_limit_cycle(rig, "phase-plane", t_end=10.0, dt=dt, kick=1.0, periods=20,
                                                 rtol=1e-5)
        assert measured.found, (name, dt)
        assert measured.omega == pytest.approx(orbit.omega, rel=1e-6)
        assert measured.amplitude == pytest.approx(orbit.amplitude, rel=1e-5)
        assert measured.bias == pytest.approx(orbit.bias, abs=1e-5 * orbit.amplitude)
        if rig.controller.torque_limit:
            # the command's first harmonic and its time on the limit, from the run's own command trace
            window = _last_periods(result, orbit.period, 20)
            time, command = result.time[window], result.command[window]
            span = time[-1] - time[0]
            harmonic = 2.0 * np.trapezoid(command * np.exp(-1j * measured.omega * time), time) / span
            assert abs(harmonic) == pytest.approx(orbit.command_amplitude, rel=1e-4)
            on_limit = np.mean(result.command_mode[window] != 0)
            assert on_limit == pytest.approx(orbit.saturated_fraction, abs=2e-3)
    if name.startswith("kp3000"):  # without the limit the loop in contact is unstable
        poles = bd.drive_loop(rig).linear_poles(rig.plant.stiffness, rig.plant.damping)
        assert poles.real.max() > 0.0


def _run_length(codes):
    """The values of a sequence with repeats collapsed."""
    codes = np.asarray(codes)
    return codes[np.r_[True, codes[1:] != codes[:-1]]].tolist()


@pytest.mark.parametrize("name, model", [("kp3000-limit50", "phase-plane"), ("sliding", "phase-plane"),
                                         ("kp300-limit30", "exact"), ("cascade-load-limit30", "phase-plane"),
                                         ("user-limit30", "phase-plane")])
def test_one_period_of_simulation_from_a_limited_orbit_returns_to_it(name, model):
    # the kernel switches the command on its own (bisection, no saltation matrices); started on the
    # section point (beyond the limit, the integrator clamped) it holds no slide there
    rig, orbit = _limited(name, model)
    steps = 4096
    result = _simulate_from(rig, model, orbit, orbit.period, orbit.period / steps)
    loop_states = result.states.shape[1]
    scale = np.abs(result.states).max(axis=0)
    assert np.abs((result.states[-1] - orbit.state[:loop_states]) / scale).max() < 1e-9
    assert result.events == len(orbit.events) + len(orbit.command_events)
    first = orbit.command_events[0][1]
    assert _run_length(result.command_mode) == [first] + [after for _, _, after in orbit.command_events]
    kinds = {abs(code) for _, before, after in orbit.command_events for code in (before, after)}
    assert kinds == ({0, 1} if name.startswith("user") else {0, 2, 3} if name == "sliding" else {0, 2})


@pytest.mark.parametrize("name, model", [("kp3000-limit50", "phase-plane"), ("sliding", "phase-plane"),
                                         ("kp300-limit30", "exact"), ("user-limit30", "phase-plane"),
                                         ("cascade-delay-limit30", "phase-plane")])
def test_limited_monodromy_matches_finite_differences_of_the_period_map(name, model):
    # 1e-8: a hundredth of what dropping the saltation at the clamp's events leaves on kp3000-limit50
    # (1.1e-6; there the integrator's rate jumps by e); S = I is exact at a plain saturation (user-limit30)
    rig, orbit = _limited(name, model)
    jacobian, error, scale = _jacobian_error(rig, model, orbit)
    assert error.max() < 1e-8 * (np.abs(jacobian) * scale).max()
    if not orbit.pade_order:
        no_saltation = _flows_only(rig, model, orbit)
        assert (np.abs(no_saltation - jacobian[:-1, :-1]) * scale[:-1]).max() > 1e3 * error.max()


def test_limited_orbit_perturbation_decays_at_the_floquet_rate():
    rig, orbit = _limited("kp300-limit30")
    mu, deviation = _deviation_along(rig, "phase-plane", orbit, periods=12, size=1e-4)
    assert orbit.max_multiplier == pytest.approx(mu) and mu < 1.0
    assert np.allclose(deviation[1:] / deviation[:-1], mu, rtol=2e-5)


def test_sliding_orbit_perturbation_decays_at_the_complex_floquet_rate():
    # the slide along the limit kills a deviation off it (a multiplier 0); the dominant pair is complex
    rig, orbit = _limited("sliding")
    mu, deviation = _deviation_along(rig, "phase-plane", orbit, periods=6, size=1e-4, real=False)
    assert abs(mu.imag) > 0.1 and abs(mu) == pytest.approx(orbit.max_multiplier)
    assert np.allclose(deviation[1:] / deviation[:-1], mu, rtol=1e-4)
    assert np.abs(orbit.multipliers).min() < 1e-12


def test_cascade_with_dead_times_converges_with_the_pade_order():
    rig, orbit = _limited("cascade-delay-limit30")
    assert orbit.state_names[6:9] == ("pade1_1", "pade1_2", "pade1_3") and orbit.state_names[-1] == "pade2_6"
    lower = periodic_orbit(rig, "phase-plane", orbit, pade_order=4)
    assert lower.amplitude == pytest.approx(orbit.amplitude, rel=1e-8)
    assert lower.period == pytest.approx(orbit.period, rel=1e-8)


def test_a_users_controller_gives_the_orbit_of_the_same_loop(load_rig, load_orbit):
    # K(s) = PI / (tau s + 1) as a user's LTI and the rig's PI with torque_lag = tau: the same G,
    # other states (no torque limit: the lag's place before or after it does not matter)
    lagged = _tuned(load_rig, torque_lag=0.001)
    user = load_rig.with_controller(speed=_user_pi(30.0, 0.5, lag=0.001))
    rig_orbit = periodic_orbit(lagged, "phase-plane", load_orbit)
    user_orbit = periodic_orbit(user, "phase-plane", load_orbit)
    assert user_orbit.state_names != rig_orbit.state_names
    assert user_orbit.amplitude == pytest.approx(rig_orbit.amplitude, rel=1e-9)
    assert user_orbit.period == pytest.approx(rig_orbit.period, rel=1e-9)
    assert np.allclose(np.sort_complex(user_orbit.multipliers[1:]), np.sort_complex(rig_orbit.multipliers[1:]),
                       atol=1e-8)


def test_limited_result_object(load_orbit):
    _, orbit = _limited("kp3000-limit50")
    data = json.loads(json.dumps(orbit.to_dict(), allow_nan=False))
    command = data["command"]
    assert command["limit"] == 50.0 and command["events"] == len(orbit.command_events) == 4
    assert command["saturated_fraction"] == pytest.approx(command["saturated_time"] / data["period"])
    assert 0.95 < command["saturated_fraction"] < 1.0
    assert command["clamped_time"] == command["saturated_time"]  # the integrator clamped whenever saturated
    # nearly a square wave of +-50 N m: its first harmonic is 4 limit / pi, the ramps take a little off
    assert 0.99 * 200.0 / math.pi < command["amplitude"] < 200.0 / math.pi
    assert np.all(np.abs(orbit.command) <= 50.0) and np.isclose(np.abs(orbit.command).max(), 50.0)
    assert "on its limit 99 % of T" in repr(orbit)
    import matplotlib

    matplotlib.use("Agg")
    drawn = orbit.plot()
    assert len(drawn.axes[1].get_lines()) == 2
    # a loop without a limit has none of it
    assert load_orbit.to_dict()["command"] is None and load_orbit.command is None
    assert load_orbit.command_events == () and load_orbit.saturated_time == 0.0


# --------------------------------------------------------------------------- seeds, results, errors


def test_seeds_of_every_kind_reach_the_same_orbit(load_rig, load_orbit):
    measured, result = simulated_limit_cycle(load_rig, "phase-plane", t_end=5.0, kick=15.0)
    for seed in (measured, result, (0.16, 98.0, 0.0), load_orbit):
        orbit = periodic_orbit(load_rig, "phase-plane", seed)
        assert orbit.period == pytest.approx(load_orbit.period, rel=1e-9)
        assert orbit.amplitude == pytest.approx(load_orbit.amplitude, rel=1e-9)


def test_exact_orbits_are_deduplicated_and_sorted(lag_rig, lag_orbits):
    prediction = bd.predict_limit_cycles(lag_rig, "phase-plane")
    measured, _ = simulated_limit_cycle(lag_rig, "phase-plane", t_end=2.0, initial=_start(lag_orbits[1]))
    orbits = exact_orbits(lag_rig, prediction, simulated=measured)
    assert [o.stable for o in orbits] == [False, True]
    assert orbits[0].amplitude < orbits[1].amplitude
    # DF error against the exact orbits: the unstable cycle is nearly sinusoidal
    assert prediction.cycles[0].amplitude == pytest.approx(orbits[0].amplitude, rel=1e-3)


def test_load_torque_moves_the_orbit_off_centre(load_rig, load_orbit):
    rig = dataclasses.replace(load_rig, load=dataclasses.replace(load_rig.load, torque=20.0))
    orbit = periodic_orbit(rig, "phase-plane", (load_orbit.amplitude, load_orbit.omega, 0.0))
    result = _simulate_from(rig, "phase-plane", orbit, orbit.period, orbit.period / 4096)
    scale = np.abs(result.states).max(axis=0)
    assert np.abs((result.states[-1] - orbit.state) / scale).max() < 1e-9
    assert abs(orbit.bias) > 1e-3


def test_result_object(load_orbit):
    data = load_orbit.to_dict()
    assert data["omega"] == pytest.approx(2.0 * math.pi / data["period"])
    assert data["multipliers"][0] == pytest.approx([1.0, 0.0], abs=1e-8)
    assert data["max_multiplier"] == pytest.approx(abs(complex(*data["multipliers"][1])))
    assert data["stable"] is True and data["events"] == 4
    assert "stable" in repr(load_orbit) and "A=0.1505" in repr(load_orbit)
    # section at the maximum of theta_d (the DF seed's phase): release, left contact, release, right contact
    assert [(before, after) for _, before, after in load_orbit.events] == [(1, 0), (0, -1), (-1, 0), (0, 1)]
    assert load_orbit.time[0] == 0.0 and load_orbit.time[-1] == pytest.approx(load_orbit.period)
    # the sampled torque: zero well inside the gap (theta* >= alpha - c v / k), the side's sign in contact
    inside = np.abs(load_orbit.theta_d) < 0.05 - 3.0 * np.abs(load_orbit.dtheta_d).max() / 5895.0
    assert inside.any() and np.all(load_orbit.torque[inside] == 0.0)
    outside = (np.abs(load_orbit.theta_d) > 0.05) & (load_orbit.torque != 0.0)
    assert np.all(np.sign(load_orbit.torque[outside]) == np.sign(load_orbit.theta_d[outside]))


def test_plot_returns_three_axes(load_orbit):
    import matplotlib

    matplotlib.use("Agg")
    axes = load_orbit.plot().axes
    assert axes.shape == (3,) and axes[2].get_xlabel() == "theta_d (rad)"


def test_no_cycle_and_bad_input_are_one_line_errors(load_rig, load_orbit):
    with pytest.raises(OrbitNotFound, match="dead-zone"):
        periodic_orbit(load_rig, "dead-zone")  # the classical DF predicts no cycle here
    with pytest.raises(OrbitNotFound):
        periodic_orbit(load_rig, "dead-zone", (0.16, 98.0))  # nor is there one
    with pytest.raises(ValueError, match="elasto-backlash.*not affine"):
        periodic_orbit(load_rig, "elasto-backlash", (0.16, 98.0))
    with pytest.raises(ValueError, match="seed"):
        periodic_orbit(load_rig, "phase-plane", (0.16, -98.0))
    with pytest.raises(ValueError, match="unknowns must hold 5 states"):
        orbit_residual(load_rig, "phase-plane", np.zeros(3))
    assert isinstance(load_orbit, PeriodicOrbit)


def test_a_solve_that_outgrows_its_sample_budget_gives_up_in_one_line(monkeypatch):
    # drives corpus rig #262 (a cascade with a 0.5 ms dead time and a 5.5 s unstable DF cycle) spent over
    # 40 minutes in the verdict's separatrix search: each Newton solve now has a budget of boundary samples
    from backlash_df import orbits

    rig = bd.rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
                                      "damping": 3.0, "half_gap": 0.05},
                            "controller": {"kp": 30.0, "ti": 0.5, "speed_filter": 0.002}})
    assert orbits.periodic_orbit(rig, "phase-plane", seed=(0.166, 98.7)).stable  # within the default budget
    monkeypatch.setattr(orbits, "_SAMPLE_BUDGET", 1)  # one period map per solve
    with pytest.raises(orbits.OrbitNotFound, match="shooting gave up: 1 period maps") as error:
        orbits.periodic_orbit(rig, "phase-plane", seed=(0.166, 98.7))
    assert "\n" not in str(error.value)


def test_a_pole_zero_cancellation_at_zero_is_a_neutral_mode_that_shooting_reduces():
    """A near-rigid shaft (k = 1e4 N m/rad, alpha = 1e-4 rad) on a torque limit of 1 N m under the user's speed
    controller 8 s / (s^3 + 2 s^2 + 2 s + 1), which cancels the drive's integrator: python-control's saturation
    example with a stiff shaft in it.  The mean speed is a neutral mode (a multiplier 1 besides the flow's), the
    shooting Jacobian singular to round-off; the least-norm step leaves it out and the orbit converges (an exact
    solve stepped along it until the budget ran out).  The orbit is the Lur'e loop's exact saturation orbit up
    to the shaft's compliance and gap: frequency to 1e-4, the command's first harmonic to 1e-3."""
    import control as ct

    s = ct.tf("s")
    rig = bd.rig_from_dict({"plant": {"motor_inertia": 0.5, "load_inertia": 0.5, "stiffness": 1e4, "damping": 20.0,
                                   "half_gap": 1e-4},
                         "controller": {"kp": 1.0, "ti": 1.0, "feedback": "motor", "torque_limit": 1.0},
                         "model": {"backlash": "phase-plane"}}).with_controller(speed=8 * s / (s**3 + 2 * s**2 + 2 * s + 1))
    measured, run = bd.simulated_limit_cycle(rig, t_end=40.0, max_t_end=160.0, kick=3.0)
    assert measured.periodic and measured.saturation > 0.5
    orbit = periodic_orbit(rig, "phase-plane", run)
    assert orbit.neutral == 1 and orbit.stable and orbit.residual < 1e-10
    lure = bd.lure_loop(ct.tf(8, [1, 2, 2, 1]), bd.Saturation(1.0)).periodic_orbit((3.344, 1.4142))
    assert orbit.omega == pytest.approx(lure.omega, rel=1e-4)
    assert orbit.command_amplitude == pytest.approx(lure.output_amplitude, rel=1e-3)
    assert orbit.to_dict()["neutral_modes"] == 1
