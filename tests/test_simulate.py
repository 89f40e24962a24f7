"""The two-mass simulation kernel: convergence, conservation laws, linear case, events.

References are independent of the kernel: scipy's solve_ivp on the linear
equations, momentum and energy balances written from the equations of motion,
and refinement of the step.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from backlash_df import make_model, theta_star
from backlash_df.config import Plant
from backlash_df.simulation import simulate_two_mass

K = 5895.0
JM, JL = 0.4, 5.6
ALPHA = 0.0025
W_DIST = 40.0 * np.pi  # 20 Hz
PERIOD = 0.05


def paper_plant(ratio=0.01, **changes):
    """The Figure 3 drive: J_m = 0.4, J_l = 5.6, k = 5895, c = ratio k, alpha = 0.0025."""
    return Plant(**{**dict(motor_inertia=JM, load_inertia=JL, stiffness=K, damping=ratio * K, half_gap=ALPHA), **changes})


def run(plant, law, preload, t_end, dt, amplitude=19.0, **kwargs):
    """Paper's Figure 3 equations: -T_preload + a sin(40 pi t) on the motor, +T_preload on the load."""
    return simulate_two_mass(
        plant, law, t_end, dt,
        motor_torque=lambda t: -preload + amplitude * np.sin(W_DIST * t),
        load_torque=preload, **kwargs,
    )


def cycle_integral(result, preload, cycle):
    """integral of T over one cycle from the load's momentum: J_l dw_l/dt = T + T_preload."""
    n = int(round(PERIOD / (result.time[1] - result.time[0])))
    w_l = result.state("load_speed")
    return JL * (w_l[(cycle + 1) * n] - w_l[cycle * n]) - preload * PERIOD


# ---------------------------------------------------------------- linear case


def linear_reference(preload, amplitude, t_end, x0, damping):
    """Right contact held: J_m w_m' = T_m - k (x - alpha) - c v, J_l w_l' = T_l + (same)."""

    def rhs(t, z):
        x, wm, wl = z
        torque = K * (x - ALPHA) + damping * (wm - wl)
        return [wm - wl, (preload + amplitude * np.sin(W_DIST * t) - torque) / JM, (-preload + torque) / JL]

    return lambda t: solve_ivp(rhs, (0.0, t_end), [x0, 0.0, 0.0], method="DOP853", t_eval=t, rtol=1e-13, atol=1e-15).y.T


@pytest.mark.parametrize("law", ["phase-plane", "damped-dead-zone", "revised-dead-zone", "rubber", "exact"])
def test_linear_case_matches_solve_ivp_with_fourth_order_convergence(law):
    """A preload of 200 N m against a 19 N m disturbance: the gap never opens, the drive is linear."""
    plant = paper_plant(rubber_thickness=0.0005 if law == "rubber" else 0.0)
    preload, t_end = 200.0, 0.2
    x0 = ALPHA + preload / K
    errors = []
    for dt in (4e-4, 2e-4, 1e-4):
        result = simulate_two_mass(
            plant, law, t_end, dt, motor_torque=lambda t: preload + 19.0 * np.sin(W_DIST * t),
            load_torque=-preload, z0=[x0, 0.0, 0.0], theta_b0=ALPHA,
        )
        assert np.all(result.mode == result.mode[0]) and result.mode[0] > 0 and result.events == 0
        reference = linear_reference(preload, 19.0, t_end, x0, plant.damping)(result.time)
        errors.append(np.abs(result.states - reference).max(axis=0) / np.abs(reference).max(axis=0))
    errors = np.array(errors)
    assert errors[-1].max() < 1e-7
    order = np.log2(errors[:-1] / errors[1:])
    assert np.all(order > 3.7), order


# ---------------------------------------------------------------- conservation laws


@pytest.mark.parametrize("law", ["phase-plane", "damped-dead-zone", "revised-dead-zone", "elasto-backlash", "exact"])
def test_total_momentum_equals_integral_of_external_torques(law):
    """J_m w_m + J_l w_l = integral of (T_m + T_l): the shaft torque is internal.

    With T_m = -P + a sin(w t), T_l = P the right side is a (1 - cos(w t)) / w.
    """
    result = run(paper_plant(), law, preload=0.5, t_end=0.3, dt=1e-4)
    momentum = JM * result.state("motor_speed") + JL * result.state("load_speed")
    expected = 19.0 * (1.0 - np.cos(W_DIST * result.time)) / W_DIST
    # exact on unsplit steps; a step split at an event interpolates the input: ~1e-8
    np.testing.assert_allclose(momentum, expected, atol=1e-6 * 19.0 / W_DIST)


