"""Benchmark: describing functions N(A, w, bias) by the switch-exact kernels (issues 3, 13, 21).

Per law, with and without bias (bias = alpha / 2), on a 100 x 100 grid of A / alpha in
[1.001, 100] and c w / k in [1e-3, 10] (the validity map's regions), through
``method="harmonic-balance"`` (the closed forms of the dead-zones are not used):

* backlash-df on one thread (CPU time of the process, best of REPEAT; and its wall time) and
  on numba's threads with ``prange`` (wall time: the threads' CPU time adds up, and on a
  shared machine the second core is not always free), in points per second;
* the numerical competitor, a vectorised numpy sampler: ``samples`` phases per period, one
  lap, sin and cos computed once, the law from the package's vectorised ``torque`` (contact
  of (23) held from theta* to the release by a cumulative maximum over each run of
  y >= alpha), N from the dot products with sin and cos; at the fewest samples (a power of
  two) that reach backlash-df's accuracy, or at 2^20, its best within the budget; and at the
  fewest that reach 1e-6 (a jump of the torque, as in (23) at theta*, converges like 1/samples);
* accuracy of both against the tests' mpmath reference at 30 digits, which locates every
  switch with its own root finder (``tests/test_describing.mp_describing_function``), on six
  points of the grid's region;
* a floor row: the classical dead-zone (24) through the same path and driver, the cheapest
  law: one arcsine and two series per side.  It is what a point costs before its law's own
  switches and integrals (input checks, broadcasting, the compiled loop);
* the share of the three functions on top of a cProfile of 0.3 s of calls (the compiled
  driver is one of them: the profiler does not see into it).

python-control's ``describing_function`` cannot take a rate-dependent law; its per-call and
per-amplitude overhead is printed apart, given Tustin's closed form (a
``DescribingFunctionNonlinearity``), beside backlash-df's on one point.  The exact model (14)
has its own route; its throughput is printed last, with its accuracy against an FFT of a
time simulation of (14).

Run: python benchmarks/bench_describing.py  (about five minutes; most of it the mpmath references)
"""

import cProfile
import math
import pstats
import sys
import time
from pathlib import Path

import control
import numba
import numpy as np

from backlash_df import describing_function, make_model
from backlash_df.describing._evaluation import evaluate
from timing import best_of

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_describing import mp_describing_function  # noqa: E402  (the tests' independent reference)

K, C, ALPHA, BETA = 5895.0, 3.0, 0.05, 0.05
REPEAT = 5
LAWS = ("dead-zone", "damped-dead-zone", "revised-dead-zone", "elasto-backlash", "phase-plane", "rubber")
BIASES = (0.0, 0.5 * ALPHA)
MAX_SAMPLES = 2**20
PRACTICAL = 1e-6  # a second accuracy target for the sampler
SAMPLER_BUDGET = 2**24  # torque evaluations of one timed sampler run
# (A / alpha, c w / k): low, middle and high rate; just above the gap at high rate; the rubber
# law's band just inside x_max at high rate
MP_POINTS = [(1.3, 0.15), (4.0, 0.9), (30.0, 0.02), (1.001, 5.9), (2.0, 0.3), (1.50101280768794, 4.050261330690965)]


def model(name):
    return make_model(name, stiffness=K, damping=C, half_gap=ALPHA, rubber_thickness=BETA)


def grid():
    """The benchmark's 10^4 points (A, w), flattened."""
    ratio, rate = np.meshgrid(np.geomspace(1.001, 100.0, 100), np.geomspace(1e-3, 10.0, 100), indexing="ij")
    return (ratio * ALPHA).ravel(), (rate * K / C).ravel()


def max_rel_error(values, reference):
    values, reference = np.asarray(values), np.asarray(reference)
    return float(np.max(np.abs(values - reference) / np.abs(reference)))


# ----------------------------------------------------------------------------- the competitor


def sampled_torque(law, x, v):
    """The law along the samples (rows: points); contact of (23) held until release."""
    if law.name != "phase-plane":
        return law.torque(x, v)
    k, c, alpha = law.stiffness, law.damping, law.half_gap
    torque = np.zeros_like(x)
    for side in (1.0, -1.0):
        xs, vs = side * x, side * v
        y_ok = k * (xs - alpha) + c * vs >= 0.0  # Theorem 1: contact holds while this holds
        closed = law.mode(xs, vs) > 0  # (20): the law closes the gap here
        # each run of y_ok is one contact arc, held from its first closed sample; the lap
        # starts at v = 0, where the held and the static mode agree
        starts = y_ok & ~np.concatenate([np.zeros((x.shape[0], 1), dtype=bool), y_ok[:, :-1]], axis=1)
        run = np.cumsum(starts, axis=1)
        first = np.maximum.accumulate(np.where(closed & y_ok, run, 0), axis=1)
        held = y_ok & (first == run)
        torque = np.where(held, side * (k * (xs - alpha) + c * vs), torque)
    return torque


