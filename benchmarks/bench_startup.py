"""Start-up: import time, first and warm ``predict``, BLAS threads (issues 12, 13, 21).

Each figure is a wall time of a fresh interpreter (a subprocess), best of N, with
Python's bytecode cache on (``PYTHONDONTWRITEBYTECODE`` removed from the children's
environment, as on a user's machine: otherwise every import compiles its source):

1. ``import backlash_df``, against ``import numpy`` (the floor every user pays) and
   with ``python -X importtime``'s own total; target < 1 s.
2. ``backlash-df predict examples/load_feedback.toml`` with a cold numba cache
   (``NUMBA_CACHE_DIR`` pointed at a fresh temporary directory: every kernel compiled,
   as on a fresh install; one run), the same on one core (no second compiling process,
   ``backlash_df/cli/warmup.py``: the sequential compile, for the ratio), and warm (same
   directory again); targets < 6 s and a warm run within 1.5x its floor (issues 21, 49).  Floor rows: a fresh
   interpreter that imports numba and calls one trivial ``cache=True`` function, cold
   (compiled) and warm (loaded from the cache), what any program built on numba pays.
3. OpenBLAS threads, library calls timed inside a subprocess with
   ``OPENBLAS_NUM_THREADS`` 1 against 2: 20 s of the loop's simulation, and
   ``predict_limit_cycles`` + ``verify_limit_cycles`` of the same rig (what ``predict``
   runs).  The command line pins one BLAS thread (threadpoolctl) for this reason.

Run: python benchmarks/bench_startup.py  (about a minute, most of it the cold compiles)
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RIG = "examples/load_feedback.toml"
# the command line of the package beside this file (what the ``backlash-df`` script runs)
CLI = [sys.executable, "-c", "from backlash_df.cli import main; main()"]
TIMED = """
import time
import backlash_df as bd
rig = bd.load_rig({rig!r})
def call():
    {call}
call()
best = float("inf")
for _ in range({repeat}):
    start = time.perf_counter()
    call()
    best = min(best, time.perf_counter() - start)
print(best)
"""
#: What ``backlash-df predict`` imports before it computes: the command line and the stages it runs.
PREDICT_IMPORTS = "import backlash_df.cli, backlash_df.cli.predict, backlash_df.analysis"
#: The floor of a program built on numba: one trivial kernel, cached beside a script of its own.
NUMBA_FLOOR = """
import numba
@numba.njit(cache=True)
def twice(x):
    return 2.0 * x
twice(1.0)
"""
THREAD_CASES = {
    "simulate 20 s of the loop (best of 5)": ("bd.simulate(rig, t_end=20.0, kick=15.0)", 5),
    "predict + verify (best of 3)": ("bd.verify_limit_cycles(rig, bd.predict_limit_cycles(rig))", 3),
}


def wall(command, env=None, repeat=1, cores=None, cwd=ROOT):
    """Best wall time (s) of ``command`` in a subprocess run from ``cwd`` (on ``cores``, a set of CPU
    numbers, where given), and its stdout."""
    best, out = float("inf"), ""
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    pin = (lambda: os.sched_setaffinity(0, cores)) if cores else None
    for _ in range(repeat):
        start = time.perf_counter()
        done = subprocess.run(command, cwd=cwd, env={**environment, **(env or {})}, capture_output=True, text=True,
                              preexec_fn=pin)
        best = min(best, time.perf_counter() - start)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(command)} failed (exit {done.returncode}): {done.stderr.strip()[-300:]}")
        out = done.stdout
    return best, out


def importtime_total():
    """Cumulative import time of backlash_df (s) as ``python -X importtime`` reports it, best of 5."""
    best = float("inf")
    for _ in range(5):
        done = subprocess.run([sys.executable, "-X", "importtime", "-c", "import backlash_df"], cwd=ROOT,
                              capture_output=True, text=True, check=True)
        last = [line for line in done.stderr.splitlines() if line.rstrip().endswith("| backlash_df")][-1]
        best = min(best, int(last.split("|")[1]) * 1e-6)
    return best


def verdict(seconds, target):
    return f"target < {target:g} s: {'met' if seconds < target else 'MISSED'}"


def main():
    python = [sys.executable, "-c"]
    floor, _ = wall(python + ["import numpy"], repeat=5)
    ours, _ = wall(python + ["import backlash_df"], repeat=5)
    stages, _ = wall(python + [PREDICT_IMPORTS], repeat=5)
    print("1. import (fresh interpreter, best of 5; the package's names load on first use)")
    print(f"   python -c 'import numpy'         {floor:6.2f} s")
    print(f"   python -c 'import backlash_df'   {ours:6.2f} s   {verdict(ours, 1.0)}")
    print(f"   -X importtime total of backlash_df {importtime_total():6.2f} s")
    print(f"   what predict imports (cli, analysis) {stages:6.2f} s   {verdict(stages, 1.0)}")
    predict = CLI + ["predict", RIG]
    with tempfile.TemporaryDirectory(prefix="numba-floor-") as floor_dir:
        script = Path(floor_dir) / "floor.py"
        script.write_text(NUMBA_FLOOR)
        floor_cold, _ = wall([sys.executable, str(script)], cwd=floor_dir)
        floor_warm, _ = wall([sys.executable, str(script)], repeat=5, cwd=floor_dir)
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache, \
            tempfile.TemporaryDirectory(prefix="numba-cache-") as one_core_cache:
        env = {"NUMBA_CACHE_DIR": cache}
        cold, _ = wall(predict, env)
        one_core, _ = wall(predict, {"NUMBA_CACHE_DIR": one_core_cache}, cores={min(os.sched_getaffinity(0))})
        warm, _ = wall(predict, env, repeat=3)
        print(f"2. backlash-df predict {RIG}")
        print(f"   first run, cold numba cache (1 run)  {cold:6.1f} s   {verdict(cold, 6.0)}")
        print(f"     the same on one core (1 run)       {one_core:6.1f} s   one core / two {one_core / cold:.2f}x")
        print(f"     floor: one trivial kernel, cold    {floor_cold:6.1f} s")
        ratio = warm / floor_warm
        print(f"   warm (best of 3)                     {warm:6.2f} s   predict / floor {ratio:.2f}x, target < 1.5x: "
              f"{'met' if ratio < 1.5 else 'MISSED'}")
        print(f"     floor: one trivial kernel, warm    {floor_warm:6.2f} s   (best of 5)")
        print("3. OpenBLAS threads (warm cache; 2 cores)")
        print(f"   {'':34s}{'1 thread':>10s}{'2 threads':>11s}{'2 / 1':>8s}")
        for label, (call, repeat) in THREAD_CASES.items():
            code = TIMED.format(rig=RIG, call=call, repeat=repeat)
            one, two = (float(wall(python + [code], {**env, "OPENBLAS_NUM_THREADS": n})[1].split()[-1])
                        for n in ("1", "2"))
            print(f"   {label:34s}{one:9.3f}s{two:10.3f}s{two / one:8.2f}")


if __name__ == "__main__":
    main()
