"""Benchmark: describing functions (issue 3).

1. Classical dead-zone on 1000 amplitudes at 1e-7 accuracy: backlash-df against
   python-control's ``describing_function`` run here at the sample count it needs
   for that accuracy (doubled until it gets there).
2. Phase plane and rubber laws on a 200 x 200 (A, w) grid: points per second (best of
   five runs: the machine is shared), with the accuracy measured against a reference
   evaluation (4x phase samples; fixed Gauss-Legendre order 32 on sub-intervals of
   pi/4, pi/8 in the rubber band, instead of adaptive Gauss-Kronrod).
3. Exact model on a 50 x 50 grid: points per second and memory peak, with accuracy
   against a 4x finer re-contact search and an FFT of a time simulation of (14).

Run: python benchmarks/bench_describing.py
"""

import time
import tracemalloc

import control
import numpy as np

from backlash_df import describing_function, make_model
from backlash_df.describing import _evaluate

K, C, ALPHA, BETA = 5895.0, 3.0, 0.05, 0.05


def timed(function, repeat=3):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        value = function()
        best = min(best, time.perf_counter() - start)
    return best, value


def tustin(ratio):
    r = 1.0 / ratio
    return K * (1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r)))


def dead_zone_benchmark():
    law = make_model("dead-zone", stiffness=K, half_gap=ALPHA)
    ratio = np.geomspace(1.01, 100.0, 1000)
    amplitude = ratio * ALPHA
    reference = tustin(ratio)
    describing_function(law, amplitude[:2], 1.0)  # compile
    ours_time, ours = timed(lambda: describing_function(law, amplitude, 1.0))
    ours_error = np.max(np.abs(ours - reference) / reference)

    def dead_zone(x):
        return K * np.sign(x) * np.maximum(np.abs(x) - ALPHA, 0.0)

    points = 64
    while True:
        start = time.perf_counter()
        theirs = control.describing_function(dead_zone, amplitude, num_points=points)
        theirs_time = time.perf_counter() - start
        theirs_error = np.max(np.abs(theirs - reference) / reference)
        if theirs_error < 1e-7 or points >= 2**20:
            break
        points *= 2
    print("1. classical dead-zone (24), 1000 amplitudes A/alpha in [1.01, 100], reference: Tustin's closed form")
    print(f"   backlash-df                          {ours_time * 1e3:9.3f} ms   max rel error {ours_error:.1e}")
    print(f"   control.describing_function, {points:7d} samples/period "
          f"{theirs_time * 1e3:9.1f} ms   max rel error {theirs_error:.1e}")
    print(f"   ratio (control / backlash-df): {theirs_time / ours_time:,.0f}x at 1e-7 accuracy")
    forced_time, forced = timed(lambda: _evaluate(law, amplitude, 1.0, 0.0, "harmonic-balance")[0], repeat=1)
    print(f"   backlash-df forced through harmonic balance: {forced_time * 1e3:.1f} ms, max rel error "
          f"{np.max(np.abs(forced - reference) / reference):.1e}, ratio {theirs_time / forced_time:,.0f}x")


def grid_benchmark(name):
    law = make_model(name, stiffness=K, damping=C, half_gap=ALPHA, rubber_thickness=BETA)
    amplitude = ALPHA * np.geomspace(1.001, 200.0, 200)[:, None]
    omega = np.geomspace(0.1, 3e4, 200)[None, :]
    describing_function(law, amplitude[:2, :], omega[:, :2])  # compile
    seconds, n = timed(lambda: describing_function(law, amplitude, omega), repeat=5)
    fine, _ = _evaluate(law, amplitude, omega, 0.0, "harmonic-balance", samples=256, gauss_order=32)
    error = np.max(np.abs(n - fine) / np.maximum(np.abs(fine), 1e-300))
    print(f"   {name:12s} {seconds:6.3f} s for 40000 points = {40000 / seconds:9.0f} points/s (one core); "
          f"max rel difference to the reference {error:.1e}")


def exact_benchmark():
    law = make_model("exact", stiffness=K, damping=C, half_gap=ALPHA)
    amplitude = ALPHA * np.geomspace(1.01, 100.0, 50)[:, None]
    omega = np.geomspace(1.0, 2e4, 50)[None, :]
    describing_function(law, amplitude[:1], omega[:, :1])  # compile
    tracemalloc.start()
    seconds, n = timed(lambda: describing_function(law, amplitude, omega), repeat=1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    fine, _ = _evaluate(law, amplitude, omega, 0.0, "auto", scan_step=0.005)
    error = np.max(np.abs(n - fine) / np.maximum(np.abs(fine), 1e-300))
    # an independent check at a few points: FFT of a simulated steady period of (14)
    worst = 0.0
    for ratio, rate in [(1.2, 0.05), (3.0, 0.5), (10.0, 2.0)]:
        a, w = ratio * ALPHA, rate * K / C
        samples = 2**14
        t = np.arange(8 * samples + 1) * (2 * np.pi / w / samples)
        torque, _ = law.torque_along(t, a * np.sin(w * t), a * w * np.cos(w * t))
        spectrum = np.fft.rfft(torque[-samples - 1:-1]) / samples
        n_sim = (-2 * spectrum[1].imag + 2j * spectrum[1].real) / a
        worst = max(worst, abs(complex(describing_function(law, a, w)) - n_sim) / abs(n_sim))
    print(f"   exact        {seconds:6.3f} s for 2500 points = {2500 / seconds:9.0f} points/s; memory peak "
          f"{peak / 1024:.0f} KiB; rel change with 4x finer search {error:.1e}; vs simulated FFT {worst:.1e} "
          "(limited by the simulation's step)")


if __name__ == "__main__":
    dead_zone_benchmark()
    print("2. 200 x 200 grid, A/alpha in [1.001, 200], w in [0.1, 3e4] rad/s (c w/k up to 15)")
    grid_benchmark("phase-plane")
    grid_benchmark("rubber")
    print("3. exact model (1)+(14), 50 x 50 grid, A/alpha in [1.01, 100], w in [1, 2e4] rad/s")
    exact_benchmark()