def numpy_sampler(law, amplitude, omega, bias, samples):
    """N and mean torque from ``samples`` phases of one period (sin, cos computed once)."""
    phi = 0.5 * np.pi + 2.0 * np.pi * np.arange(samples) / samples
    sin, cos = np.sin(phi), np.cos(phi)
    n_out = np.empty(amplitude.size, dtype=complex)
    mean_out = np.empty(amplitude.size)
    chunk = max(1, 2**22 // samples)
    for start in range(0, amplitude.size, chunk):
        part = slice(start, start + chunk)
        a, w = amplitude[part, None], omega[part, None]
        torque = sampled_torque(law, bias + a * sin, a * w * cos)
        n_out[part] = 2.0 / samples * (torque @ sin + 1j * (torque @ cos)) / amplitude[part]
        mean_out[part] = torque.mean(axis=1)
    return n_out, mean_out


def matched_samples(law, amplitude, omega, bias, reference, target):
    """Fewest samples (power of two from 64) whose N is within target of the reference, else MAX_SAMPLES."""
    samples = 64
    while samples < MAX_SAMPLES:
        if max_rel_error(numpy_sampler(law, amplitude, omega, bias, samples)[0], reference) <= target:
            break
        samples *= 2
    return samples


# ----------------------------------------------------------------------------- one law


def profile_top3(function, seconds=0.3):
    """The three functions with the most own time in a cProfile of calls adding up to ``seconds``
    (CPU time), with their share."""
    profiler = cProfile.Profile()
    start = time.process_time()
    while time.process_time() - start < seconds:
        profiler.runcall(function)
    stats = pstats.Stats(profiler).stats
    total = sum(entry[2] for entry in stats.values())
    top = sorted(stats.items(), key=lambda item: -item[1][2])[:3]
    return ", ".join(f"{key[2]} {entry[2] / total:.0%}" for key, entry in top)


def law_row(name, bias, amplitude, omega):
    law = model(name)
    points = amplitude.size
    run = lambda: evaluate(law, amplitude, omega, bias, "harmonic-balance")  # noqa: E731
    parallel = lambda: evaluate(law, amplitude, omega, bias, "harmonic-balance", parallel=True)  # noqa: E731
    run(), parallel()  # compile
    serial_cpu, _ = best_of(run, REPEAT)
    serial_wall, _ = best_of(run, REPEAT, clock=time.perf_counter)
    threaded_wall, _ = best_of(parallel, REPEAT, clock=time.perf_counter)
    mp_a = np.array([ratio * ALPHA for ratio, _ in MP_POINTS])
    mp_w = np.array([rate * K / C for _, rate in MP_POINTS])
    reference = np.array([mp_describing_function(name, a, w, bias)[0] for a, w in zip(mp_a, mp_w)])
    ours_error = max_rel_error(evaluate(law, mp_a, mp_w, bias, "harmonic-balance").n, reference)
    ours_rate = points / serial_cpu
    label = f"{name}, biased" if bias else name
    row = f"   {label:<34s}{ours_rate:10.3g}{points / serial_wall:10.3g}{points / threaded_wall:10.3g}{ours_error:9.1e}"
    for target in (max(ours_error, 1e-15), PRACTICAL):
        samples = matched_samples(law, mp_a, mp_w, bias, reference, target)
        sampler_error = max_rel_error(numpy_sampler(law, mp_a, mp_w, bias, samples)[0], reference)
        subset = np.linspace(0, points - 1, min(points, max(1, SAMPLER_BUDGET // samples))).astype(int)
        sampler_cpu, _ = best_of(lambda: numpy_sampler(law, amplitude[subset], omega[subset], bias, samples), 3)
        sampler_rate = subset.size / sampler_cpu
        row += f" |{samples:>8d}{sampler_rate:9.3g}{sampler_error:9.1e}{ours_rate / sampler_rate:9.3g}x"
    print(row)
    print(f"   {'':34s}profile: {profile_top3(run)}")


def floor_row(bias, amplitude, omega):
    law = model("dead-zone")
    run = lambda: evaluate(law, amplitude, omega, bias, "harmonic-balance")  # noqa: E731
    run()
    seconds, _ = best_of(run, REPEAT)
    print(f"   {'floor: dead-zone (24)' + (', biased' if bias else ''):<34s}"
          f"{amplitude.size / seconds:10.3g}  profile: {profile_top3(run)}")


# ----------------------------------------------------------------------------- python-control


class TustinDeadZone(control.DescribingFunctionNonlinearity):
    """The dead-zone (24) with its closed-form DF, for python-control (plain ``math``)."""

    def __call__(self, x):
        return K * (x - ALPHA) if x > ALPHA else (K * (x + ALPHA) if x < -ALPHA else 0.0)

    def _isstatic(self):
        return True

    def describing_function(self, amplitude):
        if amplitude <= ALPHA:
            return 0.0
        r = ALPHA / amplitude
        return K * (1.0 - (2.0 / math.pi) * (math.asin(r) + r * math.sqrt(1.0 - r * r)))


def overhead_rows():
    nonlinearity = TustinDeadZone()
    law = model("dead-zone")
    one, many = np.array([2.0 * ALPHA]), ALPHA * np.geomspace(1.01, 100.0, 1000)
    describing_function(law, many, 1.0)
    print("   per call, 1 amplitude; per amplitude, from 1000 (closed form given to both; CPU time, best of "
          f"{REPEAT})")
    for label, call in [
        ("control.describing_function(DescribingFunctionNonlinearity)", lambda a: control.describing_function(
            nonlinearity, a)),
        ("backlash-df describing_function (dead-zone closed form)", lambda a: describing_function(law, a, 1.0)),
        ("backlash-df describing_function (phase plane, c w / k = 0.1)", lambda a: describing_function(
            model("phase-plane"), a, 0.1 * K / C)),
    ]:
        call(many)
        single = best_of(lambda: [call(one) for _ in range(1000)], REPEAT)[0] / 1000
        bulk = best_of(lambda: call(many), REPEAT)[0] / many.size
        print(f"     {label:<64s}{single * 1e6:9.1f} us/call{bulk * 1e6:9.3f} us/amplitude")


# ----------------------------------------------------------------------------- exact model


def exact_row():
    law = make_model("exact", stiffness=K, damping=C, half_gap=ALPHA)
    amplitude = ALPHA * np.geomspace(1.01, 100.0, 50)[:, None]
    omega = np.geomspace(1.0, 2e4, 50)[None, :]
    describing_function(law, amplitude[:1], omega[:, :1])  # compile
    seconds, _ = best_of(lambda: describing_function(law, amplitude, omega), REPEAT)
    worst = 0.0
    for ratio, rate in [(1.2, 0.05), (3.0, 0.5), (10.0, 2.0)]:
        a, w = ratio * ALPHA, rate * K / C
        samples = 2**14
        t = np.arange(8 * samples + 1) * (2 * np.pi / w / samples)
        torque, _ = law.torque_along(t, a * np.sin(w * t), a * w * np.cos(w * t))
        spectrum = np.fft.rfft(torque[-samples - 1:-1]) / samples
        n_sim = (-2 * spectrum[1].imag + 2j * spectrum[1].real) / a
        worst = max(worst, abs(complex(describing_function(law, a, w)) - n_sim) / abs(n_sim))
    print(f"3. exact model (1)+(14), 50 x 50 grid, A/alpha in [1.01, 100], w in [1, 2e4] rad/s: {seconds * 1e3:.2f} ms "
          f"= {2500 / seconds:.0f} points/s (best of {REPEAT}); max rel difference to an FFT of a simulated period of "
          f"(14) {worst:.1e} (limited by the simulation's step)")


if __name__ == "__main__":
    amplitude, omega = grid()
    print(f"1. describing functions, {amplitude.size} points: A/alpha in [1.001, 100] x c w/k in [1e-3, 10] "
          f"(log grid), without bias and biased (bias = alpha/2), method='harmonic-balance'; {numba.get_num_threads()} numba "
          f"threads; error: max rel to mpmath (30 digits, own switch location) at {len(MP_POINTS)} points; "
          f"CPU time best of {REPEAT} (wall time where marked)")
    print(f"   {'':34s}{'backlash-df (points/s)':^39s}| {'numpy sampler, matched (or best)':^35s}| "
          f"{'numpy sampler at ' + format(PRACTICAL, '.0e'):^35s}")
    print(f"   {'law':<34s}{'1 thread':>10s}{'(wall)':>10s}{'prange':>10s}{'error':>9s}" +
          f" |{'samples':>8s}{'points/s':>9s}{'error':>9s}{'ratio':>10s}" * 2)
    for bias in BIASES:
        for name in LAWS:
            law_row(name, bias, amplitude, omega)
        floor_row(bias, amplitude, omega)
    print("2. python-control, per-call overhead apart (it cannot take a rate-dependent law)")
    overhead_rows()
    exact_row()
