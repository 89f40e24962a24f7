"""Compiled kernels of the closed-loop simulation (private to :mod:`backlash_df.simulation`).

Two kernels integrate ``dz/dt = A z + b T + E w(t) + e_d u_d(t - delay) - e_f F(f z)``
(:class:`~backlash_df.system.LinearPart`) closed through a backlash torque law, on a
fixed grid with the law's mode frozen over each step and every change of mode located
by bisection (:mod:`backlash_df.simulation` explains both):

* :func:`run_rk4`, classical RK4 for any law and for friction;
* :func:`run_exact`, exact discretisation of a loop that is affine inside every mode,
  stepping with the ladders ``exp(M dt 2^-j)`` of :func:`backlash_df.system.exp_ladder`.
"""

import math

import numpy as np

from .._jit import copy_into as _copy
from .._jit import jit as _jit
from ..models import EXACT, exact_step, held_mode, mode_torque

__all__ = ["run_rk4", "run_exact", "LEVELS", "BLOW_UP"]

_MAX_EVENTS_PER_STEP = 32
_BISECTIONS = 52
#: Dyadic sub-steps dt 2^-j, j < LEVELS, of the exact-discretisation kernel.
LEVELS = 42


# --------------------------------------------------------------------------- RK4 kernel (any law)


@_jit
def _lerp(series, position, col):
    """Linear interpolation of column ``col`` of ``series`` (rows on a uniform grid) at a fractional row."""
    last = series.shape[0] - 1
    if position <= 0.0:
        return series[0, col]
    if position >= last:
        return series[last, col]
    i = int(position)
    frac = position - i
    return series[i, col] + frac * (series[i + 1, col] - series[i, col])


@_jit
def _history(hist, position, last):
    """The delayed signal at a fractional row of ``hist`` whose newest recorded row is ``last``.

    Cubic through rows ``j - 1 .. j + 2`` around ``j = floor(position)`` (rows
    before 0 repeat row 0: the history is constant before t = 0), the quadratic
    through ``j - 1 .. j + 1`` while row ``j + 2`` is not recorded yet: an
    interpolation error O(dt^4) (O(dt^3)) where linear interpolation leaves O(dt^2),
    which showed as a 1e-3 amplitude error of a cycle with a 0.5 ms dead time
    (tests/test_delay.py).
    """
    if position <= 0.0:
        return hist[0, 0]
    j = int(position)
    if j >= last:
        return hist[last, 0]
    u = position - j
    f0, f1, f2 = hist[max(j - 1, 0), 0], hist[j, 0], hist[j + 1, 0]
    if j + 2 > last:
        return f1 + 0.5 * u * (f2 - f0) + 0.5 * u * u * (f2 - 2.0 * f1 + f0)
    f3 = hist[j + 2, 0]
    return (-u * (u - 1.0) * (u - 2.0) * f0 + 3.0 * (u + 1.0) * (u - 1.0) * (u - 2.0) * f1
            - 3.0 * (u + 1.0) * u * (u - 2.0) * f2 + (u + 1.0) * u * (u - 1.0) * f3) / 6.0


@_jit
def _torque(law, mode, x, v, p):
    if law == EXACT:
        if mode > 0:
            return p[0] * (x - p[2]) + p[1] * v
        if mode < 0:
            return p[0] * (x + p[2]) + p[1] * v
        return 0.0
    return mode_torque(law, mode, x, v, p[0], p[1], p[2], p[3])


@_jit
def _deriv(z, t, mode, sys, law, p, W, hist, dt, out):
    a_mat, b_t, e_mat, c_x, c_v, d_row, e_d, delay, f_row, e_f, f_level, f_eps, f_break, f_ws = sys
    x, v = _xv(z, c_x, c_v)
    torque = _torque(law, mode, x, v, p)
    # W spans the run uniformly: one row per output step, or two (half steps)
    w_row = t / dt * (W.shape[0] - 1) / (hist.shape[0] - 1)
    u_d = _history(hist, (t - delay) / dt, max(math.ceil(t / dt) - 1, 0)) if delay > 0.0 else 0.0
    fr = 0.0
    if f_level > 0.0 or f_break > 0.0:
        s = 0.0
        for j in range(z.shape[0]):
            s += f_row[j] * z[j]
        fr = (f_level + f_break * math.exp(-((s / f_ws) ** 2))) * math.tanh(s / f_eps)
    for i in range(z.shape[0]):
        out[i] = b_t[i] * torque + e_d[i] * u_d - e_f[i] * fr
    for j in range(W.shape[1]):
        w = _lerp(W, w_row, j)
        for i in range(z.shape[0]):
            out[i] += e_mat[i, j] * w
    for i in range(z.shape[0]):
        acc = out[i]
        for j in range(z.shape[0]):
            acc += a_mat[i, j] * z[j]
        out[i] = acc


