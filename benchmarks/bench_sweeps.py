"""Design maps on one process, a process pool and a Dask LocalCluster; continuation wall time.

Run: ``python benchmarks/bench_sweeps.py [--size 40] [--sim-size 12] [--repeat 1]``.

1. A ``size x size`` (kp, ti) design map of ``examples/load_feedback.toml`` with the
   phase plane law, DF only: a cell is one :func:`~backlash_df.predict_limit_cycles`
   (harmonic-balance scan on a 30 x 40 grid of (A, w), Newton, Loeb) and its verdict.
   Cells per second serially, on a ``ProcessPoolExecutor(2)`` and on a 2-worker
   ``dask.distributed.LocalCluster`` (one thread each), best of ``--repeat`` runs each,
   in this one run; the executors are started and warmed (every worker has imported
   the package and loaded the compiled kernels) before the clock starts, and the
   start-up is printed apart.  The three maps must be identical.
2. The same with time simulation (``verify_limit_cycles`` per cell) on a smaller
   ``sim-size x sim-size`` map, with the agreement of DF and simulation verdicts (the
   simulation is the independent reference).
3. ``continue_limit_cycles`` over kp in [5, 60] (target < 30 s), its amplitude checked
   against simulation (dt = 2e-5 s) at three gains.
4. What a checkpoint costs (``--checkpoint-size``, DF only, serial, CPU time of this
   process): the map without and with a checkpoint written cell by cell, and the map
   resumed from the complete checkpoint (every cell read back, none computed); the
   three maps must be identical.
"""

import argparse
import json
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from backlash_df import load_rig, simulated_limit_cycle
from backlash_df.checkpoint import Checkpoint
from backlash_df.continuation import continue_limit_cycles
from backlash_df.sweeps import design_map

ROOT = Path(__file__).resolve().parents[1]
RIG = load_rig(ROOT / "examples" / "load_feedback.toml")


def _same(a, b):
    for name in a.models:
        assert np.array_equal(a.df_verdict[name], b.df_verdict[name])
        assert np.array_equal(a.df_amplitude[name], b.df_amplitude[name], equal_nan=True)
        if name in a.sim_verdict:
            assert np.array_equal(a.sim_verdict[name], b.sim_verdict[name])
            assert np.array_equal(a.sim_amplitude[name], b.sim_amplitude[name], equal_nan=True)


def _timed_map(kp, ti, simulate, executor, repeat):
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = design_map(RIG, kp, ti, models=("phase-plane",), simulate=simulate, executor=executor,
                            t_end=5.0, max_t_end=20.0)
        best = min(best, time.perf_counter() - start)
    return best, result


def _executors():
    """(name, factory) of the executors compared; each factory returns (executor, closer)."""
    def pool():
        executor = ProcessPoolExecutor(2)
        return executor, executor.shutdown

    def dask():
        import distributed

        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        client = distributed.Client(cluster)

        def close():
            client.close()
            cluster.close()

        return client.get_executor(), close

    return [("process pool of 2", pool), ("Dask LocalCluster, 2 workers", dask)]


def compare(kp, ti, simulate, repeat):
    cells = kp.size * ti.size
    kind = "with simulation" if simulate else "DF only"
    print(f"design map {kp.size} x {ti.size} ({cells} cells, {kind}), best of {repeat}:")
    design_map(RIG, kp[:2], ti[:2], models=("phase-plane",), simulate=simulate)  # compile in this process
    serial, reference = _timed_map(kp, ti, simulate, None, repeat)
    print(f"  {'serial (one process)':30s} {cells / serial:8.2f} cells/s  ({serial:7.1f} s)")
    for name, factory in _executors():
        start = time.perf_counter()
        executor, close = factory()
        design_map(RIG, kp[:4], ti[:2], models=("phase-plane",), simulate=simulate, executor=executor)  # warm
        startup = time.perf_counter() - start
        try:
            wall, result = _timed_map(kp, ti, simulate, executor, repeat)
        finally:
            close()
        _same(reference, result)
        print(f"  {name:30s} {cells / wall:8.2f} cells/s  ({wall:7.1f} s, start-up and warm-up {startup:.1f} s)"
              f"  ratio to serial {serial / wall:.2f}; map identical")
    if simulate:
        print(f"  DF and simulation agree on {reference.agreement('phase-plane'):.1%} of the cells")


def continuation():
    start = time.perf_counter()
    branch = continue_limit_cycles(RIG, "kp", (5.0, 60.0), "phase-plane", df_values=12)
    wall = time.perf_counter() - start
    print(f"continuation over kp in [5, 60]: {wall:.1f} s wall (target < 30 s), {len(branch.points)} orbits")
    print(f"  {branch!r}")
    for kp in (10.0, 30.0, 45.0):
        orbit = branch.orbit_at(kp)
        measured, _ = simulated_limit_cycle(RIG.with_values(kp=kp), "phase-plane", t_end=20.0, max_t_end=80.0,
                                            dt=2e-5, kick=orbit.amplitude * orbit.omega)
        print(f"  kp = {kp:4.0f}: A orbit {orbit.amplitude:.7g} rad, simulation {measured.amplitude:.7g} rad, "
              f"relative difference {orbit.amplitude / measured.amplitude - 1:+.1e}")


def checkpoint_cost(size):
    kp, ti = np.linspace(5.0, 60.0, size), np.geomspace(0.1, 2.0, size)
    cells = size * size
    path = os.path.join(tempfile.mkdtemp(), "map.checkpoint")

    def timed(checkpoint):
        start = time.process_time()
        dmap = design_map(RIG, kp, ti, models=("phase-plane",), simulate=False, checkpoint=checkpoint)
        return time.process_time() - start, json.dumps(dmap.to_dict())

    bare, reference = timed(None)
    written, with_checkpoint = timed(path)
    resumed, from_checkpoint = timed(Checkpoint(path, resume=True))
    assert reference == with_checkpoint == from_checkpoint
    print(f"checkpoint of a {size} x {size} map (DF only, serial), CPU time of this process:")
    print(f"  {'no checkpoint':30s} {1e3 * bare / cells:8.2f} ms/cell")
    print(f"  {'checkpoint written':30s} {1e3 * written / cells:8.2f} ms/cell  ratio {written / bare:.3f}"
          f"  ({os.path.getsize(path) / cells:.0f} bytes/cell)")
    print(f"  {'resumed, all cells kept':30s} {1e3 * resumed / cells:8.2f} ms/cell  ratio {resumed / bare:.4f}"
          "; maps identical")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=40)
    parser.add_argument("--sim-size", type=int, default=12)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--checkpoint-size", type=int, default=12)
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs")
    compare(np.linspace(5.0, 60.0, args.size), np.geomspace(0.1, 2.0, args.size), False, args.repeat)
    compare(np.linspace(5.0, 60.0, args.sim_size), np.geomspace(0.1, 2.0, args.sim_size), True, args.repeat)
    continuation()
    checkpoint_cost(args.checkpoint_size)


if __name__ == "__main__":
    main()
