"""The compiled kernels of the diagnosis' prediction (numba), and the layouts of their values.

The models and the prediction modes are described in :mod:`backlash_df.identify.predictors`;
the friction law is :mod:`backlash_df.friction`'s.  Private to the package:
:mod:`~backlash_df.identify.predictors` calls the kernels, and the tests reach the torque law's
partial derivatives here to check them against differences of the law.

**Prediction.**  :func:`two_mass_segments` and :func:`rigid_segments` simulate every k-step
segment of a record in one call (fixed-step RK4, ``substeps`` steps a sample, the torques
interpolated linearly), each stage of the two-mass model in the mode the law holds there from
the step's start.  numpy's error model (7 % faster): their divisors, the inertias, the sample
interval and the smoothing speeds, are positive (the fit's bounds, the record's checks).

**Forward sensitivities.**  The derivative of the two-mass prediction with respect to a value
``q`` is the derivative of that very map: each RK4 stage carries ``S = dz/dq`` through
``K = (df/dz) S + df/dq`` at the stage's state, ``z = (theta_d, w_m, w_l)``, so that the result
is the exact derivative of the discrete prediction (its modes held), which a forward
difference approximates.  One run of :func:`segment_sensitivities` gives every column: the
kernel's values (inertias, the law's ``k, c, alpha, beta``, the frictions, the torque offset),
the actuator delay (through the delayed torque's slope) and the segment's initial state;
:meth:`~backlash_df.identify.predictors.TwoMassModel.speed_sensitivities` maps them to the
fit's values.  The law's partial derivatives (:func:`torque_partials`) are closed forms of
(24)-(27), (33), the Modelica ElastoBacklash and the rubber band (36) with theta*(v) of (19)
differentiated through its defining equation (``backlash_df._laws.theta_star_partials``).

**Layouts.**  A kernel's values arrive as one vector ``p`` (a tuple inside the step loop: not
reference-counted) indexed by the module's integer constants, which numba folds.
"""

import numpy as np

from .._jit import borrowing_unchecked as _borrowing_unchecked
from .._jit import inline as _inline
from .._jit import jit as _jit
from .._jit import jit_unchecked as _jit_unchecked
from ..friction import friction_kernel, friction_partials
from .._laws import DEAD_ZONE, ELASTO_BACKLASH, held_mode, mode_torque, theta_star_partials

#: The two-mass kernel's values ``p``, by their names in a model's values, in the vector's order
#: (:data:`~backlash_df.identify.predictors.MODEL_PARAMETERS`); ``p[SAMPLE_INTERVAL]``, after them, is the
#: record's sample interval (s).
KERNEL_VALUES = (
    "motor_inertia", "load_inertia", "stiffness", "damping", "half_gap", "rubber_thickness",
    "coulomb_friction_motor", "coulomb_friction_load", "viscous_friction_motor", "viscous_friction_load",
    "breakaway_friction_motor", "breakaway_friction_load", "torque_offset",
)
(MOTOR_INERTIA, LOAD_INERTIA, STIFFNESS, DAMPING, HALF_GAP, RUBBER_THICKNESS, COULOMB_MOTOR, COULOMB_LOAD,
 VISCOUS_MOTOR, VISCOUS_LOAD, BREAKAWAY_MOTOR, BREAKAWAY_LOAD, TORQUE_OFFSET, SAMPLE_INTERVAL) = range(
    len(KERNEL_VALUES) + 1)
#: Column code of the actuator delay in :func:`segment_sensitivities`, after the kernel's values.
DELAY = TORQUE_OFFSET + 1
#: The rigid-body kernel's values: the inertia (kg m^2), each friction of both sides summed (N m, N m s/rad,
#: N m) and the torque offset (N m).
RIGID_INERTIA, RIGID_COULOMB, RIGID_VISCOUS, RIGID_BREAKAWAY, RIGID_OFFSET = range(5)