@_jit
def _rk4(z, t, h, mode, sys, law, p, W, hist, dt, work, out):
    k1, k2, k3, k4, tmp = work[0], work[1], work[2], work[3], work[4]
    _deriv(z, t, mode, sys, law, p, W, hist, dt, k1)
    for i in range(z.shape[0]):
        tmp[i] = z[i] + 0.5 * h * k1[i]
    _deriv(tmp, t + 0.5 * h, mode, sys, law, p, W, hist, dt, k2)
    for i in range(z.shape[0]):
        tmp[i] = z[i] + 0.5 * h * k2[i]
    _deriv(tmp, t + 0.5 * h, mode, sys, law, p, W, hist, dt, k3)
    for i in range(z.shape[0]):
        tmp[i] = z[i] + h * k3[i]
    _deriv(tmp, t + h, mode, sys, law, p, W, hist, dt, k4)
    for i in range(z.shape[0]):
        out[i] = z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@_jit
def _xv(z, c_x, c_v):
    x = 0.0
    v = 0.0
    for j in range(c_x.shape[0]):
        x += c_x[j] * z[j]
        v += c_v[j] * z[j]
    return x, v


@_jit
def _mode_of(law, p, mode, x, v, theta_b):
    """Mode at a state reached in ``mode``: the law's region, or the exact model's contact."""
    if law != EXACT:
        return held_mode(law, mode, x, v, p[0], p[1], p[2], p[3])
    if theta_b >= p[2] and p[0] * (x - p[2]) + p[1] * v >= 0.0:
        return 1
    if theta_b <= -p[2] and p[0] * (x + p[2]) + p[1] * v <= 0.0:
        return -1
    return 0


@_jit
def _must_leave(law, p, mode, x, v, theta_b):
    """True if a state reached with ``mode`` frozen lies outside that mode (release, contact, or region)."""
    if law != EXACT:
        return held_mode(law, mode, x, v, p[0], p[1], p[2], p[3]) != mode
    if mode > 0:
        return p[0] * (x - p[2]) + p[1] * v < 0.0
    if mode < 0:
        return p[0] * (x + p[2]) + p[1] * v > 0.0
    return abs(theta_b) >= p[2]


@_jit
def _advance(z, theta_b, t, h, mode, sys, law, p, W, hist, dt, work, z_out):
    """One frozen-mode step; returns (theta_b at the end, True if the mode must change)."""
    _rk4(z, t, h, mode, sys, law, p, W, hist, dt, work, z_out)
    c_x, c_v = sys[3], sys[4]
    x1, v1 = _xv(z_out, c_x, c_v)
    if law != EXACT:
        return theta_b, _must_leave(law, p, mode, x1, v1, theta_b)
    if mode != 0:
        return p[2] if mode > 0 else -p[2], _must_leave(law, p, mode, x1, v1, theta_b)
    x0, v0 = _xv(z, c_x, c_v)
    theta_new = exact_step(theta_b, x0, v0, x1, v1, h, p[0], p[1], p[2])
    return theta_new, abs(theta_new) >= p[2]


@_jit
def _record(i, z, theta_b, mode, law, p, c_x, c_v, d_row, Z, T, THETA, MODES, hist):
    """Store sample ``i`` of a run: state, shaft torque, theta_b, mode and the delayed signal."""
    x, v = _xv(z, c_x, c_v)
    _copy(z, Z[i])
    T[i] = _torque(law, mode, x, v, p)
    THETA[i] = theta_b
    MODES[i] = mode
    u = 0.0
    for j in range(z.shape[0]):
        u += d_row[j] * z[j]
    hist[i, 0] = u


#: |state| beyond it: the run has diverged (measure_limit_cycle names it).
BLOW_UP = 1e150


@_jit
def _diverged(i, z, Z, T, THETA, MODES):
    """True when state ``z`` of sample ``i`` has blown up; the later samples are then NaN.

    Stepping on would overflow to inf and NaN, and a division by them inside a
    kernel raises; a diverged run ends here instead, and is named by
    :func:`measure_limit_cycle`.
    """
    for value in z:
        if not abs(value) <= BLOW_UP:  # NaN fails the test too
            for j in range(i + 1, Z.shape[0]):
                for col in range(Z.shape[1]):
                    Z[j, col] = np.nan
                T[j] = np.nan
                THETA[j] = np.nan
                MODES[j] = MODES[i]
            return True
    return False


