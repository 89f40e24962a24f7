"""Dead time: the simulation against an independent delayed-ODE solver and against the exact frequency response.

The issue's critical tuning (motor feedback, c = 10 N m s/rad, kp = 222, ti = 0.3 s,
speed filter 7.6 ms, torque lag 1.5 ms, dead time 0.5 ms on the measured speed; the
plant of ``examples/motor_lag_feedback.toml``, phase plane law) sits close to the edge
of the cycling region, where a small error in the delay shows in the amplitude.

* **Method of steps** (:func:`reference_cycle`): the loop's equations written out
  here from the block diagram (not the kernel's state matrices), explicit classical
  RK4 at a fixed step, every switch of the law located by bisection, a step ending at
  every ``t_event + tau`` (where the delayed speed has a kink), and the delayed motor
  speed read from a history buffer by cubic Hermite interpolation (state and
  derivative at each stored point, order 4 like RK4).  The first harmonic of theta_d
  is integrated exactly on the same Hermite pieces (3-point Gauss).  Halving the step
  twice gives the observed order and the reference's own error.
* **Linear regime**: a small sinusoid in the speed reference while a load torque
  keeps the gear in contact; the steady-state motor speed against the closed form
  ``L PI / (J_m s + Y(s) + L PI F e^{-s tau})`` at ``s = j w``.
"""

import dataclasses
import math

import numba
import numpy as np
import pytest

from backlash_df import load_rig, simulate
from backlash_df._laws import PHASE_PLANE, held_mode, mode_torque
from backlash_df.simulation import measure_limit_cycle
from conftest import EXAMPLES


def critical_rig():
    rig = load_rig(EXAMPLES / "motor_lag_feedback.toml")
    controller = dataclasses.replace(rig.controller, kp=222.0, ti=0.3, speed_filter=0.0076, torque_lag=0.0015,
                                     delay=0.0005)
    return dataclasses.replace(rig, controller=controller)


# --------------------------------------------------------------------------- independent reference


@numba.njit(cache=True)
def _delayed(s, ht, hw, hd_right, hd_left, count):
    """Motor speed at time s <= t from the history: cubic Hermite between stored points; w(0) before 0."""
    if s <= 0.0:
        return hw[0]
    lo, hi = 0, count - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ht[mid] <= s:
            lo = mid
        else:
            hi = mid
    h = ht[hi] - ht[lo]
    u = (s - ht[lo]) / h
    return ((2 * u**3 - 3 * u**2 + 1) * hw[lo] + (u**3 - 2 * u**2 + u) * h * hd_right[lo]
            + (-2 * u**3 + 3 * u**2) * hw[hi] + (u**3 - u**2) * h * hd_left[hi])


@numba.njit(cache=True)
def _rates(z, mode, y_delayed, p, out):
    """theta_d, w_m, w_l, integral of the speed error, filtered speed, motor torque (r = 0, T_l = 0)."""
    jm, jl, k, c, alpha, kp, ti, tau_f, tau_l = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8]
    shaft = mode_torque(PHASE_PLANE, mode, z[0], z[1] - z[2], k, c, alpha, 0.0)
    out[0] = z[1] - z[2]
    out[1] = (z[5] - shaft) / jm
    out[2] = shaft / jl
    out[3] = -z[4]
    out[4] = (y_delayed - z[4]) / tau_f
    out[5] = (kp * (-z[4] + z[3] / ti) - z[5]) / tau_l


@numba.njit(cache=True)
def _rk4(z, t, h, mode, p, ht, hw, hr, hl, count, out):
    tau = p[9]
    k1, k2, k3, k4 = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    _rates(z, mode, _delayed(t - tau, ht, hw, hr, hl, count), p, k1)
    _rates(z + 0.5 * h * k1, mode, _delayed(t + 0.5 * h - tau, ht, hw, hr, hl, count), p, k2)
    _rates(z + 0.5 * h * k2, mode, _delayed(t + 0.5 * h - tau, ht, hw, hr, hl, count), p, k3)
    _rates(z + h * k3, mode, _delayed(t + h - tau, ht, hw, hr, hl, count), p, k4)
    out[:] = z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@numba.njit(cache=True)
def _leaves(z, mode, p):
    return held_mode(PHASE_PLANE, mode, z[0], z[1] - z[2], p[2], p[3], p[4], 0.0) != mode


@numba.njit(cache=True)
def _motor_rate(z, mode, p):
    return (z[5] - mode_torque(PHASE_PLANE, mode, z[0], z[1] - z[2], p[2], p[3], p[4], 0.0)) / p[0]


