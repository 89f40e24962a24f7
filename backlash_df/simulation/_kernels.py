"""Compiled kernels of the closed-loop simulation (private to :mod:`backlash_df.simulation`).

Two kernels integrate ``dz/dt = A z + b T + E w(t) + e_d u_d(t - delay) - e_f F(f z)``
(:class:`~backlash_df.system.LinearPart`) closed through a backlash torque law, on a
fixed grid with the law's mode frozen over each step and every change of mode located
by bisection (:mod:`backlash_df.simulation` explains both):

* :func:`run_rk4`, classical RK4 for any law and for friction;
* :func:`run_exact`, exact discretisation of a loop that is affine inside every mode,
  stepping with the ladders ``exp(M dt 2^-j)`` of ``_switching.exp_ladder``.

With a torque limit (:class:`~backlash_df.system.Command`) a run carries a second
mode, the command's (``COMMAND_MODES`` of ``backlash_df._switching``: linear, saturated,
integrator clamped, sliding on the limit), switched and located like the backlash's.
:func:`run_rk4` takes the command as ``cmd``, a :class:`CommandRows`,
:func:`run_exact` as ``command``, an :class:`AugmentedCommand` of
``_switching.command_matrices``; both ``None`` without a limit: numba then
compiles the kernel without the command's code (it prunes the branches on ``is None``
before typing): 1 s of the exact kernel's first compile, 2.5 s of the RK4 kernel's.
"""

import math

import numpy as np

from typing import NamedTuple

from .._jit import borrowing as _borrowing
from .._jit import inline as _inline
from .._jit import jit as _jit
from .._jit import jit_unchecked as _jit_unchecked
from .._laws import DAMPING, EXACT, HALF_GAP, RUBBER_THICKNESS, STIFFNESS, exact_step, held_mode, mode_torque
from .._switching import (CHAIN, CHAINS, CURVATURE, RATE, THETA_B, VALUE, StickRows, command_index,
                          command_mode_of, initial_command_mode)
from ..friction import friction_kernel

__all__ = ["CommandRows", "AugmentedCommand", "AugmentedFriction", "StickRows", "run_rk4", "run_exact", "LEVELS",
           "BLOW_UP"]

_MAX_EVENTS_PER_STEP = 32
_BISECTIONS = 52
_COMMAND_ROW = 5  # the row of the RK4 kernel's work array that the command's rate uses (rows 0-3: the stages)
_STICK_ROW = 4  # the row the sticking friction's holding torques are evaluated in
#: Dyadic sub-steps dt 2^-j, j < LEVELS, of the exact-discretisation kernel.
LEVELS = 42


class CommandRows(NamedTuple):
    """A :class:`~backlash_df.system.Command` as the RK4 kernel takes it: rows over ``[z, w, u_d]``."""

    column: np.ndarray
    row: np.ndarray
    error: np.ndarray
    limit: float
    integrator: int


class AugmentedCommand(NamedTuple):
    """A torque limit as the exact kernel takes it: ``_switching.command_matrices``' rows over the
    augmented state, the limit (N m) and whether the loop clamps an integrator."""

    u_row: np.ndarray
    e_row: np.ndarray
    rates: np.ndarray
    limit: float
    clamps: bool


class AugmentedFriction(NamedTuple):
    """Coulomb friction as the exact kernel takes it: per rubbing side the row of its speed in the
    augmented state (``index``), its Coulomb level (N m), and per backlash mode row its holding friction
    as a row over the augmented state (``hold``, shape (3, sides, size): the friction that keeps the side
    at rest, ``e_i^T M q / column_i``).  The ladders hold, per backlash mode row, one per combination of
    the sides' modes (-1, +1 sliding, 0 stuck), numbered ``sum (mode_s + 1) 3^s``."""

    index: np.ndarray
    level: np.ndarray
    hold: np.ndarray


# --------------------------------------------------------------------------- RK4 kernel (any law)


@_inline
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


@_inline
def _history(hist, position, last, col):
    """Delayed signal ``col`` at a fractional row of ``hist`` whose newest recorded row is ``last``.

    Cubic through rows ``j - 1 .. j + 2`` around ``j = floor(position)`` (rows
    before 0 repeat row 0: the history is constant before t = 0), the quadratic
    through ``j - 1 .. j + 1`` while row ``j + 2`` is not recorded yet: an
    interpolation error O(dt^4) (O(dt^3)) where linear interpolation leaves O(dt^2),
    which showed as a 1e-3 amplitude error of a cycle with a 0.5 ms dead time
    (tests/test_delay.py).
    """
    if position <= 0.0:
        return hist[0, col]
    j = int(position)
    if j >= last:
        return hist[last, col]
    u = position - j
    f0, f1, f2 = hist[max(j - 1, 0), col], hist[j, col], hist[j + 1, col]
    if j + 2 > last:
        return f1 + 0.5 * u * (f2 - f0) + 0.5 * u * u * (f2 - 2.0 * f1 + f0)
    f3 = hist[j + 2, col]
    return (-u * (u - 1.0) * (u - 2.0) * f0 + 3.0 * (u + 1.0) * (u - 1.0) * (u - 2.0) * f1
            - 3.0 * (u + 1.0) * u * (u - 2.0) * f2 + (u + 1.0) * u * (u - 1.0) * f3) / 6.0


@_inline
def _torque(law, mode, x, v, p):
    if law == EXACT:
        if mode > 0:
            return p[STIFFNESS] * (x - p[HALF_GAP]) + p[DAMPING] * v
        if mode < 0:
            return p[STIFFNESS] * (x + p[HALF_GAP]) + p[DAMPING] * v
        return 0.0
    return mode_torque(law, mode, x, v, p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS])


@_jit_unchecked
def _signals(t, delay, W, hist, dt, wvals, dvals):
    """The inputs ``w(t)`` into ``wvals`` and the delayed signals ``u_d(t)`` into ``dvals``."""
    # W spans the run uniformly: one row per output step, or two (half steps)
    w_row = t / dt * (W.shape[0] - 1) / (hist.shape[0] - 1)
    for j in range(W.shape[1]):
        wvals[j] = _lerp(W, w_row, j)
    if delay > 0.0:
        last = max(math.ceil(t / dt) - 1, 0)
        for j in range(dvals.shape[0]):
            dvals[j] = _history(hist, (t - delay) / dt, last, j)


