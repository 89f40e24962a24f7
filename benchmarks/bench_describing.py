"""Benchmark: describing functions against python-control and numpy (issues 3, 13).

Every time is CPU time of this process (``time.process_time``: steadier than wall time on
a shared machine), the best of N runs, N the same for both sides of a ratio.  Every accuracy is measured against a reference the timed code does not use.

1. Classical dead-zone (24), 1000 amplitudes A/alpha in [1.01, 100].  Reference:
   Tustin's closed form evaluated by mpmath at 40 digits (the double-precision
   formula loses digits near A = alpha).
   a. closed form vs closed form: backlash-df, the same formula in vectorised numpy,
      and python-control's ``describing_function`` given it as a
      ``DescribingFunctionNonlinearity`` written with plain ``math``;
   b. numerical vs numerical: backlash-df's harmonic balance (switches located,
      Gauss-Kronrod) against python-control's sampling of the law written with plain
      ``math``, at the sample count that first reaches 1e-7 (doubled from 64).
   (b runs on every tenth amplitude: python-control calls the law once per sample.)
2. Rate-dependent laws (phase plane (23), rubber (40)) on a 10 x 10 (A, w) grid, numerical
   vs numerical: backlash-df against the DF sampled along the sinusoid in a numba loop
   over the package's scalar law (python-control cannot take a rate-dependent law), at
   the sample count that first reaches 1e-4 (sampling a torque jump converges like
   1 / samples).  Reference: backlash-df's fixed Gauss-Legendre rule (order 32 on
   sub-intervals) instead of adaptive Gauss-Kronrod; the sampled DF converging to it
   checks it independently.  Throughput on a 200 x 200 grid is printed below the table.
3. Exact model (1)+(14), 50 x 50 grid: throughput, with accuracy against an FFT of a
   time simulation of (14) at three points.

Run: python benchmarks/bench_describing.py  (about three minutes on one core)
"""

import math
import tracemalloc

import control
import mpmath
import numba
import numpy as np

from backlash_df import describing_function, make_model
from backlash_df.describing import _evaluate
from backlash_df.models import held_mode, mode_torque
from timing import best_of

K, C, ALPHA, BETA = 5895.0, 3.0, 0.05, 0.05
REPEAT = 5
TARGET = 1e-7  # accuracy the dead-zone competitor must reach
GRID_TARGET = 1e-4  # and the grid one (sampling a jump converges like 1 / samples)


def max_rel_error(values, reference):
    return float(np.max(np.abs(np.asarray(values) - reference) / np.abs(reference)))


def row(label, seconds, error, baseline=None):
    ratio = f"{seconds / baseline:10.3g}x" if baseline else f"{'(base)':>11s}"
    print(f"     {label:<58s}{seconds * 1e3:11.3f} ms{error:12.1e}{ratio}")


def header():
    print(f"     {'':<58s}{'best CPU':>14s}{'max rel err':>12s}{'vs base':>11s}")


# ----------------------------------------------------------------------------- 1. dead-zone


def tustin_mpmath(ratio):
    """N/k of the dead-zone (24) at A/alpha = ratio, 40 digits."""
    with mpmath.workdps(40):
        r = 1 / mpmath.mpf(ratio)
        return float(1 - (2 / mpmath.pi) * (mpmath.asin(r) + r * mpmath.sqrt(1 - r * r)))


def tustin_numpy(amplitude):
    r = ALPHA / amplitude
    return K * (1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r)))


class TustinDeadZone(control.DescribingFunctionNonlinearity):
    """The dead-zone (24) with its closed-form DF, for python-control (plain ``math``)."""

    def __call__(self, x):
        return dead_zone_math(x)

    def _isstatic(self):
        return True

    def describing_function(self, amplitude):
        if amplitude <= ALPHA:
            return 0.0
        r = ALPHA / amplitude
        return K * (1.0 - (2.0 / math.pi) * (math.asin(r) + r * math.sqrt(1.0 - r * r)))


