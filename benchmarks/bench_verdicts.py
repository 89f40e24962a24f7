"""Verdict corpora: ``predict``'s verdict against long simulations on seeded random rigs.

Run: ``python benchmarks/bench_verdicts.py [CORPUS] [N_RIGS] [SEED] [--record PATH] [--truths-from OLD]
[--verdicts-from OLD] [--first K]`` (two
worker processes; ``CORPUS`` defaults to ``loaded``).  With ``--record``, each rig's record
(its verdict, truth, reason, CPU times and the commit that made them) is appended to the
JSON-lines file ``PATH`` as it finishes, and the rigs already there are not run again: an
interrupted corpus goes on where it stopped, and the tables are printed from the whole record.
``--truths-from OLD`` takes the truths of the rigs in the record file ``OLD`` instead of
running them (after a change of the verdict alone); the table names both commits;
``--verdicts-from OLD`` likewise takes the verdicts (after a change of the truth alone).
``--first K`` runs and tabulates rigs ``K .. N_RIGS - 1`` alone (the same rigs as in the
whole corpus: each rig's draws depend on its index only), to finish a corpus whose record
is lost.
``CORPUS`` is one of

* ``loaded`` (issue 22; default 200 rigs, seed 2026): PI speed loops, both feedbacks, a
  speed filter, a torque lag and a dead time (each present or not), one of four shaft
  dampings; every third rig carries a constant load torque ``T_l`` (``|T_l| / (k alpha)``
  log-uniform in 0.05 .. 1.5, either sign), so it rests on a flank;
* ``drives`` (issue 19; default 200 rigs, seed 2027): every second rig a cascade (a P
  position loop ``kv`` around the PI, the position measured on the motor or the load,
  alternately), every other pair torque-limited (limits 0.3 .. 3 times ``k alpha``, and
  gains up to 10 times higher, so that capped loops unstable in contact are common).

The law is the phase plane (23) throughout.

* **Verdict** (:func:`backlash_df.verdict.judge_loop`): the rests, the DF cycles, the linear
  loop in contact and open, the probes from the rests.
* **Truth**: long simulations (80 s, doubled up to 1280 s until clear, then continued; all of them capped at the
  longest run ``MAX_STEPS`` allows at a very stiff rig's step) from the rest, set up
  here from the block diagram (speeds 0, the shaft on the flank carrying ``-T_l``, the
  integrator holding it), disturbed in ways the verdict does not use: kicks of the relative
  speed ``dtheta_d(0) = a w_n`` (motor and load speeds at ``+-a w_n / 2``, ``a = 1.1, 3, 10,
  40 alpha``), a released twist of ``2 alpha``, a motor-speed step ``4 alpha w_n``, and on a
  loaded rig the load switched on from the unloaded rest and a twist of a third of the
  flank's distance to release.  Each run is classified by its own rule, not by
  :func:`~backlash_df.simulation.measure_limit_cycle`: ``diverged`` (overflow or
  ``|theta_d| > 1e3 alpha``); ``cycle`` if the envelope of ``|dtheta_d|`` over the last
  tenth of the run is at least 0.97 of that over 0.45 .. 0.55 of it and it switches
  (contact, release, the command's limit) there at least 4 times, as often as in the
  middle (within a quarter, +-2); ``rest`` if that ratio is below 0.8 and the switches
  thin out (none at the end, or fewer than three quarters of those in the middle: a
  motion falling onto a cycle keeps switching as often), or the motion has died to 1e-9
  of its largest speed; otherwise the run is doubled, and at 1280 s (or the longest run
  ``MAX_STEPS`` allows at the rig's step) it is rest if nothing switched over its last
  fifth (the load coasting in the gap), or if the envelope fell below 0.8 with fewer
  than 4 switches in the middle tenth (too few for a cycle by the rule above: a load
  bouncing ever slower across the gap); a run still unclear there is continued from its
  end state by up to ``TRUTH_CONTINUATIONS`` = 3 runs of that length, each classified by
  the same rules (a rest growing from round-off onto a cycle, a position loop slewing back
  on its limit), else unsettled; while the drive turns as one body (the
  larger of ``|w_m|``, ``|w_l|`` over the last tenth more than 10 times ``|dtheta_d|`` there
  and not round-off: a position loop slewing on its torque limit) the run is rest only if the
  drive's speed falls so with no switch over its second half (one linear mode), else not clear.  A cycle is called only on a
  run of at least 320 s (a slow loop's long transient looks steady for a while), and a
  rest whose backlash never switched (no contact; the command's limit does not count),
  on an unloaded rig, is ``stayed`` (the motion never left the gap of the free load,
  where it settles by construction: no evidence either way, as for the verdict).  Classes: every run at rest -> ``no oscillation``; cycles
  only -> ``limit cycle``; rest and cycles -> ``bistable``; runs that diverge and none
  that cycles -> ``unstable``; cycles and diverging runs -> ``limit cycle`` (the cycle
  caps small motions); any unsettled run -> ``undetermined``.
* **Named alternative**: the DF alone (:func:`backlash_df.sweeps.prediction_verdict`).

Printed: both confusion matrices (rows: truth, columns: verdict), the agreement rates, the
capped loops unstable in contact, the rigs where the verdict and the truth differ, and the
CPU time per rig of verdict and truth.
"""