@_inline
def _row_value(row, z, wvals, dvals):
    """``row . [z, w, u_d]``: the command or the error of a :class:`~backlash_df.system.Command`."""
    n, m = z.shape[0], wvals.shape[0]
    acc = 0.0
    for j in range(n):
        acc += row[j] * z[j]
    for j in range(m):
        acc += row[n + j] * wvals[j]
    for j in range(dvals.shape[0]):
        acc += row[n + m + j] * dvals[j]
    return acc


@_jit_unchecked
def _friction(z, f_row, f_level, f_eps, f_break, f_ws):
    """Friction torque of the driven machine at ``z`` (N m): the law of :mod:`backlash_df.friction` at the speed
    ``f_row . z``, smoothed Coulomb and breakaway (the viscous part is in the linear part); 0 without."""
    if f_level > 0.0 or f_break > 0.0:
        s = 0.0
        for j in range(z.shape[0]):
            s += f_row[j] * z[j]
        return friction_kernel(s, 0.0, f_level, f_break, f_eps, f_ws)
    return 0.0


@_jit_unchecked
def _field(z, torque, friction, wvals, dvals, a_mat, b_t, e_mat, e_d, e_f, out, row):
    """``dz/dt = A z + b T + E w + e_d u_d - e_f F`` with the command linear, into ``out[row]``."""
    n = z.shape[0]
    for i in range(n):
        acc = b_t[i] * torque
        for j in range(e_d.shape[1]):
            acc += e_d[i, j] * dvals[j]
        out[row, i] = acc - e_f[i] * friction
    for j in range(wvals.shape[0]):
        w = wvals[j]
        for i in range(n):
            out[row, i] += e_mat[i, j] * w
    for i in range(n):
        acc = out[row, i]
        for j in range(n):
            acc += a_mat[i, j] * z[j]
        out[row, i] = acc


@_jit_unchecked
def _command_field(z, cmode, column, u_row, limit, integrator, wvals, dvals, out, row):
    """``out[row]`` in command mode ``cmode``: saturated, +-limit in place of u; clamped (and sliding,
    projected after the step), the integrator held."""
    gap = (limit if cmode > 0 else -limit) - _row_value(u_row, z, wvals, dvals)
    for i in range(z.shape[0]):
        out[row, i] += column[i] * gap
    if abs(cmode) >= 2 and integrator >= 0:
        out[row, integrator] = 0.0


@_inline
def _stick_field(z, fmodes, index, column, coulomb, breakaway, stribeck, held, out, row):
    """Each side's dry friction into ``out[row]`` (:class:`~backlash_df.system.Sticking`, a :class:`StickRows`
    one array by one): sliding, ``(F_c + F_s exp(-(w / w_s)^2))`` against the mode's direction; stuck, the
    torque that holds the speed at rest, also written to ``held``."""
    n = z.shape[0]
    for s in range(index.shape[0]):
        i = index[s]
        if fmodes[s] == 0:
            force = out[row, i] / column[s, i]
            held[s] = force
        else:
            force = coulomb[s]
            if breakaway[s] > 0.0:
                force += breakaway[s] * math.exp(-(z[i] / stribeck[s]) ** 2)
            if fmodes[s] < 0:
                force = -force
        for j in range(n):
            out[row, j] -= column[s, j] * force
        if fmodes[s] == 0:
            out[row, i] = 0.0


@_inline
def _frictions(z, t, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work, wvals, dvals):
    """The holding torques of the stuck sides at ``(z, t)`` in the given modes, into ``held`` (N m)."""
    a_mat, b_t, e_mat, c_x, c_v, _, e_d, delay, f_row, e_f, f_level, f_eps, f_break, f_ws = sys
    _stage(z, t, mode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, (f_level, f_eps, f_break, f_ws), delay,
           W, hist, dt, wvals, dvals, work, np.int64(_STICK_ROW))
    if cmd is not None and cmode != 0:
        column, u_row, _, limit, integrator = cmd
        _command_field(z, cmode, column, u_row, limit, integrator, wvals, dvals, work, np.int64(_STICK_ROW))
    index, column, coulomb, breakaway, stribeck = stick
    _stick_field(z, fmodes, index, column, coulomb, breakaway, stribeck, held, work, np.int64(_STICK_ROW))


@_jit
def _stick_leaves(z, t, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work, wvals, dvals):
    """True if a side's friction mode must change at ``(z, t)``: a sliding speed reversed, a stuck side's holding
    torque beyond its static level ``F_c + F_s``."""
    index, _, coulomb, breakaway, _ = stick
    stuck = False
    for s in range(index.shape[0]):
        if fmodes[s] * z[index[s]] < 0.0:
            return True
        stuck = stuck or fmodes[s] == 0
    if not stuck:
        return False
    _frictions(z, t, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work, wvals, dvals)
    for s in range(index.shape[0]):
        if fmodes[s] == 0 and abs(held[s]) > coulomb[s] + breakaway[s]:
            return True
    return False


@_jit
def _stick_modes(z, t, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work, wvals, dvals, out):
    """The friction modes at ``(z, t)`` reached in ``fmodes``, into ``out``: a side at rest or whose speed
    reversed (its speed set to 0 in ``z``) sticks if its holding torque is within its static level, else
    slides in the direction of that torque; a sliding side keeps its mode."""
    index, _, coulomb, breakaway, _ = stick
    for s in range(index.shape[0]):
        out[s] = fmodes[s]
        if fmodes[s] * z[index[s]] <= 0.0:
            z[index[s]] = 0.0
            out[s] = 0
    _frictions(z, t, mode, cmode, law, p, sys, cmd, stick, out, held, W, hist, dt, work, wvals, dvals)
    for s in range(index.shape[0]):
        if out[s] == 0 and abs(held[s]) > coulomb[s] + breakaway[s]:
            out[s] = 1 if held[s] > 0.0 else -1


