"""Exact periodic orbits by shooting: time per orbit against long simulation, and the DF's error.

Run: ``python benchmarks/bench_orbits.py``.

1. **Time per orbit.**  :func:`backlash_df.orbits.periodic_orbit` from the DF cycle of
   :func:`backlash_df.predict_limit_cycles` (best of five), against obtaining the same cycle
   the way the project otherwise does: :func:`backlash_df.simulate` from the DF kick
   ``dtheta_d(0) = A w`` at ``dt = T / 2048`` plus :func:`measure_limit_cycle` over 20
   periods, for the shortest simulated time (doubled from 1 s) whose measurement agrees with
   the orbit to 1e-5 in amplitude and 1e-6 in frequency, the accuracy the tests demand
   (best of three of that single run: the search for the length is not charged).  The
   simulation is the independent reference: its own kernel, events by bisection, no
   saltation matrices; the relative differences are printed.  Unstable orbits have no
   simulated counterpart: simulation cannot converge to them.
2. **The DF's error** against the exact orbit on the bundled examples with a controller and
   on ``load_feedback.toml`` with kp = 10, ti = 1 s (loci nearly tangent), for the phase
   plane (23), exact (1)+(14) and damped dead-zone (26) laws: every DF cycle, the orbit it
   leads to, its Floquet multiplier of largest modulus and the DF errors.
3. **Dead time.**  The near-critical tuning of issue 10 (motor feedback, c = 10, kp = 222,
   ti = 0.3 s, filter 7.6 ms, lag 1.5 ms, delay 0.5 ms): the orbit's amplitude for Pade
   orders 1..8 and the simulation's cycle at decreasing steps against it.
4. **Torque limit and cascades** (``load_feedback.toml`` retuned): shooting from a
   simulated seed (CPU time, best of three) against the simulation from a kick of 1 rad/s
   at ``dt = T / 2048`` for the shortest time whose measurement agrees with the orbit to
   1e-5 in amplitude and 1e-6 in frequency (CPU time, best of three of that run); the
   command's share of the period on its limit and its first-harmonic amplitude.
"""

import dataclasses
import math
import functools
import time
from pathlib import Path

import backlash_df as bd
from backlash_df.orbits import OrbitNotFound, exact_orbits, periodic_orbit
from backlash_df.simulation import measure_limit_cycle, simulated_limit_cycle

import timing

best_of = functools.partial(timing.best_of, clock=time.perf_counter)  # wall time, as before

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
MODELS = ("phase-plane", "exact", "damped-dead-zone")


def rigs():
    """The bundled rigs with a controller, and the near-tangent tuning of load_feedback."""
    out = {name: bd.load_rig(EXAMPLES / f"{name}.toml") for name in ("load_feedback", "motor_lag_feedback",
                                                                       "motor_feedback")}
    base = out["load_feedback"]
    out["load_feedback kp=10 ti=1"] = dataclasses.replace(
        base, controller=dataclasses.replace(base.controller, kp=10.0, ti=1.0))
    return out


def simulation_to_match(rig, model, cycle, orbit):
    """(simulated time s, seconds best of 3, measured cycle) of the shortest run matching the orbit."""
    dt = orbit.period / 2048
    t_end = 1.0
    while t_end <= 256.0:
        def run():
            result = bd.simulate(rig, model, t_end=t_end, dt=dt, kick=cycle.amplitude * cycle.omega)
            return measure_limit_cycle(result, periods=20, rtol=1e-6)

        measured = run()
        if (measured.found and abs(measured.amplitude / orbit.amplitude - 1.0) < 1e-5
                and abs(measured.omega / orbit.omega - 1.0) < 1e-6):
            seconds, measured = best_of(run, 3)
            return t_end, seconds, measured
        t_end *= 2.0
    return t_end, math.nan, None


