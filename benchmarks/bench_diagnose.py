"""Benchmark of ``diagnose``: accuracy over a seeded sweep, and the wall time of one diagnosis.

1. Sweep: for each catalogue entry (``none`` included) ``--seeds`` records from
   the synthetic rig (exact model (14) or rubber law (40), PI speed loop,
   finer step, noise, data-sheet errors, one hidden effect of random size),
   2 s at 1 kHz, diagnosed with all candidates.  Prints the confusion matrix,
   the accuracy (target >= 95 %) and the false effects named on ``none`` cases
   (target 0), and how often the extended model's validation fit beats the
   baseline's when an effect is hidden.
2. Timing: one diagnosis of a 4 s record at 2 kHz, all candidates (target < 60 s),
   against the named alternative "the same diagnosis on one thread" measured in
   the same run (the Jacobian columns run in threads; the kernel releases the GIL).

Run: ``python benchmarks/bench_diagnose.py [--seeds 10] [--processes 2]``.
"""

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from backlash_df import load_rig
from backlash_df.identify import EFFECT_NAMES, diagnose, synthesize

RIG = Path(__file__).resolve().parents[1] / "examples" / "diagnose_rig.toml"


def one_case(args):
    cause, seed = args
    rig = load_rig(RIG)
    record = synthesize(rig, cause, seed=seed, duration=2.0, sample_rate=1000.0)
    start = time.perf_counter()
    result = diagnose(record.measurements, rig)
    return cause, seed, record.size, result.cause, result.baseline.mean_fit_percent, \
        result.extended.mean_fit_percent, time.perf_counter() - start


def sweep(seeds, processes):
    cases = [(cause, 1000 + seed) for cause in EFFECT_NAMES for seed in range(seeds)]
    with ProcessPoolExecutor(processes) as pool:
        results = list(pool.map(one_case, cases))
    for cause, seed, size, found, base, extended, seconds in results:
        mark = "ok " if found == cause else "BAD"
        print(f"  {mark} {cause:17s} seed {seed} size {size:9.4g} -> {found:17s} "
              f"fit {base:6.1f} % -> {extended:6.1f} %  ({seconds:.1f} s)")
    names = list(EFFECT_NAMES)
    matrix = np.zeros((len(names), len(names)), dtype=int)
    for cause, _, _, found, *_ in results:
        matrix[names.index(cause), names.index(found)] += 1
    width = max(len(name) for name in names) + 2
    print("\nConfusion matrix (rows: hidden effect, columns: diagnosed cause)")
    print(" " * width + "".join(f"{name[:12]:>13s}" for name in names))
    for i, name in enumerate(names):
        print(f"{name:<{width}s}" + "".join(f"{value:13d}" for value in matrix[i]))
    correct = int(np.trace(matrix))
    false_on_none = int(matrix[0].sum() - matrix[0, 0])
    improved = sum(1 for cause, _, _, found, base, ext, _ in results if cause != "none" and found == cause and ext > base)
    hidden = sum(1 for cause, *_ in results if cause != "none")
    print(f"\naccuracy: {correct}/{len(results)} = {100.0 * correct / len(results):.1f} % (target >= 95 %)")
    print(f"false effects named on 'none' cases: {false_on_none} of {matrix[0].sum()} (target 0)")
    print(f"hidden effect found with extended validation fit > baseline's: {improved}/{hidden}")
    mean_time = np.mean([r[-1] for r in results])
    print(f"mean diagnose time, 2 s at 1 kHz, all candidates: {mean_time:.1f} s")


def timing():
    rig = load_rig(RIG)
    record = synthesize(rig, "coulomb_friction", seed=7, duration=4.0, sample_rate=2000.0)
    times = {}
    for workers in (2, 1):
        start = time.perf_counter()
        result = diagnose(record.measurements, rig, workers=workers)
        times[workers] = time.perf_counter() - start
        print(f"  workers={workers}: {times[workers]:.1f} s, cause {result.cause}, validation fit "
              f"{result.baseline.mean_fit_percent:.1f} % -> {result.extended.mean_fit_percent:.1f} %")
    print(f"one diagnose, 4 s record at 2 kHz ({record.measurements.n_samples} samples), all "
          f"{len(EFFECT_NAMES)} candidates: {times[2]:.1f} s with 2 threads (target < 60 s); "
          f"one thread {times[1]:.1f} s, ratio {times[1] / times[2]:.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="records per catalogue entry (default 10: 50 cases)")
    parser.add_argument("--processes", type=int, default=2)
    args = parser.parse_args()
    print("== timing ==")
    timing()
    print(f"\n== sweep: {args.seeds} seeds x {len(EFFECT_NAMES)} causes ==")
    sweep(args.seeds, args.processes)


if __name__ == "__main__":
    main()