@pytest.mark.parametrize("law", ["rubber", "elasto-backlash"])
def test_load_momentum_equals_integral_of_shaft_torque(law):
    """J_l (w_l(t) - w_l(0)) = integral of (T + T_l), T quadrature of the sampled torque.

    Both laws are continuous in time along a trajectory, so the trapezoid rule is
    second order and the balance closes to its accuracy.
    """
    plant = paper_plant(rubber_thickness=0.001 if law == "rubber" else 0.0)
    result = run(plant, law, preload=0.5, t_end=0.3, dt=2e-5)
    assert result.events > 10  # contact is lost and regained
    lhs = JL * result.state("load_speed")[-1]
    rhs = np.trapezoid(result.torque, result.time) + 0.5 * result.time[-1]
    assert lhs == pytest.approx(rhs, abs=1e-5 * np.trapezoid(np.abs(result.torque), result.time))


def shaft_energy(result, stiffness):
    """Kinetic energy plus the energy of the shaft spring, k (theta_d - theta_b)^2 / 2."""
    kinetic = 0.5 * JM * result.state("motor_speed") ** 2 + 0.5 * JL * result.state("load_speed") ** 2
    return kinetic + 0.5 * stiffness * (result.theta_d - result.theta_b) ** 2


def test_undamped_dead_zone_conserves_energy_and_exact_model_without_damping_is_it():
    plant = paper_plant(ratio=0.0)
    z0 = [0.0, 1.0, 0.0]
    dead = simulate_two_mass(plant, "dead-zone", 0.5, 1e-4, z0=z0)
    assert dead.events > 20
    theta_b = np.clip(dead.theta_d, -ALPHA, ALPHA)
    energy = 0.5 * JM * dead.state("motor_speed") ** 2 + 0.5 * JL * dead.state("load_speed") ** 2
    energy += 0.5 * K * (dead.theta_d - theta_b) ** 2
    np.testing.assert_allclose(energy, energy[0], rtol=1e-9)
    exact = simulate_two_mass(plant, "exact", 0.5, 1e-4, z0=z0)
    np.testing.assert_allclose(exact.states, dead.states, atol=1e-12)


def test_exact_model_dissipates_energy_as_c_times_squared_twist_rate():
    """Without external torque E = kinetic + k theta_s^2 / 2 never increases (dE/dt = -c (dtheta_s/dt)^2)."""
    plant = paper_plant(ratio=0.01)
    result = simulate_two_mass(plant, "exact", 0.5, 1e-5, z0=[0.0, 1.0, 0.0])
    assert result.events > 4
    energy = shaft_energy(result, K)
    assert np.all(np.diff(energy) <= 1e-10 * energy[0])
    assert energy[-1] < 0.9 * energy[0]


# ---------------------------------------------------------------- convergence with events


@pytest.mark.parametrize("law", ["exact", "phase-plane", "damped-dead-zone", "revised-dead-zone", "rubber"])
@pytest.mark.parametrize("preload", [19.0, 0.5])
def test_halving_the_step_changes_per_cycle_torque_integral_by_less_than_0p1_percent(law, preload):
    """The integral of T over cycle 3 of the transient from rest (load momentum balance)."""
    plant = paper_plant(rubber_thickness=0.001 if law == "rubber" else 0.0)
    coarse, fine = (run(plant, law, preload, 4 * PERIOD, dt) for dt in (1e-4, 5e-5))
    assert coarse.events >= 1  # (26) at preload 19 N m never lets go: it pulls
    i_coarse, i_fine = cycle_integral(coarse, preload, 3), cycle_integral(fine, preload, 3)
    assert abs(i_coarse - i_fine) < 1e-3 * abs(i_fine)


# ---------------------------------------------------------------- events at theta*


@pytest.mark.parametrize("ratio", [0.01, 0.1, 0.3, 1.0])
@pytest.mark.parametrize("preload", [19.0, 0.5])
def test_no_chattering_at_theta_star(ratio, preload):
    """At most a release and a contact per side and cycle, however strong the damping.

    With c^2 > k J, roughly, the contact made at theta* would be pushed back out
    across the jump at once if the law were read as memoryless; the kernel holds
    it until the release condition, as the paper's derivation of (20) does.
    """
    dt = 1e-4 if ratio < 1.0 else 2e-5  # RK4 needs dt c / mu < 2.8 in contact (mu = J_m J_l / (J_m + J_l))
    result = run(paper_plant(ratio), "phase-plane", preload, 20 * PERIOD, dt)
    assert result.events <= 4 * 20 + 2


