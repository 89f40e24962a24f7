"""Benchmark of ``tune``: its time on 2 cores, where the time goes, its parallel speed-up, its answer.

1. Time of one two-parameter tune (``--vary kp 1,1000 --vary ti 0.01,2`` on
   ``examples/motor_feedback.toml``; target: under 60 s on 2 cores) and the share
   spent in screening, boundary refinement and certification.
2. Speed-up of the same tune on a 2-worker process pool and on a Dask
   ``LocalCluster`` of 2 single-threaded workers against serial, same results.
3. The bandwidth found against the best of a brute-force grid search on the same
   rigs: every grid point's bandwidth by python-control's frequency response of the
   contact loop, certified in order of decreasing bandwidth by long simulations from
   the standard disturbance set (the first that settles from all of them).

Run: ``python benchmarks/bench_tune.py [--only time|speedup|grid] [--grid 12]``.
"""

import argparse
import dataclasses
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import control as ct
import numpy as np

import backlash_df as bd
from backlash_df.disturbances import standard_disturbances
from backlash_df.simulation import simulated_limit_cycle
from backlash_df.sweeps import rig_with

ROOT = Path(__file__).resolve().parents[1]
VARY = {"kp": (1.0, 1000.0), "ti": (0.01, 2.0)}


def timed_tune(rig, vary, executor=None):
    start, cpu = time.perf_counter(), time.process_time()
    tuning = bd.tune(rig, vary, executor=executor)
    return tuning, time.perf_counter() - start, time.process_time() - cpu


def section_time():
    rig = bd.load_rig(ROOT / "examples" / "motor_feedback.toml")
    tuning, wall, cpu = timed_tune(rig, VARY)
    print("== one two-parameter tune: examples/motor_feedback.toml, --vary kp 1,1000 --vary ti 0.01,2 ==")
    print(f"  {tuning!r}")
    print(f"  wall {wall:.1f} s, cpu {cpu:.1f} s (target < 60 s on 2 cores)")
    total = sum(tuning.seconds.values())
    for stage, seconds in tuning.seconds.items():
        print(f"  {stage:14s} {seconds:7.1f} s  {100 * seconds / total:5.1f} %")
    return tuning, wall


def section_speedup(serial, serial_wall):
    rig = bd.load_rig(ROOT / "examples" / "motor_feedback.toml")
    print("\n== speed-up against serial (same tune) ==")
    with ProcessPoolExecutor(2) as pool:
        pooled, wall, _ = timed_tune(rig, VARY, pool)
    print(f"  process pool, 2 workers: wall {wall:.1f} s, {serial_wall / wall:.2f}x serial; "
          f"same answer: {pooled.to_dict()['best'] == serial.to_dict()['best']}")
    import distributed

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dasked, wall, _ = timed_tune(rig, VARY, client.get_executor())
    print(f"  Dask LocalCluster, 2 workers: wall {wall:.1f} s, {serial_wall / wall:.2f}x serial; "
          f"same answer: {dasked.to_dict()['best'] == serial.to_dict()['best']}")


def independent_bandwidth(rig, model):
    """omega_b from python-control: the contact loop as a transfer matrix, reference to load speed."""
    law = rig.make_model(model)
    part = bd.drive_loop(rig).linear_part()
    closed = part.A + np.outer(part.b, law.stiffness * part.c_x + law.damping * part.c_v)
    out = np.zeros((1, part.n_states))
    out[0, part.state_names.index("load_angle" if rig.controller.cascade else "load_speed")] = 1.0
    system = ct.ss(closed, part.E[:, :1], out, 0.0)
    if np.max(system.poles().real) >= 0.0:
        return math.nan
    omega = np.geomspace(1e-3, 1e4, 20000)
    gain = np.abs(system(1j * omega)).ravel()
    below = np.flatnonzero(gain <= 1.0 / math.sqrt(2.0))
    return float(omega[below[0]]) if below.size else math.inf


def settles(rig, model):
    """Long simulations from the standard set: every one comes to rest (no cycle, no divergence)."""
    for disturbance in standard_disturbances(rig):
        measured, _ = simulated_limit_cycle(rig, model, initial=disturbance.initial(), t_end=40.0, max_t_end=160.0)
        if measured.found or measured.verdict in ("diverged", "growing"):
            return False
    return True


def brute_force(rig, vary, count, model=None):
    """The best bandwidth of a log grid, certified by long simulations in order of decreasing bandwidth."""
    names = list(vary)
    axes = [np.geomspace(*vary[name], count) for name in names]
    points = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(names), -1).T
    rated = []
    for values in points:
        tuned = rig
        for name, value in zip(names, values):
            tuned = rig_with(tuned, name, float(value))
        rated.append((independent_bandwidth(tuned, model), tuned, values))
    for bandwidth, tuned, values in sorted((r for r in rated if math.isfinite(r[0])), key=lambda r: -r[0]):
        if settles(tuned, model):
            return bandwidth, dict(zip(names, values))
    return math.nan, {}


def section_grid(count):
    print(f"\n== the bandwidth found against a brute-force grid ({count} values per parameter) ==")
    lag = bd.load_rig(ROOT / "examples" / "motor_lag_feedback.toml")
    cases = {
        "motor_feedback: kp, ti": (bd.load_rig(ROOT / "examples" / "motor_feedback.toml"), VARY),
        "motor_lag_feedback: kp": (lag, {"kp": (20.0, 400.0)}),
        "cascade (motor speed, load position): kv": (
            dataclasses.replace(lag, controller=dataclasses.replace(lag.controller, structure="cascade", kv=5.0)),
            {"kv": (1.0, 100.0)}),
    }
    for label, (rig, vary) in cases.items():
        start = time.perf_counter()
        tuning = bd.tune(rig, vary)
        seconds = time.perf_counter() - start
        grid, at = brute_force(rig, vary, count)
        found = tuning.best.bandwidth if tuning.feasible else math.nan
        print(f"  {label:42s} tune {found:8.4g} rad/s ({seconds:.0f} s) at {tuning.values()}; grid best {grid:8.4g} "
              f"rad/s at {at}; ratio {found / grid:.4f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=["time", "speedup", "grid"])
    parser.add_argument("--grid", type=int, default=12, help="brute-force grid values per parameter")
    args = parser.parse_args(argv)
    if args.only in (None, "time", "speedup"):
        serial, wall = section_time()
        if args.only in (None, "speedup"):
            section_speedup(serial, wall)
    if args.only in (None, "grid"):
        section_grid(args.grid)


if __name__ == "__main__":
    main()