# --------------------------------------------------------------------------- prediction


@_inline
def _rates(x, wm, wl, tm, tl, law, mode, p, eps, w_s):
    """Right-hand side of the two-mass model at theta_d = ``x`` and speeds ``wm, wl`` (rad, rad/s):
    ``(dtheta_d/dt, dw_m/dt, dw_l/dt, shaft torque in N m)``; ``p``: the kernel's values as a tuple."""
    v = wm - wl
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    m = held_mode(law, mode, x, v, k, c, alpha, beta)
    torque = mode_torque(law, m, x, v, k, c, alpha, beta)
    motor = friction_kernel(wm, p[VISCOUS_MOTOR], p[COULOMB_MOTOR], p[BREAKAWAY_MOTOR], eps, w_s)
    load = friction_kernel(wl, p[VISCOUS_LOAD], p[COULOMB_LOAD], p[BREAKAWAY_LOAD], eps, w_s)
    return (v, (tm + p[TORQUE_OFFSET] - torque - motor) / p[MOTOR_INERTIA], (tl + torque - load) / p[LOAD_INERTIA],
            torque)


@_jit_unchecked
def two_mass_segments(law, p, eps, w_s, tm, tl, starts, stops, z0, substeps, states, torque):
    """Simulate each segment ``starts[i]:stops[i]`` from state ``z0[i]`` (RK4, inputs interpolated).

    The state is held in scalars, the values ``p`` (:data:`KERNEL_VALUES`, then the sample
    interval) in a tuple (not reference-counted) and :func:`_rates` is inlined: no array is
    passed inside the step loop (numba reference-counts an array passed to an inlined helper
    that calls compiled functions: 2 of every 9 ns of a step before).  ``states`` (n, 3) and
    ``torque`` (n) are written inside the segments.
    """
    last = tm.shape[0] - 1
    values = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12])  # p's, in order
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    for s in range(starts.shape[0]):
        x, wm, wl = z0[s, 0], z0[s, 1], z0[s, 2]
        mode = held_mode(law, np.int64(0), x, wm - wl, k, c, alpha, beta)
        for i in range(starts[s], stops[s]):
            states[i, 0], states[i, 1], states[i, 2] = x, wm, wl
            a0, a1, a2, torque[i] = _rates(x, wm, wl, tm[i], tl[i], law, mode, values, eps, w_s)
            if i == last:
                continue
            d_tm, d_tl = tm[i + 1] - tm[i], tl[i + 1] - tl[i]
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                h = (f1 - f0) * p[SAMPLE_INTERVAL]
                fm = 0.5 * (f0 + f1)
                tmm, tlm = tm[i] + fm * d_tm, tl[i] + fm * d_tl
                if q > 0:  # the first stage of the sample's first step is the rate its torque came with
                    a0, a1, a2, _ = _rates(x, wm, wl, tm[i] + f0 * d_tm, tl[i] + f0 * d_tl, law, mode, values, eps,
                                           w_s)
                b0, b1, b2, _ = _rates(x + 0.5 * h * a0, wm + 0.5 * h * a1, wl + 0.5 * h * a2, tmm, tlm, law, mode,
                                       values, eps, w_s)
                c0, c1, c2, _ = _rates(x + 0.5 * h * b0, wm + 0.5 * h * b1, wl + 0.5 * h * b2, tmm, tlm, law, mode,
                                       values, eps, w_s)
                d0, d1, d2, _ = _rates(x + h * c0, wm + h * c1, wl + h * c2, tm[i] + f1 * d_tm, tl[i] + f1 * d_tl, law,
                                       mode, values, eps, w_s)
                x += h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                wm += h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
                wl += h / 6.0 * (a2 + 2.0 * b2 + 2.0 * c2 + d2)
                mode = held_mode(law, mode, x, wm - wl, k, c, alpha, beta)