@_inline
def _stage(z, t, mode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, friction, delay, W, hist, dt, wvals,
           dvals, out, row):
    """``dz/dt`` at ``(z, t)`` in backlash mode ``mode``, the command linear, into ``out[row]``.

    The arrays of :meth:`~backlash_df.system.LinearPart.kernel_arrays` one by one,
    ``friction`` its four constants.  :func:`_free_steps` writes these lines out: numba
    reference-counts an inlined helper's arrays held across a call (here the law's
    torque and the call-free helpers), and the arrays a compiled function takes if it
    calls another, on every call.
    """
    x, v = _xv(z, c_x, c_v)
    torque = _torque(law, mode, x, v, p)
    _signals(t, delay, W, hist, dt, wvals, dvals)
    f_level, f_eps, f_break, f_ws = friction
    _field(z, torque, _friction(z, f_row, f_level, f_eps, f_break, f_ws), wvals, dvals, a_mat, b_t, e_mat, e_d, e_f,
           out, row)


@_inline
def _rk4(z, t, h, mode, cmode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, friction, delay, cmd, stick,
         fmodes, held, W, hist, dt, k, tmp, wvals, dvals, out):
    """One classical RK4 step ``h`` from ``(z, t)``, the modes frozen, into ``out``; stages in rows 0-3 of ``k``.

    ``cmd`` the command (module docs), read in command modes other than 0; ``stick`` the sticking friction
    (:class:`StickRows`) in the sides' modes ``fmodes``, or None.
    """
    n = z.shape[0]
    _copy_vector(z, tmp, n)
    stage_t = t
    for stage in range(4):
        _stage(tmp, stage_t, mode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, friction, delay, W, hist,
               dt, wvals, dvals, k, stage)
        if cmd is not None and cmode != 0:
            column, u_row, _, limit, integrator = cmd
            _command_field(tmp, cmode, column, u_row, limit, integrator, wvals, dvals, k, stage)
        if stick is not None:
            index, column, coulomb, breakaway, stribeck = stick
            _stick_field(tmp, fmodes, index, column, coulomb, breakaway, stribeck, held, k, stage)
        if stage < 3:
            ahead = h if stage == 2 else 0.5 * h
            for i in range(n):
                tmp[i] = z[i] + ahead * k[stage, i]
            stage_t = t + ahead
    for i in range(n):
        out[i] = z[i] + h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])


@_jit
def _command_mode_rk4(mode, cmode, z, t, sys, cmd, stick, fmodes, held, law, p, W, hist, dt, work, wvals, dvals,
                      ahead):
    """The command mode of state ``z`` at ``t`` reached in ``cmode`` (``du/dt`` by the clamped field
    and by differences of the inputs and delayed signals over half a step; ``ahead`` holds the signals
    half a step on, inputs then delayed ones); ``cmd`` a command, not None."""
    column, row, error, limit, integrator = cmd
    a_mat, b_t, e_mat, c_x, c_v, _, e_d, delay, f_row, e_f, f_level, f_eps, f_break, f_ws = sys
    _signals(t, delay, W, hist, dt, wvals, dvals)
    u = _row_value(row, z, wvals, dvals)
    e = _row_value(error, z, wvals, dvals)
    side = (1 if cmode > 0 else -1) if cmode != 0 else (1 if u > limit else (-1 if u < -limit else 0))
    if side == 0:
        return 0
    _stage(z, t, mode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, (f_level, f_eps, f_break, f_ws), delay,
           W, hist, dt, wvals, dvals, work, np.int64(_COMMAND_ROW))
    _command_field(z, 2 * side if integrator >= 0 else side, column, row, limit, integrator, wvals, dvals, work,
                   np.int64(_COMMAND_ROW))  # not a literal: one compile of _command_field (_jit docs)
    if stick is not None:
        index, column, coulomb, breakaway, stribeck = stick
        _stick_field(z, fmodes, index, column, coulomb, breakaway, stribeck, held, work, np.int64(_COMMAND_ROW))
    clamped = 0.0
    for j in range(z.shape[0]):
        clamped += row[j] * work[5, j]
    n, m = z.shape[0], wvals.shape[0]
    h = 0.5 * dt
    _signals(t + h, delay, W, hist, dt, wvals, dvals)
    for j in range(m):
        ahead[j] = wvals[j]
    for j in range(dvals.shape[0]):
        ahead[m + j] = dvals[j]
    _signals(max(t - h, 0.0), delay, W, hist, dt, wvals, dvals)
    span = t + h - max(t - h, 0.0)
    for j in range(m):
        clamped += row[n + j] * (ahead[j] - wvals[j]) / span
    for j in range(dvals.shape[0]):
        clamped += row[n + m + j] * (ahead[m + j] - dvals[j]) / span
    integrating = clamped + (row[integrator] * e if integrator >= 0 else 0.0)
    return command_mode_of(cmode, u, e, clamped, integrating, limit, integrator >= 0)


@_inline
def _copy_vector(src, dst, count):
    """``dst[:count] = src[:count]`` without the views."""
    for i in range(count):
        dst[i] = src[i]


@_inline
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
        return held_mode(law, mode, x, v, p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS])
    if theta_b >= p[HALF_GAP] and p[STIFFNESS] * (x - p[HALF_GAP]) + p[DAMPING] * v >= 0.0:
        return 1
    if theta_b <= -p[HALF_GAP] and p[STIFFNESS] * (x + p[HALF_GAP]) + p[DAMPING] * v <= 0.0:
        return -1
    return 0


@_jit
def _must_leave(law, p, mode, x, v, theta_b):
    """True if a state reached with ``mode`` frozen lies outside that mode (release, contact, or region)."""
    if law != EXACT:
        return held_mode(law, mode, x, v, p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]) != mode
    if mode > 0:
        return p[STIFFNESS] * (x - p[HALF_GAP]) + p[DAMPING] * v < 0.0
    if mode < 0:
        return p[STIFFNESS] * (x + p[HALF_GAP]) + p[DAMPING] * v > 0.0
    return abs(theta_b) >= p[HALF_GAP]