def timing_table(all_rigs):
    print("1. Time per orbit: shooting from the DF cycle vs long simulation to the same accuracy")
    print(f"{'rig':26} {'law':12} {'orbit':9} {'shoot s':>8} {'sim t_end':>9} {'sim s':>8} {'ratio':>7} "
          f"{'dA/A':>9} {'dw/w':>9}")
    for name in ("load_feedback", "motor_lag_feedback", "load_feedback kp=10 ti=1"):
        rig = all_rigs[name]
        for cycle in bd.predict_limit_cycles(rig, "phase-plane").cycles:
            seconds, orbit = best_of(lambda: periodic_orbit(rig, "phase-plane", cycle), 5)
            kind = "stable" if orbit.stable else "unstable"
            if not orbit.stable:
                print(f"{name:26} {'phase-plane':12} {kind:9} {seconds:8.3f} {'n/a':>9} {'n/a':>8} {'n/a':>7}")
                continue
            t_end, sim_seconds, measured = simulation_to_match(rig, "phase-plane", cycle, orbit)
            if measured is None:
                print(f"{name:26} {'phase-plane':12} {kind:9} {seconds:8.3f} {'>256 s':>9}")
                continue
            print(f"{name:26} {'phase-plane':12} {kind:9} {seconds:8.3f} {t_end:9.0f} {sim_seconds:8.3f} "
                  f"{sim_seconds / seconds:7.1f} {measured.amplitude / orbit.amplitude - 1.0:9.1e} "
                  f"{measured.omega / orbit.omega - 1.0:9.1e}")


def df_error_table(all_rigs):
    print("\n2. DF against the exact orbit (A: first harmonic of theta_d, rad; w rad/s)")
    print(f"{'rig':26} {'law':17} {'DF A':>8} {'DF w':>7} {'orbit A':>8} {'orbit w':>7} {'peak':>7} "
          f"{'stability':>9} {'|mu|max':>7} {'A err':>7} {'w err':>7} {'s':>5}")
    for name, rig in all_rigs.items():
        for model in MODELS:
            prediction = bd.predict_limit_cycles(rig, model)
            start = time.perf_counter()
            simulated, _ = simulated_limit_cycle(rig, model, t_end=10.0, kick=2.0 * rig.plant.half_gap * 100.0)
            orbits = exact_orbits(rig, prediction, simulated=simulated)
            seconds = time.perf_counter() - start
            if not prediction.cycles and not orbits:
                print(f"{name:26} {model:17} {'none':>8} {'':>7} {'none':>8}   simulation: {simulated.verdict}")
            for orbit in orbits:
                near = min(prediction.cycles, key=lambda c: abs(c.omega / orbit.omega - 1.0), default=None)
                df_a = f"{near.amplitude:8.4f}" if near else f"{'none':>8}"
                df_w = f"{near.omega:7.1f}" if near else f"{'':>7}"
                err_a = f"{near.amplitude / orbit.amplitude - 1.0:+7.1%}" if near else f"{'':>7}"
                err_w = f"{near.omega / orbit.omega - 1.0:+7.1%}" if near else f"{'':>7}"
                kind = "stable" if orbit.stable else "unstable"
                print(f"{name:26} {model:17} {df_a} {df_w} {orbit.amplitude:8.4f} {orbit.omega:7.1f} "
                      f"{orbit.peak:7.4f} {kind:>9} {orbit.max_multiplier:7.4f} {err_a} {err_w} {seconds:5.2f}")
            for cycle in prediction.cycles:
                if not any(abs(cycle.omega / o.omega - 1.0) < 0.5 for o in orbits):
                    print(f"{name:26} {model:17} {cycle.amplitude:8.4f} {cycle.omega:7.1f} {'no orbit':>8}")


def dead_time_table():
    print("\n3. Dead time: near-critical tuning of issue 10 (delay 0.5 ms)")
    rig = bd.rig_from_dict({
        "plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 10.0, "half_gap": 0.05},
        "controller": {"feedback": "motor", "kp": 222.0, "ti": 0.3, "speed_filter": 0.0076,
                       "torque_lag": 0.0015, "delay": 0.0005},
    })
    seed = bd.predict_limit_cycles(rig).cycles[0]
    reference = None
    for order in (1, 2, 3, 4, 5, 6, 8):
        try:
            seconds, orbit = best_of(lambda: periodic_orbit(rig, None, seed, pade_order=order), 3)
        except OrbitNotFound as error:
            print(f"  Pade order {order}: {error}")
            continue
        reference = orbit if order == 6 else reference
        print(f"  Pade order {order}: A = {orbit.amplitude:.10f} rad, w = {orbit.omega:.8f} rad/s, "
              f"|mu|max = {orbit.max_multiplier:.5f}, {seconds:.3f} s")
    print(f"  DF (exact delay in G(jw)): A = {seed.amplitude:.5f} rad "
          f"({seed.amplitude / reference.amplitude - 1.0:+.2%}), "
          f"w = {seed.omega:.2f} rad/s ({seed.omega / reference.omega - 1.0:+.2%})")
    for dt in (None, 5e-5, 2.5e-5, 1.25e-5):
        measured, _ = simulated_limit_cycle(rig, None, t_end=20.0, dt=dt, kick=seed.amplitude * seed.omega,
                                            periods=20, rtol=1e-5)
        label = "default" if dt is None else f"{dt:.3g}"
        if measured.found:
            print(f"  simulation dt = {label:>8} s: A = {measured.amplitude:.8f} rad "
                  f"({measured.amplitude / reference.amplitude - 1.0:+.2e} against the order-6 orbit)")
        else:
            print(f"  simulation dt = {label:>8} s: {measured.verdict}")


