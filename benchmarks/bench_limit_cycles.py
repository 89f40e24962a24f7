"""Closed-loop simulation: the package's kernel against solve_ivp and a compiled integrator.

Run: ``python benchmarks/bench_limit_cycles.py``.  Every integrator runs the same loop (the
PI loop of ``examples/load_feedback.toml``, 2 s from a kick dtheta_d(0) = 15 rad/s, which
settles towards the limit cycle).  Accuracy is the largest error of theta_d on a common time
grid against an independent reference: ``solve_ivp`` DOP853 at rtol 1e-13 with every
switch of the torque law located as an event.  (Checked once against Radau with events at
rtol 1e-12, an implicit method of another family: they agree to 1.1e-12 rad on the phase
plane loop, below the kernel's error; Radau takes minutes, so it is not rerun here.)
Times are CPU times of this process (steadier than wall time on a shared machine), the
best of three on both sides of every ratio.

Phase plane law (23), numerical vs numerical at matched accuracy; each competitor runs at
the loosest rtol in 1e-9 ... 1e-13 that is at least as accurate as the kernel:

- ``solve_ivp`` RK45, DOP853 and LSODA, each with event location (the law's guards, the
  integration restarted at every switch: without events a step across a switch is only
  first-order accurate), and RK45 without events as a user might first write it;
- the compiled Dormand-Prince 5(4) with event location of ``compiled_rk.py`` (mode
  held through each step, switches bisected on the dense output), over the law's
  affine modes; ``bench_simulation.py`` adds DOP853 and CVODE and draws the
  work-precision curves.

The exact model (1)+(14) against RK45 without events (theta_b as a fourth state; LSODA
without events takes minutes through the saturations of (14)).

Last (unless ``--speed-only`` is given), full design maps (the notebook draws a 4 x 3
one): over 10 x 8 (kp, ti) grids around ``examples/load_feedback.toml`` and ``examples/motor_lag_feedback.toml``,
where the phase plane (23) and dead-zone (26) DFs predict a stable cycle and where
simulation with the same law shows one; the agreement counts are printed and the
maps saved to ``build/design_map_<rig>.png``.
"""

import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from backlash_df import load_rig, simulate
from backlash_df.sweeps import design_map
from backlash_df.loops import drive_loop
from backlash_df._laws import exact_torque, mode_torque, static_torque
from backlash_df.simulation import default_step, initial_state
import compiled_rk
from switched import phase_plane_guards, solve_switched
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / "examples" / "load_feedback.toml"
T_END, KICK = 2.0, 15.0
REPEAT = 3
RTOLS = 10.0 ** -np.arange(9, 14)


class Loop:
    """The linear part and the law of one rig as plain arrays: ``dz/dt = A z + b T(c_x z, c_v z)``."""

    def __init__(self, rig, name):
        part = drive_loop(rig).linear_part()
        self.model = rig.make_model(name)
        self.law = self.model.law
        self.params = self.model.params
        self.a, self.b, self.c_x, self.c_v = part.A, part.b, part.c_x, part.c_v
        self.z0 = initial_state(part, None, KICK)

    def xv(self, z):
        return self.c_x @ z, self.c_v @ z

    def rhs(self, mode):
        """Right-hand side with the contact mode held (smooth: the law's torque in that mode)."""
        def f(t, z):
            x, v = self.xv(z)
            return self.a @ z + self.b * mode_torque(self.law, mode, x, v, *self.params)
        return f

    def guards(self, mode):
        return phase_plane_guards(mode, self.xv, *self.params[:3])


def scipy_events(loop, method, rtol, t_eval):
    """solve_ivp with event location, restarted at each switch; theta_d on ``t_eval``."""
    return solve_switched(loop.rhs, loop.guards, loop.z0, 0, T_END, t_eval, method, rtol)


def scipy_plain(loop, method, rtol, t_eval):
    """solve_ivp without events, the law read as a memoryless T(x, v) (a user's first attempt)."""
    def f(t, z):
        x, v = loop.xv(z)
        return loop.a @ z + loop.b * static_torque(loop.law, x, v, *loop.params)

    return solve_ivp(f, (0.0, T_END), loop.z0, method=method, rtol=rtol, atol=rtol * 1e-3, t_eval=t_eval).y[0]


def numba_events(loop, rtol, t_eval):
    """The compiled Dormand-Prince 5(4) with event location of ``compiled_rk.py``; theta_d on ``t_eval``."""
    k, c, alpha, _ = loop.params
    contact = np.outer(loop.b, k * loop.c_x + c * loop.c_v)
    mats = np.stack([loop.a + (contact if m else 0.0) for m in (-2, 0, 2)])
    offs = np.stack([-np.sign(m) * k * alpha * loop.b for m in (-2, 0, 2)])
    out = np.full(t_eval.size, np.nan)
    compiled_rk.integrate(compiled_rk.DP5, *compiled_rk.tableau(compiled_rk.DP5), mats, offs, loop.law,
                          np.array(loop.params, dtype=float), loop.c_x, loop.c_v, 0, loop.z0, T_END, rtol, t_eval, out)
    return out