import argparse
import json
import math
import subprocess
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from backlash_df import rig_from_dict, simulate
from backlash_df.limit_cycles import predict_limit_cycles, verify_limit_cycles
from backlash_df.loops import drive_loop
from backlash_df.simulation import MAX_STEPS, default_step
from backlash_df.sweeps import prediction_verdict
from backlash_df.verdict import VERDICTS, judge_loop

DAMPINGS = (1.0, 3.0, 10.0, 30.0)  # N m s/rad
TRUTH_KICKS = (1.1, 3.0, 10.0, 40.0)  # a / alpha
TRUTH_T_END = 1280.0  # s, the longest truth run: four times the verdict's longest probe
TRUTH_CYCLE_T_END = 320.0  # s, the shortest run on which the truth calls a cycle
TRUTH_CONTINUATIONS = 3  # runs of the longest length that continue a run still unclear at its end
CORPORA = {"loaded": (200, 2026), "drives": (200, 2027)}


def random_rig(rng, corpus, index):
    """A PI loop around a two-mass drive: values drawn around the paper's laboratory drive."""
    feedback = str(rng.choice(["motor", "load"]))
    plant = {
        "motor_inertia": float(rng.uniform(0.2, 1.0)),
        "load_inertia": float(rng.uniform(2.0, 10.0)),
        "stiffness": float(np.exp(rng.uniform(math.log(2000.0), math.log(12000.0)))),
        "damping": float(rng.choice(DAMPINGS)),
        "half_gap": float(rng.uniform(0.02, 0.08)),
    }
    limited = corpus == "drives" and (index // 2) % 2 == 0
    kp_range = (20.0, 600.0) if feedback == "motor" else (3.0, 300.0)
    if limited:
        kp_range = (kp_range[0], 10.0 * kp_range[1])
    controller = {
        "feedback": feedback,
        "kp": float(np.exp(rng.uniform(*np.log(kp_range)))),
        "ti": float(np.exp(rng.uniform(math.log(0.1), math.log(1.5)))),
        "speed_filter": float(rng.choice([0.0, rng.uniform(0.0005, 0.008)])),
        "torque_lag": float(rng.choice([0.0, rng.uniform(0.0003, 0.003)])),
        "delay": float(rng.choice([0.0, rng.uniform(0.0001, 0.0008)])),
    }
    scale = plant["stiffness"] * plant["half_gap"]
    if corpus == "drives" and index % 2 == 0:
        controller.update(structure="cascade", kv=float(np.exp(rng.uniform(math.log(2.0), math.log(60.0)))),
                          position_feedback="motor" if (index // 4) % 2 else "load")
    if limited:
        controller["torque_limit"] = float(scale * np.exp(rng.uniform(math.log(0.3), math.log(3.0))))
    load = {}
    if corpus == "loaded" and index % 3 == 0:
        load["torque"] = float(rng.choice([-1.0, 1.0]) * scale * np.exp(rng.uniform(math.log(0.05), math.log(1.5))))
    return rig_from_dict({"plant": plant, "controller": controller, "load": load,
                          "model": {"backlash": "phase-plane"}})


def block_diagram_rest(rig):
    """The rest (states by name) from the loop's equations: speeds 0, ``T = -T_l`` on a flank, the integrator holding it."""
    plant, ctl, load = rig.plant, rig.controller, rig.load.torque
    theta = 0.0 if load == 0.0 else -math.copysign(plant.half_gap, load) - load / plant.stiffness
    rest = {"theta_d": theta, "motor_speed": 0.0, "load_speed": 0.0, "integrator": -load / ctl.ki}
    if ctl.cascade:  # the measured position at its reference 0
        rest["load_angle"] = -theta if ctl.position_feedback == "motor" else 0.0
    if ctl.torque_lag > 0.0:
        rest["motor_torque"] = -load
    return rest


def truth_starts(rig):
    """Initial states (by name) of the truth's runs (module docs)."""
    alpha = rig.plant.half_gap
    w_n = math.sqrt(rig.plant.stiffness * (1.0 / rig.plant.motor_inertia + 1.0 / rig.plant.load_inertia))
    rest = block_diagram_rest(rig)

    def shifted(**change):
        return {name: rest[name] + change.get(name, 0.0) for name in rest}

    starts = [shifted(motor_speed=0.5 * a * alpha * w_n, load_speed=-0.5 * a * alpha * w_n) for a in TRUTH_KICKS]
    starts += [shifted(theta_d=2.0 * alpha), shifted(motor_speed=4.0 * alpha * w_n)]
    if rig.load.torque != 0.0:
        starts.append({"theta_d": 0.0})  # the load switched on at the unloaded rest
        starts.append(shifted(theta_d=math.copysign(abs(rig.load.torque) / rig.plant.stiffness / 3.0,
                                                    rig.load.torque)))
    return starts


def _switching(run):
    """Per step, whether the backlash or the command (a torque limit) changed mode."""
    switching = np.diff(run.mode) != 0
    if run.command_mode is not None:
        switching |= np.diff(run.command_mode) != 0
    return switching


def classify_run(run, alpha, final=False):
    """``diverged``, ``cycle``, ``rest`` or ``None`` (not clear yet) for one long run (module docs)."""
    with np.errstate(invalid="ignore"):
        if not np.all(np.isfinite(run.states)) or np.abs(run.theta_d).max() > 1e3 * alpha:
            return "diverged"
    t, speed = run.time, np.abs(run.dtheta_d)
    in_middle, in_end = (t >= 0.45 * t[-1]) & (t <= 0.55 * t[-1]), t >= 0.9 * t[-1]
    middle, end = speed[in_middle].max(), speed[in_end].max()
    switching = _switching(run)
    drive = np.maximum(np.abs(run.state("motor_speed")), np.abs(run.state("load_speed")))
    if drive[in_end].max() > 10.0 * end and drive[in_end].max() > 1e-9 * drive.max():
        # motor and load turn together (a slew on the torque limit): the shaft's speed says nothing
        one_mode = not switching[t[1:] >= 0.5 * t[-1]].any() and drive[in_end].max() < 0.8 * drive[in_middle].max()
        return "rest" if one_mode else None
    switches_middle, switches_end = switching[in_middle[1:]].sum(), switching[in_end[1:]].sum()
    thinning = switches_end == 0 or switches_end < 0.75 * switches_middle
    if end <= 1e-9 * speed.max() or (end < 0.8 * middle and thinning):
        return "rest"
    if end >= 0.97 * middle and switches_end >= 4 and abs(switches_end - switches_middle) <= 0.25 * switches_middle + 2:
        return "cycle"
    if final and not switching[t[1:] >= 0.8 * t[-1]].any():
        return "rest"  # the load coasts in the gap: no contact over the last fifth of the longest run
    if final and end < 0.8 * middle and switches_middle < 4:
        return "rest"  # a load bouncing ever slower across the gap: too few switches for a cycle by the rule above
    return None


def longest_truth_run(rig):
    """The truth's longest run, s: ``TRUTH_T_END``, or less where ``MAX_STEPS`` of the rig's step are less."""
    return min(TRUTH_T_END, MAX_STEPS * default_step(drive_loop(rig).linear_part(), rig.make_model("phase-plane")))


def truth_run(rig, start, longest):
    """``diverged``, ``cycle``, ``rest``, ``stayed`` or ``unsettled``: one truth start run until clear (module docs),
    no run longer than ``longest`` (s, :func:`longest_truth_run`); a run still unclear at ``longest`` is continued
    from its end state, up to ``TRUTH_CONTINUATIONS`` more runs of ``longest``."""
    t_end = min(80.0, longest)  # a very stiff rig's step allows less than 80 s
    while True:
        run = simulate(rig, "phase-plane", t_end=t_end, initial=start)
        final = t_end >= longest
        outcome = classify_run(run, rig.plant.half_gap, final=final)
        if outcome == "cycle" and t_end < TRUTH_CYCLE_T_END and not final:
            # a slow loop's long transient looks steady for a while: confirmed on a run of TRUTH_CYCLE_T_END
            outcome, t_end = None, min(TRUTH_CYCLE_T_END, longest)
            continue
        if outcome is not None or final:
            break
        t_end = min(2.0 * t_end, longest)
    switched = bool(np.any(np.diff(run.mode) != 0))
    for _ in range(TRUTH_CONTINUATIONS if outcome is None else 0):
        # a growth from round-off, a slew back on the torque limit: the motion goes on from where the run ended
        run = simulate(rig, "phase-plane", t_end=longest, initial=dict(zip(run.state_names, run.states[-1])))
        switched = switched or bool(np.any(np.diff(run.mode) != 0))
        outcome = classify_run(run, rig.plant.half_gap, final=True)
        if outcome is not None:
            break
    if outcome == "rest" and rig.load.torque == 0.0 and not switched:
        return "stayed"  # never touched a flank: in the gap of a free load that settles by construction
    return outcome or "unsettled"


def truth(rig):
    """Class of what long simulations from the truth's starts show (module docs)."""
    longest = longest_truth_run(rig)
    outcomes = Counter(truth_run(rig, start, longest) for start in truth_starts(rig))
    if outcomes["unsettled"]:
        return "undetermined", outcomes
    if outcomes["cycle"]:
        return ("bistable" if outcomes["rest"] else "limit cycle"), outcomes
    return ("unstable" if outcomes["diverged"] else "no oscillation"), outcomes


_VERDICT_FIELDS = ("commit", "verdict", "reason", "df_alone", "contact_stable", "capped", "saturated", "t_verdict")


def one(job):
    """Verdict, DF-only verdict and truth of rig ``index`` of a corpus, with CPU times: one record (a dict).

    ``known``, a record of the same rig, gives the truth (its ``truth``, ``outcomes``,
    ``t_truth`` and ``truth_commit``) instead of running it again; ``said``, likewise, gives
    the verdict (its fields ``_VERDICT_FIELDS``); ``commit`` names the code that made the rest.
    """
    corpus, seed, index, known, said, commit = job
    rig = random_rig(np.random.default_rng([seed, index]), corpus, index)
    if said is None:
        start = time.process_time()
        prediction = verify_limit_cycles(rig, predict_limit_cycles(rig, "phase-plane"))
        verdict = judge_loop(rig, prediction)
        t_verdict = time.process_time() - start
        fields = {"commit": commit, "verdict": verdict.verdict, "reason": verdict.reason,
                  "df_alone": prediction_verdict(rig, prediction), "contact_stable": bool(verdict.contact_loop.stable),
                  "capped": bool(rig.controller.torque_limit > 0.0 and verdict.contact_loop.status == "unstable"
                                 and verdict.verdict != "unstable"),
                  "saturated": bool(verdict.saturated), "t_verdict": t_verdict}
    else:
        fields = {name: said[name] for name in _VERDICT_FIELDS}
    if known is None:
        start = time.process_time()
        true, outcomes = truth(rig)
        t_truth, truth_commit = time.process_time() - start, commit
    else:
        true, outcomes, t_truth = known["truth"], known["outcomes"], known["t_truth"]
        truth_commit = known.get("truth_commit", known["commit"])
    return {"corpus": corpus, "seed": seed, "index": index, "truth_commit": truth_commit, "kind": _kind(rig),
            "rig": describe(rig), "truth": true, "outcomes": dict(outcomes), "t_truth": t_truth, **fields}


def _commit():
    """The checkout's commit (``+`` if it has uncommitted changes), or ``unknown``."""
    run = subprocess.run(["git", "describe", "--always", "--dirty=+"], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parent, check=False)
    return run.stdout.strip() or "unknown"


def read_record(path, corpus, seed):
    """The records of ``corpus`` and ``seed`` already in the JSON-lines file ``path``, by index (empty if none)."""
    if path is None or not path.exists():
        return {}
    records = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError:  # a line cut short by an interrupted run: that rig is run again
            print(f"{path}:{number}: not a whole record, ignored", file=sys.stderr)
            continue
        if record.get("corpus") == corpus and record.get("seed") == seed:
            records[record["index"]] = record
    return records


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
    loop = (f"cascade kv={c.kv:.3g} on {c.position_feedback} " if c.cascade else "") + \
        (f"limit={c.torque_limit:.4g}N m " if c.torque_limit else "") + \
        (f"load={rig.load.torque:.4g}N m " if rig.load.torque else "")
    return (f"{loop}{c.feedback} kp={c.kp:.4g} ti={c.ti:.3g} filter={c.speed_filter * 1e3:.2g}ms "
            f"lag={c.torque_lag * 1e3:.2g}ms delay={c.delay * 1e3:.2g}ms c={p.damping:g} k={p.stiffness:.0f} "
            f"Jm={p.motor_inertia:.2f} Jl={p.load_inertia:.2f} alpha={p.half_gap:.3f}")


def _kind(rig):
    c = rig.controller
    return ", ".join(word for word, present in (("loaded", rig.load.torque != 0.0), ("cascade", c.cascade),
                                                ("limited", c.torque_limit > 0.0)) if present) or "speed loop"


def _line(r):
    return (f"#{r['index']:3d} {r['kind']:24s} truth {r['truth']:14s} verdict {r['verdict']:14s} DF alone "
            f"{r['df_alone']:14s} {r['t_verdict']:5.1f} s / {r['t_truth']:5.1f} s {r['outcomes']}")


def run_corpus(corpus, seed, n_rigs, record=None, truths=None, first=0, verdicts=None):
    """The records of rigs ``first .. n_rigs - 1``: those in ``record`` kept, the others run on two workers.

    Each new record is printed and appended to ``record`` (JSON lines) as it comes, so an
    interrupted run loses only the rigs in flight; run again, it does only the rest.  The
    records of ``truths`` (another record file) give their rigs' truths, which are then
    not run again: for a change of the verdict alone; those of ``verdicts`` likewise give
    the verdicts, for a change of the truth alone.
    """
    commit = _commit()
    done = {i: r for i, r in read_record(record, corpus, seed).items() if first <= i < n_rigs}
    known, said = read_record(truths, corpus, seed), read_record(verdicts, corpus, seed)
    if done:
        commits = Counter(r["commit"] for r in done.values())
        print(f"{len(done)} rigs from {record} (commits: "
              + ", ".join(f"{c} {n}" for c, n in sorted(commits.items())) + ")", flush=True)
    with ProcessPoolExecutor(2) as pool:
        jobs = [pool.submit(one, (corpus, seed, i, known.get(i), said.get(i), commit)) for i in range(first, n_rigs) if i not in done]
        for job in as_completed(jobs):
            result = job.result()
            print(_line(result), flush=True)
            if record is not None:
                with record.open("a") as out:
                    out.write(json.dumps(result) + "\n")
            done[result["index"]] = result
    return [done[i] for i in range(first, n_rigs)]


def main(corpus="loaded", n_rigs=None, seed=None, record=None, truths=None, first=0, verdicts=None):
    default_rigs, default_seed = CORPORA[corpus]
    n_rigs, seed = n_rigs or default_rigs, default_seed if seed is None else seed
    start = time.perf_counter()
    results = run_corpus(corpus, seed, n_rigs, record, truths, first, verdicts)
    wall = time.perf_counter() - start
    said = [(r["truth"], r["verdict"]) for r in results]
    alone = [(r["truth"], r["df_alone"]) for r in results]
    kinds = Counter(r["kind"] for r in results)
    commits = Counter(r["commit"] for r in results)
    truth_commits = Counter(r.get("truth_commit", r["commit"]) for r in results)
    print(f"\ncorpus {corpus!r}: {len(results)} random rigs (#{first}..#{n_rigs - 1}, seed {seed}), phase plane law; "
          "verdicts from "
          + ", ".join(f"{c} ({n} rigs)" for c, n in sorted(commits.items())) + "; truths from "
          + ", ".join(f"{c} ({n} rigs)" for c, n in sorted(truth_commits.items())))
    print("rigs: " + ", ".join(f"{n} {kind}" for kind, n in sorted(kinds.items())) + "\n")
    print("verdict (rests + DF + linear loop + probes):")
    print(confusion(said))
    print("\nDF alone (backlash_df.sweeps.prediction_verdict):")
    print(confusion(alone))
    agree = sum(t == v for t, v in said)
    agree_df = sum(t == v for t, v in alone)
    determined = [(t, v) for t, v in said if v != "undetermined"]
    n = len(results)
    print(f"\nagreement: verdict {agree}/{n} = {agree / n:.1%}; DF alone {agree_df}/{n} = {agree_df / n:.1%}")
    print(f"verdict where it commits (not undetermined): {sum(t == v for t, v in determined)}/{len(determined)} = "
          f"{sum(t == v for t, v in determined) / max(len(determined), 1):.1%}")
    for kind in sorted(kinds):
        pairs = [(r["truth"], r["verdict"]) for r in results if r["kind"] == kind]
        print(f"  {kind}: {sum(t == v for t, v in pairs)}/{len(pairs)} agree")
    unstable = [r for r in results if not r["contact_stable"]]
    print(f"contact loop unstable: {len(unstable)} rigs, called unstable: "
          f"{sum(r['verdict'] == 'unstable' for r in unstable)}, truth unstable: "
          f"{sum(r['truth'] == 'unstable' for r in unstable)}")
    capped = [r for r in results if r["capped"]]
    if any("limited" in r["kind"] for r in results):
        print(f"capped (torque limit, contact loop unstable, not called unstable): {len(capped)} rigs, called limit "
              f"cycle: {sum(r['verdict'] == 'limit cycle' for r in capped)} (saturated: "
              f"{sum(r['saturated'] for r in capped)}), truth limit cycle: "
              f"{sum(r['truth'] == 'limit cycle' for r in capped)}")
        hunting = [r for r in unstable if "limited" in r["kind"] and r["truth"] == "limit cycle"]
        print(f"contact loop unstable, torque limit, truth limit cycle (capped by the limit in the long runs): "
              f"{len(hunting)} rigs, called limit cycle: {sum(r['verdict'] == 'limit cycle' for r in hunting)}")
    t_verdict = np.array([r["t_verdict"] for r in results])
    t_truth = np.array([r["t_truth"] for r in results])
    print(f"CPU time per rig: verdict median {np.median(t_verdict):.2f} s (max {t_verdict.max():.1f}), "
          f"truth median {np.median(t_truth):.2f} s (max {t_truth.max():.1f}); wall {wall:.0f} s on 2 workers"
          + (" (this run; rigs from the record took theirs earlier)" if record is not None else ""))
    print("\nrigs where the verdict differs from the truth:")
    for r in results:
        if r["verdict"] != r["truth"]:
            print(f"  #{r['index']:3d} truth {r['truth']} {r['outcomes']}; said {r['verdict']} (DF alone: "
                  f"{r['df_alone']}) -- {r['rig']}\n        {r['reason']}")


def _arguments(args):
    """``[CORPUS] [N_RIGS] [SEED] [--record PATH] [--truths-from OLD] [--verdicts-from OLD] [--first K]`` (run_all.py passes N_RIGS
    alone); a bad argument is argparse's usage and one error line, exit code 2."""
    parser = argparse.ArgumentParser(prog="bench_verdicts.py", formatter_class=argparse.RawDescriptionHelpFormatter,
                                     description=__doc__.split("``CORPUS`` is one of", 1)[0].strip())
    parser.add_argument("values", nargs="*", metavar="[CORPUS] [N_RIGS] [SEED]",
                        help=f"CORPUS one of {', '.join(CORPORA)} (default loaded); N_RIGS and SEED whole numbers "
                             "(default: the corpus's)")
    parser.add_argument("--record", type=Path, metavar="PATH", help="JSON-lines record: appended to, and resumed from")
    parser.add_argument("--truths-from", type=Path, metavar="OLD", help="a record whose truths are taken")
    parser.add_argument("--verdicts-from", type=Path, metavar="OLD", help="a record whose verdicts are taken")
    parser.add_argument("--first", type=int, default=0, metavar="K", help="run and tabulate rigs K.. alone")
    options = parser.parse_intermixed_args(args)
    values = list(options.values)
    corpus = values.pop(0) if values and values[0] in CORPORA else "loaded"
    if len(values) > 2 or not all(value.isdigit() for value in values):
        parser.error(f"unexpected arguments {' '.join(options.values)!r}: [CORPUS] [N_RIGS] [SEED], CORPUS one of "
                     + ", ".join(CORPORA))
    if options.first < 0:
        parser.error(f"--first must be a rig index >= 0, got {options.first}")
    n_rigs, seed = ([int(value) for value in values] + [None, None])[:2]
    return corpus, n_rigs, seed, options.record, options.truths_from, options.first, options.verdicts_from


if __name__ == "__main__":
    main(*_arguments(sys.argv[1:]))