def test_held_contact_differs_from_the_static_law_only_between_release_line_and_theta_star():
    model = make_model("phase-plane", **paper_plant(0.1).shaft)
    result = run(paper_plant(0.1), model, 19.0, 20 * PERIOD, 1e-4)
    x, v = result.theta_d, result.dtheta_d
    held = result.torque != model.torque(x, v)
    assert held.sum() > 10  # the rule matters on this run
    k, c = model.stiffness, model.damping
    # right or left contact held in the sliver alpha - c v / k <= x < theta*(v) (and mirror)
    right = (v > 0) & (k * (x - ALPHA) + c * v >= 0) & (x < theta_star(v, k, c, ALPHA))
    left = (v < 0) & (k * (x + ALPHA) + c * v <= 0) & (-x < theta_star(-v, k, c, ALPHA))
    assert np.all((right | left)[held])
    # the held torque never pulls (Lemma 1)
    assert np.all(np.sign(result.torque[held]) == np.sign(v[held]))


# ---------------------------------------------------------------- stiff exact model


def test_exact_model_with_tiny_time_constant_is_stable_at_a_coarse_step():
    """c / k = 1e-7 s at dt = 1e-3 s (dt / tau = 1e4): the exponential step keeps theta_b bounded
    and the torque tends to that of the undamped dead-zone (Remark 2)."""
    stiff = run(paper_plant(ratio=1e-7), "exact", 0.5, 10 * PERIOD, 1e-3, amplitude=30.0)
    dead = run(paper_plant(ratio=0.0), "dead-zone", 0.5, 10 * PERIOD, 1e-3, amplitude=30.0)
    assert np.all(np.isfinite(stiff.states)) and np.all(np.abs(stiff.theta_b) <= ALPHA)
    assert stiff.events > 20
    assert np.abs(stiff.torque - dead.torque).max() < 1e-3 * np.abs(dead.torque).max()


def test_simulation_rejects_bad_steps():
    with pytest.raises(ValueError, match="dt must be finite and > 0"):
        run(paper_plant(), "exact", 0.5, 0.1, 0.0)
    with pytest.raises(ValueError, match="t_end .* at least one step"):
        run(paper_plant(), "exact", 0.5, 1e-5, 1e-3)
    with pytest.raises(ValueError, match="theta_b0 must lie"):
        run(paper_plant(), "exact", 0.5, 0.1, 1e-3, theta_b0=1.0)


# ---------------------------------------------------------------- closed PI loop


def pi_rig(**controller):
    """The load-feedback PI loop of examples/load_feedback.toml (it settles onto a limit cycle)."""
    from backlash_df import rig_from_dict

    return rig_from_dict({
        "plant": {"motor_inertia": JM, "load_inertia": JL, "stiffness": K, "damping": 3.0, "half_gap": 0.05},
        "controller": {"kp": 30.0, "ti": 0.5, "feedback": "load", "speed_filter": 0.002, **controller},
    })


def loop_reference(rig, law, kick, t_end, time):
    """The same loop by solve_ivp (DOP853, tight tolerances) on the memoryless law, or (14) for the exact model."""
    from backlash_df.loops import drive_loop
    from backlash_df._laws import exact_torque, static_torque
    from backlash_df.simulation import initial_state

    part, model = drive_loop(rig).linear_part(), rig.make_model(law)
    k, c, alpha, beta = model.params
    z0 = initial_state(part, None, kick)

    def rhs(t, z):
        x, v = part.c_x @ z[:-1], part.c_v @ z[:-1]
        if law != "exact":
            return np.append(part.A @ z[:-1] + part.b * static_torque(model.law, x, v, k, c, alpha, beta), 0.0)
        theta_b = min(max(z[-1], -alpha), alpha)
        rate = (k / c) * (x + c / k * v - theta_b)  # (12), limited at +-alpha (14)
        if abs(theta_b) >= alpha and rate * theta_b > 0.0:
            rate = 0.0
        return np.append(part.A @ z[:-1] + part.b * exact_torque(x, v, theta_b, k, c, alpha), rate)

    solution = solve_ivp(rhs, (0.0, t_end), np.append(z0, 0.0), method="DOP853", t_eval=time, rtol=1e-12, atol=1e-15)
    return solution.y[0]


