"""Closed-loop simulation speed against scipy's solve_ivp, and ``backlash-df predict`` wall time.

Run: ``python benchmarks/bench_limit_cycles.py``.  Same loop in both (the PI loop of
``examples/load_feedback.toml``, 5 s from a kick dtheta_d(0) = 15 rad/s, which
settles onto the limit cycle); accuracy is the largest error of theta_d against
an independent reference, ``solve_ivp`` with DOP853 at rtol 1e-13, for both
integrators, so the speed ratio is read next to the accuracy each one reached.
Besides RK45 (the issue's named alternative), LSODA at rtol 1e-8 is timed on the
phase plane loop: the strongest scipy setting found, the honest worst case.

Last, full design maps (the notebook draws a 4 x 3 one): over 10 x 8 (kp, ti)
grids around ``examples/load_feedback.toml`` and ``examples/motor_lag_feedback.toml``,
where the phase plane (23) and dead-zone (26) DFs predict a stable cycle and where
simulation with the same law shows one; the agreement counts are printed and the
maps saved to ``build/design_map_<rig>.png``.
"""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from backlash_df import load_rig, simulate
from backlash_df.sweeps import design_map
from backlash_df.loops import drive_loop
from backlash_df.models import exact_torque, static_torque
from backlash_df.simulate import _initial_state, default_step

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "examples" / "load_feedback.toml"
T_END, KICK = 5.0, 15.0


def kernel(rig, name, dt):
    start = time.perf_counter()
    result = simulate(rig, name, t_end=T_END, dt=dt, kick=KICK)
    return time.perf_counter() - start, result


def scipy_run(rig, name, rtol, t_eval, method="RK45"):
    part = drive_loop(rig).linear_part()
    model = rig.make_model(name)
    k, c, alpha, beta = model.params
    a, b = part.A, part.b
    z0 = _initial_state(part, None, KICK)
    if name == "exact":
        # theta_b as an extra state: the limited integrator (14), d theta_b/dt = (k/c)(y - theta_b) off contact
        def rhs(t, z):
            x, v, tb = part.c_x @ z[:-1], part.c_v @ z[:-1], min(max(z[-1], -alpha), alpha)
            torque = exact_torque(x, v, tb, k, c, alpha)
            rate = (k / c) * (x + c / k * v - tb)
            if (tb >= alpha and rate > 0) or (tb <= -alpha and rate < 0):
                rate = 0.0
            return np.append(a @ z[:-1] + b * torque, rate)

        z0 = np.append(z0, 0.0)
    else:
        law = model.law

        def rhs(t, z):
            return a @ z + b * static_torque(law, part.c_x @ z, part.c_v @ z, k, c, alpha, beta)

    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, T_END), z0, method=method, rtol=rtol, atol=rtol * 1e-3, t_eval=t_eval)
    return time.perf_counter() - start, sol.y[0]


def design_map_sweep(path, kp, ti):
    """Full (kp, ti) design map of one rig: DF against simulation, per model."""
    rig = load_rig(path)
    start = time.perf_counter()
    dmap = design_map(rig, kp, ti, models=("phase-plane", "damped-dead-zone"))
    wall = time.perf_counter() - start
    print(f"design map of {path.name}: {kp.size} x {ti.size} tunings, 2 laws, {wall:.1f} s wall")
    for name, predicted in dmap.predicted.items():
        simulated = dmap.simulated[name]
        print(f"  {name:17s} cycles predicted {predicted.sum():3d}, simulated {simulated.sum():3d}, "
              f"agree {np.mean(predicted == simulated):6.1%} "
              f"(predicted only {np.sum(predicted & ~simulated)}, simulated only {np.sum(simulated & ~predicted)})")
    (ROOT / "build").mkdir(exist_ok=True)
    dmap.plot()[0, 0].figure.savefig(ROOT / "build" / f"design_map_{path.stem}.png", dpi=100, bbox_inches="tight")


def main():
    rig = load_rig(RIG)
    print(f"closed loop of {RIG.name}: {T_END} s simulated, kick {KICK} rad/s")
    for name in ("phase-plane", "exact"):
        dt = default_step(drive_loop(rig).linear_part(), rig.make_model(name))
        dt = T_END / (4 * round(T_END / (4 * dt)))  # steps a multiple of 4: samples of dt and 4 dt align
        kernel(rig, name, dt)  # compile
        t_ref = np.linspace(0.0, T_END, round(T_END / (4 * dt)) + 1)
        _, reference = scipy_run(rig, name, 1e-13, t_ref, method="DOP853")
        runs = []
        for factor in (1, 4):
            wall, result = min((kernel(rig, name, factor * dt) for _ in range(3)), key=lambda r: r[0])
            assert np.allclose(result.time[:: 4 // factor], t_ref, rtol=0.0, atol=1e-9)
            error = np.abs(result.theta_d[:: 4 // factor] - reference).max()
            runs.append((error, wall))
            print(f"  {name:12s} kernel    dt={factor * dt:.1e} s   : {T_END / wall:9.1f} sim-s/wall-s, max err {error:.1e} rad")
        competitors = [("RK45", 1e-8), ("RK45", 1e-10)] + ([("LSODA", 1e-8)] if name == "phase-plane" else [])
        for method, rtol in competitors:
            wall_ivp, theta_ivp = scipy_run(rig, name, rtol, t_ref, method=method)
            error = np.abs(theta_ivp - reference).max()
            print(f"  {name:12s} solve_ivp {method} rtol={rtol:.0e}: {T_END / wall_ivp:9.1f} sim-s/wall-s, "
                  f"max err {error:.1e} rad")
            # matched accuracy: the fastest kernel run at least as accurate as this solve_ivp run
            matched = [wall for err, wall in runs if err <= error]
            if matched:
                print(f"  {name:12s}   ratio at matched accuracy (kernel at least as accurate): {wall_ivp / min(matched):.0f}x")
    command = [str(Path(sys.executable).parent / "backlash-df"), "predict", str(RIG.relative_to(ROOT))]
    start = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    status = "ok" if done.returncode == 0 else f"FAILED (exit {done.returncode}): {done.stderr.strip()[-200:]}"
    print(f"backlash-df predict examples/{RIG.name}: {wall:.1f} s wall end to end (target < 20 s), {status}")
    if done.returncode == 0:
        print(done.stdout.rstrip())
    design_map_sweep(RIG, np.geomspace(5.0, 200.0, 10), np.geomspace(0.02, 2.0, 8))
    design_map_sweep(ROOT / "examples" / "motor_lag_feedback.toml", np.geomspace(60.0, 400.0, 10),
                     np.geomspace(0.05, 1.0, 8))


if __name__ == "__main__":
    main()
