"""Time simulation of drives with backlash: compiled kernels shared by every loop.

The drive is split into a linear part and the backlash::

    dz/dt = A z + b T + E w(t) + e_d u_d(t - delay) - e_f (F + F_s exp(-(f z / w_s)^2)) tanh(f z / eps)
    theta_d = c_x z,   dtheta_d = c_v z,   T = law(theta_d, dtheta_d [, theta_b])

``w(t)`` are external inputs sampled on the output grid, or at half steps when
given as functions of time, ``u_d = d z`` an optional delayed signal (dead
time, linear between output samples), the last term an optional smoothed
Coulomb friction with a breakaway (Stribeck) part.  The open-loop two-mass
drive (:func:`two_mass_system`), the PI loops of :mod:`backlash_df.loops` and
the replay of measured data all use this form.

Integration runs on a fixed grid with the law's *mode* frozen over each step
(free, rubber band, steel contact; see :mod:`backlash_df.models`); a change of
mode at the end of a step is located by bisection and the step is split there.
So the jump of the phase plane law at theta*, and the dead-zone's jump at
``|theta_d| = alpha``, are crossed exactly instead of being smeared or
chattered over.  Contact of the phase plane law, once made at theta*, holds
until the release condition of Theorem 1, as in the paper's derivation of (20)
(:func:`~backlash_df.models.held_mode`): read as a memoryless function, (20)
lets a strongly damped contact slide along the jump at theta* with an event
every few nanoseconds.

Two kernels share these rules:

* **Exact discretisation** when the loop is linear inside every mode: the
  dead-zone family (24)-(27), the phase plane law (19)-(23) and the exact model
  (1), (14), without friction.  In contact ``T = k (theta_d -+ alpha) + c
  dtheta_d``, free ``T = 0`` with the exact model's ``dtheta_b/dt = (k / c)
  (theta_d - theta_b) + dtheta_d``; inputs and the delayed signal are quadratic
  in time over a step (through their samples at 0, dt/2, dt).  So one step is a
  product with ``exp(M dt)`` of an augmented state matrix, exact between events
  whatever the step and stable for any ``c / k``; the bisection walks a ladder
  of ``exp(M dt 2^-j)``.  Only a dead time (its linear interpolation) or inputs
  that are not quadratic over a step leave an error depending on dt.
* **Classical RK4** otherwise (the rubber band (36), elasto-backlash, friction),
  every stage of an unsplit step on an input sample; the exact model's theta_b
  by the exponential step :func:`~backlash_df.models.exact_step`.
"""

import dataclasses
import math

import numba
import numpy as np

from .models import (
    DAMPED_DEAD_ZONE,
    DEAD_ZONE,
    EXACT,
    PHASE_PLANE,
    REVISED_DEAD_ZONE,
    RUBBER,
    BacklashModel,
    exact_step,
    held_mode,
    mode_torque,
)

__all__ = ["LinearPart", "SimulationResult", "simulate_linear", "two_mass_system", "simulate_two_mass"]

_jit = numba.njit(cache=True, nogil=True)


@_jit
def _copy(src, dst):
    """``dst[...] = src`` for two arrays of one shape, element by element.

    An array-to-slice assignment makes numba compile its shape-mismatch message
    (string formatting), seconds on a cold cache; this loop does not.
    """
    for i in range(dst.size):
        dst.flat[i] = src.flat[i]


_MAX_EVENTS_PER_STEP = 32
_BISECTIONS = 52
_LEVELS = 42  # dyadic sub-steps dt 2^-j, j < _LEVELS, of the exact-discretisation kernel


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


_BLOW_UP = 1e150  # |state| beyond it: the run has diverged (measure_limit_cycle names it)


@_jit
def _diverged(i, z, Z, T, THETA, MODES):
    """True when state ``z`` of sample ``i`` has blown up; the later samples are then NaN.

    Stepping on would overflow to inf and NaN, and a division by them inside a
    kernel raises; a diverged run ends here instead, and is named by
    :func:`measure_limit_cycle`.
    """
    for value in z:
        if not abs(value) <= _BLOW_UP:  # NaN fails the test too
            for j in range(i + 1, Z.shape[0]):
                for col in range(Z.shape[1]):
                    Z[j, col] = np.nan
                T[j] = np.nan
                THETA[j] = np.nan
                MODES[j] = MODES[i]
            return True
    return False


