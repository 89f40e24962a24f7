"""Work-precision curves of the closed-loop simulation: the kernel against solve_ivp, compiled RK and CVODE.

Run: ``python benchmarks/bench_simulation.py [--repeat 3] [--cases N] [--no-profile]``
(about 10 minutes on one core with the defaults; ``--cases 1`` only the first case).

Cases: the PI loops of ``examples/load_feedback.toml`` with the phase plane law
(19)-(23) and the damped dead-zone (26), and of ``examples/motor_lag_feedback.toml``
with the phase plane law; 2 s from a kick dtheta_d(0) = 15 rad/s (the least-norm state,
:func:`backlash_df.simulation.initial_state`), which settles towards the limit cycle
through about 120 switches.  All three laws are piecewise affine.

**Error**: the largest |theta_d - theta_d,ref| over one output grid (every 1 ms,
2001 points, the same for every method), divided by the range of theta_d,ref.

**Reference**: the exact flow of each mode, the exponential of the mode's affine
matrix in long double (64-bit mantissa; balanced, scaled and squared, Taylor series),
from event to event and from output point to output point; the switching surfaces are
scanned on a 1 us grid and every crossing bisected to 1e-21 s in long double.  It is written here from the
rig's :class:`~backlash_df.system.LinearPart` and the law's surfaces
(``switched.py``), independent of the package's kernels.  Checked by refinement
(scan grid 0.25 us) and against the same computation in double precision: both
differences are printed and lie far below 1e-13.

**Methods**, each on the same right-hand side ``dz/dt = A_m z + f_m`` of mode m:

* the package's kernel, :func:`backlash_df.simulate`, at steps 1, 1/2, 1/5, 1/10 and
  1/20 of the output spacing (exact between events; the step only decides which short
  contacts it sees and how events are bracketed);
* ``scipy.integrate.solve_ivp`` RK45, DOP853, LSODA and Radau, integrated mode by mode
  with event location at the switching surfaces and a restart at every switch, rtol
  1e-5 ... 1e-13 (atol 1e-3 rtol); Radau and LSODA get the exact Jacobian ``A_m``;
* DP5 and DOP853 compiled with numba (``compiled_rk.py``), events bisected on their
  dense output, rtol 1e-5 ... 1e-13;
* SUNDIALS CVODE with root finding (scikit-sundae), Adams and BDF (exact Jacobian),
  restarted at every root, rtol 1e-5 ... 1e-13.

**CPU time**: ``time.process_time`` of this process, best of ``--repeat`` (a run over
2 s: once; runs under 0.1 s as many times as fill 0.3 s, at most 50), of the whole call a
user makes (the kernel: ``simulate`` with its setup); a method whose run takes over 20 s
is not run at tighter tolerances.
**Work**: the kernel's steps; the others' right-hand side evaluations as each reports
them (``nfev``; the compiled pairs count their own, dense-output stages included).

After each case's table: the kernel's time as a cost per call plus a cost per step
(least squares over its five runs); the **floor**, a numba loop doing the kernel's work per step
(one product with the (n + 2) x (n + 2) mode matrix of the augmented state, the state,
torque and mode recorded, the mode guard ``backlash_df._laws.held_mode``) and the
kernel's time per step against it; and the **profile** of the kernel's run by ``perf``
(sampled at 4 kHz over 200 runs after the warm-up; numba's code named through a perf map
written from the compiled libraries, which the worker compiles afresh for their symbols, the
compile's Python objects then frozen out of the garbage collector's reach, as in a process that
loads its kernels from the cache): the share of the process of the top three functions.  Then
the laws of the RK4 kernel (rubber, beta 0.01 and 0.05, and ElastoBacklash on
``load_feedback.toml``, no reference: their time per step only): the same floor row and a
**4-stage floor**, a numba loop doing RK4's work per step (four stages ``A z + b T``, each with
the law's torque, the kernel's record of state, torque, theta_b and both modes, the mode
guard), against ``simulate``'s time per step; and the RK4 kernel **with friction**, stick modes active (the
stick-slip PI cascade of ``tests/test_friction_loop.py``, 8 s: the load sticks and slips 18 times), against both
floors run on its linear part without friction (target: within 3x of the 4-stage floor), with its error against
the run at half the step.  Last, the summary at errors 1e-6 and 1e-10: the cheapest run of each method
and the kernel's time against the best competitor's; ``build/work_precision.png``.
"""

import argparse
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numba
import numpy as np
from scipy.linalg import expm, matrix_balance

from backlash_df import load_rig, make_model, rig_from_dict, simulate
from backlash_df.loops import drive_loop
from backlash_df._laws import held_mode, mode_torque
from backlash_df.models import EQUATIONS
from backlash_df.simulation import initial_state
from backlash_df._switching import mode_matrices
import compiled_rk
from switched import dead_zone_surfaces, on_state, phase_plane_surfaces, solve_modes
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
CASES = (("load_feedback.toml", "phase-plane"), ("load_feedback.toml", "damped-dead-zone"),
         ("motor_lag_feedback.toml", "phase-plane"))
