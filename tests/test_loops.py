"""The PI speed loop: G(s) against hand-derived transfer functions, closed-loop poles."""

import control as ct
import numpy as np
import pytest

from backlash_df import Controller, DriveLoop, Plant
from backlash_df.loops import frequency_response_of
from backlash_df.system import lti_linear_part

PLANT = Plant(motor_inertia=0.4, load_inertia=5.6, stiffness=5895.0, half_gap=0.05, damping=3.0)
OMEGA = np.array([0.07, 0.9, 3.3, 17.0, 125.7, 900.0])


def controller_k(s, ctl):
    """K(s) = kp (1 + 1/(ti s)) e^{-s delay} / ((tau_f s + 1)(tau_l s + 1)), written out."""
    return ctl.kp * (1 + 1 / (ctl.ti * s)) * np.exp(-s * ctl.delay) / (
        (ctl.speed_filter * s + 1) * (ctl.torque_lag * s + 1)
    )


def hand_g(s, plant, ctl):
    """G = -theta_d / T derived by hand from the loop equations (module docs of loops).

    Motor feedback: w_m = -T / (J_m s + K), w_l = T / (J_l s), theta_d = (w_m - w_l) / s.
    Load feedback:  w_l = T / (J_l s), T_m = -K w_l, w_m = (T_m - T) / (J_m s),
                    so G = (K + (J_m + J_l) s) / (J_m J_l s^3).
    """
    k = controller_k(s, ctl)
    jm, jl = plant.motor_inertia, plant.load_inertia
    if ctl.feedback == "motor":
        return (1 / (jm * s + k) + 1 / (jl * s)) / s
    return (k + (jm + jl) * s) / (jm * jl * s**3)


CONTROLLERS = [
    Controller(kp=30.0, ti=0.5, feedback=feedback, speed_filter=tf, torque_lag=tl, delay=delay)
    for feedback in ("motor", "load")
    for tf, tl, delay in ((0.0, 0.0, 0.0), (0.002, 0.0, 0.0), (0.002, 0.001, 0.0), (0.002, 0.001, 0.004))
]


@pytest.mark.parametrize("ctl", CONTROLLERS, ids=lambda c: f"{c.feedback}-{c.speed_filter}-{c.torque_lag}-{c.delay}")
def test_frequency_response_equals_hand_derived(ctl):
    loop = DriveLoop(PLANT, ctl)
    expected = hand_g(1j * OMEGA, PLANT, ctl)
    np.testing.assert_allclose(loop.frequency_response(OMEGA), expected, rtol=1e-12)
    frd = loop.frd(OMEGA)
    np.testing.assert_allclose(np.squeeze(frd.eval(OMEGA)), expected, rtol=1e-12)
    if ctl.delay == 0.0:
        np.testing.assert_allclose(loop.transfer_function()(1j * OMEGA), expected, rtol=1e-12)


def test_pade_model_approaches_exact_delay():
    ctl = CONTROLLERS[-1]
    loop = DriveLoop(PLANT, ctl)
    w = np.array([1.0, 10.0, 50.0])
    exact = hand_g(1j * w, PLANT, ctl)
    errors = [np.max(np.abs(loop.transfer_function(pade_order=n)(1j * w) / exact - 1)) for n in (1, 3, 5)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-8
    with pytest.raises(ValueError, match="dead time"):
        loop.transfer_function()


def hand_tf(plant, ctl):
    """The hand-derived G as a python-control TF (delay-free), from polynomials."""
    s = ct.tf("s")
    k = ctl.kp * (ctl.ti * s + 1) / (ctl.ti * s) / ((ctl.speed_filter * s + 1) * (ctl.torque_lag * s + 1))
    jm, jl = plant.motor_inertia, plant.load_inertia
    if ctl.feedback == "motor":
        return (1 / (jm * s + k) + 1 / (jl * s)) / s
    return (k + (jm + jl) * s) / (jm * jl * s**3)


@pytest.mark.parametrize("ctl", [c for c in CONTROLLERS if c.delay == 0.0], ids=lambda c: f"{c.feedback}-{c.torque_lag}")
def test_linear_loop_poles_match_python_control(ctl):
    # backlash replaced by the spring T = k theta_d + c dtheta_d: closed loop 1 + G(s)(k + c s) = 0
    k, c = PLANT.stiffness, PLANT.damping
    closed = ct.feedback(hand_tf(PLANT, ctl) * ct.tf([c, k], [1]), 1)
    expected = np.sort_complex(ct.minreal(closed, verbose=False).poles())
    got = np.sort_complex(DriveLoop(PLANT, ctl).linear_poles(k, c))
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-9)


def test_linear_part_states_and_inputs():
    loop = DriveLoop(PLANT, CONTROLLERS[-1])
    part = loop.linear_part()
    assert part.state_names == ("theta_d", "motor_speed", "load_speed", "integrator", "filtered_speed", "motor_torque")
    assert part.input_names == ("speed_reference", "load_torque")
    assert part.delay == 0.004


def test_user_lti_is_accepted():
    ctl = CONTROLLERS[2]
    g = hand_tf(PLANT, ctl)
    np.testing.assert_allclose(frequency_response_of(g, OMEGA), hand_g(1j * OMEGA, PLANT, ctl), rtol=1e-10)
    part = lti_linear_part(g)
    # G from the state space handed to the simulation: -c_x (sI - A)^-1 b
    s = 1j * OMEGA[2]
    via_part = -part.c_x @ np.linalg.solve(s * np.eye(part.A.shape[0]) - part.A, part.b)
    assert via_part == pytest.approx(hand_g(s, PLANT, ctl), rel=1e-9)
    with pytest.raises(ValueError, match="relative degree"):
        lti_linear_part(ct.tf([1.0, 0.0], [1.0, 2.0, 1.0]))
