"""The torque laws as the compiled kernels take them: law codes, the shaft's layout, the scalar kernels.

Shared by the vectorised laws of :mod:`backlash_df.models`, the time simulation, the
describing functions, the orbits and the identification, so that every law has exactly
one implementation (the laws, their modes and the equations are described in
:mod:`backlash_df.models`).  Private to the package: the names are plain because
several of its modules import them, and none is public API.

The kernels take the shaft as scalars ``k, c, alpha, beta``, or as the parameter vector
``p`` of :attr:`backlash_df.models.BacklashModel.params` indexed by :data:`STIFFNESS`,
:data:`DAMPING`, :data:`HALF_GAP` and :data:`RUBBER_THICKNESS` (numba folds these
module-level integers into the compiled code).
"""

import math

from ._jit import jit as _jit

__all__ = [
    "DEAD_ZONE",
    "DAMPED_DEAD_ZONE",
    "REVISED_DEAD_ZONE",
    "PHASE_PLANE",
    "RUBBER",
    "ELASTO_BACKLASH",
    "EXACT",
    "LAW_CODES",
    "SHAFT_KEYS",
    "STIFFNESS",
    "DAMPING",
    "HALF_GAP",
    "RUBBER_THICKNESS",
    "theta_star_kernel",
    "theta_star_partials",
    "right_mode",
    "right_torque",
    "static_mode",
    "held_mode",
    "mode_torque",
    "static_torque",
    "exact_torque",
    "exact_step",
]

DEAD_ZONE, DAMPED_DEAD_ZONE, REVISED_DEAD_ZONE, PHASE_PLANE, RUBBER, ELASTO_BACKLASH, EXACT = range(7)

#: Model names accepted by :func:`~backlash_df.models.make_model`, with their law codes.
LAW_CODES = {
    "dead-zone": DEAD_ZONE,
    "damped-dead-zone": DAMPED_DEAD_ZONE,
    "revised-dead-zone": REVISED_DEAD_ZONE,
    "phase-plane": PHASE_PLANE,
    "rubber": RUBBER,
    "elasto-backlash": ELASTO_BACKLASH,
    "exact": EXACT,
}

#: The shaft's values with the rig file's names, in the order of the kernels' parameter vector ``p``.
SHAFT_KEYS = ("stiffness", "damping", "half_gap", "rubber_thickness")
#: Indices of ``p``: k (N m/rad), c (N m s/rad), alpha (rad), beta (rad).
STIFFNESS, DAMPING, HALF_GAP, RUBBER_THICKNESS = range(len(SHAFT_KEYS))

# --------------------------------------------------------------------------- theta*(v)


@_jit
def _contact_fraction(big_k):
    """Root ``u`` in (0, 1] of ``u - ln u = 1 + K``, i.e. ``u = -W0(-exp(-1 - K))``.

    ``theta* = alpha - (c v / k) u`` (reading notes, item 1).  For small ``K`` the
    unknown is ``delta = 1 - u`` (branch-point series start, no cancellation);
    for larger ``K`` a fixed-point start and Newton on ``u``.
    """
    if big_k <= 0.5:
        p = math.sqrt(-2.0 * math.expm1(-big_k))
        delta = p - p * p / 3.0 + 11.0 * p**3 / 72.0
        # Newton on g(delta) = -delta - log(1 - delta) - K, g' = delta / (1 - delta);
        # once a step is below 1e-7, one more squares the error down to round-off
        for _ in range(60):
            step = _delta_newton_step(delta, big_k)
            delta -= step
            if abs(step) <= 1e-7 * delta:
                break
        return 1.0 - (delta - _delta_newton_step(delta, big_k))
    u = math.exp(-1.0 - big_k)
    for _ in range(4):
        u = math.exp(u - 1.0 - big_k)
    for _ in range(60):
        step = _u_newton_step(u, big_k)
        u -= step
        if abs(step) <= 1e-7 * u:
            break
    return u - _u_newton_step(u, big_k)


@_jit
def _delta_newton_step(delta, big_k):
    return (-delta - math.log1p(-delta) - big_k) * (1.0 - delta) / delta


@_jit
def _u_newton_step(u, big_k):
    return (u - math.log(u) - 1.0 - big_k) / (1.0 - 1.0 / u)


