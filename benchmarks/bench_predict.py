"""The harmonic balance before and after batching (issue 21): `predict_limit_cycles` and a DF-only map cell.

Run: ``python benchmarks/bench_predict.py [--repeat 3] [--rounds 3] [--baseline a47e5f6]``.

Rows (DF only, no simulation, warm: the compiled kernels loaded before the clock starts):

- ``predict <rig>``: ``predict_limit_cycles(rig)`` on three bundled rigs (default grid
  60 x 80): ``load_feedback`` and ``motor_lag_feedback`` (no load) and ``loaded_feedback``
  (a load torque: the DC balance ``BiasedDescribing``, batched like the others since each
  point's bias is solved on its own, 2026-12-05; one call per request before);
- ``map cell``: one DF-only cell of ``design_map(load_feedback, [30], [0.5],
  simulate=False)`` (the laws phase-plane and damped-dead-zone, grid 30 x 40).

"old" is the package of the ``--baseline`` commit (before the batching), extracted by
``git archive`` into ``build/bench_predict/<commit>/`` and run in a subprocess with
``PYTHONPATH`` set to it; "new" is this checkout, in a subprocess alike; the two sides run
alternately ``--rounds`` times in this run (on this shared machine the CPU time of the
same code moved by 1.5x between spells of load).  Times are CPU time of the process
(``time.process_time``, all threads), best of ``--repeat`` runs in each of the rounds.
"accuracy" is the largest relative difference between
old and new of every cycle's amplitude, omega and Loeb value and every near miss's
amplitude, omega and distance (the map cell: its amplitudes and verdicts).

The "floor" column of each case: the describing function and G(jw) evaluated once, in
one call each, at every point the new balance asks for (counted by wrapping the
describing function in :func:`~backlash_df.limit_cycles.solve_harmonic_balance`, which
``predict_limit_cycles`` calls with the same arguments); what is left above it is the
solver's own Python (Newton, scipy's least squares, the rounds).

"top 3" is the share of the CPU time (``time.thread_time`` profiles of every thread,
merged) of the three functions with the most own time, new side (then the old side's),
and the last line the share spent inside scipy's ``least_squares`` (its own Python and
the evaluations it asks for).
"""

import argparse
import cProfile
import functools
import io
import json
import os
import pathlib
import pstats
import subprocess
import sys
import tarfile
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
RIGS = ("load_feedback", "motor_lag_feedback", "loaded_feedback")
MAP_CELL = ("load_feedback", 30.0, 0.5)
#: The laws of the map cell, named: ``design_map``'s default was these two before 0.2 and is the rig's law since.
MAP_LAWS = ("phase-plane", "damped-dead-zone")


def _best(function, repeat):
    best, value = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        value = function()
        best = min(best, time.process_time() - start)
    return best, value


def _prediction_numbers(prediction):
    return ([[c.amplitude, c.omega, c.loeb] for c in prediction.cycles],
            [[m.amplitude, m.omega, m.distance] for m in prediction.near_misses])


def _cases():
    """name -> (callable, numbers of its result)."""
    import backlash_df as bd
    from backlash_df.sweeps import design_map

    cases = {}
    for name in RIGS:
        rig = bd.load_rig(ROOT / "examples" / f"{name}.toml")
        cases[f"predict {name}"] = (functools.partial(bd.predict_limit_cycles, rig), _prediction_numbers)
    rig = bd.load_rig(ROOT / "examples" / f"{MAP_CELL[0]}.toml")

    def map_numbers(dmap):
        return ([[float(dmap.df_amplitude[m][0, 0]) for m in dmap.models]],
                [[str(dmap.df_verdict[m][0, 0]) for m in dmap.models]])

    cases["map cell"] = (functools.partial(design_map, rig, [MAP_CELL[1]], [MAP_CELL[2]], simulate=False,
                                           models=MAP_LAWS), map_numbers)
    return cases


def _profile_shares(function):
    """The three functions with the most own CPU time (all threads) and their shares."""
    profiles = []

    def start_thread(*_):
        profile = cProfile.Profile(time.thread_time)
        profiles.append(profile)
        profile.enable()  # replaces this hook in the new thread

    threading.setprofile(start_thread)
    main = cProfile.Profile(time.thread_time)
    main.enable()
    try:
        function()
    finally:
        main.disable()
        threading.setprofile(None)
    stats = pstats.Stats(main)
    for profile in profiles:
        stats.add(profile)
    rows = sorted(stats.stats.items(), key=lambda item: -item[1][2])
    total = sum(row[2] for _, row in rows)
    scipy = sum(row[3] for key, row in rows if key[2] == "least_squares") / total
    return [(f"{pathlib.Path(key[0]).name}:{key[2]}", row[2] / total) for key, row in rows[:3]], scipy


def _side(repeat):
    """Time every case in this interpreter (one side); JSON on stdout."""
    out = {}
    for name, (function, numbers) in _cases().items():
        function()  # warm: compiled kernels loaded, scipy imported
        seconds, value = _best(function, repeat)
        top3, scipy = _profile_shares(function)
        out[name] = {"seconds": seconds, "numbers": numbers(value), "top3": top3, "least_squares": scipy}
    print(json.dumps(out))