@_borrowing
def _advance(z, theta_b, t, h, mode, cmode, sys, cmd, stick, fmodes, held, law, p, W, hist, dt, work, tmp, wvals,
             dvals, ahead, z_out):
    """One frozen-mode step; returns (theta_b at the end, True if the backlash, the command or a friction mode
    must change).

    On the limit (sliding) the step is the clamped one with the integrator then
    projected back onto ``u = +-limit``: with the command saturated the rest of the
    loop does not see the integrator.
    """
    a_mat, b_t, e_mat, c_x, c_v, _, e_d, delay, f_row, e_f, f_level, f_eps, f_break, f_ws = sys
    _rk4(z, t, h, mode, cmode, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, (f_level, f_eps, f_break, f_ws),
         delay, cmd, stick, fmodes, held, W, hist, dt, work, tmp, wvals, dvals, z_out)
    command_leaves = False
    if cmd is not None:
        _, row, _, limit, integrator = cmd
        if abs(cmode) == 3:
            _signals(t + h, delay, W, hist, dt, wvals, dvals)
            gap = (limit if cmode > 0 else -limit) - _row_value(row, z_out, wvals, dvals)
            z_out[integrator] += gap / row[integrator]
        command_leaves = _command_mode_rk4(mode, cmode, z_out, t + h, sys, cmd, stick, fmodes, held, law, p, W, hist,
                                           dt, work, wvals, dvals, ahead) != cmode
    friction_leaves = False
    if stick is not None:
        friction_leaves = _stick_leaves(z_out, t + h, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt,
                                        work, wvals, dvals)
    x0, v0 = _xv(z, c_x, c_v)
    x1, v1 = _xv(z_out, c_x, c_v)
    theta_new, backlash_leaves = _backlash_after(law, p, mode, theta_b, x0, v0, x1, v1, h)
    return theta_new, command_leaves or backlash_leaves or friction_leaves


@_jit
def _backlash_after(law, p, mode, theta_b, x0, v0, x1, v1, h):
    """(theta_b, True if the backlash mode must change) after a frozen-mode step ``(x0, v0) -> (x1, v1)``."""
    if law != EXACT:
        return theta_b, _must_leave(law, p, mode, x1, v1, theta_b)
    if mode != 0:
        return p[HALF_GAP] if mode > 0 else -p[HALF_GAP], _must_leave(law, p, mode, x1, v1, theta_b)
    theta_new = exact_step(theta_b, x0, v0, x1, v1, h, p[STIFFNESS], p[DAMPING], p[HALF_GAP])
    return theta_new, abs(theta_new) >= p[HALF_GAP]


@_inline
def _record(i, z, n, theta_b, mode, cmode, torque, d_rows, Z, T, THETA, MODES, CMODES, hist):
    """Store sample ``i`` of a run: state ``z[:n]``, shaft torque, theta_b, modes and the delayed signals."""
    for j in range(n):
        Z[i, j] = z[j]
    T[i] = torque
    THETA[i] = theta_b
    MODES[i] = mode
    CMODES[i] = cmode
    for k in range(d_rows.shape[0]):
        u = 0.0
        for j in range(n):
            u += d_rows[k, j] * z[j]
        hist[i, k] = u


#: |state| beyond it: the run has diverged (measure_limit_cycle names it).
BLOW_UP = 1e150


@_inline
def _diverged(i, z, n, Z, T, THETA, MODES, CMODES):
    """True when state ``z[:n]`` of sample ``i`` has blown up; the later samples are then NaN.

    Stepping on would overflow to inf and NaN, and a division by them inside a
    kernel raises; a diverged run ends here instead, and is named by
    :func:`measure_limit_cycle`.
    """
    for k in range(n):
        if not abs(z[k]) <= BLOW_UP:  # NaN fails the test too
            for j in range(i + 1, Z.shape[0]):
                for col in range(Z.shape[1]):
                    Z[j, col] = np.nan
                T[j] = np.nan
                THETA[j] = np.nan
                MODES[j] = MODES[i]
                CMODES[j] = CMODES[i]
            return True
    return False


@_borrowing
def _free_steps(i, z, theta_b, mode, cmode, limited, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d, e_f, f_row, friction,
                delay, W, hist, dt, n_steps, d_rows, k, tmp, wvals, dvals, z_new, Z, T, THETA, MODES, CMODES, stick,
                fmodes, held, FMODES):
    """Sample ``i`` recorded, then, without a torque limit, the steps that stay in their modes, each sample recorded.

    Returns ``(j, theta_b, ended)``: ``j`` the last sample recorded, ``z`` and
    ``theta_b`` its state; ``ended`` if the run ends there (the last sample, or
    diverged), else step ``j`` is left to the event path of :func:`run_rk4` (it
    leaves its modes, or a limit is set).  The step is :func:`_rk4` in command mode 0
    with :func:`_stage` written out: one call per run of such steps.  With sticking
    friction (``stick``) the sides' modes ``fmodes`` are frozen too, and a step after
    which one must change (:func:`_stick_leaves`, written out) is left to the event path.
    """
    n = z.shape[0]
    f_level, f_eps, f_break, f_ws = friction
    if stick is not None:  # unpacked once: a tuple of arrays is reference-counted member by member at each use
        index, column, coulomb, breakaway, stribeck = stick
    while True:
        x, v = _xv(z, c_x, c_v)
        torque = _torque(law, mode, x, v, p)
        _record(i, z, n, theta_b, mode, cmode, torque, d_rows, Z, T, THETA, MODES, CMODES, hist)
        for s in range(fmodes.shape[0]):
            FMODES[i, s] = fmodes[s]
        if i == n_steps or _diverged(i, z, n, Z, T, THETA, MODES, CMODES):
            return i, theta_b, True
        if limited:
            return i, theta_b, False
        t = i * dt
        _copy_vector(z, tmp, n)
        stage_t = t
        for stage in range(4):
            x_s, v_s = _xv(tmp, c_x, c_v)  # x, v: the step's start, for _backlash_after
            torque = _torque(law, mode, x_s, v_s, p)
            _signals(stage_t, delay, W, hist, dt, wvals, dvals)
            _field(tmp, torque, _friction(tmp, f_row, f_level, f_eps, f_break, f_ws), wvals, dvals, a_mat, b_t, e_mat,
                   e_d, e_f, k, stage)
            if stick is not None:
                _stick_field(tmp, fmodes, index, column, coulomb, breakaway, stribeck, held, k, stage)
            if stage < 3:
                ahead = dt if stage == 2 else 0.5 * dt
                for j in range(n):
                    tmp[j] = z[j] + ahead * k[stage, j]
                stage_t = t + ahead
        for j in range(n):
            z_new[j] = z[j] + dt / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
        x1, v1 = _xv(z_new, c_x, c_v)
        theta_end, changed = _backlash_after(law, p, mode, theta_b, x, v, x1, v1, dt)
        if changed:
            return i, theta_b, False
        if stick is not None:
            stuck = False
            for s in range(index.shape[0]):
                changed = changed or fmodes[s] * z_new[index[s]] < 0.0
                stuck = stuck or fmodes[s] == 0
            if stuck and not changed:  # the stuck sides' holding torques at the step's end
                _signals(t + dt, delay, W, hist, dt, wvals, dvals)
                _field(z_new, _torque(law, mode, x1, v1, p), _friction(z_new, f_row, f_level, f_eps, f_break, f_ws),
                       wvals, dvals, a_mat, b_t, e_mat, e_d, e_f, k, np.int64(_STICK_ROW))
                _stick_field(z_new, fmodes, index, column, coulomb, breakaway, stribeck, held, k, np.int64(_STICK_ROW))
                for s in range(index.shape[0]):
                    changed = changed or (fmodes[s] == 0 and abs(held[s]) > coulomb[s] + breakaway[s])
            if changed:
                return i, theta_b, False
        _copy_vector(z_new, z, n)
        theta_b = theta_end
        i += 1