@numba.njit(cache=True)
def _solve(z0, p, step, t_end, ht, hw, hr, hl, hx, hv):
    """Method of steps; stores every accepted point; returns the number of points."""
    tau = p[9]
    z = z0.copy()
    z_new = np.empty(6)
    mode = held_mode(PHASE_PLANE, 0, z[0], z[1] - z[2], p[2], p[3], p[4], 0.0)
    ht[0], hw[0], hx[0], hv[0] = 0.0, z[1], z[0], z[1] - z[2]
    hr[0] = hl[0] = _motor_rate(z, mode, p)
    count = 1
    kinks = np.empty(ht.shape[0] // 4 + 16)  # t_event + tau, increasing
    first_kink, n_kinks = 0, 0
    t = 0.0
    while t < t_end and count < ht.shape[0]:
        h = min(step, t_end - t)
        at_kink = first_kink < n_kinks and kinks[first_kink] <= t + h
        if at_kink:
            h = kinks[first_kink] - t
        _rk4(z, t, h, mode, p, ht, hw, hr, hl, count, z_new)
        new_mode = mode
        if _leaves(z_new, mode, p):
            lo, hi = 0.0, h
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                _rk4(z, t, mid, mode, p, ht, hw, hr, hl, count, z_new)
                if _leaves(z_new, mode, p):
                    hi = mid
                else:
                    lo = mid
            h = hi
            _rk4(z, t, h, mode, p, ht, hw, hr, hl, count, z_new)
            new_mode = held_mode(PHASE_PLANE, mode, z_new[0], z_new[1] - z_new[2], p[2], p[3], p[4], 0.0)
            at_kink = False
        hl[count] = _motor_rate(z_new, mode, p)
        t += h
        z[:] = z_new
        if new_mode != mode:
            mode = new_mode
            kinks[n_kinks] = t + tau
            n_kinks += 1
        elif at_kink:
            first_kink += 1
        ht[count], hw[count], hx[count], hv[count] = t, z[1], z[0], z[1] - z[2]
        hr[count] = _motor_rate(z, mode, p)
        count += 1
    return count


def _hermite(t0, t1, y0, y1, d0, d1, s):
    h = t1 - t0
    u = (s - t0) / h
    return ((2 * u**3 - 3 * u**2 + 1) * y0 + (u**3 - 2 * u**2 + u) * h * d0
            + (-2 * u**3 + 3 * u**2) * y1 + (u**3 - u**2) * h * d1)


def _first_harmonic(t, x, v, periods):
    """(amplitude, omega) of theta_d over the last ``periods`` periods, on the Hermite pieces of (x, v)."""
    up = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    crossings = []
    for i in up[-(periods + 1):]:  # the zero of each cubic piece, by bisection
        lo, hi = t[i], t[i + 1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if _hermite(t[i], t[i + 1], x[i], x[i + 1], v[i], v[i + 1], mid) < 0.0:
                lo = mid
            else:
                hi = mid
        crossings.append((0.5 * (lo + hi), i))
    (start, i0), (stop, i1) = crossings[0], crossings[-1]
    omega = 2.0 * math.pi * periods / (stop - start)
    nodes, weights = np.polynomial.legendre.leggauss(3)
    total = 0.0
    for a_i, b_i, j in [(start, t[i0 + 1], i0)] + [(t[j], t[j + 1], j) for j in range(i0 + 1, i1)] + [(t[i1], stop, i1)]:
        s = 0.5 * (a_i + b_i) + 0.5 * (b_i - a_i) * nodes
        values = _hermite(t[j], t[j + 1], x[j], x[j + 1], v[j], v[j + 1], s) * np.exp(-1j * omega * s)
        total += 0.5 * (b_i - a_i) * np.dot(weights, values)
    return abs(2.0 * total / (stop - start)), omega


def reference_cycle(rig, step, t_end, kick, periods=20):
    """First-harmonic amplitude (rad) and frequency (rad/s) of the cycle by the method of steps."""
    plant, ctl = rig.plant, rig.controller
    p = np.array([plant.motor_inertia, plant.load_inertia, plant.stiffness, plant.damping, plant.half_gap,
                  ctl.kp, ctl.ti, ctl.speed_filter, ctl.torque_lag, ctl.delay])
    size = int(t_end / step * 1.05) + 1000
    arrays = [np.empty(size) for _ in range(6)]
    z0 = np.array([0.0, 0.5 * kick, -0.5 * kick, 0.0, 0.0, 0.0])
    count = _solve(z0, p, step, t_end, *arrays)
    assert count < size
    ht, _, _, _, hx, hv = (a[:count] for a in arrays)
    return _first_harmonic(ht, hx, hv, periods)


T_END, KICK = 12.0, 0.2 * 267.0  # from A w of the cycle: within 1e-5 of it by 12 s, the same transient for both


STEPS = (8e-5, 4e-5, 2e-5)  # s; the dead time is 5e-4 s


@pytest.fixture(scope="module")
def references():
    rig = critical_rig()
    return {step: reference_cycle(rig, step, T_END, KICK) for step in STEPS}


@pytest.mark.xdist_group("delay-reference")  # the references computed (and their solver compiled) on one worker
def test_reference_converges_at_its_order(references):
    (a1, w1), (a2, w2), (a3, w3) = (references[h] for h in STEPS)
    order = math.log2(abs(a1 - a2) / abs(a2 - a3))
    print(f"\nreference A: {a1:.10f} {a2:.10f} {a3:.10f} rad, observed order {order:.2f}; "
          f"w {w3:.8f} rad/s")
    assert order > 3.0  # RK4 with located switches and delay kinks: fourth order
    assert abs(a2 - a3) < 1e-7 * a3  # so the finest reference is good to far below 1e-4


@pytest.mark.xdist_group("delay-reference")
def test_simulation_with_dead_time_matches_the_reference(references):
    rig = critical_rig()
    amplitude, omega = references[STEPS[-1]]
    result = simulate(rig, "phase-plane", t_end=T_END, kick=KICK)
    measured = measure_limit_cycle(result, periods=20)
    print(f"\nkernel A = {measured.amplitude:.8f} rad (reference {amplitude:.8f}), "
          f"{measured.amplitude / amplitude - 1:+.2e}; w {measured.omega / omega - 1:+.2e}")
    assert measured.found
    assert abs(measured.amplitude / amplitude - 1.0) < 1e-4
    assert abs(measured.omega / omega - 1.0) < 1e-4


# --------------------------------------------------------------------------- linear regime


def closed_form_motor_speed(rig, omega, delay):
    """w_m / r at s = j w for the loop in contact: L PI / (J_m s + Y + L PI F e^{-s tau}).

    Y(s) = Z / (1 + Z / (J_l s)), Z = (k + c s) / s, is the shaft-and-load admittance
    seen by the motor; PI = kp (1 + 1 / (ti s)), F the speed filter, L the torque lag.
    """
    plant, ctl = rig.plant, rig.controller
    s = 1j * omega
    z = (plant.stiffness + plant.damping * s) / s
    y = z / (1.0 + z / (plant.load_inertia * s))
    pi = ctl.kp * (1.0 + 1.0 / (ctl.ti * s))
    f = 1.0 / (ctl.speed_filter * s + 1.0)
    lag = 1.0 / (ctl.torque_lag * s + 1.0)
    return lag * pi / (plant.motor_inertia * s + y + lag * pi * f * np.exp(-s * delay))


@pytest.mark.parametrize("omega", [60.0, 180.0, 300.0])
def test_linear_regime_follows_the_exact_frequency_response(omega):
    rig = critical_rig()
    amplitude, load = 0.02, 200.0  # rad/s of reference; N m pressing the gear into contact
    period = 2.0 * math.pi / omega
    t_end = 8.0  # the slowest contact pole decays at 2.2 1/s
    result = simulate(rig, "phase-plane", t_end=t_end, load_torque=load,
                      speed_reference=lambda t: amplitude * np.sin(omega * t))
    tail = result.time >= t_end - 20 * period
    assert np.all(result.mode[tail] == result.mode[-1]) and result.mode[-1] != 0  # in contact throughout
    t = result.time[tail]
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(basis, result.states[tail, 1], rcond=None)
    simulated = complex(coef[0], coef[1]) / amplitude  # w_m = Re(H) sin + Im(H) cos for r = sin
    exact = closed_form_motor_speed(rig, omega, rig.controller.delay)
    without = closed_form_motor_speed(rig, omega, 0.0)
    print(f"\nw = {omega}: |H| {abs(simulated):.6f} / {abs(exact):.6f}, phase "
          f"{math.degrees(np.angle(simulated / exact)):+.4f} deg off (no delay: "
          f"{math.degrees(np.angle(without / exact)):+.3f} deg)")
    assert abs(simulated / exact - 1.0) < 2e-4
    assert abs(without / exact - 1.0) > 20 * abs(simulated / exact - 1.0)  # the delay is what is being checked
