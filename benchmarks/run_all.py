"""Run every benchmark, print the machine, the commit and the load, and check that the ratios are stable.

    python benchmarks/run_all.py                   # every benchmark once: about 20 minutes on 2 idle cores
    python benchmarks/run_all.py --runs 3          # three times, then the spread of every ratio
    python benchmarks/run_all.py bench_simulation  # a selection (names without .py)
    python benchmarks/run_all.py --runs 3 --saved  # the spread of the outputs kept by earlier runs

Every benchmark runs in its own interpreter from the repository root, one after the
other, with one BLAS thread; its output is printed as it comes and kept in
``build/benchmarks/<name>.run<i>.txt``.  The workflow benchmarks run with options that
keep the whole under about 20 minutes on 2 idle cores (:data:`OPTIONS`: smaller design maps,
fewer diagnosis seeds and verdict rigs than when each runs alone; run a file
directly for its full size): 18.5 minutes end to end at f26d3e4 (AMD EPYC, 2 cores, load
1.0), 11 of them ``bench_simulation``'s work-precision curves.  The wall time grows with
the machine's load: ``bench_simulation`` alone took 25-51 minutes at a load of 6-14.  The
speed benchmarks time CPU time of the process (``time.process_time``), best of N: on a
shared machine wall time swings with the other processes' load, CPU time much less.

Printed first: the commit (``git rev-parse --short HEAD``), the CPU model, Python and
the numeric libraries; after each benchmark the load average (``os.getloadavg()``, 1,
5 and 15 minutes) and its wall time.  With ``--runs N > 1`` every printed ratio (a
number followed by ``x``) is collected per line, and its values over the runs and their
spread (largest / smallest) are printed to two significant digits; a spread above 1.5
is flagged.
"""

import argparse
import os
import platform
import re
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Every benchmark, in the order run, with the options of a whole run (about 20 min on 2 idle cores).
OPTIONS = {
    "bench_describing": [],
    "bench_models": [],
    "bench_simulation": [],
    "bench_limit_cycles": [],  # its speed table and the two design maps
    "bench_predict": [],  # the harmonic balance before and after batching (issue 21)
    "bench_orbits": [],
    "bench_startup": [],
    "bench_sweeps": ["--size", "16", "--sim-size", "6", "--repeat", "1"],
    "bench_verdicts": ["40"],
    "bench_diagnose": ["--seeds", "2", "--repeat", "1"],
    "bench_measurements": ["--rows", "500000"],
    "bench_friction": [],
}
RATIO = re.compile(r"(\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?)x\b")
NUMBER = re.compile(r"[-+]?\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?")
LIMIT = 1.5


def machine():
    """The commit, nproc, CPU model, Python and the numeric libraries' versions."""
    cpu = platform.processor() or "unknown"
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        names = [line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                 if line.startswith("model name")]
        cpu = names[0] if names else cpu
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    versions = ", ".join(f"{name} {metadata.version(name)}" for name in ("numpy", "scipy", "numba", "control"))
    return (f"commit {commit.stdout.strip() or 'unknown'}; {os.cpu_count()} cores ({cpu}), "
            f"Python {platform.python_version()}, {versions}")


def load():
    return "load average " + " / ".join(f"{value:.2f}" for value in os.getloadavg()) + " (1 / 5 / 15 min)"


def run(name, index):
    """Run one benchmark, echo and keep its output."""
    out_dir = ROOT / "build" / "benchmarks"
    out_dir.mkdir(parents=True, exist_ok=True)
    print(f"\n=== {name} (run {index}) {' '.join(OPTIONS.get(name, []))} ===", flush=True)
    print(load(), flush=True)
    lines = []
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}  # CPU times of one thread (bench_startup sets its own)
    start = time.perf_counter()
    with subprocess.Popen([sys.executable, "-u", str(ROOT / "benchmarks" / f"{name}.py"), *OPTIONS.get(name, [])],
                          cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as process:
        for line in process.stdout:
            print(line, end="", flush=True)
            lines.append(line)
    (out_dir / f"{name}.run{index}.txt").write_text("".join(lines))
    if process.returncode:
        raise SystemExit(f"{name} failed (exit {process.returncode})")
    print(f"--- {name}: {time.perf_counter() - start:.0f} s wall; {load()}", flush=True)
    return lines


def ratios(lines):
    """{line with its numbers blanked: [ratios in it]} for every line that prints a ratio."""
    found = {}
    for line in lines:
        values = [float(v.replace(",", "")) for v in RATIO.findall(line)]
        if values:
            label = re.sub(r"(\s+\([^)]*\))+\s*$", "", line.strip())  # notes may change between runs
            key = " ".join(NUMBER.sub("#", label).split())  # columns pad to the numbers' widths
            repeated = sum(1 for known in found if known == key or known.startswith(key + " ["))
            found[f"{key} [{repeated + 1}]" if repeated else key] = values  # lines alike but for numbers
    return found


def spread(name, runs):
    """Print every ratio's values over the runs and max/min, to two significant digits; True if all within LIMIT."""
    stable = True
    print(f"\n=== {name}: ratio spread over {len(runs)} runs (flagged above {LIMIT}) ===")
    for key in runs[0]:
        series = [found.get(key) for found in runs]
        if any(values is None or len(values) != len(series[0]) for values in series):
            print(f"  {key if len(key) <= 90 else key[:62] + ' ... ' + key[-23:]:90s} not printed in every run")
            continue
        count = len(series[0])
        for position in range(count):
            values = [values[position] for values in series]
            ratio = max(values) / min(values) if min(values) > 0 else float("inf")
            stable &= ratio <= LIMIT
            flag = "" if ratio <= LIMIT else "   <-- unstable"
            which = f" (ratio {position + 1} of {count})" if count > 1 else ""  # a line printing several
            shown = (key if len(key) + len(which) <= 90 else f"{key[:62 - len(which)]} ... {key[-23:]}") + which
            print(f"  {shown:90s} {' / '.join(f'{v:.2g}' for v in values):>24s}   spread {ratio:.2g}{flag}")
    return stable


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=list(OPTIONS), help="benchmarks to run (default: all)")
    parser.add_argument("--runs", type=int, default=1, help="how many times to run each (default 1)")
    parser.add_argument("--saved", action="store_true",
                        help="run nothing: the spread of the outputs kept in build/benchmarks/ by earlier runs")
    args = parser.parse_args()
    print(f"machine: {machine()}")
    print(load())
    found = {name: [] for name in args.names}
    start = time.perf_counter()
    for index in range(1, args.runs + 1):
        for name in args.names:
            saved = ROOT / "build" / "benchmarks" / f"{name}.run{index}.txt"
            lines = saved.read_text().splitlines(True) if args.saved else run(name, index)
            found[name].append(ratios(lines))
    if not args.saved:
        print(f"\n=== {len(args.names)} benchmark(s) x {args.runs} run(s): {time.perf_counter() - start:.0f} s wall; "
              f"{load()}")
    if args.runs > 1:
        stable = all([spread(name, runs) for name, runs in found.items()])
        print(f"\nevery ratio within {LIMIT}x over the runs: {'yes' if stable else 'NO'}")


if __name__ == "__main__":
    main()
