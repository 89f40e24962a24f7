"""Compiled explicit Runge-Kutta pairs with event location: the benchmarks' compiled competitors.

Dormand-Prince 5(4) and DOP853 (Hairer, Norsett and Wanner, *Solving Ordinary
Differential Equations I*, sections II.5 and II.10) in numba, for a piecewise-affine
loop ``dz/dt = A_m z + f_m`` whose mode ``m`` (-2, 0, 2: left contact, free, right
contact) is held through each step, as a user would write them for speed:

* adaptive steps, error control as in Hairer's codes (DOP853: the 5th- and
  3rd-order estimators combined), ``atol = 1e-3 rtol``;
* after each accepted step the law's ``backlash_df._laws.held_mode`` is
  checked at the end; where it leaves the mode, the switch is bisected on the
  method's dense output (quartic for DP5, 7th order for DOP853, three more stages)
  and the integration restarts there in the new mode;
* output on a given grid from the dense output.

Only the tableaux are taken from scipy, as the public solver classes
``scipy.integrate.RK45`` and ``scipy.integrate.DOP853`` carry them (attributes ``A``,
``B``, ``E``, ``P`` and ``E3``, ``E5``, ``D``, ``A_EXTRA``), so that no coefficient is
retyped; the stepping, error norm, dense output and event location are written here.
"""

import math

import numba
import numpy as np
from scipy.integrate import DOP853, RK45

from backlash_df._laws import held_mode

DP5, DP8 = 0, 1
_BISECTIONS = 60


def tableau(method):
    """The arrays :func:`integrate` takes for ``DP5`` or ``DP8``: (a, b, e5, e3, dense, a_extra).

    ``a`` is square (stages x stages); for DP5 ``e3`` is zero and ``a_extra`` empty.
    """
    if method == DP5:
        stages = RK45.n_stages
        a = np.zeros((stages, stages))
        a[:, :stages - 1] = RK45.A
        return a, RK45.B, RK45.E, np.zeros_like(RK45.E), RK45.P, np.zeros((0, 0))
    return DOP853.A, DOP853.B, DOP853.E5, DOP853.E3, DOP853.D, DOP853.A_EXTRA


@numba.njit(cache=True)
def _dot(row, z):
    acc = 0.0
    for i in range(z.size):
        acc += row[i] * z[i]
    return acc


@numba.njit(cache=True)
def _rhs(mats, offs, mode, z, out):
    """``out = A_m z + f_m`` for mode -2, 0 or 2 (rows 0, 1, 2 of ``mats``, ``offs``)."""
    m = mode // 2 + 1
    for i in range(z.size):
        acc = offs[m, i]
        for j in range(z.size):
            acc += mats[m, i, j] * z[j]
        out[i] = acc


@numba.njit(cache=True)
def _combine(k, weights, count, z, h, out):
    """``out = z + h sum_j weights[j] k[j]`` over the first ``count`` stages."""
    for i in range(z.size):
        acc = 0.0
        for j in range(count):
            acc += weights[j] * k[j, i]
        out[i] = z[i] + h * acc


@numba.njit(cache=True)
def _error_norm(method, k, e5, e3, h, z, new, rtol, atol):
    """Scaled RMS norm of the local error estimate (DOP853: Hairer's combination of two estimators)."""
    n = z.size
    s5 = 0.0
    s3 = 0.0
    for i in range(n):
        scale = atol + rtol * max(abs(z[i]), abs(new[i]))
        r5 = 0.0
        r3 = 0.0
        for j in range(e5.size):
            r5 += e5[j] * k[j, i]
            r3 += e3[j] * k[j, i]
        s5 += (r5 / scale) ** 2
        s3 += (r3 / scale) ** 2
    if method == DP5:
        return abs(h) * math.sqrt(s5 / n)
    if s5 == 0.0:
        return 0.0
    return abs(h) * s5 / math.sqrt((s5 + 0.01 * s3) * n)


@numba.njit(cache=True)
def _prepare_dense(method, k, dense, a_extra, mats, offs, mode, z, new, h, work, coef):
    """Coefficients of the dense output over the last step in ``coef``; returns the extra RHS evaluations.

    DP5: ``y(t + x h) = z + sum_p coef[p] x^(p + 1)``.  DOP853: the three extra stages,
    then ``y = z + x (F0 + (1 - x) (F1 + x (F2 + (1 - x) (F3 + ...))))`` with ``F = coef``.
    """
    n = z.size
    if method == DP5:
        for p in range(4):
            for i in range(n):
                acc = 0.0
                for j in range(dense.shape[0]):
                    acc += k[j, i] * dense[j, p]
                coef[p, i] = h * acc
        return 0
    first = k.shape[0] - a_extra.shape[0]
    for s in range(a_extra.shape[0]):
        _combine(k, a_extra[s], first + s, z, h, work)
        _rhs(mats, offs, mode, work, k[first + s])
    last = first - 1  # the derivative at the end of the step
    for i in range(n):
        dy = new[i] - z[i]
        coef[0, i] = dy
        coef[1, i] = h * k[0, i] - dy
        coef[2, i] = 2.0 * dy - h * (k[last, i] + k[0, i])
        for r in range(dense.shape[0]):
            acc = 0.0
            for j in range(dense.shape[1]):
                acc += dense[r, j] * k[j, i]
            coef[3 + r, i] = h * acc
    return a_extra.shape[0]