T_END, KICK, GRID = 2.0, 15.0, 1e-3
SPLITS = (1, 2, 5, 10, 20)  # kernel steps GRID / split
RTOLS = 10.0 ** -np.arange(5, 14)
SCAN, BISECT_TO = 1e-6, 1e-21  # the reference's surface scan and event precision, s
TARGETS = (1e-6, 1e-10)
ONCE_ABOVE = 2.0
MIN_TIMED, MAX_REPEAT = 0.3, 50  # s: runs shorter than MIN_TIMED / repeat are repeated more, up to MAX_REPEAT
GIVE_UP = 20.0  # s: a method slower than this per run is not run at tighter tolerances
PROFILE_RUNS = 200
COMPILED = {"numba DP5 + events": compiled_rk.DP5, "numba DOP853 + events": compiled_rk.DP8}


class ClosedLoop:
    """One case: a rig's PI loop and a piecewise-affine law, as per-mode affine systems ``dz/dt = A_m z + f_m``."""

    def __init__(self, rig_name, law_name):
        self.rig_name, self.law_name = rig_name, law_name
        self.rig = load_rig(ROOT / "examples" / rig_name)
        self.name = f"{rig_name}, {law_name} {EQUATIONS[law_name]}"
        self.label = f"{Path(rig_name).stem}/{law_name}"
        self.model = self.rig.make_model(law_name)
        self.part = part = drive_loop(self.rig).linear_part()
        k, c, alpha, _ = self.model.params
        inputs = part.E @ np.array([0.0, self.rig.load.torque])  # simulate's defaults: r = 0, the rig's load
        contact = np.outer(part.b, k * part.c_x + c * part.c_v)
        self.affine = {m: (part.A + (contact if m else 0.0), inputs - np.sign(m) * k * alpha * part.b)
                       for m in (-2, 0, 2)}
        self.mats = np.stack([self.affine[m][0] for m in (-2, 0, 2)])
        self.offs = np.stack([self.affine[m][1] for m in (-2, 0, 2)])
        self.z0 = initial_state(part, None, KICK)
        self.t_eval = np.arange(round(T_END / GRID) + 1) * GRID
        if law_name == "phase-plane":
            self.surfaces = lambda mode: phase_plane_surfaces(mode, k, c, alpha)
        else:
            self.surfaces = lambda mode: dead_zone_surfaces(mode, alpha)

    def xv(self, z):
        return self.part.c_x @ z, self.part.c_v @ z

    def rhs(self, mode):
        a_m, f_m = self.affine[mode]
        return lambda t, z: a_m @ z + f_m

    def jac(self, mode):
        a_m = self.affine[mode][0]
        return lambda t, z: a_m

    def guards(self, mode):
        return on_state(self.surfaces(mode), self.xv)


# --------------------------------------------------------------------------- the reference


def expm_taylor(m, dtype=np.longdouble):
    """``exp(m)`` in ``dtype``: balanced (exact powers of 2), scaled and squared, Taylor series to degree 30.

    Without the balancing, the loop's mixed units (rad against rad/s, entries from 1 to
    1e4) leave a relative error some 1e5 times the precision after the squarings.
    """
    _, (scaling, _) = matrix_balance(np.asarray(m, dtype=float), permute=False, separate=True)
    scaling = scaling.astype(dtype)
    x = np.asarray(m, dtype=dtype) * scaling[None, :] / scaling[:, None]
    norm = float(np.abs(x).sum(axis=1).max())
    squarings = max(0, math.ceil(math.log2(norm))) if norm > 0.0 else 0
    x = x / dtype(2.0) ** squarings
    term = result = np.eye(m.shape[0], dtype=dtype)
    for j in range(1, 31):
        term = term @ x / j
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result * scaling[:, None] / scaling[None, :]