def dead_zone_math(x):
    """The dead-zone (24) as a user writes it for python-control's sampling: plain ``math``."""
    return K * (x - ALPHA) if x > ALPHA else (K * (x + ALPHA) if x < -ALPHA else 0.0)


def samples_for(target, evaluate, reference, start=64, limit=2**20):
    """Smallest power-of-two sample count (from ``start``) whose error is below ``target``."""
    points = start
    while max_rel_error(evaluate(points), reference) > target and points < limit:
        points *= 2
    return points


def dead_zone_benchmark():
    law = make_model("dead-zone", stiffness=K, half_gap=ALPHA)
    ratio = np.geomspace(1.01, 100.0, 1000)
    amplitude = ratio * ALPHA
    reference = K * np.array([tustin_mpmath(x) for x in ratio])
    describing_function(law, amplitude[:2], 1.0, method="harmonic-balance")  # compile
    nonlinearity = TustinDeadZone()
    print(f"1. classical dead-zone (24), 1000 amplitudes A/alpha in [1.01, 100]; best of {REPEAT}; "
          "reference: Tustin's closed form in mpmath, 40 digits")
    header()
    print("   a. closed form vs closed form")
    ours, n = best_of(lambda: describing_function(law, amplitude, 1.0), REPEAT)
    row("backlash-df describing_function (closed form)", ours, max_rel_error(n, reference))
    seconds, n = best_of(lambda: tustin_numpy(amplitude), REPEAT)
    row("Tustin's formula, vectorised numpy", seconds, max_rel_error(n, reference), ours)
    seconds, n = best_of(lambda: control.describing_function(nonlinearity, amplitude), REPEAT)
    row("control.describing_function(DescribingFunctionNonlinearity)", seconds, max_rel_error(n, reference), ours)
    print(f"   b. numerical vs numerical (competitor at the fewest samples reaching {TARGET:.0e})")
    amplitude, reference = amplitude[::10], reference[::10]
    ours, n = best_of(lambda: describing_function(law, amplitude, 1.0, method="harmonic-balance"), REPEAT)
    row("backlash-df harmonic balance, 100 amplitudes", ours, max_rel_error(n, reference))
    points = samples_for(TARGET, lambda m: control.describing_function(dead_zone_math, amplitude, num_points=m),
                         reference)
    seconds, n = best_of(lambda: control.describing_function(dead_zone_math, amplitude, num_points=points), 3)
    row(f"control.describing_function, {points} samples (best of 3)", seconds, max_rel_error(n, reference), ours)


# ----------------------------------------------------------------------------- 2. rate-dependent laws


@numba.njit(cache=True)
def _sampled_df(law, k, c, alpha, beta, amplitude, omega, samples, out):
    """Bin 1 of the DFT of the torque over the second of two periods, contact held as the package holds it."""
    for i in range(amplitude.size):
        a, w, mode, b1, a1 = amplitude[i], omega[i], 0, 0.0, 0.0
        for lap in range(2):
            for j in range(samples):
                sin, cos = math.sin(2.0 * math.pi * j / samples), math.cos(2.0 * math.pi * j / samples)
                x, v = a * sin, a * w * cos
                mode = held_mode(law, mode, x, v, k, c, alpha, beta)
                if lap == 1:
                    torque = mode_torque(law, mode, x, v, k, c, alpha, beta)
                    b1, a1 = b1 + torque * sin, a1 + torque * cos
        out[i] = (b1 + 1j * a1) * 2.0 / (samples * a)


def sampled_df(law, amplitude, omega, samples):
    """N(A, w) from ``samples`` equally spaced phases (trapezoid rule), compiled with numba.

    The competitor at its best: the package's scalar law (mode held in contact until
    release, as in (20)) sampled along the sinusoid in a compiled loop.
    """
    a, w = (np.ascontiguousarray(x, dtype=float).ravel() for x in np.broadcast_arrays(amplitude, omega))
    out = np.empty(a.size, dtype=complex)
    _sampled_df(law.law, *law.params, a, w, samples, out)
    return out


