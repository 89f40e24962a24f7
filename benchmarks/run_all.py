"""Run the benchmarks, print the machine they ran on, and check that their ratios are stable.

    python benchmarks/run_all.py                 # the speed benchmarks, once
    python benchmarks/run_all.py --runs 3        # three times, then the spread of every ratio
    python benchmarks/run_all.py bench_startup   # a selection (names without .py)

Each benchmark runs in its own interpreter from the repository root, with one BLAS
thread; its output is printed as it comes and kept in ``build/benchmarks/<name>.run<i>.txt``.
The speed benchmarks time CPU time of the process (``time.process_time``), best of N:
on a shared machine wall time swings with the other processes' load, CPU time much less.  With
``--runs N > 1`` every printed ratio (a number followed by ``x``) is collected per
line and reported with its smallest and largest value over the runs; a spread above
1.5 is flagged.
"""

import argparse
import os
import platform
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEED = ("bench_describing", "bench_models", "bench_limit_cycles", "bench_startup")
SPEED_ONLY = {"bench_limit_cycles": ["--speed-only"]}  # its design maps: run the file itself
RATIO = re.compile(r"(\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?)x\b")
NUMBER = re.compile(r"[-+]?\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?")
LIMIT = 1.5


def machine():
    """nproc, CPU model, Python and the numeric libraries' versions."""
    cpu = platform.processor() or "unknown"
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        names = [line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                 if line.startswith("model name")]
        cpu = names[0] if names else cpu
    versions = ", ".join(f"{name} {metadata.version(name)}" for name in ("numpy", "scipy", "numba", "control"))
    return f"{os.cpu_count()} cores ({cpu}), Python {platform.python_version()}, {versions}"


def run(name, index):
    """Run one benchmark, echo and keep its output."""
    out_dir = ROOT / "build" / "benchmarks"
    out_dir.mkdir(parents=True, exist_ok=True)
    print(f"\n=== {name} (run {index}) ===", flush=True)
    lines = []
    options = SPEED_ONLY.get(name, [])
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}  # CPU times of one thread (bench_startup sets its own)
    with subprocess.Popen([sys.executable, "-u", str(ROOT / "benchmarks" / f"{name}.py"), *options], cwd=ROOT, env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as process:
        for line in process.stdout:
            print(line, end="", flush=True)
            lines.append(line)
    (out_dir / f"{name}.run{index}.txt").write_text("".join(lines))
    if process.returncode:
        raise SystemExit(f"{name} failed (exit {process.returncode})")
    return lines


def ratios(lines):
    """{line with its numbers blanked: [ratios in it]} for every line that prints a ratio."""
    found = {}
    for line in lines:
        values = [float(v.replace(",", "")) for v in RATIO.findall(line)]
        if values:
            label = re.sub(r"(\s+\([^)]*\))+\s*$", "", line.strip())  # notes may change between runs
            found[" ".join(NUMBER.sub("#", label).split())] = values  # columns pad to the numbers' widths
    return found


def spread(runs):
    """Print min, max and max/min of every ratio over the runs; True if all are within LIMIT."""
    stable = True
    print(f"\n=== ratio spread over {len(runs)} runs (flagged above {LIMIT}) ===")
    for key in runs[0]:
        series = [found.get(key) for found in runs]
        if any(values is None or len(values) != len(series[0]) for values in series):
            continue
        for position in range(len(series[0])):
            values = [values[position] for values in series]
            ratio = max(values) / min(values) if min(values) > 0 else float("inf")
            stable &= ratio <= LIMIT
            flag = "" if ratio <= LIMIT else "   <-- unstable"
            print(f"  {key[:70]:70s} {' / '.join(f'{v:.3g}' for v in values):>30s}   spread {ratio:.2f}{flag}")
    return stable


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=SPEED, help="benchmarks to run (default: the speed ones)")
    parser.add_argument("--runs", type=int, default=1, help="how many times to run each (default 1)")
    args = parser.parse_args()
    print(f"machine: {machine()}")
    found = {name: [] for name in args.names}
    for index in range(1, args.runs + 1):
        for name in args.names:
            found[name].append(ratios(run(name, index)))
    if args.runs > 1:
        stable = all([spread(runs) for runs in found.values()])
        print(f"\nevery ratio within {LIMIT}x over the runs: {'yes' if stable else 'NO'}")


if __name__ == "__main__":
    main()