@_inline
def _rigid_rate(w, tm, tl, p, eps, w_s):
    """``dw/dt`` of the rigid body (rad/s^2); ``p``: the rigid-body kernel's values."""
    rubbing = friction_kernel(w, p[RIGID_VISCOUS], p[RIGID_COULOMB], p[RIGID_BREAKAWAY], eps, w_s)
    return (tm + tl + p[RIGID_OFFSET] - rubbing) / p[RIGID_INERTIA]


@_jit_unchecked
def rigid_segments(p, eps, w_s, dt, tm, tl, starts, stops, w0, substeps, speed):
    """Simulate the rigid body over each segment ``starts[i]:stops[i]`` from ``w0[i]`` (RK4, inputs interpolated)
    into ``speed``."""
    last = tm.shape[0] - 1
    for s in range(starts.shape[0]):
        w = w0[s]
        for i in range(starts[s], stops[s]):
            speed[i] = w
            if i == last:
                continue
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                fm = 0.5 * (f0 + f1)
                h = (f1 - f0) * dt
                tm0, tl0 = tm[i] + f0 * (tm[i + 1] - tm[i]), tl[i] + f0 * (tl[i + 1] - tl[i])
                tmm, tlm = tm[i] + fm * (tm[i + 1] - tm[i]), tl[i] + fm * (tl[i + 1] - tl[i])
                tm1, tl1 = tm[i] + f1 * (tm[i + 1] - tm[i]), tl[i] + f1 * (tl[i + 1] - tl[i])
                k1 = _rigid_rate(w, tm0, tl0, p, eps, w_s)
                k2 = _rigid_rate(w + 0.5 * h * k1, tmm, tlm, p, eps, w_s)
                k3 = _rigid_rate(w + 0.5 * h * k2, tmm, tlm, p, eps, w_s)
                k4 = _rigid_rate(w + h * k3, tm1, tl1, p, eps, w_s)
                w += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


# --------------------------------------------------------------------------- the law's partial derivatives


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
    """Partial derivatives of ``_laws.right_torque`` of mode ``m`` (held)."""
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
    """``(dT/dx, dT/dv, dT/dk, dT/dc, dT/dalpha, dT/dbeta)`` of ``_laws.mode_torque``
    with the signed mode ``m`` held (N m/rad, N m s/rad, rad, rad/s, N m/rad, N m/rad)."""
    if m >= 0:
        return _right_partials(law, m, x, v, k, c, alpha, beta)
    t_x, t_v, t_k, t_c, t_a, t_b = _right_partials(law, -m, -x, -v, k, c, alpha, beta)
    return t_x, t_v, -t_k, -t_c, -t_a, -t_b