def exact_reference(loop, scan=SCAN, dtype=np.longdouble):
    """theta_d on ``loop.t_eval`` by the exact flow of each mode; (theta_d, switches).

    The state ``q = (z, 1)`` is carried in ``dtype`` from event to event and from output
    to output with ``exp(M_m s)``; each mode's surfaces are scanned on a grid of ``scan``
    seconds (in double) and every crossing bisected on the exact flow to ``BISECT_TO``.
    """
    n = loop.z0.size
    augmented = {}
    for mode, (a_m, f_m) in loop.affine.items():
        m_aug = np.zeros((n + 1, n + 1))
        m_aug[:n, :n], m_aug[:n, n] = a_m, f_m
        augmented[mode] = m_aug
    def exp(m):
        return expm_taylor(m, dtype)

    steps = round(GRID / scan)
    scans = {mode: np.stack([expm(m_aug * scan * j) for j in range(1, steps + 1)]) for mode, m_aug in augmented.items()}
    rows = np.array([loop.part.c_x, loop.part.c_v])
    q = np.append(loop.z0, 1.0).astype(dtype)
    t, mode, switches = dtype(0.0), 0, 0
    out = np.empty(loop.t_eval.size)
    out[0] = float(loop.part.c_x @ loop.z0)

    def crossed(state, surfaces):
        x, v = (rows @ state[:n].astype(float)) if state.ndim == 1 else rows @ state[:, :n].T.astype(float)
        return np.array([np.asarray(g(x, v)) < 0.0 for g, _ in surfaces])

    for i in range(1, loop.t_eval.size):
        while True:
            span = dtype(loop.t_eval[i]) - t
            surfaces = loop.surfaces(mode)
            count = min(steps, math.ceil(float(span) / scan))
            ahead = np.vstack([scans[mode][:count - 1] @ q.astype(float), exp(augmented[mode] * span) @ q])
            below = crossed(ahead, surfaces)
            if not below.any():
                q, t = ahead[-1].astype(dtype), t + span
                break
            first = int(np.argmax(below.any(axis=0)))
            lo, hi = dtype(first * scan), min(dtype((first + 1) * scan), span)
            while hi - lo > BISECT_TO and lo < (lo + hi) / 2 < hi:
                mid = (lo + hi) / 2
                if crossed(exp(augmented[mode] * mid) @ q, surfaces).any():
                    hi = mid
                else:
                    lo = mid
            state = exp(augmented[mode] * hi) @ q
            mode = surfaces[int(np.argmax(crossed(state, surfaces)))][1]
            q, t, switches = state, t + hi, switches + 1
        out[i] = float(rows[0] @ q[:n].astype(float))
    return out, switches


# --------------------------------------------------------------------------- the methods


def kernel_run(loop, split):
    result = simulate(loop.rig, loop.model, t_end=T_END, dt=GRID / split, kick=KICK)
    return result.theta_d[::split], result.time.size - 1


def scipy_run(loop, method, rtol):
    states, nfev, _ = solve_modes(loop.rhs, loop.guards, loop.z0, 0, T_END, loop.t_eval, method, rtol, loop.jac)
    return loop.part.c_x @ states, nfev


def compiled_run(loop, method, rtol):
    arrays = compiled_rk.tableau(method)
    out = np.full(loop.t_eval.size, np.nan)
    nfev, _ = compiled_rk.integrate(method, *arrays, loop.mats, loop.offs, loop.model.law, loop.model.params,
                                    loop.part.c_x, loop.part.c_v, 0, loop.z0, T_END, rtol, loop.t_eval, out)
    return out, nfev


def cvode_run(loop, method, rtol):
    """CVODE (scikit-sundae) with root finding, restarted in the new mode at every root."""
    solvers = {mode: cvode_solver(loop, mode, method, rtol) for mode in (-2, 0, 2)}
    out = np.full(loop.t_eval.size, np.nan)
    out[0] = loop.part.c_x @ loop.z0
    t, z, mode, nfev = 0.0, loop.z0, 0, 0
    while t < T_END:
        later = loop.t_eval[loop.t_eval > t]
        first = loop.t_eval.size - later.size
        # more than two times: output at them (two would mean CVODE's own steps)
        tspan = np.concatenate(([t], later if later.size > 1 else [0.5 * (t + later[0]), later[0]]))
        result = solvers[mode].solve(tspan, z)
        if not result.success:
            raise RuntimeError(f"CVODE failed at t = {t}: {result.message}")
        nfev += result.nfev
        stopped = result.status == 2  # a root (the events of earlier solves stay listed before it)
        times, states = (result.t[1:-1], result.y[1:-1]) if stopped else (result.t[1:], result.y[1:])
        reached = np.isin(times, later)
        out[first:first + reached.sum()] = states[reached] @ loop.part.c_x
        if not stopped:
            break
        which = int(np.flatnonzero(result.i_events[-1])[0])
        t, z, mode = float(result.t_events[-1]), result.y_events[-1].copy(), loop.surfaces(mode)[which][1]
    return out, nfev


def cvode_solver(loop, mode, method, rtol):
    """A CVODE solver of one mode, its surfaces as terminal roots (falling through zero)."""

    a_m, f_m = loop.affine[mode]
    surfaces = loop.surfaces(mode)

    def rhs(t, y, yp):
        yp[:] = a_m @ y + f_m

    def events(t, y, values):
        x, v = loop.xv(y)
        for i, (g, _) in enumerate(surfaces):
            values[i] = g(x, v)

    def jacobian(t, y, yp, jj):
        jj[:, :] = a_m

    events.terminal, events.direction = [True] * len(surfaces), [-1] * len(surfaces)
    options = {"jacfn": jacobian} if method == "BDF" else {}
    from sksundae.cvode import CVODE  # here: only the CVODE rows need scikit-sundae (the bench extra)

    return CVODE(rhs, method=method, rtol=rtol, atol=1e-3 * rtol, eventsfn=events, num_events=len(surfaces),
                 max_num_steps=1_000_000, **options)


