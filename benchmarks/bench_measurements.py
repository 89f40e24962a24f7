"""Benchmark of loading a long measurement CSV (issue 12: a 2-million-row record).

A record of ``--rows`` rows (time, motor_torque, motor_speed, load_speed; 9
significant digits, as ``write_measurements`` writes) is parsed by

* ``backlash_df``: the loader's parser (numpy's C ``loadtxt`` fast path),
* ``csv module``: the stdlib ``csv.reader`` with ``float()`` per cell, the
  loader's own row-by-row path (what the loader did before) and what a user
  would write by hand,
* ``np.genfromtxt``: numpy's other text reader,

best of ``--repeat`` runs each, in this process.  Accuracy: the largest relative
difference of every parsed value from the generating float64 arrays (the file
holds 9 significant digits, so 5e-9 is the floor for all three).  Then the whole
``load_measurements`` (parse, every check, decimation to ``MAX_SAMPLES`` by
block means) is timed, and the decimated record compared with block means of the
generating arrays.

Run: ``python benchmarks/bench_measurements.py [--rows 2000000] [--repeat 3]``.
"""

import argparse
import csv
import tempfile
import functools
import time
from pathlib import Path

import numpy as np

from backlash_df.identify import load_measurements, measurements_from_arrays, write_measurements
from backlash_df.identify.measurements import read_columns

import timing

best_of = functools.partial(timing.best_of, clock=time.perf_counter)  # wall time: file I/O is part of it

NAMES = ("time", "motor_torque", "motor_speed", "load_speed")


def record(rows):
    """The generating arrays: 1e-5 s steps, a chirp-like torque and two speeds."""
    time_ = np.arange(rows) * 1e-5
    torque = 10.0 * np.sin(2 * np.pi * (1.0 + 2.0 * time_) * time_)
    return {"time": time_, "motor_torque": torque, "motor_speed": 5.0 * np.cos(3.0 * time_) + 0.01 * torque,
            "load_speed": 4.9 * np.cos(3.0 * time_ - 0.01)}


def parse_csv_module(path):
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        header = next(reader)
        columns = [[] for _ in header]
        for row in reader:
            for column, cell in zip(columns, row):
                column.append(float(cell))
    return {name: np.array(column) for name, column in zip(header, columns)}


def parse_genfromtxt(path):
    table = np.genfromtxt(path, delimiter=",", names=True)
    return {name: table[name] for name in NAMES}


def parse_backlash_df(path):
    return read_columns(Path(path))


def relative_error(parsed, exact):
    """Largest relative difference of any parsed value (inf if a column is missing or short)."""
    if any(parsed[name].shape != exact[name].shape for name in NAMES):
        return np.inf
    return max(float(np.max(np.abs(parsed[name] - exact[name]) / np.maximum(np.abs(exact[name]), 1e-300)))
               for name in NAMES)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    exact = record(args.rows)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "long.csv"
        write_measurements(path, measurements_from_arrays(**exact, max_samples=args.rows))
        print(f"{args.rows} rows x {len(NAMES)} columns, {path.stat().st_size / 1e6:.1f} MB, best of {args.repeat}")
        timings = {}
        for name, function in (("backlash_df", parse_backlash_df), ("csv module", parse_csv_module),
                               ("np.genfromtxt", parse_genfromtxt)):
            seconds, parsed = best_of(lambda: function(path), args.repeat)
            timings[name] = seconds
            print(f"  parse  {name:14s} {seconds:7.2f} s   max relative error {relative_error(parsed, exact):.1e}")
        for name in ("csv module", "np.genfromtxt"):
            print(f"  ratio  {name} / backlash_df: {timings[name] / timings['backlash_df']:.1f}x")
        seconds, loaded = best_of(lambda: load_measurements(path), args.repeat)
        factor = args.rows // loaded.n_samples
        means = exact["motor_speed"][: loaded.n_samples * factor].reshape(-1, factor).mean(axis=1)
        print(f"  load_measurements (parse, checks, decimation) {seconds:.2f} s: {loaded.n_samples} samples, "
              f"note: {'; '.join(loaded.notes) or 'none'}")
        print(f"  decimated motor_speed against block means of the exact values: "
              f"max abs error {np.max(np.abs(loaded.motor_speed - means)):.1e} rad/s")


if __name__ == "__main__":
    main()