# --------------------------------------------------------------------------- forward sensitivities


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
    ``with_tanh, with_exp`` of :func:`~backlash_df.friction.friction_partials` on the motor
    side, then the load side.  Returns the stage's rates ``(dtheta_d/dt, dw_m/dt, dw_l/dt)``.
    """
    v = wm - wl
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    m = held_mode(law, mode, x, v, k, c, alpha, beta)  # as the prediction kernel's stage (its ``_rates``)
    torque = mode_torque(law, m, x, v, k, c, alpha, beta)
    t_x, t_v, t_k, t_c, t_a, t_b = torque_partials(law, m, x, v, k, c, alpha, beta)
    f_m, f_m_w, f_m_c, f_m_b = friction_partials(wm, p[VISCOUS_MOTOR], p[COULOMB_MOTOR], p[BREAKAWAY_MOTOR], eps, w_s,
                                                 terms[0], terms[1])
    f_l, f_l_w, f_l_c, f_l_b = friction_partials(wl, p[VISCOUS_LOAD], p[COULOMB_LOAD], p[BREAKAWAY_LOAD], eps, w_s,
                                                 terms[2], terms[3])
    jm, jl = p[MOTOR_INERTIA], p[LOAD_INERTIA]
    a1 = (tm + p[TORQUE_OFFSET] - torque - f_m) / jm
    a2 = (tl + torque - f_l) / jl
    im, il = 1.0 / jm, 1.0 / jl
    # d(dw_m/dt)/dq and d(dw_l/dt)/dq for q in the order of KERNEL_VALUES, then DELAY
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

    The trajectory is :func:`two_mass_segments`' (RK4, ``substeps`` steps a sample, inputs
    interpolated linearly, each stage in the mode the law holds there); its sensitivities
    ride along (module docs).

    Parameters
    ----------
    law : int
        Law code.
    p : ndarray, shape (14,)
        The kernel's values (:data:`KERNEL_VALUES`) and the sample interval (s).
    eps, w_s : float
        Smoothing and Stribeck speeds of the friction law (rad/s).
    tm, dtm, tl : ndarray, shape (n,)
        Delayed motor torque (N m), its derivative by the delay (N m/s), load torque (N m).
    starts, stops : ndarray of int64
        Segments.
    z0 : ndarray, shape (segments, 3)
        Initial states (rad, rad/s, rad/s).
    substeps : int
        RK4 steps a sample.
    columns : ndarray of int64
        Values to differentiate by: indices into ``p`` (:data:`MOTOR_INERTIA` to :data:`TORQUE_OFFSET`) or
        :data:`DELAY`.
    initial : ndarray of int64
        Initial states to differentiate by, the segment's own (0 theta_d, 1 w_m, 2 w_l).
    work : ndarray, shape (11, columns.size + initial.size)
        Work space (the kernel allocates nothing).
    out : ndarray, shape (n, 2, columns.size + initial.size)
        Written inside the segments: ``d(w_m, w_l)/d(columns, initial)``.
    """
    last = tm.shape[0] - 1
    values = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12])  # p's, in order
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    n_columns = columns.shape[0]
    width = n_columns + initial.shape[0]
    sens, stage, acc, by_value = work[0:3], work[3:6], work[6:9], work[9:11]
    motor_exp = _friction_term(p[BREAKAWAY_MOTOR], columns, BREAKAWAY_MOTOR)
    load_exp = _friction_term(p[BREAKAWAY_LOAD], columns, BREAKAWAY_LOAD)
    terms = (_friction_term(p[COULOMB_MOTOR], columns, COULOMB_MOTOR) or motor_exp, motor_exp,
             _friction_term(p[COULOMB_LOAD], columns, COULOMB_LOAD) or load_exp, load_exp)
    for s in range(starts.shape[0]):
        x, wm, wl = z0[s, 0], z0[s, 1], z0[s, 2]
        for r in range(3):
            for q in range(width):
                sens[r, q] = 1.0 if q >= n_columns and initial[q - n_columns] == r else 0.0
        mode = held_mode(law, np.int64(0), x, wm - wl, k, c, alpha, beta)
        for i in range(starts[s], stops[s]):
            for q in range(width):
                out[i, 0, q], out[i, 1, q] = sens[1, q], sens[2, q]
            if i == last:
                continue
            d_tm, d_dtm, d_tl = tm[i + 1] - tm[i], dtm[i + 1] - dtm[i], tl[i + 1] - tl[i]
            for q in range(substeps):
                f0, f1 = q / substeps, (q + 1.0) / substeps
                h = (f1 - f0) * p[SAMPLE_INTERVAL]
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
                                    tl[i] + f1 * d_tl, law, mode, values, eps, w_s, terms, columns, stage, sens, stage,
                                    0.0, acc, 1.0, by_value)
                for r in range(3):
                    for q in range(width):
                        sens[r, q] += h / 6.0 * acc[r, q]
                x += h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                wm += h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
                wl += h / 6.0 * (a2 + 2.0 * b2 + 2.0 * c2 + d2)
                mode = held_mode(law, mode, x, wm - wl, k, c, alpha, beta)