def methods(loop):
    """(method, setting, run) for every point of every curve, curve by curve: run() gives (theta_d, work)."""
    for split in SPLITS:
        yield "backlash-df kernel", f"dt = {GRID / split:.0e} s", lambda s=split: kernel_run(loop, s)
    curves = [(label, lambda m, r: compiled_run(loop, m, r), method) for label, method in COMPILED.items()]
    curves += [(f"solve_ivp {m} + events", lambda m, r: scipy_run(loop, m, r), m)
               for m in ("RK45", "DOP853", "LSODA", "Radau")]
    curves += [(f"CVODE {m} + roots", lambda m, r: cvode_run(loop, m, r), m) for m in ("Adams", "BDF")]
    for label, run, method in curves:
        for rtol in RTOLS:
            yield label, f"rtol {rtol:.0e}", lambda run=run, m=method, r=rtol: run(m, r)


# --------------------------------------------------------------------------- the floor and the profile


@numba.njit(cache=True, inline="always")
def _stored(i, q, c_x, c_v, states):
    """``q[:n]`` stored as row ``i`` of ``states``; returns (x, v) = (c_x . q, c_v . q), as the kernels' record."""
    x = 0.0
    v = 0.0
    for j in range(c_x.size):
        states[i, j] = q[j]
        x += c_x[j] * q[j]
        v += c_v[j] * q[j]
    return x, v


@numba.njit(cache=True)
def floor_loop(phis, q0, law, p, c_x, c_v, n_steps, states, torque, modes):
    """The kernel's work per step without its event location: product, record, mode guard."""
    size = q0.size
    q, new = q0.copy(), np.empty(size)
    mode = 0
    for i in range(n_steps + 1):
        x, v = _stored(i, q, c_x, c_v, states)
        torque[i] = mode_torque(law, mode, x, v, p[0], p[1], p[2], p[3])
        modes[i] = mode
        if i == n_steps:
            break
        phi = phis[mode // 2 + 1]
        for r in range(size):
            acc = 0.0
            for j in range(size):
                acc += phi[r, j] * q[j]
            new[r] = acc
        q, new = new, q
        mode = held_mode(law, mode, x, v, p[0], p[1], p[2], p[3])
    return mode


def floor_row(loop, repeat):
    """(floor ns per step, kernel ns per step, matrix size) at the kernel's finest step of the table."""
    floor, size = product_floor(loop, repeat)
    kernel, _ = best_of(lambda: kernel_run(loop, SPLITS[-1]), max(repeat, 5))
    return floor, kernel / round(T_END / (GRID / SPLITS[-1])) * 1e9, size


def product_floor(loop, repeat, t_end=T_END):
    """(floor ns per step, matrix size): the floor loop over ``t_end`` at the kernel's finest step of the table."""
    dt = GRID / SPLITS[-1]
    n_steps = round(t_end / dt)
    phis = np.stack([expm(m_aug * dt) for m_aug in mode_matrices(loop.part, loop.model, loop.model.law)])
    q0 = np.zeros(phis.shape[1])
    q0[:loop.z0.size], q0[loop.z0.size + 1] = loop.z0, 1.0
    outputs = (np.empty((n_steps + 1, loop.z0.size)), np.empty(n_steps + 1), np.empty(n_steps + 1, dtype=np.int64))

    def run():
        return floor_loop(phis, q0, loop.model.law, loop.model.params, loop.part.c_x, loop.part.c_v, n_steps,
                          *outputs)

    run()
    floor, _ = best_of(run, max(repeat, 5))
    return floor / n_steps * 1e9, phis.shape[1]


@numba.njit(cache=True)
def floor_rk4_loop(a_mat, b_t, z0, law, p, c_x, c_v, dt, n_steps, states, torque, theta, modes, cmodes):
    """The RK4 kernel's work per step without events, inputs or friction: four stages ``A z + b T(mode, z)``,
    the combination, the kernel's record (state, torque, theta_b, both modes) and the mode guard."""
    n = z0.size
    z, tmp, k = z0.copy(), np.empty(n), np.empty((4, n))
    mode = 0
    for i in range(n_steps + 1):
        x, v = _stored(i, z, c_x, c_v, states)
        torque[i] = mode_torque(law, mode, x, v, p[0], p[1], p[2], p[3])
        theta[i] = 0.0
        modes[i] = mode
        cmodes[i] = 0
        if i == n_steps:
            break
        for j in range(n):
            tmp[j] = z[j]
        for s in range(4):
            xs = 0.0
            vs = 0.0
            for j in range(n):
                xs += c_x[j] * tmp[j]
                vs += c_v[j] * tmp[j]
            stage_torque = mode_torque(law, mode, xs, vs, p[0], p[1], p[2], p[3])
            for r in range(n):
                acc = b_t[r] * stage_torque
                for j in range(n):
                    acc += a_mat[r, j] * tmp[j]
                k[s, r] = acc
            if s < 3:
                ahead = dt if s == 2 else 0.5 * dt
                for j in range(n):
                    tmp[j] = z[j] + ahead * k[s, j]
        x = 0.0
        v = 0.0
        for j in range(n):
            z[j] = z[j] + dt / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            x += c_x[j] * z[j]
            v += c_v[j] * z[j]
        mode = held_mode(law, mode, x, v, p[0], p[1], p[2], p[3])
    return mode


#: The laws the RK4 kernel integrates (not piecewise affine), on load_feedback.toml: (law, beta).
RK4_LAWS = (("rubber", 0.01), ("rubber", 0.05), ("elasto-backlash", 0.0))


def rk4_loop(law, beta):
    """A case of the RK4 kernel: the PI loop of load_feedback.toml with ``law``, the attributes floor_row reads."""
    rig = load_rig(ROOT / "examples" / "load_feedback.toml")
    plant = rig.plant
    model = make_model(law, stiffness=plant.stiffness, damping=plant.damping, half_gap=plant.half_gap,
                       **({"rubber_thickness": beta} if beta else {}))
    part = drive_loop(rig).linear_part()
    return SimpleNamespace(rig=rig, model=model, part=part, z0=initial_state(part, None, KICK))


def rk4_floor_row(loop, repeat):
    """(floor_row's three numbers, the 4-stage floor's ns per step) of an RK4 case, in one process."""
    dt = GRID / SPLITS[-1]
    n_steps = round(T_END / dt)
    n = loop.z0.size
    outputs = (np.empty((n_steps + 1, n)), np.empty(n_steps + 1), np.empty(n_steps + 1),
               np.empty(n_steps + 1, dtype=np.int64), np.zeros(n_steps + 1, dtype=np.int64))

    def run():
        return floor_rk4_loop(loop.part.A, loop.part.b, loop.z0, loop.model.law, loop.model.params, loop.part.c_x,
                              loop.part.c_v, dt, n_steps, *outputs)

    run()
    four, _ = best_of(run, max(repeat, 5))
    return (*floor_row(loop, repeat), four / n_steps * 1e9)


def print_rk4_rows(repeat):
    for law, beta in RK4_LAWS:
        floor, kernel, size, four = rk4_floor_row(rk4_loop(law, beta), repeat)
        name = f"{law} (beta = {beta:g})" if beta else law
        print(f"  RK4 kernel, {name}, load_feedback (dt = {GRID / SPLITS[-1]:.0e} s): floor ({size} x {size} product) "
              f"{floor:.1f} ns/step, 4-stage floor {four:.1f} ns/step; kernel (whole call) {kernel:.0f} ns/step = "
              f"{kernel / floor:.1f}x the floor, {kernel / four:.1f}x the 4-stage floor", flush=True)


#: The RK4 kernel with friction, stick modes active: the stick-slip PI cascade of tests/test_friction_loop.py
#: (dead-zone shaft; Coulomb and breakaway friction on the load), hunting from a load angle of 0.01 rad.
FRICTION_RIG = {"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 0.0,
                          "half_gap": 0.002},
                "controller": {"structure": "cascade", "kp": 30.0, "ti": 0.2, "feedback": "motor", "kv": 20.0,
                               "position_feedback": "load"},
                "friction": {"coulomb_load": 20.0, "breakaway_load": 20.0, "stribeck_speed": 0.01},
                "model": {"backlash": "dead-zone"}}