@_jit
def theta_star_kernel(v, k, c, alpha):
    """Re-contact displacement theta*(v) of eq. (19) for v > 0 (rad); alpha for v <= 0 (compiled, scalar)."""
    s = c * v / k
    if s <= 0.0:
        return alpha
    if 20.0 * s < alpha:  # K > 40: alpha - theta* = 2 alpha u / K < 1e-19 alpha rounds off
        return alpha
    return alpha - s * _contact_fraction(2.0 * alpha / s)


@_jit
def theta_star_partials(v, k, c, alpha):
    """theta*(v) of (19) (v > 0) and its partial derivatives ``(theta*, d/dv, d/dk, d/dc, d/dalpha)``.

    ``theta* = alpha - s u(K)`` with ``s = c v / k``, ``K = 2 alpha / s`` and
    ``u - ln u = 1 + K`` (reading notes, item 1), so ``du/dK = u / (u - 1)``;
    where :func:`theta_star_kernel` returns alpha (K > 40),
    theta* follows alpha alone.
    """
    s = c * v / k
    if s <= 0.0 or 20.0 * s < alpha:
        return alpha, 0.0, 0.0, 0.0, 1.0
    u = _contact_fraction(2.0 * alpha / s)
    slope = u / (u - 1.0)  # du/dK
    by_s = -u + (2.0 * alpha / s) * slope  # d theta*/ds
    return alpha - s * u, by_s * c / k, -by_s * s / k, by_s * v / k, 1.0 - 2.0 * slope

# --------------------------------------------------------------------------- static laws


@_jit
def right_mode(law, x, v, k, c, alpha, beta):
    """Right-contact mode of a static law: 0 free, 1 rubber band, 2 steel contact."""
    if law == DEAD_ZONE or law == DAMPED_DEAD_ZONE:
        return 2 if x > alpha else 0
    if law == REVISED_DEAD_ZONE:
        return 2 if k * x + c * v > k * alpha else 0
    if law == ELASTO_BACKLASH:
        return 2 if x > alpha and k * (x - alpha) + c * v > 0.0 else 0
    if law == PHASE_PLANE or (law == RUBBER and beta == 0.0):
        # (20), both lines together (reading notes, item 2)
        if v > 0.0:
            if x >= alpha:  # theta* lies in [alpha - c v / k, alpha]
                return 2
            if k * (x - alpha) + c * v < 0.0:
                return 0
            return 2 if x >= theta_star_kernel(v, k, c, alpha) else 0
        return 2 if k * (x - alpha) + c * v >= 0.0 else 0
    if law == RUBBER:
        if v > 0.0:  # (28) first line: |x - theta*| < beta / 2
            if x >= alpha + 0.5 * beta:  # theta* lies in [alpha - c v / k, alpha]
                return 2
            if x <= alpha - c * v / k - 0.5 * beta:
                return 0
            ts = theta_star_kernel(v, k, c, alpha)
            if x >= ts + 0.5 * beta:
                return 2
            return 1 if x > ts - 0.5 * beta else 0
        if x >= alpha + 0.5 * beta:
            return 2 if k * (x - alpha) + c * v >= 0.0 else 0
        # (28) second line for v <= 0 (reading notes, item 5)
        return 1 if x > alpha - 0.5 * beta - 2.0 * c * v / k else 0
    return 0


@_jit
def right_torque(law, m, x, v, k, c, alpha, beta):
    """Torque (N m, >= 0 inside its region) of right-contact mode ``m`` of a static law."""
    if m == 0:
        return 0.0
    if law == DEAD_ZONE:
        return k * (x - alpha)
    if law == ELASTO_BACKLASH:
        tau_c = k * (x - alpha)
        return tau_c + min(tau_c, c * v)
    if m == 2:
        return k * (x - alpha) + c * v  # (23), (26), (27), (33)
    # rubber band, (36) with the corrected denominator (reading notes, item 5)
    if v > 0.0:
        ts = theta_star_kernel(v, k, c, alpha)
        w = x - ts + 0.5 * beta
        return (0.5 * k * w + k * (ts - alpha) + c * v) * w / beta
    lower = alpha - 0.5 * beta - 2.0 * c * v / k
    return 0.5 * k * (x - lower) ** 2 / (beta + 2.0 * c * v / k)


@_jit
def static_mode(law, x, v, k, c, alpha, beta):
    """Signed mode: positive on the right, negative (mirrored) on the left, 0 free."""
    m = right_mode(law, x, v, k, c, alpha, beta)
    if m != 0:
        return m
    return -right_mode(law, -x, -v, k, c, alpha, beta)


