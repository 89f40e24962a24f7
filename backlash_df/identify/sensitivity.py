"""Forward sensitivities of the diagnosis' prediction kernel: a Jacobian in one run.

The k-step prediction of :mod:`.calibrate` integrates the two-mass model
``z' = f(z, p, t)``, ``z = (theta_d, w_m, w_l)``, by RK4, each stage in the
mode the law holds there from the step's start.  Its derivative with respect
to a value ``q`` is the derivative of that very map: each RK4 stage carries
``S = dz/dq`` through ``K = (df/dz) S + df/dq`` at the stage's state, so that
the result is the exact derivative of the discrete prediction (its modes
held), which a forward difference approximates.  One run gives every column: the kernel's
values (inertias, the law's ``k, c, alpha, beta``, the frictions, the torque
offset), the actuator delay (through the delayed torque's slope) and the
segment's initial state; :meth:`~.calibrate.TwoMassModel.speed_sensitivities`
maps them to the fit's values.

The law's partial derivatives are closed forms of (24)-(27), (33), the
Modelica ElastoBacklash and the rubber band (36) with theta*(v) of (19)
differentiated through its defining equation
(:func:`~backlash_df.models.theta_star_partials`).
"""

import math

import numpy as np

from .._jit import inline as _inline
from .._jit import jit as _jit
from .._jit import borrowing_unchecked as _borrowing_unchecked
from ..models import DEAD_ZONE, ELASTO_BACKLASH, held_mode, mode_torque, theta_star_partials

__all__ = ["DELAY", "segment_sensitivities", "torque_partials", "friction_partials"]

#: Column code of the actuator delay (after the kernel's values).
DELAY = 13  # the kernel's values are p[0] to p[12] (:data:`~.calibrate.MODEL_PARAMETERS`)


@_jit
def _band_partials(x, v, k, c, alpha, beta):
    """``(dT/dx, dT/dv, dT/dk, dT/dc, dT/dalpha, dT/dbeta)`` of the rubber band (36), right side."""
    if v > 0.0:
        ts, ts_v, ts_k, ts_c, ts_a = theta_star_partials(v, k, c, alpha)
        w = x - ts + 0.5 * beta
        g = 0.5 * k * w + k * (ts - alpha) + c * v
        torque = g * w / beta
        # d w and d g along x, v, k, c, alpha, beta
        w_d = (1.0, -ts_v, -ts_k, -ts_c, -ts_a, 0.5)
        g_d = (0.5 * k * w_d[0], 0.5 * k * w_d[1] + k * ts_v + c, 0.5 * w + 0.5 * k * w_d[2] + (ts - alpha) + k * ts_k,
               0.5 * k * w_d[3] + k * ts_c + v, 0.5 * k * w_d[4] + k * (ts_a - 1.0), 0.5 * k * w_d[5])
        return ((g_d[0] * w + g * w_d[0]) / beta, (g_d[1] * w + g * w_d[1]) / beta,
                (g_d[2] * w + g * w_d[2]) / beta, (g_d[3] * w + g * w_d[3]) / beta,
                (g_d[4] * w + g * w_d[4]) / beta, (g_d[5] * w + g * w_d[5]) / beta - torque / beta)
    y = x - (alpha - 0.5 * beta - 2.0 * c * v / k)
    d = beta + 2.0 * c * v / k
    torque = 0.5 * k * y * y / d
    y_d = (1.0, 2.0 * c / k, -2.0 * c * v / (k * k), 2.0 * v / k, -1.0, 0.5)
    d_d = (0.0, 2.0 * c / k, -2.0 * c * v / (k * k), 2.0 * v / k, 0.0, 1.0)
    return (k * y * y_d[0] / d, k * y * y_d[1] / d - torque * d_d[1] / d,
            0.5 * y * y / d + k * y * y_d[2] / d - torque * d_d[2] / d, k * y * y_d[3] / d - torque * d_d[3] / d,
            k * y * y_d[4] / d, k * y * y_d[5] / d - torque * d_d[5] / d)


@_jit
def _right_partials(law, m, x, v, k, c, alpha, beta):
    """Partial derivatives of :func:`~backlash_df.models.right_torque` of mode ``m`` (held)."""
    if m == 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if law == DEAD_ZONE:
        return k, 0.0, x - alpha, 0.0, -k, 0.0
    if law == ELASTO_BACKLASH:
        if k * (x - alpha) <= c * v:  # min(tau_c, c v) = tau_c
            return 2.0 * k, 0.0, 2.0 * (x - alpha), 0.0, -2.0 * k, 0.0
        return k, c, x - alpha, v, -k, 0.0
    if m == 2:
        return k, c, x - alpha, v, -k, 0.0
    return _band_partials(x, v, k, c, alpha, beta)