FRICTION_T_END, FRICTION_START = 8.0, 0.01  # s, rad
FRICTION_TARGET = 3.0  # the target: the kernel with friction within 3x of the 4-stage floor


def friction_loop():
    """The stick-slip case: floor_row's attributes (its z0 the run's first state)."""
    rig = rig_from_dict(FRICTION_RIG, source="stick-slip cascade")
    part = drive_loop(rig, dry_friction=True).linear_part()
    z0 = np.zeros(part.A.shape[0])
    z0[part.state_names.index("load_angle")] = FRICTION_START
    return SimpleNamespace(rig=rig, model=rig.make_model(), part=part, z0=z0)


def friction_run(loop, dt):
    """``simulate`` of the stick-slip case at step ``dt``: the whole call a user makes, with one BLAS thread as the
    command line pins it (the CPU clock of best_of would otherwise count OpenBLAS threads spinning after the
    call's few small matrix functions, twice the kernel's time)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):
        return simulate(loop.rig, t_end=FRICTION_T_END, dt=dt, initial={"load_angle": FRICTION_START})


def friction_accuracy(loop, dt):
    """(max |load angle(dt) - load angle(dt / 2)| / its range, stick-slip transitions, share of the run stuck)."""
    coarse, fine = friction_run(loop, dt), friction_run(loop, dt / 2)
    reference = fine.state("load_angle")[::2]
    error = np.abs(coarse.state("load_angle") - reference).max() / np.ptp(reference)
    stuck = coarse.friction_mode[:, 0] == 0
    return float(error), int(np.count_nonzero(np.diff(stuck))), float(stuck.mean())


def friction_row(repeat):
    """(floor, 4-stage floor, kernel ns per step, matrix size, error, transitions, stuck share) of the stick-slip case,
    the floors run on its linear part and dead-zone law without friction, at the RK4 rows' step."""
    loop = friction_loop()
    dt = GRID / SPLITS[-1]
    n_steps = round(FRICTION_T_END / dt)
    n = loop.z0.size
    outputs = (np.empty((n_steps + 1, n)), np.empty(n_steps + 1), np.empty(n_steps + 1),
               np.empty(n_steps + 1, dtype=np.int64), np.zeros(n_steps + 1, dtype=np.int64))

    def floor4():
        return floor_rk4_loop(loop.part.A, loop.part.b, loop.z0, loop.model.law, loop.model.params, loop.part.c_x,
                              loop.part.c_v, dt, n_steps, *outputs)

    floor4()
    four, _ = best_of(floor4, max(repeat, 5))
    friction_run(loop, dt)  # compiles
    kernel, _ = best_of(lambda: friction_run(loop, dt), max(repeat, 5))
    floor, size = product_floor(loop, repeat, FRICTION_T_END)
    return floor, four / n_steps * 1e9, kernel / n_steps * 1e9, size, *friction_accuracy(loop, dt)