@_jit
def run_rk4(sys, cmd, stick, law, p, W, z0, theta_b0, dt, n_steps, Z, T, THETA, MODES, CMODES, FMODES, hist, first,
            mode0, cmode0, fmodes0):
    """RK4 run to sample ``n_steps`` (steps ``dt``), filling ``Z``, ``T``, ``THETA``, the modes and ``hist``.

    ``sys`` is :meth:`~backlash_df.system.LinearPart.kernel_arrays`, ``cmd`` the
    command (module docs), ``stick`` the sticking friction (:class:`StickRows`, None
    without), ``W`` the inputs on the output grid or at half steps, ``p`` the law's
    ``(k, c, alpha, beta)``, ``hist`` the delayed signals at every sample, ``FMODES``
    the friction modes of the sides at every sample (-1, 1 sliding backward, forward;
    0 stuck).  From ``z0`` and ``theta_b0`` at sample ``first = 0`` (the modes found
    there), or, going on with a run, from its state, ``mode0``, ``cmode0`` and
    ``fmodes0`` at its last sample ``first`` (its samples and history up to there
    filled in); returns the event count of the steps taken.
    """
    n = z0.shape[0]
    d_rows = sys.d
    work = np.empty((_COMMAND_ROW + 1, n))
    wvals = np.zeros(W.shape[1])
    dvals = np.zeros(d_rows.shape[0])
    ahead = np.empty(W.shape[1] + d_rows.shape[0])
    z = z0.copy()
    z_new = np.empty(n)
    z_try = np.empty(n)
    theta_b = theta_b0
    mode = mode0
    cmode = cmode0
    fmodes = fmodes0.copy()
    new_fmodes = fmodes0.copy()
    held = np.zeros(fmodes0.shape[0])
    if first == 0:
        x, v = _xv(z, sys.c_x, sys.c_v)
        mode = _mode_of(law, p, np.int64(0), x, v, theta_b)
        cmode = 0
        _record(0, z, n, theta_b, mode, cmode, _torque(law, mode, x, v, p), d_rows, Z, T, THETA, MODES, CMODES, hist)
        if cmd is not None:  # the command mode of the initial state
            _signals(0.0, sys.delay, W, hist, dt, wvals, dvals)
            cmode = initial_command_mode(_row_value(cmd.row, z, wvals, dvals), _row_value(cmd.error, z, wvals, dvals),
                                         cmd.limit, cmd.integrator >= 0)
        if stick is not None:  # the friction modes of the initial state: sliding where moving, else as held
            for s in range(fmodes.shape[0]):
                speed = z[stick.index[s]]
                fmodes[s] = 1 if speed > 0.0 else (-1 if speed < 0.0 else 0)
            _stick_modes(z, 0.0, mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work, wvals, dvals,
                         new_fmodes)
            _copy_vector(new_fmodes, fmodes, fmodes.shape[0])
    events = 0
    tmp = np.empty(n)
    # unpacked once: a tuple of arrays passed on, even to an inlined helper, is reference-counted member by member
    a_mat, b_t, e_mat, c_x, c_v, _, e_d, delay, f_row, e_f, f_level, f_eps, f_break, f_ws = sys
    friction = (f_level, f_eps, f_break, f_ws)
    limited = cmd is not None
    i = first
    while True:
        i, theta_b, ended = _free_steps(i, z, theta_b, mode, cmode, limited, law, p, a_mat, b_t, e_mat, c_x, c_v, e_d,
                                        e_f, f_row, friction, delay, W, hist, dt, n_steps, d_rows, work, tmp, wvals,
                                        dvals, z_new, Z, T, THETA, MODES, CMODES, stick, fmodes, held, FMODES)
        if ended:
            break
        t = i * dt
        remaining = dt
        for _ in range(_MAX_EVENTS_PER_STEP):
            theta_end, changed = _advance(z, theta_b, t, remaining, mode, cmode, sys, cmd, stick, fmodes, held, law,
                                          p, W, hist, dt, work, tmp, wvals, dvals, ahead, z_new)
            if not changed:
                _copy_vector(z_new, z, n)
                theta_b = theta_end
                remaining = 0.0
                break
            # bisect for the first fraction of the remaining step where a mode changes
            lo = 0.0
            hi = 1.0
            for _b in range(_BISECTIONS):
                mid = 0.5 * (lo + hi)
                _, ch = _advance(z, theta_b, t, mid * remaining, mode, cmode, sys, cmd, stick, fmodes, held, law, p,
                                 W, hist, dt, work, tmp, wvals, dvals, ahead, z_try)
                if ch:
                    hi = mid
                else:
                    lo = mid
            h = hi * remaining
            theta_try, _ = _advance(z, theta_b, t, h, mode, cmode, sys, cmd, stick, fmodes, held, law, p, W, hist, dt,
                                    work, tmp, wvals, dvals, ahead, z_try)
            x, v = _xv(z_try, c_x, c_v)
            if law == EXACT and mode == 0:
                theta_try = p[HALF_GAP] if theta_try > 0.0 else -p[HALF_GAP]
            new_mode = _mode_of(law, p, mode, x, v, theta_try)
            same_friction = True
            if stick is not None:
                _stick_modes(z_try, t + h, new_mode, cmode, law, p, sys, cmd, stick, fmodes, held, W, hist, dt, work,
                             wvals, dvals, new_fmodes)
                for s in range(fmodes.shape[0]):
                    same_friction = same_friction and new_fmodes[s] == fmodes[s]
            new_cmode = 0 if cmd is None else _command_mode_rk4(new_mode, cmode, z_try, t + h, sys, cmd, stick,
                                                                new_fmodes, held, law, p, W, hist, dt, work, wvals,
                                                                dvals, ahead)
            if new_mode == mode and new_cmode == cmode and same_friction:  # grazing or round-off: no real switch
                break
            _copy_vector(z_try, z, n)
            _copy_vector(new_fmodes, fmodes, fmodes.shape[0])
            theta_b = theta_try
            mode = new_mode
            cmode = new_cmode
            t += h
            remaining -= h
            events += 1
            if remaining <= 1e-14 * dt:
                break
        if remaining > 1e-14 * dt:
            theta_b, _ = _advance(z, theta_b, t, remaining, mode, cmode, sys, cmd, stick, fmodes, held, law, p, W, hist,
                                  dt, work, tmp, wvals, dvals, ahead, z_new)
            _copy_vector(z_new, z, n)
        i += 1
    return events


