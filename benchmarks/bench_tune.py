"""Benchmark of ``tune``: its time on 2 cores, where the time goes, its parallel speed-up, its answer.

1. Time of one two-parameter tune (``--vary kp 1,1000 --vary ti 0.01,2`` on
   ``examples/motor_feedback.toml``; target: under 60 s on 2 cores) and the share
   spent in screening, boundary refinement and certification.
2. Speed-up of the same tune on a 2-worker process pool and on a Dask
   ``LocalCluster`` of 2 single-threaded workers against serial, same results.
3. The bandwidth found against the best of a brute-force grid search on the rigs of
   ``tests/test_tuning.py`` (and the two-parameter tune of 1.): every grid point's
   bandwidth by python-control's frequency response of the loop assembled from blocks,
   certified in order of decreasing bandwidth by long simulations from the standard
   disturbance set (the first that settles from all of them), both the test's own
   references (``blocks_bandwidth``, ``settles``).
4. The robust tune: two gains (``kp 20,400``, ``ti 0.05,2``, gain margin 1) on
   ``examples/motor_lag_feedback.toml`` over a box of three uncertain values (load
   inertia +-10 %, stiffness +-10 %, damping +-30 %: 9 rigs) on a 2-worker process pool
   (target: under 120 s), the share of each stage; and the bandwidth given up for
   robustness (robust against nominal, ``kp`` alone, gain margin 1) on four rigs: the
   example and two of this file's (a stiffer, more damped shaft; a heavier load behind a
   slower integral action), and ``examples/load_feedback.toml`` with Coulomb friction of
   200 N m and viscous friction of 2 N m s/rad on the load, its Coulomb friction +-30 % in
   the box in place of the damping (the friction rig of ``tests/test_tuning_uncertainty.py``).

5. The same robust tune at the default gain margin 1.25 (no target: the answer and each
   of its 8 scaled tunings certified at the 9 rigs), its stages and certificates.

Run: ``python benchmarks/bench_tune.py [--only time|speedup|grid|robust|margin] [--grid 12]``.
"""

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import backlash_df as bd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from test_tuning import CASES, blocks_bandwidth, settles  # noqa: E402  (the tests' independent references)
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
    print(f"  gain margin {tuning.gain_margin}; plateau {tuning.plateau}; on a bound {tuning.on_bound}")
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


def brute_force(rig, vary, count):
    """The best bandwidth of a log grid (``count`` values per parameter of two, ``count**2`` of one), certified
    by long simulations in order of decreasing bandwidth."""
    names = list(vary)
    count = count if len(names) == 2 else count * count  # the same number of cells for one parameter
    axes = [np.geomspace(*vary[name], count) for name in names]
    points = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(names), -1).T
    rated = []
    for values in points:
        tuned = rig.with_values(**{name: float(value) for name, value in zip(names, values)})
        rated.append((blocks_bandwidth(tuned), tuned, values))
    for bandwidth, tuned, values in sorted((r for r in rated if math.isfinite(r[0])), key=lambda r: -r[0]):
        if settles(tuned):
            return bandwidth, dict(zip(names, values))
    return math.nan, {}


def section_grid(count):
    print(f"\n== the bandwidth found against a brute-force grid ({count} values per parameter) ==")
    cases = {"motor_feedback: kp, ti": (bd.load_rig(ROOT / "examples" / "motor_feedback.toml"), VARY),
             **{f"{name}: {', '.join(vary)}": (rig, vary) for name, (rig, vary) in CASES.items()}}
    for label, (rig, vary) in cases.items():
        start = time.perf_counter()
        tuning = bd.tune(rig, vary, gain_margin=1)  # the grid's best has no margin either
        seconds = time.perf_counter() - start
        grid, at = brute_force(rig, vary, count)
        found = tuning.best.bandwidth if tuning.feasible else math.nan
        print(f"  {label:42s} tune {found:8.4g} rad/s ({seconds:.0f} s) at {tuning.values()}; grid best {grid:8.4g} "
              f"rad/s at {at}; ratio {found / grid:.4f}")


#: Three uncertain values, each around the rig's own: load inertia and stiffness +-10 %, damping +-30 %.
SPREAD = {"load_inertia": 0.1, "stiffness": 0.1, "damping": 0.3}
#: On the rig with dry friction, its Coulomb friction +-30 % in place of the damping.
FRICTION_SPREAD = {"load_inertia": 0.1, "stiffness": 0.1, "coulomb_load": 0.3}