def print_friction_row(repeat):
    floor, four, kernel, size, error, transitions, stuck = friction_row(repeat)
    print(f"  RK4 kernel with friction, stick-slip cascade (dead-zone, Coulomb 20 + breakaway 20 N m on the load), "
          f"{FRICTION_T_END:g} s, dt = {GRID / SPLITS[-1]:.0e} s: {transitions} stick/slip transitions, stuck "
          f"{100 * stuck:.0f} % of the run; floor ({size} x {size} product) {floor:.1f} ns/step, 4-stage floor "
          f"{four:.1f} ns/step; kernel (whole call) {kernel:.0f} ns/step = {kernel / floor:.1f}x the floor, "
          f"{kernel / four:.1f}x the 4-stage floor (target within {FRICTION_TARGET:g}x); error against the run at "
          f"dt/2: {error:.1e} of the load angle's range", flush=True)


#: Coulomb friction in the exact kernel, stick modes active: motor_lag_feedback with 500 N m of Coulomb friction on
#: the load, kicked onto its backlash cycle, on which the load sticks twice a period (tests/test_friction_orbits.py).
COULOMB_CASE = ("motor_lag_feedback.toml", {"coulomb_load": 500.0}, {"motor_speed": 62.83}, 2.0)  # rig, friction, start, s


def coulomb_row(repeat):
    """(friction ns/step, frictionless ns/step, RK4 ns/step, floor ns/step, size, error, transitions, stuck share).

    ``simulate`` of the Coulomb case at the RK4 rows' step against the same rig without its friction (the
    exact kernel's own path, the named alternative), the same friction on the RK4 kernel (a breakaway of 1e-9
    N m, which the exact kernel does not take) and the one-product floor; the error is theta_d's against the
    run at dt/2, relative to its range (the exact kernel has no step-size error).
    """
    from threadpoolctl import threadpool_limits

    name, friction, start, t_end = COULOMB_CASE
    plain = load_rig(ROOT / "examples" / name)
    rubbing = plain.with_values(**friction)
    smooth = rubbing.with_values(breakaway_load=1e-9, stribeck_speed=1.0)
    dt = GRID / SPLITS[-1]
    n_steps = round(t_end / dt)

    def run(rig, step=dt):
        with threadpool_limits(1, user_api="blas"):
            return simulate(rig, t_end=t_end, dt=step, initial=start)

    times = []
    for rig in (rubbing, plain, smooth):
        run(rig)  # compiles
        times.append(best_of(lambda rig=rig: run(rig), max(repeat, 5))[0] / n_steps * 1e9)
    part = drive_loop(plain).linear_part()
    z0 = initial_state(part, start)
    floor, size = product_floor(SimpleNamespace(part=part, model=plain.make_model(), z0=z0), repeat, t_end)
    coarse, fine = run(rubbing), run(rubbing, dt / 2)
    error = np.abs(coarse.theta_d - fine.theta_d[::2]).max() / np.ptp(fine.theta_d)
    stuck = coarse.friction_mode[:, 0] == 0
    return (*times, floor, size, float(error), int(np.count_nonzero(np.diff(stuck))), float(stuck.mean()))


def print_coulomb_row(repeat):
    kernel, plain, rk4, floor, size, error, transitions, stuck = coulomb_row(repeat)
    name, friction, _, t_end = COULOMB_CASE
    print(f"  exact kernel with Coulomb friction, {name[:-5]} with {friction['coulomb_load']:g} N m on the load, "
          f"{t_end:g} s, dt = {GRID / SPLITS[-1]:.0e} s: {transitions} stick/slip transitions, stuck {100 * stuck:.0f} "
          f"% of the run; {kernel:.0f} ns/step = {kernel / floor:.1f}x the floor ({size} x {size} product, "
          f"{floor:.1f} ns/step, target within {FRICTION_TARGET:g}x), {kernel / plain:.2f}x the same loop without "
          f"friction ({plain:.0f} ns/step), the same friction on RK4 {rk4:.0f} ns/step ({rk4 / kernel:.1f}x); error "
          f"against the run at dt/2: {error:.1e} of theta_d's range", flush=True)