# --------------------------------------------------------------------------- exact-discretisation kernel
#
# The per-step path takes whole arrays and indices (the ladder by its row in ``ladders``,
# the state by its length): a view such as ``ladders[k]`` or ``q[:n]`` costs numba a
# reference count increment and decrement, which took over half of a step.


@_jit
def _mode_index(mode):
    """Row of a mode's matrices: 0 left contact, 1 free, 2 right contact."""
    return 0 if mode < 0 else (2 if mode > 0 else 1)


@_inline
def _apply(ladders, which, level, q, out, rows):
    """``out = ladders[which, level] q`` on the first ``rows`` rows; the other entries copied from ``q``."""
    size = q.shape[0]
    for i in range(rows):
        acc = 0.0
        for j in range(size):
            acc += ladders[which, level, i, j] * q[j]
        out[i] = acc
    for i in range(rows, size):
        out[i] = q[i]


@_jit
def _set_inputs(q, base, f0, fm, f1, dt):
    """Value, slope and curvature of the quadratic through samples at 0, dt/2, dt."""
    q[base + VALUE] = f0
    q[base + RATE] = (4.0 * fm - 3.0 * f0 - f1) / dt
    q[base + CURVATURE] = 4.0 * (f0 - 2.0 * fm + f1) / (dt * dt)


@_jit
def _advance_exactly(ladders, which, q, fraction, out, tmp):
    """``q`` advanced by ``fraction * dt`` with ladder ``which`` (residual < 2^-levels dt dropped)."""
    size = q.shape[0]
    _copy_vector(q, out, size)
    for j in range(ladders.shape[1]):
        s = 0.5**j
        if fraction >= s:
            _apply(ladders, which, j, out, tmp, size)
            _copy_vector(tmp, out, size)
            fraction -= s


@_jit
def _dot(row, q):
    acc = 0.0
    for j in range(q.shape[0]):
        acc += row[j] * q[j]
    return acc


@_jit
def _command_side(cmode, u, limit):
    """The limit a command mode is held at or, from linear, crossed: 1 upper, -1 lower, 0 inside."""
    if cmode != 0:
        return 1 if cmode > 0 else -1
    return 1 if u > limit else (-1 if u < -limit else 0)


@_jit
def _command_rates(q, e_row, rates, b, s):
    """(error, clamped rate, integrating rate) at ``q`` in backlash mode row ``b`` on limit side ``s``."""
    e = 0.0
    clamped = 0.0
    integrating = 0.0
    for j in range(q.shape[0]):
        e += e_row[j] * q[j]
        clamped += rates[b, s, 0, j] * q[j]
        integrating += rates[b, s, 1, j] * q[j]
    return e, clamped, integrating


@_jit
def _command_mode_exact(mode, cmode, q, u_row, e_row, rates, limit, clamps):
    """The command mode of augmented state ``q`` reached in ``cmode``; ``u_row, e_row, rates`` those
    of ``_switching.command_matrices``."""
    u = _dot(u_row, q)
    side = _command_side(cmode, u, limit)
    if side == 0:
        return 0
    e, clamped, integrating = _command_rates(q, e_row, rates, _mode_index(mode), 0 if side > 0 else 1)
    return command_mode_of(cmode, u, e, clamped, integrating, limit, clamps)


@_jit
def _leaves(law, p, mode, cmode, q, c_x, c_v, command, friction, fmodes):
    """True if ``q``, reached with the modes frozen, lies outside the backlash mode, a rubbing side's or the
    command mode."""
    n = c_x.shape[0]
    x, v = _xv(q, c_x, c_v)
    if _must_leave(law, p, mode, x, v, q[n + THETA_B]):
        return True
    if friction is not None and _rubbing_leaves(friction, fmodes, mode, q):
        return True
    if command is None:
        return False
    return _command_mode_exact(mode, cmode, q, command.u_row, command.e_row, command.rates, command.limit,
                               command.clamps) != cmode