@numba.njit(cache=True)
def _dense_at(method, coef, z, x, out):
    """The dense output at the fraction ``x`` of the last step."""
    for i in range(z.size):
        if method == DP5:
            acc = 0.0
            for p in range(3, -1, -1):
                acc = (acc + coef[p, i]) * x
            out[i] = z[i] + acc
        else:
            acc = coef[6, i]
            for r in range(5, -1, -1):
                acc = coef[r, i] + (x if r % 2 == 1 else 1.0 - x) * acc
            out[i] = z[i] + x * acc


@numba.njit(cache=True)
def _locate(method, coef, z, law, p, mode, c_x, c_v, work):
    """Fraction of the last step at which ``held_mode`` first leaves ``mode``, bisected on the dense output."""
    lo, hi = 0.0, 1.0
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        _dense_at(method, coef, z, mid, work)
        if held_mode(law, mode, _dot(c_x, work), _dot(c_v, work), p[0], p[1], p[2], p[3]) != mode:
            hi = mid
        else:
            lo = mid
    return hi


@numba.njit(cache=True)
def integrate(method, a, b, e5, e3, dense, a_extra, mats, offs, law, p, c_x, c_v, mode, z0, t_end, rtol, t_eval,
              out):
    """Integrate from ``z0`` (t = 0) to ``t_end``; theta_d = ``c_x z`` on ``t_eval`` into ``out``.

    Returns (right-hand side evaluations, switches).
    """
    n, stages = z0.size, b.size
    atol = 1e-3 * rtol
    exponent = -1.0 / (5.0 if method == DP5 else 8.0)
    k = np.empty((stages + 1 + a_extra.shape[0], n))
    z, new, work, coef = z0.copy(), np.empty(n), np.empty(n), np.empty((7, n))
    _rhs(mats, offs, mode, z, k[0])
    nfev, switches, i_out = 1, 0, 0
    t, h, rejected = 0.0, 1e-5, False
    while i_out < t_eval.size and t_eval[i_out] <= 0.0:
        out[i_out] = _dot(c_x, z)
        i_out += 1
    while t < t_end:
        h = min(h, t_end - t)
        for s in range(1, stages):
            _combine(k, a[s], s, z, h, work)
            _rhs(mats, offs, mode, work, k[s])
        _combine(k, b, stages, z, h, new)
        _rhs(mats, offs, mode, new, k[stages])
        nfev += stages
        norm = _error_norm(method, k, e5, e3, h, z, new, rtol, atol)
        if norm > 1.0:
            h *= max(0.2, 0.9 * norm**exponent)
            rejected = True
            continue
        factor = 10.0 if norm == 0.0 else min(10.0, 0.9 * norm**exponent)
        if rejected:
            factor = min(1.0, factor)
            rejected = False
        next_mode = held_mode(law, mode, _dot(c_x, new), _dot(c_v, new), p[0], p[1], p[2], p[3])
        ready, fraction = False, 1.0
        if next_mode != mode:
            nfev += _prepare_dense(method, k, dense, a_extra, mats, offs, mode, z, new, h, work, coef)
            ready = True
            fraction = _locate(method, coef, z, law, p, mode, c_x, c_v, work)
            _dense_at(method, coef, z, fraction, new)
            next_mode = held_mode(law, mode, _dot(c_x, new), _dot(c_v, new), p[0], p[1], p[2], p[3])
        t_new = t + fraction * h
        while i_out < t_eval.size and t_eval[i_out] <= t_new:
            if not ready:
                nfev += _prepare_dense(method, k, dense, a_extra, mats, offs, mode, z, new, h, work, coef)
                ready = True
            _dense_at(method, coef, z, (t_eval[i_out] - t) / h, work)
            out[i_out] = _dot(c_x, work)
            i_out += 1
        t = t_new
        z[:] = new
        if fraction < 1.0:  # restart at the switch
            switches += next_mode != mode
            mode = next_mode
            _rhs(mats, offs, mode, z, k[0])
            nfev += 1
        else:
            k[0] = k[stages]
            h *= factor
    while i_out < t_eval.size:  # output times a round-off beyond the last step's end
        out[i_out] = _dot(c_x, z)
        i_out += 1
    return nfev, switches