PROFILE_WORKER = """
import gc, sys, time
sys.path.insert(0, {bench!r})
import bench_simulation as b
loop = b.ClosedLoop({rig!r}, {law!r})
b.kernel_run(loop, {split})
b.write_perf_map()
# the compile's garbage, kept out of the collector's way: a user's process loads the kernels from
# numba's cache and holds none of it (unfrozen, a full collection of it was 22 % of the samples)
gc.collect()
gc.freeze()
print("ready", flush=True)
sys.stdin.readline()
for _ in range({runs}):
    b.kernel_run(loop, {split})
"""


def write_perf_map():
    """Name numba's compiled functions for perf: ``/tmp/perf-<pid>.map`` from every loaded library's symbols.

    The functions are those the libraries' LLVM IR defines; a function's extent is taken
    up to the next one's address (at most 64 KiB).
    """
    found = {}
    for module in list(sys.modules.values()):
        for value in list(vars(module).values()) if module else ():
            if isinstance(value, numba.core.registry.CPUDispatcher):
                for result in value.overloads.values():
                    library = result.library
                    for name in DEFINED.findall(library.get_llvm_str()):
                        address = library.get_pointer_to_function(name)
                        if address:
                            found[address] = name
    addresses = sorted(found)
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as handle:
        for address, following in zip(addresses, addresses[1:] + [addresses[-1] + 4096]):
            handle.write(f"{address:x} {min(following - address, 1 << 16):x} {demangled(found[address])}\n")


DEFINED = re.compile(r'^define [^@]*@"?([^"(]+)"?\(', re.MULTILINE)


def demangled(symbol):
    """``backlash_df.simulation._kernels._step_exactly`` from numba's mangled name."""
    parts, rest = [], symbol.removeprefix("cfunc.").removeprefix("_ZN")
    while rest and rest[0].isdigit():
        digits = len(rest) - len(rest.lstrip("0123456789"))
        size = int(rest[:digits])
        parts.append(rest[digits:digits + size])
        rest = rest[digits + size:]
    return ".".join(parts) or symbol


