"""Speed of the torque laws and of the two-mass simulation (run by hand).

    python benchmarks/bench_models.py

1. Torque evaluations per second of every static law on 10^6 points, beside a
   plain numpy implementation of the same law written here (np.where, and
   scipy.special.lambertw for theta*), with the largest difference between them.
2. Simulated seconds per wall-clock second of the Figure 3 drive (crossing setup
   of Table I: T_preload = 0.5 N m, 19 N m at 20 Hz, c = 0.01 k) with the exact and
   the phase plane model, compiled kernel at the step the convergence tests use,
   beside scipy.integrate.solve_ivp RK45 with and without event location (the same
   law through the compiled scalar functions) at the loosest tolerance that is at
   least as accurate (with events: 1e-6 ... 1e-13; without: 1e-8, 1e-10).  Accuracy
   of all: largest error of the motor speed over the last cycle, relative to its
   range, against an independent reference: solve_ivp DOP853 at rtol 1e-13, every
   switch of the law located as an event.  Times are CPU times of this process, the
   best of three on both sides.
"""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import lambertw

from backlash_df import make_model
from backlash_df._laws import EXACT, mode_torque, static_torque
from backlash_df.reproduce import PAPER_PLANT, SETUPS
from backlash_df.simulation import simulate_two_mass
from switched import phase_plane_guards, solve_switched
from timing import best_of

N_POINTS = 1_000_000
DT = 5e-5  # step of tests/test_simulate.py's halving test (1e-4 -> 5e-5)
T_END = 2.0


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


class Drive:
    """The Figure 3 drive for solve_ivp: z = (theta_d, w_m, w_l), plus theta_b for the exact model (14)."""

    def __init__(self, name, setup):
        self.model = make_model(name, **PAPER_PLANT.shaft)
        self.exact = self.model.law == EXACT
        self.k, self.c, self.alpha, _ = self.model.params
        self.motor, self.load = drive_inputs(setup)
        self.z0 = np.zeros(4 if self.exact else 3)

    @staticmethod
    def xv(z):
        return z[0], z[1] - z[2]

    def derivative(self, t, z, torque, rate=None):
        v = z[1] - z[2]
        out = [v, (self.motor(t) - torque) / PAPER_PLANT.motor_inertia, (self.load + torque) / PAPER_PLANT.load_inertia]
        return out + [rate] if self.exact else out

    def rhs(self, mode):
        """Smooth right-hand side with the mode held: a phase plane mode (+-2, 0) or, for the
        exact model, contact at theta_b = +-alpha (+-1) or the free shaft (0) of (14)."""
        k, c, alpha = self.k, self.c, self.alpha

        def f(t, z):
            x, v = self.xv(z)
            if not self.exact:
                return self.derivative(t, z, mode_torque(self.model.law, mode, x, v, *self.model.params))
            if mode:
                return self.derivative(t, z, k * (x - mode * alpha) + c * v, 0.0)
            return self.derivative(t, z, 0.0, v + (k / c) * (x - z[3]))

        return f

    def guards(self, mode):
        if not self.exact:
            return phase_plane_guards(mode, self.xv, self.k, self.c, self.alpha)
        if mode:  # contact ends where the torque k (x -+ alpha) + c v changes sign
            return [(lambda t, z: mode * (self.k * (z[0] - mode * self.alpha) + self.c * (z[1] - z[2])), 0)]
        return [(lambda t, z: self.alpha - z[3], 1), (lambda t, z: z[3] + self.alpha, -1)]

    def plain(self, t, z):
        """The law read as a memoryless T(x, v) (theta_b clipped for the exact model), for solve_ivp without events."""
        k, c, alpha = self.k, self.c, self.alpha
        x, v = self.xv(z)
        if not self.exact:
            return self.derivative(t, z, static_torque(self.model.law, x, v, *self.model.params))
        theta_b = min(max(z[3], -alpha), alpha)
        rate = v + (k / c) * (x - theta_b)
        if (theta_b >= alpha and rate > 0) or (theta_b <= -alpha and rate < 0):
            rate = 0.0
        return self.derivative(t, z, k * (x - theta_b) + c * (v - rate), rate)


def with_events(drive, method, rtol, t_eval):
    return solve_switched(drive.rhs, drive.guards, drive.z0, 0, T_END, t_eval, method, rtol, row=1)


def without_events(drive, method, rtol, t_eval):
    return solve_ivp(drive.plain, (0.0, T_END), drive.z0, method=method, t_eval=t_eval, rtol=rtol,
                     atol=rtol * 1e-3).y[1]


def last_cycle_error(speed, reference, n_cycle):
    tail = slice(len(reference) - n_cycle - 1, None)
    return np.abs(speed[tail] - reference[tail]).max() / np.ptp(reference[tail])


def matched(run, error_of, target, rtols):
    """The loosest of ``rtols`` at least as accurate as ``target`` (else the tightest), timed."""
    for rtol in rtols:
        if error_of(run(rtol)) <= target:
            break
    seconds, values = best_of(lambda: run(rtol))
    return rtol, seconds, error_of(values)


def bench_simulation():
    setup = SETUPS["crossing"]
    n_cycle = int(round(setup.period / DT))
    print(f"\n2. two-mass drive, {setup.name} setup, {T_END:g} s simulated, best of 3; error: motor speed over "
          "the last cycle against solve_ivp DOP853 at rtol 1e-13 with every switch located as an event, "
          "relative to its range; competitors at the loosest rtol as accurate as the kernel")
    print(f"   {'model':<13}{'integrator':<28}{'rtol':>7}{'s/s':>8}{'error':>10}{'vs kernel':>11}")
    for name in ("exact", "phase-plane"):
        drive = Drive(name, setup)
        kernel_run(name, DT, setup)  # compile
        wall, result = best_of(lambda: kernel_run(name, DT, setup))
        t_eval = result.time
        reference = with_events(drive, "DOP853", 1e-13, t_eval)

        def error_of(speed):
            return last_cycle_error(speed, reference, n_cycle)

        target = error_of(result.state("motor_speed"))
        print(f"   {name:<13}{f'kernel, dt = {DT:g} s':<28}{'-':>7}{T_END / wall:8.1f}{target:10.1e}{'(base)':>11}")
        for label, run, rtols in (("solve_ivp RK45 + events", with_events, 10.0 ** -np.arange(6, 14)),
                                  ("solve_ivp RK45, no events", without_events, (1e-8, 1e-10))):
            rtol, seconds, theirs = matched(lambda r: run(drive, "RK45", r, t_eval), error_of, target, rtols)
            note = "" if theirs <= target else "  (never as accurate)"
            print(f"   {name:<13}{label:<28}{rtol:7.0e}{T_END / seconds:8.2f}{theirs:10.1e}{seconds / wall:10.1f}x{note}")


if __name__ == "__main__":
    bench_laws()
    bench_simulation()