@pytest.mark.parametrize("law", ["phase-plane", "exact"])
def test_closed_loop_through_contacts_matches_solve_ivp(law):
    """PI loop on the load speed, 0.3 s from a kick of 15 rad/s: about twenty contacts and releases."""
    from backlash_df import simulate

    rig = pi_rig()
    result = simulate(rig, law, t_end=0.3, kick=15.0)
    assert result.events > 15
    reference = loop_reference(rig, law, 15.0, result.time[-1], result.time)
    assert np.abs(result.theta_d - reference).max() < 1e-8 * 0.05


@pytest.mark.parametrize("law", ["phase-plane", "exact", "damped-dead-zone", "dead-zone"])
def test_piecewise_linear_loop_without_dead_time_does_not_depend_on_the_step(law):
    """Within a mode these loops are linear with constant inputs: the kernel steps them exactly
    (exponential of the mode's matrix), so only the located switching times carry round-off."""
    from backlash_df import simulate

    rig = pi_rig(torque_lag=0.001)
    coarse, fine = (simulate(rig, law, t_end=0.5, dt=dt, kick=15.0, speed_reference=2.0) for dt in (4e-4, 1e-4))
    assert coarse.events > 15
    np.testing.assert_allclose(coarse.states, fine.states[::4], rtol=0.0, atol=1e-9 * np.abs(fine.states).max())
    np.testing.assert_array_equal(coarse.mode, fine.mode[::4])


def test_dead_time_converges_at_second_order():
    """The delayed speed is interpolated linearly between samples: errors fall by 4 per halving."""
    from backlash_df import simulate

    rig = pi_rig(delay=0.001)
    runs = [simulate(rig, "phase-plane", t_end=0.5, dt=1e-4 / 2**j, kick=15.0) for j in range(4)]
    errors = np.array([np.abs(runs[j].theta_d - runs[3].theta_d[:: 2 ** (3 - j)]).max() for j in range(2)])
    assert errors[0] < 1e-3 * 0.05
    assert np.log2(errors[0] / errors[1]) > 1.8


def test_coulomb_and_breakaway_friction_against_solve_ivp():
    """A load coasting in the gap (no shaft torque) under Coulomb plus breakaway friction,
    ``J dw/dt = -(F_c + F_s exp(-(w/w_s)^2)) tanh(w/eps)``, against solve_ivp of that equation;
    the breakaway part slows the last stretch to rest, where exp(-(w/w_s)^2) is near 1."""
    from backlash_df.simulation import simulate_linear
    from backlash_df.system import LinearPart

    coulomb, breakaway, w_s, eps = 2.0, 3.0, 0.2, 0.01
    system = LinearPart(A=np.zeros((3, 3)), b=np.array([0.0, -1.0 / JM, 1.0 / JL]), E=np.zeros((3, 0)),
                        c_x=np.array([1.0, 0.0, 0.0]), c_v=np.array([0.0, 1.0, -1.0]),
                        state_names=("theta_d", "motor_speed", "load_speed"), input_names=(),
                        friction=coulomb, friction_speed=eps, f=np.array([0.0, 0.0, 1.0]),
                        e_f=np.array([0.0, 0.0, 1.0 / JL]), breakaway=breakaway, breakaway_speed=w_s)
    model = make_model("dead-zone", stiffness=K, half_gap=10.0)  # never in contact here
    result = simulate_linear(system, model, 1.0, 1e-3, z0=[0.0, 0.0, 0.3])

    def rhs(t, w):
        return [-(coulomb + breakaway * np.exp(-((w[0] / w_s) ** 2))) * np.tanh(w[0] / eps) / JL]

    reference = solve_ivp(rhs, (0.0, 1.0), [0.3], method="LSODA", t_eval=result.time, rtol=1e-10, atol=1e-12).y[0]
    np.testing.assert_allclose(result.states[:, 2], reference, atol=1e-6)
    assert np.all(result.states[:, 1] == 0.0)  # the motor feels nothing
    assert result.states[-1, 2] < 0.005  # at rest (within the smoothing) before the end
    stopped = result.time[np.argmax(result.states[:, 2] < 0.005)]
    assert stopped < 0.8 * 0.3 * JL / coulomb  # sooner than Coulomb friction alone (0.84 s) would stop it