@_jit
def _locate(ladders, which, q, left, law, p, mode, cmode, c_x, c_v, command, q_lo, trial, q_hi, friction, fmodes):
    """Bisect for the first time the frozen-mode trajectory must leave its modes; returns it (fraction of dt).

    Binary search on the dyadic ladder ``which`` from ``q`` (a sub-step ``dt 2^-j`` is
    kept while the trajectory stays in its modes); ``q_hi`` must already hold the state
    at ``left``, outside them, and ends as the earliest state found outside.
    """
    size = q.shape[0]
    _copy_vector(q, q_lo, size)
    lo = 0.0
    hi = left
    for j in range(1, ladders.shape[1]):
        s = 0.5**j
        if lo + s >= hi:
            continue
        _apply(ladders, which, j, q_lo, trial, size)
        if _leaves(law, p, mode, cmode, trial, c_x, c_v, command, friction, fmodes):
            _copy_vector(trial, q_hi, size)
            hi = lo + s
        else:
            _copy_vector(trial, q_lo, size)
            lo += s
    return hi


@_jit
def _set_step_inputs(q, i, W, hist, delay, dt, n):
    """Quadratics in time over step ``i`` of the varying inputs and of the delayed signals."""
    rows_per_step = (W.shape[0] - 1) / (hist.shape[0] - 1)
    row = i * rows_per_step
    for j in range(W.shape[1]):
        f0, fm, f1 = _lerp(W, row, j), _lerp(W, row + 0.5 * rows_per_step, j), _lerp(W, row + rows_per_step, j)
        _set_inputs(q, n + CHAINS + CHAIN * j, f0, fm, f1, dt)
    if delay > 0.0:
        row = i - delay / dt
        for k in range(hist.shape[1]):
            f0, fm, f1 = _history(hist, row, i, k), _history(hist, row + 0.5, i, k), _history(hist, row + 1.0, i, k)
            _set_inputs(q, n + CHAINS + CHAIN * (W.shape[1] + k), f0, fm, f1, dt)


@_jit
def _ladder_of(count, mode, cmode):
    """Row among ``count`` ladders of a backlash mode and a command mode (one command mode without a limit)."""
    per_backlash = count // 3
    return _mode_index(mode) * per_backlash + (command_index(cmode) if per_backlash > 1 else 0)


