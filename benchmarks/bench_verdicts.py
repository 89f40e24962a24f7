"""Verdict corpus: ``predict``'s verdict against long simulations on seeded random rigs.

Run: ``python benchmarks/bench_verdicts.py [N_RIGS] [SEED]`` (default 200 rigs, seed 2026;
two worker processes).  Each rig draws both feedbacks, a speed filter, a torque lag and a
dead time (each present or not), and one of four shaft dampings; the law is the phase
plane (23).

* **Verdict** (:func:`backlash_df.verdict.judge_loop`): the DF cycles, the linear loop
  in contact and open, five kicked simulations from rest.
* **Truth**: long simulations (40 s first, doubled up to 320 s until steady; twice the
  verdict's) from six initial conditions: kicks ``dtheta_d(0) = a w_n`` with ``a = 1.1,
  3, 10, 40 alpha`` (1.1 and 3 are among the verdict's too), a released twist
  ``theta_d(0) = 2 alpha`` and a motor-speed step ``w_m(0) = 4 alpha w_n``.  A run that
  has not settled by then but whose twist rate over the last quarter stays below 1 % of
  its largest value (the load creeping through the gap with ever rarer contacts) counts
  as rest.  Classes: every run at rest -> ``no
  oscillation``; cycles only -> ``limit cycle``; rest and cycles -> ``bistable``; runs
  that diverge and none that cycles -> ``unstable``; cycles and diverging runs ->
  ``limit cycle`` (the cycle caps small motions); any run that does not settle ->
  ``undetermined``.
* **Named alternative**: the DF alone (:func:`backlash_df.sweeps.prediction_verdict`:
  stable cycle -> limit cycle / bistable, contact poles for delay-free loops).

Printed: both confusion matrices (rows: truth, columns: verdict), the agreement rates,
the rigs where the verdict and the truth differ, and the time per rig of verdict and truth.
"""

import math
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from backlash_df import rig_from_dict
from backlash_df.limit_cycles import default_ranges, predict_limit_cycles, verify_limit_cycles
from backlash_df.simulation import simulated_limit_cycle
from backlash_df.sweeps import prediction_verdict
from backlash_df.verdict import VERDICTS, Probe, judge_loop

DAMPINGS = (1.0, 3.0, 10.0, 30.0)  # N m s/rad
TRUTH_KICKS = (1.1, 3.0, 10.0, 40.0)  # a / alpha


def random_rig(rng):
    """A PI loop around a two-mass drive: values drawn around the paper's laboratory drive."""
    feedback = str(rng.choice(["motor", "load"]))
    kp_range = (20.0, 600.0) if feedback == "motor" else (3.0, 300.0)
    return rig_from_dict({
        "plant": {
            "motor_inertia": float(rng.uniform(0.2, 1.0)),
            "load_inertia": float(rng.uniform(2.0, 10.0)),
            "stiffness": float(np.exp(rng.uniform(math.log(2000.0), math.log(12000.0)))),
            "damping": float(rng.choice(DAMPINGS)),
            "half_gap": float(rng.uniform(0.02, 0.08)),
        },
        "controller": {
            "feedback": feedback,
            "kp": float(np.exp(rng.uniform(*np.log(kp_range)))),
            "ti": float(np.exp(rng.uniform(math.log(0.1), math.log(1.5)))),
            "speed_filter": float(rng.choice([0.0, rng.uniform(0.0005, 0.008)])),
            "torque_lag": float(rng.choice([0.0, rng.uniform(0.0003, 0.003)])),
            "delay": float(rng.choice([0.0, rng.uniform(0.0001, 0.0008)])),
        },
        "model": {"backlash": "phase-plane"},
    })


def truth(rig):
    """Class of what long simulations from six initial conditions show (module docs)."""
    alpha = rig.plant.half_gap
    w_n = default_ranges(rig)[1][1] / 3.0
    starts = [{"kick": a * alpha * w_n} for a in TRUTH_KICKS]
    starts += [{"initial": {"theta_d": 2.0 * alpha}}, {"initial": {"motor_speed": 4.0 * alpha * w_n}}]
    outcomes = Counter()
    for start in starts:
        measured, run = simulated_limit_cycle(rig, "phase-plane", t_end=40.0, max_t_end=320.0, **start)
        outcome = Probe(0.0, 0.0, measured).outcome
        rate = np.abs(run.dtheta_d)
        if outcome == "unsettled" and rate[run.time >= 0.75 * run.time[-1]].max() < 1e-2 * rate.max():
            outcome = "rest"
        outcomes[outcome] += 1
    if outcomes["unsettled"]:
        return "undetermined", outcomes
    if outcomes["cycle"]:
        return ("bistable" if outcomes["rest"] else "limit cycle"), outcomes
    return ("unstable" if outcomes["diverged"] else "no oscillation"), outcomes