@pytest.mark.parametrize("law", ["phase-plane", "rubber"])
def test_constant_inputs_give_the_run_of_their_array_on_every_half_step(law):
    """A constant load torque and speed reference (timed_inputs of constants: two rows span the run) give, to the
    bit, the run of the same inputs written out on every half step; the limited loop's command trace too.  The
    rubber law runs the RK4 kernel, the phase plane law the exact one."""
    from backlash_df.loops import drive_loop
    from backlash_df.simulation.linear import default_step, simulate_linear, timed_inputs

    rig = pi_rig(torque_limit=100.0, delay=3e-4)
    part = drive_loop(rig).linear_part()
    model = make_model(law, stiffness=K, damping=3.0, half_gap=0.05, rubber_thickness=0.01)
    dt, t_end = default_step(part, model), 0.3
    constant = timed_inputs(0.5, -40.0)
    assert constant.constant == (0.5, -40.0) and not hasattr(timed_inputs(0.5, np.sin), "constant")
    z0 = np.zeros(part.A.shape[0])
    z0[part.state_names.index("motor_speed")] = 60.0
    n_steps = int(round(t_end / dt))
    written = np.tile([0.5, -40.0], (2 * n_steps + 1, 1))
    fast = simulate_linear(part, model, t_end, dt, inputs=constant, z0=z0)
    full = simulate_linear(part, model, t_end, dt, inputs=lambda time: written[:time.size], z0=z0)
    assert fast.events > 5 and np.array_equal(fast.states, full.states) and np.array_equal(fast.mode, full.mode)
    assert np.array_equal(fast.command, full.command) and np.abs(fast.command).max() == 100.0


@pytest.mark.parametrize(("law", "limit", "delay"), [("phase-plane", 100.0, 3e-4), ("rubber", 100.0, 3e-4),
                                                     ("exact", 0.0, 0.0), ("exact-undamped", 0.0, 3e-4)])
def test_a_continued_run_is_the_run_to_its_end(law, limit, delay):
    """A run gone on twice from its end (``continued``) is, to the bit, the run simulated to that end in one go:
    states, torque, theta_b, modes, command trace and event count.  The exact kernel carries its augmented
    state, the RK4 kernel (rubber) its state and theta_b, both the dead time's history and the command's mode;
    the undamped exact model's halved modes are halved once."""
    from backlash_df.loops import drive_loop
    from backlash_df.simulation.linear import default_step, simulate_linear, timed_inputs

    rig = pi_rig(**({"torque_limit": limit} if limit else {}), **({"delay": delay} if delay else {}))
    part = drive_loop(rig).linear_part()
    damping = 0.0 if law == "exact-undamped" else 3.0
    model = make_model(law.removesuffix("-undamped"), stiffness=K, damping=damping, half_gap=0.05,
                       rubber_thickness=0.01)
    dt = default_step(part, model)
    z0 = np.zeros(part.A.shape[0])
    z0[part.state_names.index("motor_speed")] = 60.0
    inputs = timed_inputs(0.5, lambda t: -40.0 * np.cos(7.0 * t))
    run = lambda t_end: simulate_linear(part, model, t_end, dt, inputs=inputs, z0=z0)  # noqa: E731
    whole, pieces = run(0.6), run(0.15).continued(0.4).continued(0.6)
    assert whole.events > 5 and pieces.events == whole.events
    names = ("time", "states", "torque", "theta_b", "mode") + (("command", "command_mode") if limit else ())
    for name in names:
        assert np.array_equal(getattr(pieces, name), getattr(whole, name), equal_nan=True), name
    assert whole.command is None if not limit else np.abs(whole.command).max() == limit


def test_a_run_goes_on_only_forward_and_not_from_an_array_of_inputs():
    from backlash_df.simulation.linear import simulate_linear
    from backlash_df.system import two_mass_system

    model = make_model("phase-plane", stiffness=K, damping=3.0, half_gap=ALPHA)
    system = two_mass_system(JM, JL)
    run = simulate_linear(system, model, 0.1, 1e-4, inputs=lambda t: np.zeros((t.size, 2)))
    with pytest.raises(ValueError, match="beyond the run's end"):
        run.continued(0.1)
    arrays = simulate_linear(system, model, 0.1, 1e-4, inputs=np.zeros((1001, 2)))
    with pytest.raises(ValueError, match="array on its grid"):
        arrays.continued(0.2)