@_jit
def _ladder_with(count, mode, cmode, friction, fmodes):
    """:func:`_ladder_of`, with Coulomb friction the row of the sides' modes among the backlash mode's ladders
    (:class:`AugmentedFriction`; no torque limit with it)."""
    if friction is None:
        return _ladder_of(count, mode, cmode)
    code = 0
    scale = 1
    for s in range(fmodes.shape[0]):
        code += (fmodes[s] + 1) * scale
        scale *= 3
    return _mode_index(mode) * (count // 3) + code


@_jit
def _held(friction, b, s, q):
    """The friction (N m) that holds rubbing side ``s`` at rest at ``q`` in backlash mode row ``b``."""
    acc = 0.0
    for j in range(q.shape[0]):
        acc += friction.hold[b, s, j] * q[j]
    return acc


@_jit
def _at_rest(friction, b, s, q):
    """A rubbing side's mode at rest at ``q``: stuck (0) while its holding friction is within the Coulomb level,
    else sliding (+-1) the way it is pushed."""
    held = _held(friction, b, s, q)
    if abs(held) <= friction.level[s]:
        return 0
    return 1 if held > 0.0 else -1


@_jit
def _rubbing_leaves(friction, fmodes, mode, q):
    """True if a rubbing side has left its mode at ``q``: a sliding side's speed past zero, a stuck side's holding
    friction past its level."""
    b = _mode_index(mode)
    for s in range(fmodes.shape[0]):
        if fmodes[s] != 0:
            if fmodes[s] * q[friction.index[s]] < 0.0:
                return True
        elif abs(_held(friction, b, s, q)) > friction.level[s]:
            return True
    return False


@_jit
def _rubbing_after(friction, fmodes, mode, q, out):
    """The rubbing sides' modes just past an event at ``q``, the backlash in ``mode`` (the one entered), into
    ``out``: a sliding side whose speed reached zero and every stuck side decided at rest (:func:`_at_rest`: it
    sticks, reverses or breaks away); True if one changed."""
    b = _mode_index(mode)
    changed = False
    for s in range(fmodes.shape[0]):
        side = fmodes[s]
        if side == 0 or side * q[friction.index[s]] <= 0.0:
            side = _at_rest(friction, b, s, q)
        out[s] = side
        changed = changed or side != fmodes[s]
    return changed


@_jit
def _rubbing_enter(friction, fmodes, new, q):
    """Take the new modes of the rubbing sides; a side that sticks rests at zero speed (round-off removed)."""
    for s in range(fmodes.shape[0]):
        if new[s] == 0:
            q[friction.index[s]] = 0.0
        fmodes[s] = new[s]


@_jit
def _step_exactly(ladders, law, p, mode, cmode, q, c_x, c_v, command, q_new, q_lo, trial, q_hi, friction, fmodes,
                  f_new):
    """Advance ``q`` by one step ``dt``, switching modes at every located event; returns (mode, cmode, events)
    (the rubbing sides' modes updated in ``fmodes``)."""
    n, size = c_x.shape[0], q.shape[0]
    # z and theta_b only: the other entries are constant or reset every step (all of them when the
    # command, which reads the inputs and delayed signals, can switch)
    first_rows = n + THETA_B + 1 if command is None else size
    left = 1.0  # fraction of the step still to go
    events = 0
    for _ in range(_MAX_EVENTS_PER_STEP):
        which = _ladder_with(ladders.shape[0], mode, cmode, friction, fmodes)
        if left == 1.0:
            _apply(ladders, which, 0, q, q_new, first_rows)
        else:
            _advance_exactly(ladders, which, q, left, q_new, trial)
        if not _leaves(law, p, mode, cmode, q_new, c_x, c_v, command, friction, fmodes):
            _copy_vector(q_new, q, size)
            return mode, cmode, events
        if left == 1.0:
            _apply(ladders, which, 0, q, q_hi, size)
        else:
            _copy_vector(q_new, q_hi, size)
        h = _locate(ladders, which, q, left, law, p, mode, cmode, c_x, c_v, command, q_lo, trial, q_hi, friction,
                    fmodes)
        if law == EXACT and mode == 0:
            q_hi[n + THETA_B] = p[HALF_GAP] if q_hi[n + THETA_B] > 0.0 else -p[HALF_GAP]
        x, v = _xv(q_hi, c_x, c_v)
        new_mode = _mode_of(law, p, mode, x, v, q_hi[n + THETA_B])
        new_cmode = 0 if command is None else _command_mode_exact(new_mode, cmode, q_hi, command.u_row, command.e_row,
                                                                  command.rates, command.limit, command.clamps)
        rubbed = False if friction is None else _rubbing_after(friction, fmodes, new_mode, q_hi, f_new)
        if new_mode == mode and new_cmode == cmode and not rubbed:  # grazing or round-off: no real switch
            break
        _copy_vector(q_hi, q, size)
        if friction is not None:
            _rubbing_enter(friction, fmodes, f_new, q)
        mode = new_mode
        cmode = new_cmode
        left -= h
        events += 1
        if left <= 1e-14:
            return mode, cmode, events
    _advance_exactly(ladders, _ladder_with(ladders.shape[0], mode, cmode, friction, fmodes), q, left, q_new, trial)
    _copy_vector(q_new, q, size)
    return mode, cmode, events


@_jit
def run_exact(ladders, command, law, p, W, q, delay, d_rows, c_x, c_v, dt, n_steps, Z, T, THETA, MODES, CMODES, hist,
              first, mode0, cmode0, friction, fmodes, FMODES):
    """Exact-discretisation run on the augmented state ``q`` of ``_switching.mode_matrices``.

    ``ladders`` holds ``_switching.exp_ladder`` of the left-contact,
    free and right-contact matrices (each by command mode with a limit,
    ``_switching.command_matrices``, whose rows ``u_row, e_row, rates``
    it switches on; ``command`` holds them, or is None without a limit).  ``W`` is None
    where neither an input varies nor a signal is delayed.  The run goes
    from ``q`` at sample ``first`` (0, the modes
    found there; or a run's last sample, going on with it, its modes ``mode0`` and
    ``cmode0``, its samples and history ``hist`` up to there filled in) to sample
    ``n_steps``, where ``q`` is left; returns the event count of the steps taken.  With Coulomb
    friction (``friction``, an :class:`AugmentedFriction`; None without, and the kernel compiles
    without its code) the rubbing sides' modes are ``fmodes`` (found at the start, or a run's
    last ones going on with it; left at the end) and are stored in ``FMODES``.
    """
    n = Z.shape[1]
    size = ladders.shape[2]
    q_new, q_lo, trial, q_hi = np.empty(size), np.empty(size), np.empty(size), np.empty(size)
    f_new = np.empty(fmodes.shape[0], dtype=np.int64)
    mode = mode0
    cmode = cmode0
    if first == 0:
        x, v = _xv(q, c_x, c_v)
        mode = _mode_of(law, p, np.int64(0), x, v, q[n + THETA_B])
        cmode = 0
        if friction is not None:
            for s in range(fmodes.shape[0]):
                w = q[friction.index[s]]
                fmodes[s] = (1 if w > 0.0 else -1) if w != 0.0 else _at_rest(friction, _mode_index(mode), s, q)
    events = 0
    first_rows = n + THETA_B + 1 if command is None else size  # the rows _step_exactly advances over a whole step
    for i in range(first, n_steps + 1):
        x, v = _xv(q, c_x, c_v)
        _record(i, q, n, q[n + THETA_B], mode, cmode, _torque(law, mode, x, v, p), d_rows, Z, T, THETA, MODES, CMODES,
                hist)
        if friction is not None:
            for s in range(fmodes.shape[0]):
                FMODES[i, s] = fmodes[s]
        if i == n_steps or _diverged(i, q, n, Z, T, THETA, MODES, CMODES):
            if friction is not None and i < n_steps:  # a diverged run: its later samples keep the last modes
                for j in range(i + 1, n_steps + 1):
                    for s in range(fmodes.shape[0]):
                        FMODES[j, s] = fmodes[s]
            break
        if W is not None:
            _set_step_inputs(q, i, W, hist, delay, dt, n)
        if i == 0 and command is not None:  # the command mode of the initial state, its inputs set
            u_row, e_row, _, limit, clamps = command
            cmode = initial_command_mode(_dot(u_row, q), _dot(e_row, q), limit, clamps)
            CMODES[0] = cmode
        # the first try of _step_exactly, here: a step that stays in its modes calls only functions
        # without calls (whose arrays numba does not reference-count)
        _apply(ladders, _ladder_with(ladders.shape[0], mode, cmode, friction, fmodes), 0, q, q_new, first_rows)
        x, v = _xv(q_new, c_x, c_v)
        stays = not _must_leave(law, p, mode, x, v, q_new[n + THETA_B])
        if stays and friction is not None:
            stays = not _rubbing_leaves(friction, fmodes, mode, q_new)
        if stays and command is not None:
            u_row, e_row, rates, limit, clamps = command
            u = _dot(u_row, q_new)
            side = _command_side(cmode, u, limit)
            if side == 0:
                stays = cmode == 0
            else:
                e, clamped, integrating = _command_rates(q_new, e_row, rates, _mode_index(mode), 0 if side > 0 else 1)
                stays = command_mode_of(cmode, u, e, clamped, integrating, limit, clamps) == cmode
        if stays:
            _copy_vector(q_new, q, size)
        else:
            mode, cmode, found = _step_exactly(ladders, law, p, mode, cmode, q, c_x, c_v, command, q_new, q_lo, trial,
                                               q_hi, friction, fmodes, f_new)
            events += found
        if friction is not None:  # a stuck side's speed stays zero (the flow's round-off removed)
            for s in range(fmodes.shape[0]):
                if fmodes[s] == 0:
                    q[friction.index[s]] = 0.0
    return events