def box(rig, spread=SPREAD):
    """The box ``spread`` around ``rig``'s values (of its ``[plant]`` or ``[friction]``)."""
    values = {name: getattr(rig.plant if hasattr(rig.plant, name) else rig.friction, name) for name in spread}
    return {name: (values[name] * (1 - share), values[name] * (1 + share)) for name, share in spread.items()}


def robust_tune(margin, target):
    """The robust tune of :func:`section_robust` at gain margin ``margin``: its answer, wall time, stages."""
    lag = bd.load_rig(ROOT / "examples" / "motor_lag_feedback.toml")
    vary = {"kp": (20.0, 400.0), "ti": (0.05, 2.0)}
    print("\n== the robust tune: examples/motor_lag_feedback.toml, --vary kp 20,400 --vary ti 0.05,2, "
          f"3 uncertain values (9 rigs), gain margin {margin:g}, 2-worker process pool ==")
    with ProcessPoolExecutor(2) as pool:
        start = time.perf_counter()
        tuning = bd.tune(lag, vary, gain_margin=margin, uncertainty=box(lag), executor=pool)
        wall = time.perf_counter() - start
    print(f"  {tuning!r}")
    for line in tuning.sentences()[2:]:
        print(f"  {line}")
    print(f"  wall {wall:.1f} s ({target}); {len(tuning.certificates)} tunings certified over the box")
    total = sum(tuning.seconds.values())
    for stage, seconds in tuning.seconds.items():
        print(f"  {stage:14s} {seconds:7.1f} s  {100 * seconds / total:5.1f} %")
    return lag


def section_margin():
    """The robust tune at the default gain margin 1.25: each scaled tuning certified over the box too."""
    robust_tune(1.25, "no target: the margin's 8 scaled tunings, each certified at the box's 9 rigs")


def section_robust():
    lag = robust_tune(1.0, "target < 120 s on 2 cores")
    print("\n== the bandwidth given up for robustness: kp alone, gain margin 1, robust against nominal ==")
    rubbing = bd.load_rig(ROOT / "examples" / "load_feedback.toml").with_values(coulomb_load=200.0, viscous_load=2.0)
    lag_kp = {"kp": (20.0, 400.0)}
    rigs = {"motor_lag_feedback (examples)": (lag, lag_kp, SPREAD),
            "stiff, damped (k 8000, c 20)": (lag.with_values(stiffness=8000.0, damping=20.0), lag_kp, SPREAD),
            "heavy load, slow ti (J_l 8, ti 0.5)": (lag.with_values(load_inertia=8.0, ti=0.5), lag_kp, SPREAD),
            "load_feedback, F_c 200 on the load": (rubbing, {"kp": (2.0, 100.0)}, FRICTION_SPREAD)}
    for label, (rig, vary, spread) in rigs.items():
        start = time.perf_counter()
        nominal = bd.tune(rig, vary, gain_margin=1)
        middle = time.perf_counter()
        robust = bd.tune(rig, vary, gain_margin=1, uncertainty=box(rig, spread))
        end = time.perf_counter()
        given = 1.0 - robust.best.bandwidth / nominal.best.bandwidth
        print(f"  {label:36s} nominal kp {nominal.best.values[0]:7.4g}, {nominal.best.bandwidth:6.4g} rad/s "
              f"({middle - start:.0f} s); robust kp {robust.best.values[0]:7.4g}, {robust.best.bandwidth:6.4g} "
              f"rad/s ({end - middle:.0f} s), worst over the box {robust.uncertainty['worst_bandwidth']:6.4g} rad/s; "
              f"given up {100 * given:.1f} %; binding {robust.uncertainty['binding']}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=["time", "speedup", "grid", "robust", "margin"])
    parser.add_argument("--grid", type=int, default=12, help="brute-force grid values per parameter")
    args = parser.parse_args(argv)
    if args.only in (None, "time", "speedup"):
        serial, wall = section_time()
        if args.only in (None, "speedup"):
            section_speedup(serial, wall)
    if args.only in (None, "grid"):
        section_grid(args.grid)
    if args.only in (None, "robust"):
        section_robust()
    if args.only in (None, "margin"):
        section_margin()


if __name__ == "__main__":
    main()