@_jit
def held_mode(law, mode, x, v, k, c, alpha, beta):
    """Mode at ``(x, v)`` reached by a trajectory that held ``mode`` until there.

    The static law's region, except that contact of the phase plane law, once
    made at theta*, holds until the release condition of Theorem 1
    (``k (x -+ alpha) + c v`` changes sign), as the paper's derivation of (20)
    states ("right contact will then be preserved ... until the release
    condition ... is fulfilled").  Read as a memoryless function, (20) would let
    a strongly damped contact (c^2 > k J, roughly) slide out across the jump at
    theta* and back in again without end (Zeno chattering).
    """
    m = static_mode(law, x, v, k, c, alpha, beta)
    if m == 0 and (law == PHASE_PLANE or (law == RUBBER and beta == 0.0)):
        if mode > 0 and k * (x - alpha) + c * v >= 0.0:
            return mode
        if mode < 0 and k * (x + alpha) + c * v <= 0.0:
            return mode
    return m


@_jit
def mode_torque(law, m, x, v, k, c, alpha, beta):
    """Torque of signed mode ``m``; the left side is the odd mirror of the right side."""
    if m >= 0:
        return right_torque(law, m, x, v, k, c, alpha, beta)
    return -right_torque(law, -m, -x, -v, k, c, alpha, beta)


@_jit
def static_torque(law, x, v, k, c, alpha, beta):
    """Shaft torque (N m) of a static law at displacement x (rad) and rate v (rad/s)."""
    return mode_torque(law, static_mode(law, x, v, k, c, alpha, beta), x, v, k, c, alpha, beta)

# --------------------------------------------------------------------------- exact model


@_jit
def exact_torque(x, v, theta_b, k, c, alpha):
    """Torque (1) of the exact model given its state theta_b (N m).

    In contact (``|theta_b| = alpha`` and the limited integrator (14) saturated)
    ``T = k (x -+ alpha) + c v``; off contact the shaft is free and ``T = 0``.
    """
    if theta_b >= alpha:
        t = k * (x - alpha) + c * v
        return t if t > 0.0 else 0.0
    if theta_b <= -alpha:
        t = k * (x + alpha) + c * v
        return t if t < 0.0 else 0.0
    return 0.0


@_jit
def _free_step(theta_b, y0, y1, h, tau):
    """theta_b after h seconds of (12), ``dtheta_b/dt = (y - theta_b) / tau``, y linear."""
    r = h / tau
    if r <= 0.0:
        return theta_b
    # exact for a linear ramp of y: the lag term is (y1 - y0) (1 - exp(-r)) / r
    ramp = -math.expm1(-r) / r if r > 1e-8 else 1.0 - 0.5 * r
    return y1 + (theta_b - y0) * math.exp(-r) - (y1 - y0) * ramp


@_jit
def exact_step(theta_b, x0, v0, x1, v1, h, k, c, alpha):
    """Advance theta_b of the limited integrator (14) over a step of h seconds.

    Off contact ``dtheta_b/dt = (k / c) (y - theta_b)`` with ``y = x + (c / k) v``
    (eq. 12): integrated exactly for ``y`` linear over the step, then limited to
    ``[-alpha, alpha]``.  A step that starts in contact (``theta_b = +-alpha``
    with ``y`` beyond it) holds theta_b until y crosses the limit (release,
    Theorem 1) and runs free from there.  Stable for any ``h`` however small
    ``c / k`` is; with ``c = 0`` it reduces to ``theta_b = clip(x)``, the
    classical dead-zone.
    """
    if c == 0.0:
        theta = x1
    else:
        tau = c / k
        y0 = x0 + tau * v0
        y1 = x1 + tau * v1
        edge = 0.0
        if theta_b >= alpha and y0 >= alpha:
            edge = alpha
        elif theta_b <= -alpha and y0 <= -alpha:
            edge = -alpha
        if edge == 0.0:
            theta = _free_step(theta_b, y0, y1, h, tau)
        elif (y1 - edge) * edge >= 0.0:
            return edge  # y stays beyond the limit: held in contact all the step
        else:
            held = (y0 - edge) / (y0 - y1)  # fraction of the step still in contact
            theta = _free_step(edge, edge, y1, (1.0 - held) * h, tau)
    if theta > alpha:
        return alpha
    if theta < -alpha:
        return -alpha
    return theta