def one(seed_and_index):
    """Verdict, DF-only verdict and truth of rig ``index`` of the corpus, with timings."""
    seed, index = seed_and_index
    rig = random_rig(np.random.default_rng([seed, index]))
    start = time.perf_counter()
    prediction = verify_limit_cycles(rig, predict_limit_cycles(rig, "phase-plane"))
    verdict = judge_loop(rig, prediction)
    t_verdict = time.perf_counter() - start
    df_only = prediction_verdict(rig, prediction)
    start = time.perf_counter()
    true, outcomes = truth(rig)
    t_truth = time.perf_counter() - start
    return index, rig, verdict, df_only, true, dict(outcomes), t_verdict, t_truth


def confusion(pairs):
    """Text confusion matrix: rows truth, columns verdict."""
    short = {"no oscillation": "none", "limit cycle": "cycle", "bistable": "bistable", "unstable": "unstable",
             "undetermined": "undet."}
    counts = Counter(pairs)
    lines = ["truth \\ said   " + " ".join(f"{short[v]:>9}" for v in VERDICTS) + "    total"]
    for t in VERDICTS:
        row = [counts[t, v] for v in VERDICTS]
        lines.append(f"{t:15s}" + " ".join(f"{n:9d}" for n in row) + f"    {sum(row):5d}")
    return "\n".join(lines)


def describe(rig):
    c, p = rig.controller, rig.plant
    return (f"{c.feedback} kp={c.kp:.4g} ti={c.ti:.3g} filter={c.speed_filter * 1e3:.2g}ms "
            f"lag={c.torque_lag * 1e3:.2g}ms delay={c.delay * 1e3:.2g}ms c={p.damping:g} k={p.stiffness:.0f} "
            f"Jm={p.motor_inertia:.2f} Jl={p.load_inertia:.2f} alpha={p.half_gap:.3f}")


def main(n_rigs=200, seed=2026):
    start = time.perf_counter()
    results = []
    with ProcessPoolExecutor(2) as pool:
        for result in pool.map(one, [(seed, i) for i in range(n_rigs)]):
            index, _, verdict, df, true, outcomes, t_verdict, t_truth = result
            print(f"#{index:3d} truth {true:14s} verdict {verdict.verdict:14s} DF alone {df:14s} "
                  f"{t_verdict:5.1f} s / {t_truth:5.1f} s {outcomes}", flush=True)
            results.append(result)
    wall = time.perf_counter() - start
    said = [(true, verdict.verdict) for _, _, verdict, _, true, _, _, _ in results]
    alone = [(true, df) for _, _, _, df, true, _, _, _ in results]
    print(f"\n{n_rigs} random rigs (seed {seed}), phase plane law; truth from 6 long simulations per rig\n")
    print("verdict (DF + linear loop + kicked simulations):")
    print(confusion(said))
    print("\nDF alone (backlash_df.sweeps.prediction_verdict):")
    print(confusion(alone))
    agree = sum(t == v for t, v in said)
    agree_df = sum(t == v for t, v in alone)
    determined = [(t, v) for t, v in said if v != "undetermined"]
    print(f"\nagreement: verdict {agree}/{n_rigs} = {agree / n_rigs:.1%}; DF alone {agree_df}/{n_rigs} = "
          f"{agree_df / n_rigs:.1%}")
    print(f"verdict where it commits (not undetermined): {sum(t == v for t, v in determined)}/{len(determined)} = "
          f"{sum(t == v for t, v in determined) / max(len(determined), 1):.1%}")
    unstable = [(t, v) for _, _, verdict, _, t, _, _, _ in results
                for v in [verdict.verdict] if not verdict.contact_loop.stable]
    print(f"contact loop unstable: {len(unstable)} rigs, called unstable: {sum(v == 'unstable' for _, v in unstable)}, "
          f"truth unstable: {sum(t == 'unstable' for t, _ in unstable)}")
    t_verdict = np.array([r[6] for r in results])
    t_truth = np.array([r[7] for r in results])
    print(f"time per rig (one worker): verdict median {np.median(t_verdict):.2f} s (max {t_verdict.max():.1f}), "
          f"truth median {np.median(t_truth):.2f} s (max {t_truth.max():.1f}); wall {wall:.0f} s on 2 workers")
    print("\nrigs where the verdict differs from the truth:")
    for index, rig, verdict, df, true, outcomes, _, _ in results:
        if verdict.verdict != true:
            print(f"  #{index:3d} truth {true} {outcomes}; said {verdict.verdict} (DF alone: {df}) -- {describe(rig)}\n"
                  f"        {verdict.reason}")


if __name__ == "__main__":
    main(*(int(arg) for arg in sys.argv[1:3]))