def _floor(repeat):
    """Per case: (points, seconds) of one DF call and one G call at every point the balance asks for."""
    import numpy as np

    import backlash_df as bd
    from backlash_df.describing import BiasedDescribing, describing_function
    from backlash_df.limit_cycles import default_ranges, solve_harmonic_balance
    from backlash_df.system import frequency_response

    def asked(rig, model, grid):
        model = rig.make_model(model)
        part = bd.drive_loop(rig).linear_part()
        (lo_a, hi_a), omega_range = default_ranges(rig)
        points = []
        if rig.load.torque != 0.0:
            class Recording(BiasedDescribing):
                def __call__(self, amplitude, omega):
                    points.append(np.broadcast_arrays(amplitude, omega))
                    return super().__call__(amplitude, omega)

            n_of, half_gap, lo_a = Recording(model, rig.load.torque), 0.0, 0.02 * model.half_gap
        else:
            def n_of(amplitude, omega):
                points.append(np.broadcast_arrays(amplitude, omega))
                return describing_function(model, amplitude, omega)
            half_gap = model.half_gap
        solve_harmonic_balance(functools.partial(frequency_response, part), n_of, half_gap, (lo_a, hi_a),
                               omega_range, grid=grid)
        a = np.concatenate([np.ravel(x) for x, _ in points])
        w = np.concatenate([np.ravel(y) for _, y in points])
        n_final = (n_of if isinstance(n_of, BiasedDescribing) else functools.partial(describing_function, model))

        def once():
            frequency_response(part, w)
            n_final(a, w)
        once()
        return a.size, _best(once, repeat)[0]

    out = {}
    for name in RIGS:
        out[f"predict {name}"] = asked(bd.load_rig(ROOT / "examples" / f"{name}.toml"), None, (60, 80))
    rig = bd.load_rig(ROOT / "examples" / f"{MAP_CELL[0]}.toml")
    tuned = rig.with_values(kp=MAP_CELL[1], ti=MAP_CELL[2])
    cells = [asked(tuned, model, (30, 40)) for model in MAP_LAWS]
    out["map cell"] = (sum(c[0] for c in cells), sum(c[1] for c in cells))
    print(json.dumps(out))


def _baseline_package(commit):
    """The package of ``commit`` extracted under build/bench_predict/<commit>/ (kept: its compiled cache too)."""
    target = ROOT / "build" / "bench_predict" / commit
    if not (target / "backlash_df").exists():
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "backlash_df"], check=True,
                                 capture_output=True).stdout
        target.mkdir(parents=True, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(target)
    return target


def _run(path, *arguments):
    env = dict(os.environ, PYTHONPATH=str(path), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               MKL_NUM_THREADS="1")
    done = subprocess.run([sys.executable, __file__, *arguments], env=env, check=True, capture_output=True,
                          text=True, cwd=ROOT)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _keep_best(kept, side):
    """Each case's faster run of two sides' outputs (None: the new one)."""
    if kept is None:
        return side
    return {name: min(kept[name], side[name], key=lambda case: case["seconds"]) for name in side}


def _difference(old, new):
    """Largest relative difference of the numbers (inf if the cycles or near misses differ in number)."""
    worst = 0.0
    for old_rows, new_rows in zip(old, new):
        if len(old_rows) != len(new_rows):
            return float("inf")
        for old_row, new_row in zip(old_rows, new_rows):
            for a, b in zip(old_row, new_row):
                if isinstance(a, str) or isinstance(b, str):
                    worst = worst if a == b else float("inf")
                elif a != b:
                    worst = max(worst, abs(b - a) / abs(a) if a else float("inf"))
    return worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each case in a side")
    parser.add_argument("--rounds", type=int, default=3, help="old and new sides run alternately this often")
    parser.add_argument("--baseline", default="a47e5f6", help="commit of the old path (before issue 21)")
    parser.add_argument("--side", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--floor", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.side:
        return _side(args.repeat)
    if args.floor:
        return _floor(args.repeat)
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.baseline], check=True,
                            capture_output=True, text=True).stdout.strip()
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], check=True,
                          capture_output=True, text=True).stdout.strip()
    load = os.getloadavg()
    old_path = _baseline_package(commit)
    old = new = None
    for _ in range(args.rounds):  # the sides alternate: both see the same spells of load
        old = _keep_best(old, _run(old_path, "--side", "--repeat", str(args.repeat)))
        new = _keep_best(new, _run(ROOT, "--side", "--repeat", str(args.repeat)))
    floor = _run(ROOT, "--floor", "--repeat", str(args.repeat))
    print(f"harmonic balance, DF only: old = {commit} (before batching), new = {head}; "
          f"CPU s, best of {args.repeat} x {args.rounds} "
          f"(sides alternating); "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} before, "
          f"{os.getloadavg()[0]:.2f} after")
    print(f"{'case':<28}{'old (s)':>9}{'new (s)':>9}{'old/new':>9}{'accuracy':>10}"
          f"{'floor (s)':>11}{'points':>8}  top 3 (new, own CPU share)")
    for name in new:
        o, n = old[name], new[name]
        points, floor_s = floor[name]
        top = ", ".join(f"{where} {100 * share:.0f} %" for where, share in n["top3"])
        print(f"{name:<28}{o['seconds']:>9.4f}{n['seconds']:>9.4f}{o['seconds'] / n['seconds']:>8.2f}x"
              f"{_difference(o['numbers'], n['numbers']):>10.1e}{floor_s:>11.4f}{points:>8d}  {top}")
    for name in new:
        top = ", ".join(f"{where} {100 * share:.0f} %" for where, share in old[name]["top3"])
        print(f"  old top 3, {name}: {top}")
    print("  share of the CPU time inside scipy's least_squares (the near misses), old -> new: "
          + ", ".join(f"{name} {100 * old[name]['least_squares']:.0f} % -> {100 * new[name]['least_squares']:.0f} %"
                      for name in new))


if __name__ == "__main__":
    main()