@_jit
def torque_partials(law, m, x, v, k, c, alpha, beta):
    """``(dT/dx, dT/dv, dT/dk, dT/dc, dT/dalpha, dT/dbeta)`` of :func:`~backlash_df.models.mode_torque`
    with the signed mode ``m`` held (N m/rad, N m s/rad, rad, rad/s, N m/rad, N m/rad)."""
    if m >= 0:
        return _right_partials(law, m, x, v, k, c, alpha, beta)
    t_x, t_v, t_k, t_c, t_a, t_b = _right_partials(law, -m, -x, -v, k, c, alpha, beta)
    return t_x, t_v, -t_k, -t_c, -t_a, -t_b


@_inline
def friction_partials(w, viscous, coulomb, breakaway, eps, w_s, with_tanh=True, with_exp=True):
    """``(F, dF/dw, dF/dcoulomb, dF/dbreakaway)`` of the friction law ``F`` of :mod:`.calibrate` (N m;
    ``dF/dviscous = w``); ``F`` to the bit of the prediction kernel's (a zero level adds zero).

    Without ``with_tanh`` (no Coulomb nor breakaway friction, neither differentiated by) no tanh, without
    ``with_exp`` (no breakaway friction, not differentiated by) no exp is evaluated, as in the prediction
    kernel; the partial derivatives they would give are then returned as zero.
    """
    th = math.tanh(w / eps) if with_tanh else 0.0
    e = math.exp(-(w / w_s) ** 2) if with_exp else 0.0
    level = coulomb + breakaway * e
    by_w = viscous + level * (1.0 - th * th) / eps - 2.0 * breakaway * e * th * w / (w_s * w_s)
    return viscous * w + level * th, by_w, th, e * th


@_inline
def _stage(x, wm, wl, tm, dtm, tl, law, mode, p, eps, w_s, terms, columns, source, sens, target, step, acc, weight,
           by_value):
    """One RK4 stage of the sensitivities at the stage's state ``(x, wm, wl)`` and inputs.

    ``K = (df/dz) source + df/dq`` for every column ``q`` (the kernel's value
    ``columns[q]``, then the three initial states, whose ``df/dq`` is zero);
    ``acc += weight K`` (``acc = K`` when ``weight`` is 0: the first stage) and
    ``target = sens + step K``, the next stage's input (skipped when ``step`` is
    0: the last stage).  ``source`` may be ``target``: a column is read before it is
    written.  ``by_value`` (2, columns): work space for ``df/dq``.  ``terms``: the
    ``with_tanh, with_exp`` of :func:`friction_partials` on the motor side, then the
    load side.  Returns the stage's rates ``(dtheta_d/dt, dw_m/dt, dw_l/dt)``.
    """
    v = wm - wl
    k, c, alpha, beta = p[2], p[3], p[4], p[5]
    m = held_mode(law, mode, x, v, k, c, alpha, beta)  # as the prediction kernel's stage (its ``_rates``)
    torque = mode_torque(law, m, x, v, k, c, alpha, beta)
    t_x, t_v, t_k, t_c, t_a, t_b = torque_partials(law, m, x, v, k, c, alpha, beta)
    f_m, f_m_w, f_m_c, f_m_b = friction_partials(wm, p[8], p[6], p[10], eps, w_s, terms[0], terms[1])
    f_l, f_l_w, f_l_c, f_l_b = friction_partials(wl, p[9], p[7], p[11], eps, w_s, terms[2], terms[3])
    jm, jl = p[0], p[1]
    a1 = (tm + p[12] - torque - f_m) / jm
    a2 = (tl + torque - f_l) / jl
    im, il = 1.0 / jm, 1.0 / jl
    # d(dw_m/dt)/dq and d(dw_l/dt)/dq for q in the order of p, then the delay
    b1 = (-a1 * im, 0.0, -t_k * im, -t_c * im, -t_a * im, -t_b * im, -f_m_c * im, 0.0, -wm * im, 0.0, -f_m_b * im,
          0.0, im, dtm * im)
    b2 = (0.0, -a2 * il, t_k * il, t_c * il, t_a * il, t_b * il, 0.0, -f_l_c * il, 0.0, -wl * il, 0.0, -f_l_b * il,
          0.0, 0.0)
    for q in range(columns.shape[0]):
        by_value[0, q] = b1[columns[q]]
        by_value[1, q] = b2[columns[q]]
    m0, m1, m2 = -t_x * im, -(t_v + f_m_w) * im, t_v * im
    l0, l1, l2 = t_x * il, t_v * il, -(t_v + f_l_w) * il
    for q in range(source.shape[1]):
        s0, s1, s2 = source[0, q], source[1, q], source[2, q]
        k0 = s1 - s2
        k1 = m0 * s0 + m1 * s1 + m2 * s2 + by_value[0, q]
        k2 = l0 * s0 + l1 * s1 + l2 * s2 + by_value[1, q]
        if weight == 0.0:
            acc[0, q], acc[1, q], acc[2, q] = k0, k1, k2
        else:
            acc[0, q] += weight * k0
            acc[1, q] += weight * k1
            acc[2, q] += weight * k2
        if step != 0.0:
            target[0, q] = sens[0, q] + step * k0
            target[1, q] = sens[1, q] + step * k1
            target[2, q] = sens[2, q] + step * k2
    return v, a1, a2