@_jit
def run_rk4(sys, law, p, W, z0, theta_b0, dt, n_steps, Z, T, THETA, MODES):
    """RK4 run of ``n_steps`` steps ``dt`` from ``z0``, filling ``Z``, ``T``, ``THETA``, ``MODES``; returns the event count.

    ``sys`` is :meth:`~backlash_df.system.LinearPart.kernel_arrays`, ``W`` the
    inputs on the output grid or at half steps, ``p`` the law's ``(k, c, alpha, beta)``.
    """
    n = z0.shape[0]
    d_row = sys[5]
    hist = np.zeros((n_steps + 1, 1))
    work = np.empty((5, n))
    z = z0.copy()
    z_new = np.empty(n)
    z_try = np.empty(n)
    theta_b = theta_b0
    x, v = _xv(z, sys[3], sys[4])
    mode = _mode_of(law, p, 0, x, v, theta_b)
    events = 0
    for i in range(n_steps + 1):
        _record(i, z, theta_b, mode, law, p, sys[3], sys[4], d_row, Z, T, THETA, MODES, hist)
        if i == n_steps or _diverged(i, z, Z, T, THETA, MODES):
            break
        t = i * dt
        remaining = dt
        for _ in range(_MAX_EVENTS_PER_STEP):
            theta_end, changed = _advance(z, theta_b, t, remaining, mode, sys, law, p, W, hist, dt, work, z_new)
            if not changed:
                _copy(z_new, z)
                theta_b = theta_end
                remaining = 0.0
                break
            # bisect for the first fraction of the remaining step where the mode changes
            lo = 0.0
            hi = 1.0
            for _b in range(_BISECTIONS):
                mid = 0.5 * (lo + hi)
                _, ch = _advance(z, theta_b, t, mid * remaining, mode, sys, law, p, W, hist, dt, work, z_try)
                if ch:
                    hi = mid
                else:
                    lo = mid
            h = hi * remaining
            theta_try, _ = _advance(z, theta_b, t, h, mode, sys, law, p, W, hist, dt, work, z_try)
            x, v = _xv(z_try, sys[3], sys[4])
            if law == EXACT and mode == 0:
                theta_try = p[2] if theta_try > 0.0 else -p[2]
            new_mode = _mode_of(law, p, mode, x, v, theta_try)
            if new_mode == mode:  # grazing or round-off at a boundary: no real switch
                break
            _copy(z_try, z)
            theta_b = theta_try
            mode = new_mode
            t += h
            remaining -= h
            events += 1
            if remaining <= 1e-14 * dt:
                break
        if remaining > 1e-14 * dt:
            theta_b, _ = _advance(z, theta_b, t, remaining, mode, sys, law, p, W, hist, dt, work, z_new)
            _copy(z_new, z)
    return events


# --------------------------------------------------------------------------- exact-discretisation kernel


@_jit
def _mode_index(mode):
    """Row of a mode's matrices: 0 left contact, 1 free, 2 right contact."""
    return 0 if mode < 0 else (2 if mode > 0 else 1)


@_jit
def _apply(phi, q, out, rows):
    """``out = phi q`` on the first ``rows`` rows; the other entries copied from ``q``."""
    size = q.shape[0]
    for i in range(rows):
        acc = 0.0
        for j in range(size):
            acc += phi[i, j] * q[j]
        out[i] = acc
    for i in range(rows, size):
        out[i] = q[i]


@_jit
def _set_inputs(q, base, f0, fm, f1, dt):
    """Value, slope and curvature of the quadratic through samples at 0, dt/2, dt."""
    q[base] = f0
    q[base + 1] = (4.0 * fm - 3.0 * f0 - f1) / dt
    q[base + 2] = 4.0 * (f0 - 2.0 * fm + f1) / (dt * dt)


@_jit
def _advance_exactly(ladder, q, fraction, out, tmp):
    """``q`` advanced by ``fraction * dt`` with the dyadic ladder (residual < 2^-levels dt dropped)."""
    _copy(q, out)
    for j in range(ladder.shape[0]):
        s = 0.5**j
        if fraction >= s:
            _apply(ladder[j], out, tmp, q.shape[0])
            _copy(tmp, out)
            fraction -= s


