"""Speed of the torque laws and of the two-mass simulation (run by hand).

    python benchmarks/bench_models.py

1. Torque evaluations per second of every static law on 10^6 points, beside a
   plain numpy implementation of the same law written here (np.where, and
   scipy.special.lambertw for theta*), with the largest difference between them.
2. Simulated seconds per wall-clock second of the Figure 3 drive (crossing setup
   of Table I: T_preload = 0.5 N m, 19 N m at 20 Hz, c = 0.01 k) with the exact and
   the phase plane model, compiled kernel at the step the convergence tests use,
   beside scipy.integrate.solve_ivp (RK45, the same right-hand side through the
   compiled scalar torque law) at the loosest tolerance that is at least as
   accurate.  Accuracy of both: largest error of the motor speed over the last
   cycle against a reference run (kernel at dt / 16), relative to its range.
"""

import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import lambertw

from backlash_df import make_model
from backlash_df.models import EXACT, static_torque
from backlash_df.reproduce import PAPER_PLANT, SETUPS
from backlash_df.simulate import simulate_two_mass

N_POINTS = 1_000_000
DT = 5e-5  # step of tests/test_simulate.py's halving test (1e-4 -> 5e-5)
T_END = 2.0


def best_of(function, repeat=3):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        value = function()
        times.append(time.perf_counter() - start)
    return min(times), value


def numpy_law(name, x, v, k, c, alpha):
    """The law in plain numpy, right side written out and mirrored (reference implementation)."""
    def right(x, v):
        if name == "dead-zone":
            return np.where(x > alpha, k * (x - alpha), 0.0)
        if name == "damped-dead-zone":
            return np.where(x > alpha, k * (x - alpha) + c * v, 0.0)
        if name == "revised-dead-zone":
            return np.where(k * x + c * v > k * alpha, k * (x - alpha) + c * v, 0.0)
        if name == "elasto-backlash":
            tau_c, tau_d = k * (x - alpha), c * v
            return np.where((x > alpha) & (tau_c + tau_d > 0), tau_c + np.minimum(tau_c, tau_d), 0.0)
        s = c * np.maximum(v, 1e-300) / k
        star = alpha + s * lambertw(-np.exp(-1.0 - 2.0 * alpha / s), 0).real
        contact = np.where(v > 0, x >= star, k * (x - alpha) + c * v >= 0)
        return np.where(contact, k * (x - alpha) + c * v, 0.0)

    return right(x, v) - right(-x, -v)


def bench_laws():
    plant = PAPER_PLANT
    k, c, alpha = plant.stiffness, plant.damping, plant.half_gap
    rng = np.random.default_rng(1)
    x = rng.uniform(-3 * alpha, 3 * alpha, N_POINTS)
    v = rng.uniform(-3 * k * alpha / c, 3 * k * alpha / c, N_POINTS)
    print(f"1. torque laws on {N_POINTS:.0e} points (k = {k:g}, c = {c:g}, alpha = {alpha:g})")
    print(f"   {'law':<20}{'backlash-df (1/s)':>19}{'numpy (1/s)':>14}{'ratio':>8}{'max |diff| (N m)':>18}")
    for name in ("dead-zone", "damped-dead-zone", "revised-dead-zone", "elasto-backlash", "phase-plane", "rubber"):
        model = make_model(name, **{**plant.shaft, "rubber_thickness": alpha if name == "rubber" else 0.0})
        model.torque(x[:10], v[:10])
        ours, torque = best_of(lambda: model.torque(x, v))
        if name == "rubber":
            print(f"   {name:<20}{N_POINTS / ours:19.3e}{'-':>14}{'-':>8}{'-':>18}")
            continue
        theirs, reference = best_of(lambda: numpy_law(name, x, v, k, c, alpha))
        print(f"   {name:<20}{N_POINTS / ours:19.3e}{N_POINTS / theirs:14.3e}{theirs / ours:8.1f}"
              f"{np.abs(torque - reference).max():18.2e}")


def drive_inputs(setup):
    def motor(t):
        return -setup.preload + setup.amplitude * np.sin(2 * np.pi * setup.frequency * t)

    return motor, setup.preload


def kernel_run(name, dt, setup):
    motor, load = drive_inputs(setup)
    return simulate_two_mass(PAPER_PLANT, name, T_END, dt, motor_torque=motor, load_torque=load)


def scipy_run(name, rtol, setup):
    """The same drive as a solve_ivp right-hand side; the exact model's theta_b as a 4th state (14)."""
    model = make_model(name, **PAPER_PLANT.shaft)
    law, (k, c, alpha, beta) = model.law, model.params
    jm, jl = PAPER_PLANT.motor_inertia, PAPER_PLANT.load_inertia
    motor, load = drive_inputs(setup)

    def rhs(t, z):
        x, wm, wl = z[0], z[1], z[2]
        v = wm - wl
        if law == EXACT:
            theta_b = min(max(z[3], -alpha), alpha)
            rate = v + (k / c) * (x - theta_b)  # (14): limited integrator
            if (theta_b >= alpha and rate > 0) or (theta_b <= -alpha and rate < 0):
                rate = 0.0
            torque = k * (x - theta_b) + c * (v - rate)  # (1)
        else:
            torque = static_torque(law, x, v, k, c, alpha, beta)
        derivative = [v, (motor(t) - torque) / jm, (load + torque) / jl]
        return derivative + [rate] if law == EXACT else derivative

    z0 = [0.0, 0.0, 0.0] + ([0.0] if law == EXACT else [])
    t_eval = np.arange(int(round(T_END / DT)) + 1) * DT
    return solve_ivp(rhs, (0.0, T_END), z0, method="RK45", t_eval=t_eval, rtol=rtol, atol=rtol * 1e-3)


def last_cycle_error(speed, reference, n_cycle):
    tail = slice(len(reference) - n_cycle - 1, None)
    return np.abs(speed[tail] - reference[tail]).max() / np.ptp(reference[tail])


def bench_simulation():
    setup = SETUPS["crossing"]
    n_cycle = int(round(setup.period / DT))
    print(f"\n2. two-mass drive, {setup.name} setup, {T_END:g} s simulated; kernel dt = {DT:g} s")
    print(f"   {'model':<13}{'kernel (s/s)':>13}{'error':>10}{'solve_ivp (s/s)':>17}{'rtol':>8}{'error':>10}{'ratio':>8}")
    for name in ("exact", "phase-plane"):
        kernel_run(name, DT, setup)  # compile
        reference = kernel_run(name, DT / 16, setup).state("motor_speed")[::16]
        wall, result = best_of(lambda: kernel_run(name, DT, setup))
        error = last_cycle_error(result.state("motor_speed"), reference, n_cycle)
        for rtol in 10.0 ** -np.arange(3, 13):
            start = time.perf_counter()
            solution = scipy_run(name, rtol, setup)
            scipy_wall = time.perf_counter() - start
            scipy_error = last_cycle_error(solution.y[1], reference, n_cycle)
            if scipy_error <= error:
                break
        matched = "" if scipy_error <= error else "  (solve_ivp never as accurate)"
        print(f"   {name:<13}{T_END / wall:13.1f}{error:10.1e}{T_END / scipy_wall:17.2f}{rtol:8.0e}"
              f"{scipy_error:10.1e}{scipy_wall / wall:8.1f}{matched}")


if __name__ == "__main__":
    bench_laws()
    bench_simulation()