@_jit
def _run(sys, law, p, W, z0, theta_b0, dt, n_steps, Z, T, THETA, MODES):
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
def _taylor(powers, ratio, scaled):
    """``sum_k ratio^k A0^k / k!`` from the powers of ``A0`` (``||A0||_1 = scaled <= 1/2``), terms down to 1e-18."""
    out = powers[0].copy()
    coef = 1.0
    for k in range(1, powers.shape[0]):
        coef *= ratio / k
        if coef * scaled**k < 1e-18:
            break
        out += coef * powers[k]
    return out


@_jit
def _ladder(m_aug, dt, levels):
    """``exp(M dt 2^-j)`` for ``j = 0 .. levels - 1``, shape (levels, N, N).

    Scaling and squaring: Taylor series of ``A0 = M dt 2^-j0`` (``||A0||_1 <=
    1/2``) at the levels ``j >= j0``, repeated squaring of level ``j0`` above.
    """
    size = m_aug.shape[0]
    norm = 0.0
    for j in range(size):
        norm = max(norm, np.abs(m_aug[:, j]).sum() * dt)
    base = 0
    while norm * 0.5**base > 0.5:
        base += 1
    scaled = norm * 0.5**base
    powers = np.empty((25, size, size))
    _copy(np.eye(size), powers[0])
    _copy(m_aug * (dt * 0.5**base), powers[1])
    for k in range(2, powers.shape[0]):
        _copy(powers[k - 1] @ powers[1], powers[k])
    out = np.empty((levels, size, size))
    for j in range(base, levels):
        _copy(_taylor(powers, 0.5 ** (j - base), scaled), out[j])
    square = _taylor(powers, 1.0, scaled)
    for j in range(base - 1, -1, -1):
        square = square @ square
        if j < levels:
            _copy(square, out[j])
    return out


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
def _run_exactly(ladders, law, p, W, z0, theta_b0, delay, d_row, c_x, c_v, dt, n_steps, Z, T, THETA, MODES):
    """Exact-discretisation run on the augmented state of :func:`_mode_matrices`; returns the event count."""
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


# --------------------------------------------------------------------------- Python API