def grid_benchmark(name):
    law = make_model(name, stiffness=K, damping=C, half_gap=ALPHA, rubber_thickness=BETA)
    amplitude = ALPHA * np.geomspace(1.001, 200.0, 10)[:, None]
    omega = np.geomspace(0.1, 3e4, 10)[None, :]
    describing_function(law, amplitude[:2], omega[:, :2])  # compile
    sampled_df(law, amplitude[:1], omega[:, :1], 8)
    reference = _evaluate(law, amplitude, omega, 0.0, "harmonic-balance", samples=256, gauss_order=32)[0].ravel()
    ours, n = best_of(lambda: describing_function(law, amplitude, omega), REPEAT)
    row(f"backlash-df, {name}", ours, max_rel_error(n.ravel(), reference))
    points = samples_for(GRID_TARGET, lambda m: sampled_df(law, amplitude, omega, m), reference, limit=2**20)
    seconds, n = best_of(lambda: sampled_df(law, amplitude, omega, points), 3)
    row(f"numba sampling, {name}, {points} samples (best of 3)", seconds, max_rel_error(n, reference), ours)


def grid_throughput(name):
    law = make_model(name, stiffness=K, damping=C, half_gap=ALPHA, rubber_thickness=BETA)
    amplitude = ALPHA * np.geomspace(1.001, 200.0, 200)[:, None]
    omega = np.geomspace(0.1, 3e4, 200)[None, :]
    seconds, _ = best_of(lambda: describing_function(law, amplitude, omega), 3)
    print(f"     {name:12s} 200 x 200 grid: {seconds:6.3f} s = {40000 / seconds:9.0f} points/s (one core, best of 3)")


# ----------------------------------------------------------------------------- 3. exact model


def exact_benchmark():
    law = make_model("exact", stiffness=K, damping=C, half_gap=ALPHA)
    amplitude = ALPHA * np.geomspace(1.01, 100.0, 50)[:, None]
    omega = np.geomspace(1.0, 2e4, 50)[None, :]
    describing_function(law, amplitude[:1], omega[:, :1])  # compile
    tracemalloc.start()
    describing_function(law, amplitude, omega)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    seconds, _ = best_of(lambda: describing_function(law, amplitude, omega), 3)
    worst = 0.0
    for ratio, rate in [(1.2, 0.05), (3.0, 0.5), (10.0, 2.0)]:
        a, w = ratio * ALPHA, rate * K / C
        samples = 2**14
        t = np.arange(8 * samples + 1) * (2 * np.pi / w / samples)
        torque, _ = law.torque_along(t, a * np.sin(w * t), a * w * np.cos(w * t))
        spectrum = np.fft.rfft(torque[-samples - 1:-1]) / samples
        n_sim = (-2 * spectrum[1].imag + 2j * spectrum[1].real) / a
        worst = max(worst, abs(complex(describing_function(law, a, w)) - n_sim) / abs(n_sim))
    print(f"3. exact model (1)+(14), 50 x 50 grid, A/alpha in [1.01, 100], w in [1, 2e4] rad/s: {seconds:.3f} s "
          f"= {2500 / seconds:.0f} points/s (best of 3), memory peak {peak / 1024:.0f} KiB; max rel difference "
          f"to an FFT of a simulated period of (14) {worst:.1e} (limited by the simulation's step)")


if __name__ == "__main__":
    dead_zone_benchmark()
    print(f"2. rate-dependent laws, 10 x 10 grid, A/alpha in [1.001, 200], w in [0.1, 3e4] rad/s (c w/k up to 15); "
          f"best of {REPEAT}; reference: Gauss-Legendre 32 on fixed sub-intervals")
    print("   numerical vs numerical (competitor at the fewest samples reaching 1e-4, at most 2^20)")
    header()
    for name in ("phase-plane", "rubber"):
        grid_benchmark(name)
    for name in ("phase-plane", "rubber"):
        grid_throughput(name)
    exact_benchmark()