def profile(loop):
    """The top three functions of the kernel's run by perf samples: [(share, name)], or a reason why not."""
    if shutil.which("perf") is None:
        return "perf not found"
    with tempfile.TemporaryDirectory() as scratch:
        data = Path(scratch) / "perf.data"
        code = PROFILE_WORKER.format(bench=str(ROOT / "benchmarks"), rig=loop.rig_name, law=loop.law_name,
                                     split=SPLITS[-1],
                                     runs=PROFILE_RUNS)
        env = {**os.environ, "NUMBA_CACHE_DIR": scratch}  # compiled afresh: the libraries keep their symbols
        worker = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  text=True, env=env)
        try:
            worker.stdout.readline()
            record = subprocess.Popen(["perf", "record", "-F", "4000", "-o", str(data), "-p", str(worker.pid)],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            time.sleep(1.0)
            worker.stdin.write("go\n")
            worker.stdin.flush()
            worker.wait()
            record.wait()
            report = subprocess.run(["perf", "report", "-i", str(data), "--stdio", "--sort", "sym"],
                                    capture_output=True, text=True).stdout
        finally:
            Path(f"/tmp/perf-{worker.pid}.map").unlink(missing_ok=True)
    rows = []
    for line in report.splitlines():
        fields = line.split()
        if len(fields) >= 3 and fields[0].endswith("%") and fields[1] in ("[.]", "[k]"):
            rows.append((float(fields[0].rstrip("%")), " ".join(fields[2:])))
    if not rows:
        return "perf recorded no samples"
    compiled = sum(share for share, name in rows if name.startswith(("backlash_df.", "NRT_")))
    top = ", ".join(f"{name} {share:.1f} %" for share, name in sorted(rows, reverse=True)[:3])
    return f"{top}; all numba code (backlash-df's and numba's runtime NRT_*) {compiled:.1f} %"


# --------------------------------------------------------------------------- tables


def case_table(loop, repeat):
    """Every curve point of one case: [(method, setting, error, seconds, work)], printed."""
    reference, switches = exact_reference(loop)
    refined, _ = exact_reference(loop, scan=SCAN / 4)
    double, _ = exact_reference(loop, dtype=np.float64)
    scale = np.ptp(reference)
    print(f"\n{loop.name}: {T_END:g} s from a kick of {KICK:g} rad/s, {switches} switches, "
          f"{loop.t_eval.size} output points every {GRID * 1e3:g} ms; theta_d range {scale:.4g} rad")
    print(f"  reference (exact flow, long double): refined scan {np.abs(refined - reference).max() / scale:.1e}, "
          f"in double {np.abs(double - reference).max() / scale:.1e} (relative to the range)")
    print(f"  {'method':<30}{'setting':>16}{'error':>10}{'CPU s':>11}{'work':>11}")
    points, given_up = [], set()
    for method, setting, run in methods(loop):
        if method in given_up:
            continue
        if not any(p[0] == method for p in points):
            run()  # the first run of a method compiles or imports
        first, _ = best_of(run, 1)
        runs = min(MAX_REPEAT, max(repeat, int(MIN_TIMED / first)))  # short runs: more of them, for a steady best
        seconds, (theta, work) = best_of(run, runs, once_above=ONCE_ABOVE)
        error = float(np.abs(theta - reference).max() / scale)
        unit = "steps" if method.startswith("backlash") else "RHS"
        note = ""
        if seconds > GIVE_UP:
            given_up.add(method)
            note = f"  (over {GIVE_UP:g} s: tighter rtol not run)"
        print(f"  {method:<30}{setting:>16}{error:10.1e}{seconds:11.4f}{work:>11d} {unit}{note}", flush=True)
        points.append((method, setting, error, seconds, work))
    return points


def cheapest(points, target):
    """{method: (seconds, setting, error)} of the cheapest run of each method at an error <= target."""
    best = {}
    for method, setting, error, seconds, _ in points:
        if error <= target and (method not in best or seconds < best[method][0]):
            best[method] = (seconds, setting, error)
    return best


def summary(name, points):
    for target in TARGETS:
        best = cheapest(points, target)
        print(f"  at error {target:.0e}:")
        kernel = best.get("backlash-df kernel")
        others = {m: v for m, v in best.items() if m != "backlash-df kernel"}
        for method, (seconds, setting, error) in sorted(best.items(), key=lambda item: item[1][0]):
            print(f"    {method:<30}{setting:>16}{error:10.1e}{seconds * 1e3:10.2f} ms")
        if kernel is None or not others:
            print(f"    {name}: no ratio (the kernel or every competitor never reaches {target:.0e})")
            continue
        rival = min(others, key=lambda m: others[m][0])
        print(f"    best competitor at {target:.0e} on {name}: {rival} ({others[rival][1]}): "
              f"{others[rival][0] / kernel[0]:.2f}x the kernel's CPU time")


def plot(cases):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, len(cases), figsize=(6 * len(cases), 5), squeeze=False, layout="constrained")
    for ax, (loop, points) in zip(axes[0], cases):
        for method in dict.fromkeys(p[0] for p in points):
            curve = [(p[3], max(p[2], 1e-17)) for p in points if p[0] == method]
            style = "k-o" if method.startswith("backlash") else "-.."
            ax.loglog(*zip(*curve), style, label=method, markersize=4)
        ax.set_xlabel("CPU time per run (s)")
        ax.set_ylabel("max |theta_d error| / range")
        ax.set_title(loop.name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    (ROOT / "build").mkdir(exist_ok=True)
    path = ROOT / "build" / "work_precision.png"
    figure.savefig(path, dpi=110)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    parser.add_argument("--cases", type=int, default=len(CASES), help="how many of the cases to run")
    parser.add_argument("--no-profile", action="store_true", help="skip the perf profile")
    args = parser.parse_args()
    print(f"work-precision of the closed loop; CPU time best of {args.repeat} (runs over {ONCE_ABOVE:g} s once)")
    cases = []
    for rig_name, law_name in CASES[:args.cases]:
        loop = ClosedLoop(rig_name, law_name)
        points = case_table(loop, args.repeat)
        kernel_points = [(work, seconds) for method, _, _, seconds, work in points if method == "backlash-df kernel"]
        per_step, per_call = np.polyfit(*np.array(kernel_points).T, 1)
        print(f"  kernel's CPU time, least squares over its steps: {per_call * 1e3:.2f} ms per call + "
              f"{per_step * 1e9:.0f} ns per step")
        floor, kernel, size = floor_row(loop, args.repeat)
        print(f"  floor: numba loop, one {size} x {size} product, record, mode guard per step (dt = "
              f"{GRID / SPLITS[-1]:.0e} s): {floor:.1f} ns/step; kernel {kernel:.1f} ns/step = {kernel / floor:.1f}x the floor")
        if not args.no_profile:
            print(f"  profile of the kernel's run (perf, {PROFILE_RUNS} runs, share of the process): {profile(loop)}")
        cases.append((loop, points))
    print(f"\nthe RK4 kernel's laws (load average {os.getloadavg()[0]:.2f})")
    print_rk4_rows(args.repeat)
    print_friction_row(args.repeat)
    print_coulomb_row(args.repeat)
    print("\nsummary: the cheapest run of each method reaching the error")
    for loop, points in cases:
        print(f" {loop.name}")
        summary(loop.label, points)
    print(f"\ncurves saved to {plot(cases).relative_to(ROOT)}")


if __name__ == "__main__":
    main()