@dataclasses.dataclass(frozen=True)
class LinearPart:
    """The linear part of a drive: ``dz/dt = A z + b T + E w + ...`` (see module docs).

    Attributes
    ----------
    A, b, E : ndarray
        State matrix (n x n), shaft-torque column (n), input matrix (n x m).
    c_x, c_v : ndarray
        Rows giving theta_d (rad) and dtheta_d (rad/s) from the state.
    state_names, input_names : tuple of str
        Names of the states and of the input channels, for results and errors.
    delay, d, e_d : float, ndarray, ndarray
        Dead time (s), the row of the delayed signal and the column it enters by.
    friction, friction_speed, f, e_f : float, float, ndarray, ndarray
        Coulomb friction level (N m), smoothing speed (rad/s), the row of the
        speed it opposes and the column it enters by.
    breakaway, breakaway_speed : float
        Breakaway (Stribeck) friction added to the Coulomb level near zero speed,
        ``F_s exp(-(s / w_s)^2)`` (N m), and its Stribeck speed ``w_s`` (rad/s).
    """

    A: np.ndarray
    b: np.ndarray
    E: np.ndarray
    c_x: np.ndarray
    c_v: np.ndarray
    state_names: tuple
    input_names: tuple
    delay: float = 0.0
    d: np.ndarray | None = None
    e_d: np.ndarray | None = None
    friction: float = 0.0
    friction_speed: float = 1e-3
    f: np.ndarray | None = None
    e_f: np.ndarray | None = None
    breakaway: float = 0.0
    breakaway_speed: float = 1.0

    def __post_init__(self):
        n = len(self.state_names)
        zeros = np.zeros(n)
        for name in ("A", "b", "E", "c_x", "c_v"):
            object.__setattr__(self, name, np.ascontiguousarray(getattr(self, name), dtype=float))
        for name in ("d", "e_d", "f", "e_f"):
            value = getattr(self, name)
            object.__setattr__(self, name, zeros.copy() if value is None else np.ascontiguousarray(value, dtype=float))
        if self.A.shape != (n, n) or self.E.shape != (n, len(self.input_names)):
            raise ValueError("LinearPart: A must be n x n and E n x m for n states and m inputs")
        if not (self.delay >= 0.0 and math.isfinite(self.delay)):
            raise ValueError(f"delay must be finite and >= 0, got {self.delay!r}")
        if self.friction < 0.0 or not self.friction_speed > 0.0:
            raise ValueError("friction must be >= 0 and friction_speed > 0")
        if self.breakaway < 0.0 or not self.breakaway_speed > 0.0:
            raise ValueError("breakaway must be >= 0 and breakaway_speed > 0")

    def _kernel_tuple(self):
        return (
            self.A, self.b, self.E, self.c_x, self.c_v, self.d, self.e_d,
            float(self.delay), self.f, self.e_f, float(self.friction), float(self.friction_speed),
            float(self.breakaway), float(self.breakaway_speed),
        )


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """Time response of a drive with backlash.

    Attributes
    ----------
    time : ndarray
        Output grid, s.
    states : ndarray
        State trajectory, shape (len(time), n), columns named by ``state_names``.
    theta_d, dtheta_d : ndarray
        Displacement (rad) and its rate (rad/s).
    torque : ndarray
        Shaft torque T (N m).
    theta_b : ndarray
        Backlash angle of the exact model (rad); NaN for static laws.
    mode : ndarray
        Contact mode at each sample (0 free, +-1 rubber band or exact contact,
        +-2 steel contact).
    events : int
        Number of located mode changes.
    model : BacklashModel
        The torque law simulated.
    state_names : tuple of str
    """

    time: np.ndarray
    states: np.ndarray
    theta_d: np.ndarray
    dtheta_d: np.ndarray
    torque: np.ndarray
    theta_b: np.ndarray
    mode: np.ndarray
    events: int
    model: BacklashModel
    state_names: tuple

    def state(self, name):
        """One state's trajectory by name (for example ``"motor_speed"``)."""
        try:
            return self.states[:, self.state_names.index(name)]
        except ValueError:
            raise ValueError(f"no state {name!r}; states are: {', '.join(self.state_names)}") from None

    def __repr__(self):
        return (f"<SimulationResult {self.model.name}: {self.time.size} samples, t = {self.time[0]:g} .. "
                f"{self.time[-1]:g} s, {self.events} mode changes, states {', '.join(self.state_names)}>")

    def plot(self, ax=None):
        """Plot theta_d and the shaft torque against time; returns the two axes (ndarray)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5), layout="constrained")
        ax[0].plot(self.time, self.theta_d)
        ax[0].set_ylabel("theta_d (rad)")
        ax[1].plot(self.time, self.torque)
        ax[1].set_ylabel("shaft torque T (N m)")
        ax[1].set_xlabel("time (s)")
        ax[0].set_title(f"{self.model.name}")
        return ax


def _piecewise_affine(system, model):
    """True if the loop is linear within every mode: no friction, torque affine in (theta_d, dtheta_d)."""
    if system.friction > 0.0 or system.breakaway > 0.0:
        return False
    if model.law == RUBBER:
        return model.rubber_thickness == 0.0
    return model.law in (DEAD_ZONE, DAMPED_DEAD_ZONE, REVISED_DEAD_ZONE, PHASE_PLANE, EXACT)


def _mode_matrices(system, model, law, varying, constant):
    """Augmented state matrices of the left-contact, free and right-contact modes, shape (3, N, N).

    State ``[z, theta_b, 1, (w_j, dw_j/dt, d2w_j/dt2) for the inputs j in
    varying and the delayed signal]``: in contact ``T = k (theta_d -+ alpha) +
    c dtheta_d`` (``c = 0`` for the dead-zone (24)); free, ``T = 0`` and, for
    the exact model, ``dtheta_b/dt = (k / c) (theta_d - theta_b) + dtheta_d``
    (12), (14).  Inputs are quadratic in time over a step (chains of
    integrators); those constant over the run (values ``constant``, the other
    channels) enter with the state ``1``.
    """
    n = system.A.shape[0]
    columns = [system.E[:, j] for j in varying] + ([system.e_d] if system.delay > 0.0 else [])
    size = n + 2 + 3 * len(columns)
    k, c, alpha = model.stiffness, model.damping, model.half_gap
    fixed = np.delete(system.E, varying, axis=1) @ constant
    out = np.zeros((3, size, size))
    for m_aug, side in zip(out, (-1, 0, 1)):
        m_aug[:n, :n] = system.A
        m_aug[:n, n + 1] = fixed
        if side:
            damping = 0.0 if law == DEAD_ZONE else c
            m_aug[:n, :n] += np.outer(system.b, k * system.c_x + damping * system.c_v)
            m_aug[:n, n + 1] -= system.b * k * side * alpha
        elif law == EXACT:
            m_aug[n, :n] = k / c * system.c_x + system.c_v
            m_aug[n, n] = -k / c
        for j, column in enumerate(columns):
            base = n + 2 + 3 * j
            m_aug[:n, base] = column
            m_aug[base, base + 1] = m_aug[base + 1, base + 2] = 1.0
    return out


def _simulate_exactly(system, model, w, z0, theta_b0, dt, n_steps, states, torque, theta_b, modes):
    """Fill the outputs with the exact-discretisation kernel; returns the number of events."""
    law = DEAD_ZONE if model.law == EXACT and model.damping == 0.0 else model.law
    varying = [j for j in range(w.shape[1]) if np.ptp(w[:, j]) > 0.0]
    constant = np.delete(w[0], varying)
    matrices = _mode_matrices(system, model, law, varying, constant)
    ladders = np.stack([_ladder(m_aug, dt, _LEVELS) for m_aug in matrices])
    events = _run_exactly(
        ladders, law, model.params, np.ascontiguousarray(w[:, varying]), z0, theta_b0, float(system.delay),
        system.d, system.c_x, system.c_v, dt, n_steps, states, torque, theta_b, modes,
    )
    if law != model.law:  # the exact model without damping is the dead-zone (Remark 2)
        modes //= 2
        theta_b[:] = np.clip(states @ system.c_x, -model.half_gap, model.half_gap)
    return events


#: Most steps of one simulation: every sample is stored (about 80 bytes a step), and the
#: bundled rigs need at most 2e6 (160 s at the default step of 1e-4 s).
MAX_STEPS = 20_000_000


def simulate_linear(system, model, t_end, dt, inputs=None, z0=None, theta_b0=0.0):
    """Simulate a linear part closed through a backlash torque law.

    Parameters
    ----------
    system : LinearPart
    model : BacklashModel
        Any law from :func:`~backlash_df.make_model`, the exact model included.
    t_end, dt : float
        Final time and output/integration step, s.
    inputs : array_like or callable, optional
        External inputs ``w``: an array of shape (N, m) on the grid
        ``arange(N) * dt`` (N = number of output samples), or a callable
        ``w(t) -> (len(t), m)``, sampled at half steps ``arange(2 N - 1) * dt / 2``
        (the RK4 stage times).  Default: zero.
    z0 : array_like, optional
        Initial state (default zero).
    theta_b0 : float
        Initial backlash angle of the exact model, rad.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        A step or duration that is not finite and positive, a step longer than
        the delay, or more than :data:`MAX_STEPS` steps.
    """
    if not (dt > 0.0 and math.isfinite(dt)):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    if not (t_end > 0.0 and math.isfinite(t_end)):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
    if 0.0 < system.delay < dt:
        raise ValueError(f"dt = {dt!r} s must not exceed the delay {system.delay!r} s")
    n_steps = int(round(t_end / dt))
    if n_steps < 1:
        raise ValueError(f"t_end = {t_end!r} s must be at least one step dt = {dt!r} s")
    if n_steps > MAX_STEPS:
        raise ValueError(f"t_end = {t_end:g} s at dt = {dt:.3g} s is {n_steps:.3g} steps, more than {MAX_STEPS:.0e}: "
                         f"the loop's fastest dynamics need that step; check the rig's units (stiffness, damping, inertias, kp)")
    time = np.arange(n_steps + 1) * dt
    n, m = system.E.shape
    if inputs is None:
        w = np.zeros((n_steps + 1, m))
    elif callable(inputs):
        w = np.asarray(inputs(np.arange(2 * n_steps + 1) * (0.5 * dt)), dtype=float).reshape(2 * n_steps + 1, m)
    else:
        w = np.asarray(inputs, dtype=float)
        if w.ndim == 1 and m == 1:
            w = w[:, None]
        if w.shape != (n_steps + 1, m):
            raise ValueError(f"inputs must have shape ({n_steps + 1}, {m}) for channels {system.input_names}, got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError("inputs must be finite")
    z0 = np.zeros(n) if z0 is None else np.asarray(z0, dtype=float).copy()
    if z0.shape != (n,) or not np.all(np.isfinite(z0)):
        raise ValueError(f"z0 must be {n} finite numbers for states {system.state_names}")
    if abs(theta_b0) > model.half_gap:
        raise ValueError(f"theta_b0 must lie in [-half_gap, half_gap], got {theta_b0!r}")
    states = np.empty((n_steps + 1, n))
    torque = np.empty(n_steps + 1)
    theta_b = np.empty(n_steps + 1)
    modes = np.empty(n_steps + 1, dtype=np.int64)
    w = np.ascontiguousarray(w)
    if _piecewise_affine(system, model):
        events = _simulate_exactly(system, model, w, z0, float(theta_b0), float(dt), n_steps,
                                   states, torque, theta_b, modes)
    else:
        events = _run(system._kernel_tuple(), model.law, model.params, w, z0,
                      float(theta_b0), float(dt), n_steps, states, torque, theta_b, modes)
    if model.is_static:
        theta_b[:] = np.nan
    with np.errstate(over="ignore", invalid="ignore"):  # a diverged run is named by measure_limit_cycle
        theta_d, dtheta_d = states @ system.c_x, states @ system.c_v
    return SimulationResult(
        time=time,
        states=states,
        theta_d=theta_d,
        dtheta_d=dtheta_d,
        torque=torque,
        theta_b=theta_b,
        mode=modes,
        events=int(events),
        model=model,
        state_names=system.state_names,
    )


def two_mass_system(motor_inertia, load_inertia, motor_damping=0.0, load_damping=0.0):
    """Open-loop two-mass drive: states theta_d, motor_speed, load_speed.

    ``J_m dw_m/dt = T_m - T - d_m w_m``, ``J_l dw_l/dt = T_l + T - d_l w_l``,
    ``dtheta_d/dt = w_m - w_l`` (paper eq. 42 and the Figure 3 model).
    Inputs: ``motor_torque`` T_m and ``load_torque`` T_l (N m).
    """
    for name, value in (("motor_inertia", motor_inertia), ("load_inertia", load_inertia)):
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    jm, jl = float(motor_inertia), float(load_inertia)
    a_mat = np.array([[0.0, 1.0, -1.0], [0.0, -motor_damping / jm, 0.0], [0.0, 0.0, -load_damping / jl]])
    return LinearPart(
        A=a_mat,
        b=np.array([0.0, -1.0 / jm, 1.0 / jl]),
        E=np.array([[0.0, 0.0], [1.0 / jm, 0.0], [0.0, 1.0 / jl]]),
        c_x=np.array([1.0, 0.0, 0.0]),
        c_v=np.array([0.0, 1.0, -1.0]),
        state_names=("theta_d", "motor_speed", "load_speed"),
        input_names=("motor_torque", "load_torque"),
    )


def simulate_two_mass(plant, model, t_end, dt, motor_torque=0.0, load_torque=0.0, z0=None, theta_b0=0.0):
    """Open-loop two-mass drive with backlash under given external torques.

    Parameters
    ----------
    plant : Plant
        Inertias (and the shaft, unless ``model`` is given as an object).
    model : str or BacklashModel
        A law name (built from ``plant``'s shaft) or a model object.
    t_end, dt : float
        Final time and step, s.
    motor_torque, load_torque : float, array_like or callable
        T_m and T_l (N m): constants, arrays on the grid, or functions of time.
    z0 : array_like, optional
        Initial ``(theta_d, motor_speed, load_speed)``.
    theta_b0 : float
        Initial backlash angle of the exact model, rad.

    Returns
    -------
    SimulationResult
    """
    from .models import make_model

    if isinstance(model, str):
        model = make_model(model, **plant.shaft)
    system = two_mass_system(plant.motor_inertia, plant.load_inertia)

    def inputs(time):
        columns = []
        for value in (motor_torque, load_torque):
            column = value(time) if callable(value) else value
            columns.append(np.broadcast_to(np.asarray(column, dtype=float), time.shape))
        return np.stack(columns, axis=1)

    return simulate_linear(system, model, t_end, dt, inputs=inputs, z0=z0, theta_b0=theta_b0)


# ---- closed loop and limit-cycle measurement

__all__ += ["MeasuredCycle", "measure_limit_cycle", "simulate_rig", "simulated_limit_cycle", "default_step"]


@dataclasses.dataclass(frozen=True)
class MeasuredCycle:
    """A limit cycle measured in a time simulation, or the finding that there is none.

    Attributes
    ----------
    found : bool
        True if the response settled to a sustained oscillation with shaft contact.
    amplitude : float
        First-harmonic amplitude of theta_d (rad), the DF's ``A``; NaN if none.
    peak : float
        Half the peak-to-peak excursion of theta_d (rad); NaN if none.
    omega : float
        Angular frequency of the cycle (rad/s); NaN if none.
    bias : float
        Mean of theta_d over the measured periods (rad); NaN if none.
    settled : bool
        True if a steady state was reached (a periodic cycle, or rest in the gap),
        or the run diverged (longer runs cannot change that).
    verdict : str
        ``"limit cycle"``, ``"no limit cycle"`` (rest: no shaft contact at the end),
        ``"decaying"``, ``"growing"``, ``"drifting in the gap"`` or ``"irregular"`` (not settled),
        or ``"diverged"`` (overflow, NaN, or theta_d beyond the bound of :func:`measure_limit_cycle`).
    periods : int
        Number of periods averaged.
    """

    found: bool
    amplitude: float
    peak: float
    omega: float
    bias: float
    settled: bool
    verdict: str
    periods: int = 0

    def __repr__(self):
        if not self.found:
            return f"MeasuredCycle({self.verdict})"
        return (
            f"MeasuredCycle(amplitude={self.amplitude:.6g} rad, peak={self.peak:.6g} rad, "
            f"omega={self.omega:.6g} rad/s, bias={self.bias:.3g} rad, periods={self.periods})"
        )

    def __str__(self):
        """What a report prints: ``limit cycle: A = 0.151 rad, w = 95.9 rad/s (...)`` or the verdict."""
        if not self.found:
            return self.verdict
        return (f"limit cycle: A = {self.amplitude:.4g} rad, w = {self.omega:.4g} rad/s "
                f"(peak {self.peak:.4g} rad, bias {self.bias:.3g} rad, {self.periods} periods averaged)")

    def to_dict(self):
        """``{"amplitude", "omega"}`` (rad, rad/s) as in the ``predict`` JSON, or ``None``."""
        if not self.found:
            return None
        return {"amplitude": float(self.amplitude), "omega": float(self.omega)}


def _upward_crossings(time, signal):
    """Times (s) where ``signal`` crosses zero upwards, linearly interpolated."""
    below = signal[:-1] < 0.0
    above = signal[1:] >= 0.0
    i = np.nonzero(below & above)[0]
    frac = -signal[i] / (signal[i + 1] - signal[i])
    return time[i] + frac * (time[i + 1] - time[i])


def _window_integral(time, values, t0, t1):
    """Trapezoid integral of sampled ``values`` over [t0, t1] with interpolated ends."""
    inside = (time > t0) & (time < t1)
    t = np.concatenate(([t0], time[inside], [t1]))
    y = np.concatenate(([np.interp(t0, time, values.real)], values.real[inside], [np.interp(t1, time, values.real)]))
    if np.iscomplexobj(values):
        y = y + 1j * np.concatenate(
            ([np.interp(t0, time, values.imag)], values.imag[inside], [np.interp(t1, time, values.imag)])
        )
    return np.trapezoid(y, t)


def measure_limit_cycle(result, periods=6, rtol=1e-3, window=0.25, bound=None):
    """Measure the limit cycle at the end of a closed-loop simulation.

    The last ``periods`` full periods of theta_d (between upward crossings of its
    mean, located by linear interpolation) give the frequency; the first harmonic
    ``|2/T int theta_d e^{-jwt} dt|`` over them gives the amplitude (the DF
    convention of DESIGN.md).  Steady state: the period lengths and per-period
    peak amplitudes agree to ``rtol``.  A relative speed dtheta_d below ``rtol``
    times its largest value over the last ``window`` of the record means the
    motion decayed: no limit cycle, whether it came to rest in the gap (with a
    free load the last contacts come ever more rarely) or at a side of it, where
    round-off can leave a periodic-looking wobble of 1e-15 rad.  The test is
    relative: after a kick 1000 times faster than a small cycle, the cycle is
    taken for rest (``benchmarks/bench_verdicts.py`` meets three such runs).

    Parameters
    ----------
    result : SimulationResult
    periods : int
        Number of full periods to average (at least 2).
    rtol : float
        Relative tolerance of the steady-state test.
    window : float
        Fraction of the record (at its end) examined for shaft contact.
    bound : float, optional
        Largest ``|theta_d|`` (rad) of a run that has not diverged (default ``1e3
        alpha``, five times the largest amplitude the DF search considers).  A run
        that exceeds it, overflows or turns NaN is ``"diverged"``: never a cycle or rest.

    Returns
    -------
    MeasuredCycle
    """
    time, x = result.time, result.theta_d
    bound = 1e3 * result.model.half_gap if bound is None else bound
    if not (np.all(np.isfinite(result.states)) and np.abs(x).max() <= bound):
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, True, "diverged")
    tail = time >= time[-1] * (1.0 - window)
    # decayed: the relative speed has fallen below rtol of its largest value
    resting = np.abs(result.dtheta_d[tail]).max() < rtol * np.abs(result.dtheta_d).max()
    if resting:
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, True, "no limit cycle")
    if np.all(result.mode[tail] == 0):
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, "drifting in the gap")
    half = time >= 0.5 * time[-1]
    center = 0.5 * (x[half].max() + x[half].min())
    crossings = _upward_crossings(time[half], x[half] - center)
    if crossings.size < periods + 1:
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, "irregular")
    edges = crossings[-(periods + 1):]
    lengths = np.diff(edges)
    peaks = np.array([np.ptp(x[(time >= a) & (time <= b)]) for a, b in zip(edges[:-1], edges[1:])]) / 2.0
    period = (edges[-1] - edges[0]) / periods
    omega = 2.0 * math.pi / period
    bias = _window_integral(time, x, edges[0], edges[-1]) / (edges[-1] - edges[0])
    c1 = 2.0 * _window_integral(time, x * np.exp(-1j * omega * time), edges[0], edges[-1]) / (edges[-1] - edges[0])
    settled = np.ptp(lengths) <= rtol * period and np.ptp(peaks) <= rtol * peaks.mean()
    if not settled:
        verdict = "decaying" if peaks[-1] < peaks[0] else "growing" if peaks[-1] > peaks[0] else "irregular"
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, verdict)
    return MeasuredCycle(True, float(abs(c1)), float(peaks.mean()), float(omega), float(bias), True, "limit cycle", periods)


def _initial_state(system, initial, kick):
    """Initial state: named values, plus the least-norm state with theta_d = 0, dtheta_d = kick."""
    rows = np.array([system.c_x, system.c_v])
    z0 = np.linalg.pinv(rows) @ np.array([0.0, float(kick)])
    for name, value in (initial or {}).items():
        if name not in system.state_names:
            raise ValueError(f"initial: no state {name!r}; states are: {', '.join(system.state_names)}")
        z0[system.state_names.index(name)] = float(value)
    return z0


def default_step(system, model):
    """A step (s) resolving the fastest closed-loop dynamics: ``0.05 / max|eigenvalue|``.

    The eigenvalues are those of the loop with the shaft in full contact
    (``T = k theta_d + c dtheta_d``); the step never exceeds the dead time.
    """
    closed = system.A + np.outer(system.b, model.stiffness * system.c_x + model.damping * system.c_v)
    fastest = max(np.abs(np.linalg.eigvals(closed)).max(), 1e-3)
    dt = 0.05 / fastest
    if system.delay > 0.0:
        dt = min(dt, system.delay / math.ceil(system.delay / dt))
    return dt


def simulate_rig(rig, model=None, t_end=20.0, dt=None, speed_reference=0.0, load_torque=None,
                 initial=None, kick=0.0, linear=None):
    """Closed-loop time simulation of a rig's PI speed loop with a backlash torque law.

    Public as :func:`backlash_df.simulate`.  The loop is that of
    :mod:`backlash_df.loops` (states ``theta_d``, ``motor_speed``,
    ``load_speed``, ``integrator`` and, when present, ``filtered_speed`` and
    ``motor_torque``), integrated by the compiled kernel of this module.

    Parameters
    ----------
    rig : Rig
        Plant and ``[controller]`` (the shaft parameters build ``model`` if a name).
    model : str or BacklashModel, optional
        Torque law (default: the rig's ``[model] backlash``); the exact model included.
    t_end : float
        Simulated time, s.
    dt : float, optional
        Step, s (default :func:`default_step`).
    speed_reference, load_torque : float or callable
        r (rad/s) and T_l (N m): constants or functions of time (default
        ``load_torque``: the rig's ``[load] torque``).
    initial : dict, optional
        Initial values by state name, e.g. ``{"motor_speed": 0.5}``; others 0.
    kick : float
        Initial rate dtheta_d (rad/s) added as the least-norm state with
        ``theta_d = 0`` (for the PI loop: motor and load speeds at +-kick/2).
    linear : control.LTI, optional
        A user's linear part G (shaft torque -> -theta_d) replacing the rig's loop;
        then the loop has no external inputs and ``initial`` names ``x0, x1, ...``.

    Returns
    -------
    SimulationResult

    Examples
    --------
    >>> from backlash_df import rig_from_dict, simulate
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5, "feedback": "motor"}})
    >>> result = simulate(rig, "phase-plane", t_end=1.0, initial={"motor_speed": 1.0})
    >>> result.state_names
    ('theta_d', 'motor_speed', 'load_speed', 'integrator')
    """
    from .loops import drive_loop, lti_linear_part
    from .models import BacklashModel

    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    system = drive_loop(rig).linear_part() if linear is None else lti_linear_part(linear)
    dt = default_step(system, model) if dt is None else dt
    z0 = _initial_state(system, initial, kick)
    load_torque = rig.load.torque if load_torque is None else load_torque
    inputs = None
    if system.E.shape[1] == 2:

        def inputs(time):
            columns = []
            for value in (speed_reference, load_torque):
                column = value(time) if callable(value) else value
                columns.append(np.broadcast_to(np.asarray(column, dtype=float), time.shape))
            return np.stack(columns, axis=1)

    return simulate_linear(system, model, t_end, dt, inputs=inputs, z0=z0)


def simulated_limit_cycle(rig, model=None, t_end=20.0, max_t_end=160.0, dt=None, periods=6, rtol=1e-3, **kwargs):
    """Simulate until a steady state and measure the limit cycle.

    Runs :func:`simulate_rig` for ``t_end`` and doubles it (re-running from the
    start, so a dead time's history stays exact) until :func:`measure_limit_cycle`
    finds a steady state or ``max_t_end`` is passed.

    Parameters
    ----------
    rig, model, dt, **kwargs
        As :func:`simulate_rig` (``speed_reference``, ``load_torque``, ``initial``, ``kick``, ``linear``).
    t_end, max_t_end : float
        First and largest simulated time, s.
    periods, rtol
        As :func:`measure_limit_cycle`.

    Returns
    -------
    measured : MeasuredCycle
    result : SimulationResult
        The last simulation run.
    """
    while True:
        result = simulate_rig(rig, model, t_end=t_end, dt=dt, **kwargs)
        measured = measure_limit_cycle(result, periods=periods, rtol=rtol)
        if measured.settled or 2.0 * t_end > max_t_end:
            return measured, result
        t_end *= 2.0