LIMITED = {
    "kp=3000 limit 50": {"kp": 3000.0, "torque_limit": 50.0},
    "kp=3000 limit 200": {"kp": 3000.0, "torque_limit": 200.0},
    "kp=300 limit 30": {"kp": 300.0, "torque_limit": 30.0},
    "ti=2ms limit 30, T_l=20": {"kp": 100.0, "ti": 0.002, "torque_limit": 30.0},
    "cascade motor kv=20": {"structure": "cascade", "kv": 20.0, "position_feedback": "motor"},
    "cascade load, limit 30": {"structure": "cascade", "kv": 20.0, "position_feedback": "load", "kp": 300.0,
                               "torque_limit": 30.0},
    "  + delay 0.5 ms": {"structure": "cascade", "kv": 20.0, "position_feedback": "load", "kp": 300.0,
                         "torque_limit": 30.0, "delay": 0.0005},
}


def limited_table(base):
    print("\n4. Torque limit and cascades (load_feedback.toml retuned; CPU s)")
    print(f"{'loop':24} {'orbit A':>8} {'w':>7} {'on limit':>8} {'cmd N m':>8} {'|mu|max':>7} {'shoot s':>8} "
          f"{'sim t_end':>9} {'sim s':>7} {'dA/A':>9} {'dw/w':>9}")
    for name, values in LIMITED.items():
        load = 20.0 if "T_l" in name else 0.0
        rig = dataclasses.replace(base, controller=dataclasses.replace(base.controller, **values),
                                  load=dataclasses.replace(base.load, torque=load))
        _, result = simulated_limit_cycle(rig, "phase-plane", t_end=5.0, kick=1.0)
        seconds, orbit = timing.best_of(lambda: periodic_orbit(rig, "phase-plane", result), 3)
        dt, t_end, found = orbit.period / 2048, 1.0, None
        while t_end <= 256.0 and found is None:
            def run():
                return measure_limit_cycle(bd.simulate(rig, "phase-plane", t_end=t_end, dt=dt, kick=1.0),
                                           periods=20, rtol=1e-5)

            measured = run()
            if (measured.found and abs(measured.amplitude / orbit.amplitude - 1.0) < 1e-5
                    and abs(measured.omega / orbit.omega - 1.0) < 1e-6):
                found = timing.best_of(run, 3)
            else:
                t_end *= 2.0
        limit = (f"{orbit.saturated_fraction:8.1%} {orbit.command_amplitude:8.2f}" if orbit.torque_limit
                 else f"{'none':>8} {'':>8}")
        simulated = (f"{t_end:9.0f} {found[0]:7.2f} {found[1].amplitude / orbit.amplitude - 1.0:9.1e} "
                     f"{found[1].omega / orbit.omega - 1.0:9.1e}" if found else f"{'>256 s':>9}")
        print(f"{name:24} {orbit.amplitude:8.4f} {orbit.omega:7.2f} {limit} {orbit.max_multiplier:7.4f} "
              f"{seconds:8.3f} {simulated}")


def main():
    all_rigs = rigs()
    periodic_orbit(all_rigs["load_feedback"], "phase-plane", (0.166, 98.7))  # compile the kernels once
    timing_table(all_rigs)
    df_error_table(all_rigs)
    dead_time_table()
    limited_table(all_rigs["load_feedback"])


if __name__ == "__main__":
    main()