@_jit
def _locate(ladder, q, left, law, p, mode, c_x, c_v, q_lo, trial, q_hi):
    """Bisect for the first time the frozen-mode trajectory must leave ``mode``; returns it (fraction of dt).

    Binary search on the dyadic ladder from ``q`` (a sub-step ``dt 2^-j`` is kept
    while the trajectory stays in ``mode``); ``q_hi`` must already hold the state
    at ``left``, outside ``mode``, and ends as the earliest state found outside.
    """
    n = c_x.shape[0]
    size = q.shape[0]
    _copy(q, q_lo)
    lo = 0.0
    hi = left
    for j in range(1, ladder.shape[0]):
        s = 0.5**j
        if lo + s >= hi:
            continue
        _apply(ladder[j], q_lo, trial, size)
        x, v = _xv(trial, c_x, c_v)
        if _must_leave(law, p, mode, x, v, trial[n]):
            _copy(trial, q_hi)
            hi = lo + s
        else:
            _copy(trial, q_lo)
            lo += s
    return hi


@_jit
def _set_step_inputs(q, i, W, hist, delay, dt, n):
    """Quadratics in time over step ``i`` of the varying inputs and of the delayed signal."""
    rows_per_step = (W.shape[0] - 1) / (hist.shape[0] - 1)
    row = i * rows_per_step
    for j in range(W.shape[1]):
        f0, fm, f1 = _lerp(W, row, j), _lerp(W, row + 0.5 * rows_per_step, j), _lerp(W, row + rows_per_step, j)
        _set_inputs(q, n + 2 + 3 * j, f0, fm, f1, dt)
    if delay > 0.0:
        row = i - delay / dt
        f0, fm, f1 = _history(hist, row, i), _history(hist, row + 0.5, i), _history(hist, row + 1.0, i)
        _set_inputs(q, n + 2 + 3 * W.shape[1], f0, fm, f1, dt)


@_jit
def _step_exactly(ladders, law, p, mode, q, c_x, c_v, work):
    """Advance ``q`` by one step ``dt``, switching mode at every located event; returns (mode, events)."""
    n, size = c_x.shape[0], q.shape[0]
    q_new, q_lo, trial, q_hi = work[0], work[1], work[2], work[3]
    left = 1.0  # fraction of the step still to go
    events = 0
    for _ in range(_MAX_EVENTS_PER_STEP):
        ladder = ladders[_mode_index(mode)]
        if left == 1.0:  # z and theta_b only: the other entries are constant or reset every step
            _apply(ladder[0], q, q_new, n + 1)
        else:
            _advance_exactly(ladder, q, left, q_new, trial)
        x, v = _xv(q_new, c_x, c_v)
        if not _must_leave(law, p, mode, x, v, q_new[n]):
            _copy(q_new, q)
            return mode, events
        if left == 1.0:
            _apply(ladder[0], q, q_hi, size)
        else:
            _copy(q_new, q_hi)
        h = _locate(ladder, q, left, law, p, mode, c_x, c_v, q_lo, trial, q_hi)
        if law == EXACT and mode == 0:
            q_hi[n] = p[2] if q_hi[n] > 0.0 else -p[2]
        x, v = _xv(q_hi, c_x, c_v)
        new_mode = _mode_of(law, p, mode, x, v, q_hi[n])
        if new_mode == mode:  # grazing or round-off at a boundary: no real switch
            break
        _copy(q_hi, q)
        mode = new_mode
        left -= h
        events += 1
        if left <= 1e-14:
            return mode, events
    _advance_exactly(ladders[_mode_index(mode)], q, left, q_new, trial)
    _copy(q_new, q)
    return mode, events


@_jit
def run_exact(ladders, law, p, W, z0, theta_b0, delay, d_row, c_x, c_v, dt, n_steps, Z, T, THETA, MODES):
    """Exact-discretisation run on the augmented state of :func:`~backlash_df.system.mode_matrices`.

    ``ladders`` holds :func:`~backlash_df.system.exp_ladder` of the left-contact,
    free and right-contact matrices; returns the event count.
    """
    n = z0.shape[0]
    hist = np.zeros((n_steps + 1, 1))
    q = np.zeros(ladders.shape[2])
    work = np.empty((4, q.shape[0]))
    _copy(z0, q[:n])
    q[n] = theta_b0
    q[n + 1] = 1.0
    x, v = _xv(q, c_x, c_v)
    mode = _mode_of(law, p, 0, x, v, theta_b0)
    events = 0
    for i in range(n_steps + 1):
        _record(i, q[:n], q[n], mode, law, p, c_x, c_v, d_row, Z, T, THETA, MODES, hist)
        if i == n_steps or _diverged(i, q[:n], Z, T, THETA, MODES):
            break
        _set_step_inputs(q, i, W, hist, delay, dt, n)
        mode, found = _step_exactly(ladders, law, p, mode, q, c_x, c_v, work)
        events += found
    return events