def scipy_exact(loop, method, rtol, t_eval):
    """The exact model (1)+(14) in solve_ivp: theta_b as a fourth state, no events."""
    k, c, alpha, _ = loop.params

    def f(t, z):
        x, v = loop.xv(z[:-1])
        tb = min(max(z[-1], -alpha), alpha)
        rate = (k / c) * (x + c / k * v - tb)  # (14): the limited integrator
        if (tb >= alpha and rate > 0) or (tb <= -alpha and rate < 0):
            rate = 0.0
        return np.append(loop.a @ z[:-1] + loop.b * exact_torque(x, v, tb, k, c, alpha), rate)

    z0 = np.append(loop.z0, 0.0)
    return solve_ivp(f, (0.0, T_END), z0, method=method, rtol=rtol, atol=rtol * 1e-3, t_eval=t_eval).y[0]


def max_error(values, reference):
    return float(np.max(np.abs(values - reference)))


def matched(run, reference, target, rtols=RTOLS):
    """The loosest of ``rtols`` at least as accurate as ``target`` (else the tightest), timed."""
    for rtol in rtols:
        if max_error(run(rtol), reference) <= target:
            break
    seconds, values = best_of(lambda: run(rtol), REPEAT)
    return rtol, seconds, max_error(values, reference)


def speed_table(rig, name, competitors, reference_run):
    """Kernel against each competitor at matched accuracy, on the kernel's time grid (every 4th sample)."""
    dt = default_step(drive_loop(rig).linear_part(), rig.make_model(name))
    dt = T_END / (4 * round(T_END / (4 * dt)))
    simulate(rig, name, t_end=T_END, dt=dt, kick=KICK)  # compile
    ours, result = best_of(lambda: simulate(rig, name, t_end=T_END, dt=dt, kick=KICK), REPEAT)
    t_eval = result.time[::4]
    reference = reference_run(1e-13, t_eval)
    ours_error = target = max_error(result.theta_d[::4], reference)
    print(f"  {name}: competitors must reach the kernel's {target:.1e} rad")
    print(f"    {'integrator':<44s}{'rtol':>7s}{'best CPU':>12s}{'sim-s/s':>9s}{'max err (rad)':>15s}{'vs kernel':>11s}")
    print(f"    {f'backlash-df kernel, dt = {dt:.1e} s':<44s}{'-':>7s}{ours * 1e3:9.1f} ms{T_END / ours:9.0f}"
          f"{ours_error:15.1e}{'(base)':>11s}")
    for label, run, rtols in competitors:
        rtol, seconds, error = matched(lambda r: run(r, t_eval), reference, target, rtols)
        note = "" if error <= target else "  (never as accurate)"
        note += "  (the reference's method)" if error == 0.0 else ""
        print(f"    {label:<44s}{rtol:7.0e}{seconds * 1e3:9.1f} ms{T_END / seconds:9.1f}{error:15.1e}"
              f"{seconds / ours:10.0f}x{note}")


def speed_tables(rig):
    print(f"closed loop of {RIG.name}: {T_END:g} s simulated from a kick of {KICK:g} rad/s; best of {REPEAT}; "
          "each competitor at the loosest rtol as accurate as the kernel")
    loop = Loop(rig, "phase-plane")
    competitors = [("numba Dormand-Prince 5(4) + events (compiled)", lambda r, t: numba_events(loop, r, t), RTOLS)]
    for method in ("RK45", "DOP853", "LSODA"):
        competitors.append((f"solve_ivp {method} + events", lambda r, t, m=method: scipy_events(loop, m, r, t), RTOLS))
    competitors.append(("solve_ivp RK45, no events", lambda r, t: scipy_plain(loop, "RK45", r, t), (1e-6, 1e-8)))
    speed_table(rig, "phase-plane", competitors, lambda r, t: scipy_events(loop, "DOP853", r, t))
    exact = Loop(rig, "exact")
    competitors = [(f"solve_ivp {m}, theta_b a state, no events", lambda r, t, m=m: scipy_exact(exact, m, r, t),
                    (1e-6, 1e-8)) for m in ("RK45",)]
    speed_table(rig, "exact", competitors, lambda r, t: scipy_exact(exact, "DOP853", r, t))


def design_map_sweep(path, kp, ti):
    """Full (kp, ti) design map of one rig: DF against simulation, per model."""
    rig = load_rig(path)
    start = time.process_time()
    dmap = design_map(rig, kp, ti, models=("phase-plane", "damped-dead-zone"))
    wall = time.process_time() - start
    print(f"design map of {path.name}: {kp.size} x {ti.size} tunings, 2 laws, {wall:.1f} s wall")
    for name, predicted in dmap.predicted.items():
        simulated = dmap.simulated[name]
        print(f"  {name:17s} cycles predicted {predicted.sum():3d}, simulated {simulated.sum():3d}, "
              f"agree {np.mean(predicted == simulated):6.1%} "
              f"(predicted only {np.sum(predicted & ~simulated)}, simulated only {np.sum(simulated & ~predicted)})")
    (ROOT / "build").mkdir(exist_ok=True)
    dmap.plot().figure.savefig(ROOT / "build" / f"design_map_{path.stem}.png", dpi=100, bbox_inches="tight")


def main():
    speed_tables(load_rig(RIG))
    if "--speed-only" in sys.argv[1:]:
        return
    design_map_sweep(RIG, np.geomspace(5.0, 200.0, 10), np.geomspace(0.02, 2.0, 8))
    design_map_sweep(ROOT / "examples" / "motor_lag_feedback.toml", np.geomspace(60.0, 400.0, 10),
                     np.geomspace(0.05, 1.0, 8))


if __name__ == "__main__":
    main()