@_inline
def _friction_term(level, columns, code):
    """Whether a friction level (``p[code]``) needs its function evaluated: nonzero, or differentiated by."""
    if level != 0.0:
        return True
    for q in range(columns.shape[0]):
        if columns[q] == code:
            return True
    return False


@_borrowing_unchecked
def segment_sensitivities(law, p, eps, w_s, tm, dtm, tl, starts, stops, z0, substeps, columns, initial, work, out):
    """Sensitivities of the measured speeds to ``columns`` and to the segment's initial state.

    The trajectory is the prediction kernel's (``_segments`` of :mod:`.calibrate`: RK4,
    ``substeps`` steps a sample, inputs interpolated linearly, each stage in the mode
    the law holds there); its sensitivities ride along (module docs).

    Parameters
    ----------
    law : int
        Law code.
    p : ndarray, shape (14,)
        The kernel's values (:data:`~.calibrate.MODEL_PARAMETERS`) and the sample interval (s).
    eps, w_s : float
        Smoothing and Stribeck speeds of the friction law (rad/s).
    tm, dtm, tl : ndarray, shape (n,)
        Delayed motor torque (N m), its derivative by the delay (N m/s), load torque (N m).
    starts, stops : ndarray of int64
        Segments.
    z0 : ndarray, shape (segments, 3)
        Initial states (rad, rad/s, rad/s).
    columns : ndarray of int64
        Values to differentiate by: indices into ``p`` (0-12) or :data:`DELAY`.
    initial : ndarray of int64
        Initial states to differentiate by, the segment's own (0 theta_d, 1 w_m, 2 w_l).
    work : ndarray, shape (11, columns.size + initial.size)
        Work space (the kernel allocates nothing).
    out : ndarray, shape (n, 2, columns.size + initial.size)
        Written inside the segments: ``d(w_m, w_l)/d(columns, initial)``.
    """
    last = tm.shape[0] - 1
    values = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12])
    n_columns = columns.shape[0]
    width = n_columns + initial.shape[0]
    sens, stage, acc, by_value = work[0:3], work[3:6], work[6:9], work[9:11]
    terms = (_friction_term(p[6], columns, 6) or _friction_term(p[10], columns, 10), _friction_term(p[10], columns, 10),
             _friction_term(p[7], columns, 7) or _friction_term(p[11], columns, 11), _friction_term(p[11], columns, 11))
    for s in range(starts.shape[0]):
        x, wm, wl = z0[s, 0], z0[s, 1], z0[s, 2]
        for r in range(3):
            for q in range(width):
                sens[r, q] = 1.0 if q >= n_columns and initial[q - n_columns] == r else 0.0
        mode = held_mode(law, np.int64(0), x, wm - wl, p[2], p[3], p[4], p[5])
        for i in range(starts[s], stops[s]):
            for q in range(width):
                out[i, 0, q], out[i, 1, q] = sens[1, q], sens[2, q]
            if i == last:
                continue
            d_tm, d_dtm, d_tl = tm[i + 1] - tm[i], dtm[i + 1] - dtm[i], tl[i + 1] - tl[i]
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                h = (f1 - f0) * p[13]
                fm = 0.5 * (f0 + f1)
                a0, a1, a2 = _stage(x, wm, wl, tm[i] + f0 * d_tm, dtm[i] + f0 * d_dtm, tl[i] + f0 * d_tl, law, mode,
                                    values, eps, w_s, terms, columns, sens, sens, stage, 0.5 * h, acc, 0.0, by_value)
                b0, b1, b2 = _stage(x + 0.5 * h * a0, wm + 0.5 * h * a1, wl + 0.5 * h * a2, tm[i] + fm * d_tm,
                                    dtm[i] + fm * d_dtm, tl[i] + fm * d_tl, law, mode, values, eps, w_s, terms, columns,
                                    stage, sens, stage, 0.5 * h, acc, 2.0, by_value)
                c0, c1, c2 = _stage(x + 0.5 * h * b0, wm + 0.5 * h * b1, wl + 0.5 * h * b2, tm[i] + fm * d_tm,
                                    dtm[i] + fm * d_dtm, tl[i] + fm * d_tl, law, mode, values, eps, w_s, terms, columns,
                                    stage, sens, stage, h, acc, 2.0, by_value)
                d0, d1, d2 = _stage(x + h * c0, wm + h * c1, wl + h * c2, tm[i] + f1 * d_tm, dtm[i] + f1 * d_dtm,
                                    tl[i] + f1 * d_tl, law, mode, values, eps, w_s, terms, columns, stage, sens, stage, 0.0,
                                    acc, 1.0, by_value)
                for r in range(3):
                    for q in range(width):
                        sens[r, q] += h / 6.0 * acc[r, q]
                x += h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                wm += h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
                wl += h / 6.0 * (a2 + 2.0 * b2 + 2.0 * c2 + d2)
                mode = held_mode(law, mode, x, wm - wl, p[2], p[3], p[4], p[5])
