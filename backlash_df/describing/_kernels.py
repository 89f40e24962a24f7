"""The compiled kernels of the describing functions (numba): the switch-exact harmonic
balance of the static laws, the sampled walk that is its reference, and the exact model.

The methods are described in :mod:`backlash_df.describing`; the equation numbers are the
paper's.  Private to the package: :mod:`backlash_df.describing._evaluation` calls them,
and the tests reach the switch location, the quadrature rule and the contact fraction
here to check them against references of their own.
"""

import functools
import math

import numba
import numpy as np

from .._jit import borrowing_unchecked as _borrowing
from .._jit import jit_unchecked as _jit
from .._laws import (
    DAMPED_DEAD_ZONE,
    DAMPING,
    DEAD_ZONE,
    ELASTO_BACKLASH,
    HALF_GAP,
    PHASE_PLANE,
    REVISED_DEAD_ZONE,
    RUBBER,
    RUBBER_THICKNESS,
    STIFFNESS,
    held_mode,
    mode_torque,
    static_mode,
    theta_star_kernel,
)

_TWO_PI = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi
_RUBBER_BAND = -1  # law code of _kronrod for the rubber band torque of the switch-exact kernels
SAMPLES = 64  # phase samples that bracket mode changes (plus special phases)
SCAN_STEP = 0.02  # phase step (rad) of the exact model's search for re-contact
_BISECTIONS = 60
_MAX_PIECE = 0.25 * math.pi  # longest sub-interval of the fixed reference rule
_START_PIECE = 0.5 * math.pi  # longest first sub-interval of the adaptive rule
_KRONROD_TOLERANCE = 1e-9  # accepted |K15 - G7| / int |T| of a sub-interval
_MAX_LEVEL = 40  # halvings of a sub-interval before it is accepted as it is
# Sub-intervals one adaptive integration evaluates at most (QUADPACK's ``limit``); the rubber law's
# sets of 10^4 points use at most 13 (beta / alpha from 1e-3 to 1.9)
_MAX_PANELS = 200

# Gauss-Kronrod 7-15 rule on [-1, 1] (Piessens et al., QUADPACK qk15), one row per node pair
# +-x (the last row the centre x = 0): x, its Kronrod weight, and its weight in the embedded
# 7-point Gauss rule (zero at the Kronrod-only nodes)
KRONROD = np.array((
    (0.991455371120812639206854697526329, 0.022935322010529224963732008058970, 0.0),
    (0.949107912342758524526189684047851, 0.063092092629978553290700663189204, 0.129484966168869693270611432679082),
    (0.864864423359769072789712788640926, 0.104790010322250183839876322541518, 0.0),
    (0.741531185599394439863864773280788, 0.140653259715525918745189590510238, 0.279705391489276667901467771423780),
    (0.586087235467691130294144845693013, 0.169004726639267902826583426598550, 0.0),
    (0.405845151377397166906606412076961, 0.190350578064785409913256402421014, 0.381830050505118944950369775488975),
    (0.207784955007898467600689403773245, 0.204432940075298892414161999234649, 0.0),
    (0.0, 0.209482141084727828012999174891714, 0.417959183673469387755102040816327),
))


# --------------------------------------------------------------------------- static laws


@_jit
def piece(law, mode, phi, amp, omega, bias, p):
    """(mode, smooth-piece index) at phase phi for a trajectory that held ``mode``.

    The mode follows ``_laws.held_mode``, as in the simulation:
    contact of the phase plane law, once made at theta*, holds until release.
    The piece index adds the side of the ElastoBacklash kink ``min(tau_c, tau_d)``
    and the sign of v in the rubber band (the two lines of (36) meet with a kink
    at v = 0).
    """
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    x = bias + amp * math.sin(phi)
    v = amp * omega * math.cos(phi)
    m = held_mode(law, mode, x, v, k, c, alpha, beta)
    if law == RUBBER and (m == 1 or m == -1):
        return m, 2 * m + (1 if v > 0.0 else 0)
    if law == ELASTO_BACKLASH and m != 0:
        if m > 0:
            kink = 1 if k * (x - alpha) < c * v else 0
        else:
            kink = 1 if k * (x + alpha) > c * v else 0
        return m, 2 * m + kink
    return m, 2 * m


@_jit
def _integrate_fixed(law, m, a, e, amp, omega, bias, p, nodes, weights, acc):
    """Add int T sin, int T cos, int T over [a, e] to ``acc`` by a fixed composite rule.

    Gauss-Legendre ``nodes``, ``weights`` on sub-intervals of at most pi/4 (pi/8 in
    the rubber band, where theta*(v) is steep at high rate): the reference that
    the adaptive rule is tested against.
    """
    longest = 0.5 * _MAX_PIECE if law == RUBBER and (m == 1 or m == -1) else _MAX_PIECE
    n_sub = int(math.ceil((e - a) / longest))
    width = (e - a) / n_sub
    for s in range(n_sub):
        centre = a + (s + 0.5) * width
        for i in range(nodes.shape[0]):
            phi = centre + 0.5 * width * nodes[i]
            sn = math.sin(phi)
            cs = math.cos(phi)
            torque = mode_torque(law, m, bias + amp * sn, amp * omega * cs, p[STIFFNESS], p[DAMPING], p[HALF_GAP],
                                 p[RUBBER_THICKNESS])
            w = 0.5 * width * weights[i] * torque
            acc[0] += w * sn
            acc[1] += w * cs
            acc[2] += w


@_jit
def _kronrod(law, m, a, e, amp, omega, bias, k, c, alpha, beta):
    """15-point Kronrod integrals of T sin, T cos, T over [a, e], |K15 - G7| and int |T|
    (T of mode m of the law, or the rubber band torque of :func:`_band_torque` if law is _RUBBER_BAND).

    The law's parameters come as scalars: an array argument of a compiled helper called in a
    loop is reference-counted on every call (see ``backlash_df._jit.inline``)."""
    half = 0.5 * (e - a)
    centre = a + half
    sin_centre, cos_centre = math.sin(centre), math.cos(centre)
    k_sin = k_cos = k_one = g_sin = g_cos = g_one = total = 0.0
    for i in range(KRONROD.shape[0]):
        offset = half * KRONROD[i, 0]  # the pair centre +- offset shares one sine and cosine
        sin_offset, cos_offset = math.sin(offset), math.cos(offset)
        for side in range(2 if i < KRONROD.shape[0] - 1 else 1):
            sign = 1.0 - 2.0 * side
            sn = sin_centre * cos_offset + sign * cos_centre * sin_offset
            cs = cos_centre * cos_offset - sign * sin_centre * sin_offset
            x, v = bias + amp * sn, amp * omega * cs
            torque = (_band_torque(x, v, k, c, alpha, beta) if law == _RUBBER_BAND
                      else mode_torque(law, m, x, v, k, c, alpha, beta))
            kronrod = KRONROD[i, 1] * torque
            gauss = KRONROD[i, 2] * torque
            k_sin += kronrod * sn
            k_cos += kronrod * cs
            k_one += kronrod
            g_sin += gauss * sn
            g_cos += gauss * cs
            g_one += gauss
            total += abs(kronrod)
    error = max(abs(k_sin - g_sin), abs(k_cos - g_cos), abs(k_one - g_one))
    return half * k_sin, half * k_cos, half * k_one, half * error, half * total


@_jit
def integrate_adaptive(law, m, a, e, amp, omega, bias, p, stack, acc):
    """Add int T sin, int T cos, int T over [a, e] to ``acc`` by adaptive Gauss-Kronrod.

    A sub-interval is accepted when its 15-point Kronrod and embedded 7-point
    Gauss integrals differ by at most ``_KRONROD_TOLERANCE`` times its int |T|,
    and halved otherwise.  For an analytic integrand the Kronrod error is of
    order ``|K15 - G7|^(23/14)`` (degrees of exactness 23 and 13), below 1e-14
    relative at that tolerance.  Affine modes, sinusoids along phi, pass on
    intervals of pi/2; the rubber band, with theta*(v), is refined where needed.

    After ``_MAX_PANELS`` sub-intervals every further one is accepted as it is: where the
    integrand's own round-off exceeds the tolerance no halving meets it, and the halvings
    would grow as 2^level.  A rubber band thinner than about 1e-7 of the amplitude is such
    an integrand (``x - theta* + beta / 2`` keeps ``beta / (eps A)`` of its digits); it took
    seconds to a minute a point before this bound.
    """
    n_start = int(math.ceil((e - a) / _START_PIECE))
    width = (e - a) / n_start
    top = 0
    panels = 0
    for s in range(n_start):  # pushed last to first: integrated in order of phase
        stack[top, 0] = e - (s + 1) * width
        stack[top, 1] = e - s * width
        stack[top, 2] = 0.0
        top += 1
    while top > 0:
        top -= 1
        lo, hi, level = stack[top, 0], stack[top, 1], stack[top, 2]
        k_sin, k_cos, k_one, error, total = _kronrod(law, m, lo, hi, amp, omega, bias, p[STIFFNESS], p[DAMPING],
                                                     p[HALF_GAP], p[RUBBER_THICKNESS])
        panels += 1
        if (error <= _KRONROD_TOLERANCE * total or level >= _MAX_LEVEL or top + 2 > stack.shape[0]
                or panels >= _MAX_PANELS):
            acc[0] += k_sin
            acc[1] += k_cos
            acc[2] += k_one
            continue
        mid = 0.5 * (lo + hi)
        stack[top, 0], stack[top, 1], stack[top, 2] = mid, hi, level + 1.0
        stack[top + 1, 0], stack[top + 1, 1], stack[top + 1, 2] = lo, mid, level + 1.0
        top += 2


@_jit
def _integrate_piece(law, m, a, e, amp, omega, bias, p, nodes, weights, stack, acc):
    """Add int T sin, int T cos, int T over [a, e] (one smooth piece in mode m) to ``acc``:
    adaptively if ``nodes`` is empty, else by the fixed composite rule."""
    if m == 0:
        return
    if nodes.shape[0] == 0:
        integrate_adaptive(law, m, a, e, amp, omega, bias, p, stack, acc)
    else:
        _integrate_fixed(law, m, a, e, amp, omega, bias, p, nodes, weights, acc)


# Boundary functions of the modes along the sinusoid (right side; index + _SIDE is
# the mirror image): their zeros are where a law may change mode or piece.
_X_ALPHA, _RELEASE, _KINK, _RATE, _THETA_STAR, _BAND_TOP, _BAND_BOTTOM, _RUBBER_TOP, _BAND_BACK = range(9)
_SIDE = 9


@_jit
def _boundary_of(index, x, v, ts, p):
    """Right-side boundary function ``index`` at (x, v), with ts = theta*(v)."""
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    s = c * v / k
    if index == _X_ALPHA:  # contact of the dead-zones (24), (26)
        return x - alpha
    if index == _RELEASE:  # k (x - alpha) + c v = 0: release, Theorem 1; (27)
        return x - alpha + s
    if index == _KINK:  # ElastoBacklash: k (x - alpha) = c v
        return x - alpha - s
    if index == _RATE:  # v = 0: the two lines of (36)
        return s
    if index == _RUBBER_TOP:  # x = alpha + beta / 2
        return x - alpha - 0.5 * beta
    if index == _BAND_BACK:  # (28) second line
        return x - alpha + 0.5 * beta + 2.0 * s
    if index == _THETA_STAR:  # contact of the phase plane law, (20)
        return x - ts
    if index == _BAND_TOP:  # (28) first line, both edges
        return x - ts - 0.5 * beta
    return x - ts + 0.5 * beta


@_jit
def _boundary(index, phi, amp, omega, bias, p):
    """Value at phase phi of boundary function ``index`` (zero on the boundary)."""
    x = bias + amp * math.sin(phi)
    v = amp * omega * math.cos(phi)
    if index >= _SIDE:
        x, v, index = -x, -v, index - _SIDE
    if index >= _THETA_STAR and index <= _BAND_BOTTOM:
        ts = theta_star_kernel(v, p[STIFFNESS], p[DAMPING], p[HALF_GAP])
    else:
        ts = p[HALF_GAP]
    return _boundary_of(index, x, v, ts, p)


@_jit
def _slot(index, x, v, ts, p):
    return 1.0 if index < 0 else _boundary_of(index, x, v, ts, p)


@_jit
def _boundary_values(law, phi, amp, omega, bias, p):
    """The law's boundary functions at phase phi, right side and mirrored (tuples in the
    order of :func:`_boundaries`; one theta* evaluation per side at most)."""
    x = bias + amp * math.sin(phi)
    v = amp * omega * math.cos(phi)
    i = _boundaries(law, p[RUBBER_THICKNESS])
    ts = theta_star_kernel(v, p[STIFFNESS], p[DAMPING], p[HALF_GAP])
    right = (_slot(i[0], x, v, ts, p), _slot(i[1], x, v, ts, p), _slot(i[2], x, v, ts, p),
             _slot(i[3], x, v, ts, p), _slot(i[4], x, v, ts, p), _slot(i[5], x, v, ts, p))
    ts = theta_star_kernel(-v, p[STIFFNESS], p[DAMPING], p[HALF_GAP])
    left = (_slot(i[0], -x, -v, ts, p), _slot(i[1], -x, -v, ts, p), _slot(i[2], -x, -v, ts, p),
            _slot(i[3], -x, -v, ts, p), _slot(i[4], -x, -v, ts, p), _slot(i[5], -x, -v, ts, p))
    return right, left


@_jit
def _boundaries(law, beta):
    """Indices of the right-side boundary functions of a law (see :func:`_boundary`),
    padded with -1."""
    if law == RUBBER and beta > 0.0:
        return (_RELEASE, _RATE, _BAND_TOP, _BAND_BOTTOM, _RUBBER_TOP, _BAND_BACK)
    if law == PHASE_PLANE or law == RUBBER:
        return (_RELEASE, _THETA_STAR, -1, -1, -1, -1)
    if law == ELASTO_BACKLASH:
        return (_X_ALPHA, _RELEASE, _KINK, -1, -1, -1)
    if law == REVISED_DEAD_ZONE:
        return (_RELEASE, -1, -1, -1, -1, -1)
    return (_X_ALPHA, -1, -1, -1, -1, -1)


@_jit
def _illinois(index, a, e, fa, fe, amp, omega, bias, p):
    """Zero of boundary function ``index`` in [a, e], where it changes sign, by the
    Illinois variant of regula falsi (superlinear, bracketing)."""
    root = a
    last = 0
    for _ in range(_BISECTIONS):
        previous = root
        root = (fa * e - fe * a) / (fa - fe)
        if not a <= root <= e:
            root = 0.5 * (a + e)
        f = _boundary(index, root, amp, omega, bias, p)
        if f == 0.0 or abs(root - previous) <= 4e-16 * abs(root):
            return root
        if (f > 0.0) == (fe > 0.0):
            e, fe = root, f
            if last == 1:
                fa *= 0.5
            last = 1
        else:
            a, fa = root, f
            if last == -1:
                fe *= 0.5
            last = -1
    return root


@_jit
def _hinted_switch(law, mode, current, lo, hi, amp, omega, bias, p):
    """Switch in (lo, hi] at a zero of one of the law's boundary functions, checked by
    the mode itself: returns a bracket of a few ulps around the switch, or NaNs.

    The boundary functions that change sign over the bracket are tried in the
    order of their linearly interpolated zeros.  They only propose phases;
    :func:`piece` (the law of :mod:`backlash_df.models`) decides, so a wrong
    proposal costs time, never accuracy.
    """
    right_lo, left_lo = _boundary_values(law, lo, amp, omega, bias, p)
    right_hi, left_hi = _boundary_values(law, hi, amp, omega, bias, p)
    indices = _boundaries(law, p[RUBBER_THICKNESS])
    tried = 0
    while True:
        first, f_first_lo, f_first_hi, estimate = -1, 0.0, 0.0, math.inf
        for j in range(12):
            i = j % 6
            f_lo = right_lo[i] if j < 6 else left_lo[i]
            f_hi = right_hi[i] if j < 6 else left_hi[i]
            if indices[i] < 0 or tried & (1 << j) or (f_lo > 0.0) == (f_hi > 0.0) or f_lo == 0.0 or f_hi == 0.0:
                continue
            guess = (f_lo * hi - f_hi * lo) / (f_lo - f_hi)
            if guess < estimate:
                first, f_first_lo, f_first_hi, estimate = j, f_lo, f_hi, guess
        if first < 0:
            return math.nan, math.nan
        tried |= 1 << first
        index = indices[first % 6] + (first // 6) * _SIDE
        root = _illinois(index, lo, hi, f_first_lo, f_first_hi, amp, omega, bias, p)
        for ulps in (2.0, 64.0):  # the law's rounding may move its switch a few ulps
            margin = ulps * 2.2e-16 * max(1.0, abs(root))
            before = max(lo, root - margin)
            after = min(hi, root + margin)
            if (piece(law, mode, before, amp, omega, bias, p)[1] == current
                    and piece(law, mode, after, amp, omega, bias, p)[1] != current):
                return before, after


@_jit
def locate_switch(law, mode, current, lo, hi, amp, omega, bias, p):
    """First phase in (lo, hi] of another smooth piece than ``current`` (at lo).

    Bisection on the mode to round-off, from the bracket of a few ulps where a
    boundary function locates the switch (:func:`_hinted_switch`), else from
    (lo, hi].  Round-off matters: at a jump of the torque (contact at alpha or
    theta*) a switch misplaced by h costs the jump times h in the integrals.
    """
    before, after = _hinted_switch(law, mode, current, lo, hi, amp, omega, bias, p)
    if not math.isnan(before):
        lo, hi = before, after
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if piece(law, mode, mid, amp, omega, bias, p)[1] == current:
            lo = mid
        else:
            hi = mid
    return hi


@_jit
def static_harmonics(law, amp, omega, bias, p, nodes, weights, samples, stack, acc):
    """Fourier integrals of a static law's torque over one period (see module docs).

    The walk starts at phi = pi/2, where v = 0 and the held mode does not depend
    on the history, and runs one period.
    """
    tau_omega = p[DAMPING] * omega / p[STIFFNESS]
    psi = math.atan(tau_omega)
    phi0 = 0.5 * math.pi
    grid = np.empty(samples + 7)
    for i in range(samples + 1):
        grid[i] = phi0 + _TWO_PI * i / samples
    # special phases: extrema of x and of y = x + (c/k) v, zero crossings of v
    specials = (0.5 * math.pi, 1.5 * math.pi, 0.5 * math.pi - psi, 1.5 * math.pi - psi, math.pi, 0.0)
    for j in range(6):
        grid[samples + 1 + j] = phi0 + (specials[j] - phi0) % _TWO_PI
    grid.sort()
    acc[0] = 0.0
    acc[1] = 0.0
    acc[2] = 0.0
    start = phi0
    x0 = bias + amp * math.sin(phi0)
    mode = static_mode(law, x0, 0.0, p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS])
    mode, current = piece(law, mode, phi0, amp, omega, bias, p)
    for j in range(1, grid.shape[0]):
        if grid[j] <= grid[j - 1]:
            continue
        target = piece(law, mode, grid[j], amp, omega, bias, p)[1]
        while target != current:
            switch = locate_switch(law, mode, current, max(start, grid[j - 1]), grid[j], amp, omega, bias, p)
            _integrate_piece(law, mode, start, switch, amp, omega, bias, p, nodes, weights, stack, acc)
            start = switch
            mode, current = piece(law, mode, switch, amp, omega, bias, p)
            target = piece(law, mode, grid[j], amp, omega, bias, p)[1]
    _integrate_piece(law, mode, start, phi0 + _TWO_PI, amp, omega, bias, p, nodes, weights, stack, acc)
    return 1.0


# --------------------------------------------------------------------------- exact model


@_jit
def _contact_integrals(a, e, amp, omega, bias, side, p, acc):
    """Closed-form Fourier integrals of T = k (y - side alpha) over [a, e]."""
    k, c, alpha = p[STIFFNESS], p[DAMPING], p[HALF_GAP]
    p0 = k * (bias - side * alpha)
    p1 = k * amp
    p2 = c * amp * omega
    sa, se = math.sin(a), math.sin(e)
    ca, ce = math.cos(a), math.cos(e)
    half = 0.5 * (e - a)
    quarter = 0.25 * (math.sin(2.0 * e) - math.sin(2.0 * a))
    sin2 = half - quarter
    cos2 = half + quarter
    sincos = 0.5 * (se * se - sa * sa)
    acc[0] += p0 * (ca - ce) + p1 * sin2 + p2 * sincos
    acc[1] += p0 * (se - sa) + p1 * sincos + p2 * cos2
    acc[2] += p0 * (e - a) + p1 * (ca - ce) + p2 * (se - sa)


@_jit
def _free_theta(phi, phi0, offset, amp, bias, tau_omega):
    """theta_b in free motion (13): x(phi) + offset exp(-(phi - phi0) / (c w / k))."""
    return bias + amp * math.sin(phi) + offset * math.exp(-(phi - phi0) / tau_omega)


@_jit
def _next_contact(phi0, theta0, amp, bias, tau_omega, alpha, horizon, scan_step):
    """First phase after phi0 where the free theta_b reaches +-alpha; (phase, side).

    Returns side 0 if the shaft stays free up to ``phi0 + horizon``.
    """
    offset = theta0 - (bias + amp * math.sin(phi0))
    transient = 40.0 * tau_omega
    fine = 0.25 * tau_omega
    phi_prev = phi0
    phi = phi0
    while phi - phi0 < horizon:
        step = fine if (phi - phi0 < transient and fine < scan_step) else scan_step
        phi = phi + step
        theta = _free_theta(phi, phi0, offset, amp, bias, tau_omega)
        if theta >= alpha or theta <= -alpha:
            side = 1.0 if theta >= alpha else -1.0
            lo = phi_prev
            hi = phi
            for _ in range(_BISECTIONS):
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                if side * _free_theta(mid, phi0, offset, amp, bias, tau_omega) >= alpha:
                    hi = mid
                else:
                    lo = mid
            return hi, side
        phi_prev = phi
    return phi, 0.0


@_jit
def _release_phase(side, amp, bias, tau_omega, alpha):
    """Phase in [0, 2 pi) where y = x + (c/k) v leaves contact on ``side`` (Theorem 1).

    ``y = bias + R sin(phi + psi)``; right contact ends where y falls through
    alpha, left contact where y rises through -alpha.  NaN if y never crosses.
    """
    radius = amp * math.sqrt(1.0 + tau_omega * tau_omega)
    psi = math.atan(tau_omega)
    level = (side * alpha - bias) / radius
    if abs(level) >= 1.0:
        return math.nan
    if side > 0.0:
        phi = math.pi - math.asin(level) - psi
    else:
        phi = math.asin(level) - psi
    return phi % _TWO_PI


@_jit
def _exact_harmonics(amp, omega, bias, p, scan_step, acc):
    """Fourier integrals of the exact model's periodic steady-state torque, per period.

    Returns the number of input periods the response repeats over (1 normally).
    """
    k, c, alpha = p[STIFFNESS], p[DAMPING], p[HALF_GAP]
    tau_omega = c * omega / k
    radius = amp * math.sqrt(1.0 + tau_omega * tau_omega)
    acc[0] = 0.0
    acc[1] = 0.0
    acc[2] = 0.0
    if bias - radius >= alpha:  # y >= alpha throughout: permanent right contact
        _contact_integrals(0.0, _TWO_PI, amp, omega, bias, 1.0, p, acc)
        return 1.0
    if bias + radius <= -alpha:
        _contact_integrals(0.0, _TWO_PI, amp, omega, bias, -1.0, p, acc)
        return 1.0
    start_side = 1.0
    start = _release_phase(1.0, amp, bias, tau_omega, alpha)
    if math.isnan(start):
        start_side = -1.0
        start = _release_phase(-1.0, amp, bias, tau_omega, alpha)
        if math.isnan(start):  # |y| < alpha throughout: the gap never closes
            return 1.0
    # the shaft needs about 40 time constants to forget its twist; search that long
    horizon = _TWO_PI * (2.0 + math.ceil(40.0 * tau_omega / _TWO_PI))
    # The state right after a release is (theta_b = side alpha, fixed phase), so the
    # response repeats from one release of a side to the next release of that side.
    # Integrals are kept since the last release of each side: index 0 right, 1 left.
    since = np.zeros((2, 3))
    opened = np.zeros(2)
    released_at = np.zeros(2)
    index = 0 if start_side > 0.0 else 1
    opened[index] = 1.0
    released_at[index] = start
    phi = start
    theta = start_side * alpha
    for _ in range(4):  # with two sides a side repeats within three contacts
        contact, side = _next_contact(phi, theta, amp, bias, tau_omega, alpha, horizon, scan_step)
        if side == 0.0:  # the gap is not closed again: the steady state is free, T = 0
            return 1.0
        release = _release_phase(side, amp, bias, tau_omega, alpha)
        release += _TWO_PI * math.ceil((contact - release) / _TWO_PI)
        segment = np.zeros(3)
        _contact_integrals(contact, release, amp, omega, bias, side, p, segment)
        since += segment
        index = 0 if side > 0.0 else 1
        if opened[index] > 0.0:
            acc[:] = since[index]
            return float(round((release - released_at[index]) / _TWO_PI))
        opened[index] = 1.0
        released_at[index] = release
        since[index] = 0.0
        phi = release
        theta = side * alpha
    return 1.0


# --------------------------------------------------------------------------- switch-exact kernels
#
# The default harmonic balance of the static laws.  Along x = bias + A sin(phi) every boundary
# of a law except theta* is a sinusoid, b + R sin(phi + shift) = level, crossed in closed form
# (an arc of half-width h about phi = pi/2 - shift, _arc); every contact torque is affine in
# (1, sin phi, cos phi) and integrated in closed form (_arc_integrals, or the series forms of
# _y_arc_side where the arc is symmetric).  The theta* boundaries are located by Newton on
# eq. (19) written with one exponential (_contact_residual), inside brackets where the
# boundary is monotone (critical_points).  Right contact is integrated for the bias, left
# contact as the mirror image, right contact of -bias (odd symmetry, reading notes item 3).

_TAIL_W = -41.0  # ln u at K = 40, where theta* rounds to alpha (_laws.theta_star_kernel); u ~ 1.6e-18
_CRIT_FLOOR = 1.0233  # min over u of p(u; r = 0) = 1.023388 is a lower bound of p: no critical points below


@_jit
def _u_minus_sin(u):
    """u - sin u without cancellation (Taylor series below 1)."""
    if u < 1.0:
        q = u * u
        return u * q / 6.0 * (1.0 - q / 20.0 * (1.0 - q / 42.0 * (1.0 - q / 72.0 * (1.0 - q / 110.0 * (
            1.0 - q / 156.0 * (1.0 - q / 210.0 * (1.0 - q / 272.0 * (1.0 - q / 342.0))))))))
    return u - math.sin(u)


@_jit
def _one_minus_cos(h):
    """1 - cos h without cancellation (Taylor series below 1)."""
    if h < 1.0:
        q = h * h
        return 0.5 * q * (1.0 - q / 12.0 * (1.0 - q / 30.0 * (1.0 - q / 56.0 * (1.0 - q / 90.0 * (
            1.0 - q / 132.0 * (1.0 - q / 182.0 * (1.0 - q / 240.0 * (1.0 - q / 306.0))))))))
    return 1.0 - math.cos(h)


@_jit
def _sin_minus_h_cos(h):
    """sin h - h cos h without cancellation (Taylor series below 1)."""
    if h < 1.0:
        q = h * h
        return h * q / 3.0 * (1.0 - q / 10.0 * (1.0 - q / 28.0 * (1.0 - q / 54.0 * (1.0 - q / 88.0 * (
            1.0 - q / 130.0 * (1.0 - q / 180.0 * (1.0 - q / 238.0 * (1.0 - q / 304.0 * (1.0 - q / 378.0)))))))))
    return math.sin(h) - h * math.cos(h)


@_jit
def _arc(offset, radius, level):
    """Half-width h of the arc where offset + radius sin(theta) > level, centred at theta = pi/2,
    with cos h = (level - offset) / radius and sin h; h = -1 if the arc is empty, pi if it is
    the whole circle (then sin h = 0 and cos h <= -1).

    Computed from the excess 1 - cos h = (radius + offset - level) / radius, which keeps full
    precision as the arc shrinks (A -> alpha)."""
    excess = (radius + offset - level) / radius
    if excess <= 0.0:
        return -1.0, 1.0, 0.0
    if excess >= 2.0:
        return math.pi, 1.0 - excess, 0.0
    half = math.sqrt(0.5 * excess)  # sin(h / 2)
    return 2.0 * math.asin(half), 1.0 - excess, 2.0 * half * math.sqrt(1.0 - half * half)


@_jit
def _inside(phi, centre, half):
    """Whether phase phi lies inside the arc centre +- half (see _arc for half = -1 or pi)."""
    if half >= math.pi:
        return True
    if half < 0.0:
        return False
    offset = phi - centre
    return abs(offset - _TWO_PI * math.floor(offset / _TWO_PI + 0.5)) < half


@_jit
def _shifted(sin_t, cos_t, sin_s, cos_s):
    """sin and cos of t - s from those of t and s."""
    return sin_t * cos_s - cos_t * sin_s, cos_t * cos_s + sin_t * sin_s


@_jit
def _rate_geometry(rate):
    """cos psi, sin psi and psi = atan(rate): y = x + (c/k) v = bias + R sin(phi + psi), R = A sqrt(1 + rate^2)."""
    cos_psi = 1.0 / math.sqrt(1.0 + rate * rate)
    return cos_psi, rate * cos_psi, math.atan(rate)


@_jit
def _affine(p0, p1, p2, a, sa, ca, e, se, ce):
    """int T sin, int T cos, int T over [a, e] of T = p0 + p1 sin phi + p2 cos phi, from the
    phases and their sines and cosines."""
    span = e - a
    d_cos = ca - ce
    d_sin = se - sa
    sin_sq = 0.5 * (se * se - sa * sa)
    sin_cos = 0.5 * (se * ce - sa * ca)
    return (p0 * d_cos + p1 * (0.5 * span - sin_cos) + p2 * sin_sq,
            p0 * d_sin + p1 * sin_sq + p2 * (0.5 * span + sin_cos),
            p0 * span + p1 * d_cos + p2 * d_sin)


@_jit
def _centred(t_m, u_m, du_m, sin_m, cos_m, d):
    """int T sin, int T cos, int T over m +- d of T(m + t) = t_m - u_m (1 - cos t) + du_m sin t,
    in the cancellation-free forms d - sin d, 2 d - sin 2 d, 1 - cos d."""
    sin_d = math.sin(d)
    int_cos = 2.0 * t_m * sin_d - u_m * (sin_d * _one_minus_cos(d) - _u_minus_sin(d))  # int T cos t dt
    int_sin = 0.5 * du_m * _u_minus_sin(2.0 * d)  # int T sin t dt
    return (sin_m * int_cos + cos_m * int_sin, cos_m * int_cos - sin_m * int_sin,
            2.0 * d * t_m - 2.0 * u_m * _u_minus_sin(d))


@_jit
def _arc_integrals(scale, centre, sin_c, cos_c, h, cos_h, a, sa, ca, e, se, ce):
    """int T sin, int T cos, int T over [a, e] inside the arc centre +- h (see _arc) of
    T = scale (cos(phi - centre) - cos h): k (y - alpha) on the arc y > alpha, 2 k (x - alpha)
    on x > alpha.

    On pieces shorter than 1 rad about their middle m, with T(m) in the product form
    2 scale sin((h + theta) / 2) sin((h - theta) / 2), theta = m - centre: T is small where the
    piece is short next to the gap, and the ends' values would cancel.
    """
    if e - a >= 1.0:
        return _affine(-scale * cos_h, scale * sin_c, scale * cos_c, a, sa, ca, e, se, ce)
    d = 0.5 * (e - a)
    m = a + d
    sin_m, cos_m = math.sin(m), math.cos(m)
    sin_t, cos_t = _shifted(sin_m, cos_m, sin_c, cos_c)
    if h < math.pi:
        theta = m - centre
        theta -= _TWO_PI * math.floor(theta / _TWO_PI + 0.5)
        t_m = 2.0 * scale * math.sin(0.5 * (h + theta)) * math.sin(0.5 * (h - theta))
    else:
        t_m = scale * (cos_t - cos_h)
    return _centred(t_m, scale * cos_t, -scale * sin_t, sin_m, cos_m, d)


@_jit
def _dead_zone_side(damped, amp, omega, bias, k, c, alpha):
    """Right-contact integrals of (24) or (26): contact on the arc x > alpha, T = k (x - alpha) (+ c v)."""
    h, _, _ = _arc(bias, amp, alpha)
    if h < 0.0:
        return 0.0, 0.0, 0.0
    rate_term = c * amp * omega if damped else 0.0
    if h >= math.pi:
        return math.pi * k * amp, math.pi * rate_term, _TWO_PI * k * (bias - alpha)
    # phi = pi/2 + t, |t| < h: x - alpha = A (cos t - cos h), v = -A w sin t
    lens = 0.5 * _u_minus_sin(2.0 * h)
    return k * amp * lens, rate_term * lens, 2.0 * k * amp * _sin_minus_h_cos(h)


@_jit
def _y_arc_side(amp, omega, bias, k, c, alpha, radius, h):
    """Right-contact integrals of T = k (y - alpha) over the whole arc y > alpha of half-width h, as (27)."""
    if h >= math.pi:
        return math.pi * k * amp, math.pi * c * amp * omega, _TWO_PI * k * (bias - alpha)
    # theta = phi + psi = pi/2 + t: y - alpha = R (cos t - cos h); R cos psi = A, R sin psi = A c w / k
    lens = 0.5 * _u_minus_sin(2.0 * h)
    return k * amp * lens, c * amp * omega * lens, 2.0 * k * radius * _sin_minus_h_cos(h)


@_jit
def _revised_side(amp, omega, bias, k, c, alpha):
    """Right-contact integrals of (27): T = k (y - alpha) wherever y = x + (c/k) v > alpha."""
    rate = c * omega / k
    radius = amp * math.sqrt(1.0 + rate * rate)
    h, _, _ = _arc(bias, radius, alpha)
    if h < 0.0:
        return 0.0, 0.0, 0.0
    return _y_arc_side(amp, omega, bias, k, c, alpha, radius, h)


@_jit
def _add_event(events, n, phi, sin_phi, cos_phi, start, end):
    """Append (phi, sin, cos), phi moved by whole periods into [start, start + 2 pi), if start < phi < end."""
    phi += _TWO_PI * math.floor((start - phi) / _TWO_PI + 1.0)
    if phi - _TWO_PI >= start:
        phi -= _TWO_PI
    if start < phi < end:
        events[n, 0], events[n, 1], events[n, 2] = phi, sin_phi, cos_phi
        return n + 1
    return n


@_borrowing
def _add_arc_ends(events, n, centre, sin_centre, cos_centre, h, cos_h, sin_h, start, end):
    """Append both ends centre -+ h of an arc (see _arc) that is neither empty nor the whole circle."""
    if h <= 0.0 or h >= math.pi:
        return n
    for side in (-1.0, 1.0):
        # the arc's own angle theta = phi + pi/2 - centre is pi/2 + side h at the end
        sin_phi, cos_phi = _shifted(cos_h, -side * sin_h, cos_centre, sin_centre)
        n = _add_event(events, n, centre + side * h, sin_phi, cos_phi, start, end)
    return n


@_jit
def _sort_events(events, n):
    """Sort the first n rows of events by phase (insertion sort: a handful of rows)."""
    for i in range(1, n):
        j = i
        while j > 0 and events[j - 1, 0] > events[j, 0]:
            for col in range(events.shape[1]):
                events[j - 1, col], events[j, col] = events[j, col], events[j - 1, col]
            j -= 1


@_jit
def _elasto_side(amp, omega, bias, k, c, alpha, events):
    """Right-contact integrals of the ElastoBacklash law: contact where x > alpha and y > alpha,
    T = 2 k (x - alpha) where z = x - (c/k) v < alpha (the damper clipped), else k (x - alpha) + c v."""
    hx, cos_hx, sin_hx = _arc(bias, amp, alpha)
    if hx < 0.0:
        return 0.0, 0.0, 0.0
    rate = c * omega / k
    cos_psi, sin_psi, psi = _rate_geometry(rate)
    radius = amp * math.sqrt(1.0 + rate * rate)
    hy, cos_hy, sin_hy = _arc(bias, radius, alpha)  # y and z: same R and level
    if hy < 0.0:
        return 0.0, 0.0, 0.0
    if hx >= math.pi:
        start, sin_start, cos_start, end, sin_end, cos_end = -_HALF_PI, -1.0, 0.0, 1.5 * math.pi, -1.0, 0.0
    else:
        start, sin_start, cos_start = _HALF_PI - hx, cos_hx, sin_hx
        end, sin_end, cos_end = _HALF_PI + hx, cos_hx, -sin_hx
    n = _add_arc_ends(events, np.int64(0), _HALF_PI - psi, cos_psi, sin_psi, hy, cos_hy, sin_hy, start, end)
    n = _add_arc_ends(events, n, _HALF_PI + psi, cos_psi, -sin_psi, hy, cos_hy, sin_hy, start, end)
    _sort_events(events, n)
    events[n, 0], events[n, 1], events[n, 2] = end, sin_end, cos_end
    total_sin = total_cos = total_one = 0.0
    a, sa, ca = start, sin_start, cos_start
    for i in range(n + 1):
        e, se, ce = events[i, 0], events[i, 1], events[i, 2]
        mid = 0.5 * (a + e)
        if _inside(mid, _HALF_PI - psi, hy):
            if _inside(mid, _HALF_PI + psi, hy):  # T = k (y - alpha)
                piece = _arc_integrals(k * radius, _HALF_PI - psi, cos_psi, sin_psi, hy, cos_hy, a, sa, ca, e, se, ce)
            else:  # T = 2 k (x - alpha)
                piece = _arc_integrals(2.0 * k * amp, _HALF_PI, 1.0, 0.0, hx, cos_hx, a, sa, ca, e, se, ce)
            total_sin += piece[0]
            total_cos += piece[1]
            total_one += piece[2]
        a, sa, ca = e, se, ce
    return total_sin, total_cos, total_one


# theta* along the sinusoid.  With s = S cos phi (S = A c w / k) on the rising half (v > 0),
# gamma(phi) = A sin phi - theta*(s) is x - theta* less the bias: its shape does not depend on
# the bias, so both sides and every level share it.  gamma rises on [-pi/2, 0] (x rises, s
# rises, theta* falls); on [0, pi/2] it rises, or rises, falls and rises again between two
# critical points phi1 < phi2 (a dip at high rate, where (23) read as a function would drop
# contact before the peak).  The contact curve is parametrised by w = ln u, u the contact
# fraction of theta* = alpha - s u, K = 2 alpha / s = u - 1 - ln u (reading notes, item 1).


@_jit
def _criticality(w, rate):
    """p(w) = ln(sqrt(1 + (r D)^2) / (K D)), dp/dw and D = -d theta*/ds = u (1 + K / (1 - u)), at u = e^w.

    gamma' = A cos phi - D S sin phi vanishes where cot phi = r D (r = c w / k); with
    s = 2 alpha / K = S cos phi this reads p(w) = ln(r S / (2 alpha)).
    """
    u = math.exp(w)
    om = -math.expm1(w) if w > -0.7 else 1.0 - u
    big_k = -om - w
    d = u + u * big_k / om
    rd2 = (rate * d) ** 2
    value = 0.5 * math.log((1.0 + rd2) / (big_k * d) ** 2)
    slope = om / big_k - u * big_k / (om * om * d * (1.0 + rd2))
    return value, slope, d


@_jit
def _upper_critical(level, rate):
    """(found, w) with p(w) = level on the branch u -> 1 of the convex p, by Newton from the right
    (monotone: the iterates stay right of the root), started where p ~ -2 ln(-w) + ln 2 +
    ln(1 + r^2) / 2 lies above level; not found when an iterate passes the minimum of p."""
    w = -0.5 * math.exp(0.5 * (math.log(2.0) + 0.5 * math.log1p(rate * rate) - level))
    while w < -1e-4 and _criticality(w, rate)[0] <= level:
        w *= 0.25
    for _ in range(100):
        value, slope, _ = _criticality(w, rate)
        if slope <= 0.0:
            return False, w
        step = (value - level) / slope
        w = max(w - step, _TAIL_W)
        if abs(step) <= 1e-13 * abs(w):
            break
    return True, w


@_jit
def _lower_critical(level, rate):
    """w with p(w) = level on the branch u -> 0 (p ~ -w - 2 ln(-w)), by Newton in w; at least _TAIL_W."""
    w = max(-(level + 2.0 * math.log(max(level, 1.0)) + 3.0), _TAIL_W)
    if _criticality(w, rate)[0] <= level:
        return w
    for _ in range(100):
        value, slope, _ = _criticality(w, rate)
        step = (value - level) / slope
        w -= step
        if abs(step) <= 1e-13 * abs(w):
            break
    return w


@_jit
def _critical_phase(w, rate, alpha, amp):
    """phi (cot phi = r D) and gamma there, at the critical point with contact fraction u = e^w."""
    _, _, d = _criticality(w, rate)
    u = math.exp(w)
    s = 2.0 * alpha / (u - 1.0 - w)
    return math.atan2(1.0, rate * d), amp / math.sqrt(1.0 + (rate * d) ** 2) - (alpha - s * u)


@_jit
def critical_points(amp, rate, alpha, crit, lower):
    """The critical points of gamma on (0, pi/2), computed once per point into crit:
    crit[0] = -1 not yet, 0 none, 1 phi1 and gamma1 in crit[1:3], 2 also phi2 and gamma2 in crit[3:5].

    p is convex in w and p >= _CRIT_FLOOR: two critical points (phi1 from the branch u -> 1)
    or none.  Returns whether they exist; phi2 is computed only if ``lower``.
    """
    if crit[0] < 0.0:
        crit[0] = 0.0
        scale = rate * rate * amp / (2.0 * alpha)
        if scale > math.exp(_CRIT_FLOOR):
            found, w = _upper_critical(math.log(scale), rate)
            if found:
                crit[0] = 1.0
                crit[1], crit[2] = _critical_phase(w, rate, alpha, amp)
    if lower and crit[0] == 1.0:
        crit[0] = 2.0
        crit[3], crit[4] = _critical_phase(_lower_critical(math.log(rate * rate * amp / (2.0 * alpha)), rate),
                                           rate, alpha, amp)
    return crit[0] > 0.0


@_jit
def _contact_residual(sin_phi, cos_phi, level, amp, slope_scale, alpha):
    """F = X - alpha + s exp(-(X + alpha) / s - 1) with X = A sin phi - level, s = S cos phi, and dF/dphi.

    (19) as f(X + alpha, s) - 2 alpha: f rises in its first argument where X + s >= alpha, so
    there F has the sign of gamma - level (no Lambert W)."""
    x = amp * sin_phi - level
    s = slope_scale * cos_phi
    if s <= 0.0:
        return x - alpha, amp * cos_phi
    ratio = (x + alpha) / s
    e = math.exp(-ratio - 1.0)
    return x - alpha + s * e, amp * cos_phi * (1.0 - e) - slope_scale * sin_phi * e * (1.0 + ratio)


@_jit
def _rotated(sin_phi, cos_phi, step):
    """sin and cos of phi - step by the Taylor series of the rotation; NaN if |step| >= 0.01."""
    if abs(step) >= 0.01:
        return math.nan, math.nan
    q = step * step
    sin_step = step * (1.0 - q / 6.0 * (1.0 - q / 20.0 * (1.0 - q / 42.0)))
    cos_step = 1.0 - q / 2.0 * (1.0 - q / 12.0 * (1.0 - q / 30.0))
    return sin_phi * cos_step - cos_phi * sin_step, cos_phi * cos_step + sin_phi * sin_step


@_jit
def _contact_root(level, lo, hi, rising, amp, slope_scale, alpha):
    """Phase, sin and cos of the only crossing of gamma = level in [lo, hi] (upward if rising).

    Newton on F (_contact_residual) from the end nearest x' = A sin phi = alpha + level (the
    root itself where theta* = alpha), kept in the bracket by bisection; converged when the
    Newton step is below 1e-9 rad (the next would be ~1e-18)."""
    phi = hi if rising else lo
    sin_phi, cos_phi = math.sin(phi), math.cos(phi)
    for _ in range(100):
        value, slope = _contact_residual(sin_phi, cos_phi, level, amp, slope_scale, alpha)
        if value == 0.0:
            break
        if (value < 0.0) == rising:
            lo = phi
        else:
            hi = phi
        step = value / slope if slope != 0.0 else math.inf
        if lo <= phi - step <= hi:
            sin_new, cos_new = _rotated(sin_phi, cos_phi, step)
            phi -= step
            if abs(step) <= 1e-9:
                return phi, sin_new, cos_new
        elif hi - lo <= 1e-15:
            break
        else:
            phi = 0.5 * (lo + hi)
            sin_new = math.nan
        if math.isnan(sin_new):
            sin_phi, cos_phi = math.sin(phi), math.cos(phi)
        else:
            sin_phi, cos_phi = sin_new, cos_new
    return phi, sin_phi, cos_phi


@_jit
def _top_above(level, amp, slope_scale, alpha):
    """Whether gamma(0) = -theta*(S) lies above level (valid where S >= alpha + level)."""
    return _contact_residual(0.0, 1.0, level, amp, slope_scale, alpha)[0] > 0.0


@_jit
def _first_contact(level, lo, hi, amp, rate, alpha, crit):
    """(found, phi, sin, cos): the first phase in [lo, hi] where gamma reaches level, given
    gamma < level at lo, y' = A sin phi + S cos phi >= alpha + level on [lo, hi] and
    hi <= the phase where x' = A sin phi reaches alpha + level (there gamma >= level)."""
    slope_scale = rate * amp
    rising = np.bool_(True)  # not a literal: one compile of _contact_root (_jit docs)
    sin_x = (alpha + level) / amp
    reaches = sin_x < 1.0 and hi >= math.asin(max(sin_x, -1.0))  # gamma(hi) >= level
    if lo < 0.0 < hi:
        if _top_above(level, amp, slope_scale, alpha):
            return (True,) + _contact_root(level, lo, 0.0, rising, amp, slope_scale, alpha)
        lo = 0.0
    elif hi <= 0.0 and not reaches:
        return False, 0.0, 0.0, 0.0
    if lo >= 0.0 and critical_points(amp, rate, alpha, crit, np.bool_(False)) and crit[1] <= hi:
        if lo < crit[1] and crit[2] >= level:  # the first rise of gamma crosses level
            return (True,) + _contact_root(level, lo, crit[1], rising, amp, slope_scale, alpha)
        lo = max(lo, crit[1])  # beyond phi1 gamma falls, then rises once through level if it reaches it
    if not reaches:
        return False, 0.0, 0.0, 0.0
    return (True,) + _contact_root(level, lo, hi, rising, amp, slope_scale, alpha)


@_jit
def _phase_plane_side(amp, omega, bias, p, crit):
    """Right-contact integrals of the phase plane law (23), contact held until release (Theorem 1).

    Contact holds on part of the arc where y = x + (c/k) v >= alpha: from the first phase
    where the law closes the gap (x >= theta*(v) while v > 0, or anywhere v <= 0) to the
    release where y falls through alpha.  T = k (y - alpha) there.
    """
    k, c, alpha = p[STIFFNESS], p[DAMPING], p[HALF_GAP]
    rate = c * omega / k
    cos_psi, sin_psi, psi = _rate_geometry(rate)
    radius = amp * math.sqrt(1.0 + rate * rate)
    h, cos_h, sin_h = _arc(bias, radius, alpha)
    if h < 0.0:
        return 0.0, 0.0, 0.0
    up = _HALF_PI - psi - h
    if h >= math.pi or up <= -_HALF_PI:  # y reaches alpha while v <= 0: contact on all the arc
        return _y_arc_side(amp, omega, bias, k, c, alpha, radius, h)
    down = _HALF_PI - psi + h
    sin_down, cos_down = _shifted(cos_h, -sin_h, sin_psi, cos_psi)  # theta = phi + psi = pi/2 + h
    sin_x = (alpha - bias) / amp
    hi = min(down, _HALF_PI, math.asin(sin_x) if sin_x < 1.0 else _HALF_PI)
    found, phi, sin_phi, cos_phi = _first_contact(-bias, up, hi, amp, rate, alpha, crit)
    if not found:
        if down <= _HALF_PI:
            return 0.0, 0.0, 0.0
        phi, sin_phi, cos_phi = _HALF_PI, 1.0, 0.0  # contact where v reaches 0 inside the arc
    return _arc_integrals(k * radius, _HALF_PI - psi, cos_psi, sin_psi, h, cos_h, max(phi, up), sin_phi, cos_phi,
                          down, sin_down, cos_down)


# The rubber law (28)-(40): the band torque needs theta*(v) at the quadrature nodes, computed
# from a table of the contact fraction (u - ln u = 1 + K) with quintic Hermite interpolation.
_FRACTION_MAX = 40.0  # K beyond which theta* = alpha to round-off (_laws.theta_star_kernel)
_FRACTION_NODES = 4096  # u itself interpolated, fine enough to keep its error relative (u ~ e^(-1-K))
_FRACTION_STEP = math.sqrt(_FRACTION_MAX) / _FRACTION_NODES


def _fraction_table():
    """u and its first two derivatives in t = sqrt(K) (times the step and its square) on a uniform
    grid of t.  y = ln u solves e^y - y - 1 = K by bisection (decreasing in y < 0) to the last bit;
    y' = -2 t / (1 - u), y'' = -2 / (1 - u) + 4 t^2 u / (1 - u)^3, at t = 0 -sqrt(2) and -2/3
    (1 - u = sqrt(2 K) - 2 K / 3 + ...); u' = u y', u'' = u (y'' + y'^2)."""
    t = np.arange(_FRACTION_NODES + 2) * _FRACTION_STEP
    big_k = t * t
    lo, hi = -big_k - 2.0, np.zeros_like(t)
    for _ in range(90):
        mid = 0.5 * (lo + hi)
        below = np.expm1(mid) - mid < big_k  # y above the root
        lo, hi = np.where(below, lo, mid), np.where(below, mid, hi)
    log_u = 0.5 * (lo + hi)
    u, om = np.exp(log_u), -np.expm1(log_u)
    slope = np.full_like(t, -math.sqrt(2.0))
    curvature = np.full_like(t, -2.0 / 3.0)
    slope[1:] = -2.0 * t[1:] / om[1:]
    curvature[1:] = -2.0 / om[1:] + 4.0 * big_k[1:] * u[1:] / om[1:] ** 3
    return np.stack([u, u * slope * _FRACTION_STEP, u * (curvature + slope**2) * _FRACTION_STEP**2], axis=1)


_FRACTION_TABLE = _fraction_table()


@_jit
def contact_fraction(big_k):
    """The contact fraction u in (0, 1] with u - ln u = 1 + K, 0 < K <= 40: quintic Hermite
    interpolation of u in sqrt(K); relative error below 1e-15 (1 + K), the ulp of ln u, as
    interpolating ln u would give at an exp per call (5.3e-16 (1 + K) at most against mpmath)."""
    t = math.sqrt(big_k) / _FRACTION_STEP
    i = min(int(t), _FRACTION_NODES - 1)
    z = t - i
    y0, d0, e0 = _FRACTION_TABLE[i, 0], _FRACTION_TABLE[i, 1], _FRACTION_TABLE[i, 2]
    y1, d1, e1 = _FRACTION_TABLE[i + 1, 0], _FRACTION_TABLE[i + 1, 1], _FRACTION_TABLE[i + 1, 2]
    rise = y1 - y0
    c3 = 10.0 * rise - 6.0 * d0 - 4.0 * d1 - 1.5 * e0 + 0.5 * e1
    c4 = -15.0 * rise + 8.0 * d0 + 7.0 * d1 + 1.5 * e0 - e1
    c5 = 6.0 * rise - 3.0 * d0 - 3.0 * d1 - 0.5 * e0 + 0.5 * e1
    return y0 + z * (d0 + z * (0.5 * e0 + z * (c3 + z * (c4 + z * c5))))


@_jit
def _band_torque(x, v, k, c, alpha, beta):
    """Right rubber-band torque (36) of _laws.right_torque, mode 1 (N m), theta* by contact_fraction."""
    s = c * v / k
    if v > 0.0:
        ts = alpha if 20.0 * s < alpha else alpha - s * contact_fraction(2.0 * alpha / s)
        w = x - ts + 0.5 * beta
        return (0.5 * k * w + k * (ts - alpha) + c * v) * w / beta
    lower = alpha - 0.5 * beta - 2.0 * s
    return 0.5 * k * (x - lower) ** 2 / (beta + 2.0 * s)


@_borrowing
def _add_piece(mode, a, sa, ca, e, se, ce, amp, omega, bias, p, contact, stack, acc):
    """Add the integrals of the right rubber torque in mode (0 free, 1 band, 2 contact, k (y - alpha)
    on the arc ``contact`` of _arc_integrals) over [a, e] to acc."""
    if mode == 0 or e <= a:
        return
    if mode == 2:
        piece = _arc_integrals(*contact, a, sa, ca, e, se, ce)
        acc[0] += piece[0]
        acc[1] += piece[1]
        acc[2] += piece[2]
    else:
        integrate_adaptive(_RUBBER_BAND, 1, a, e, amp, omega, bias, p, stack, acc)


@_borrowing
def _push_crossing(events, n, mode, level, lo, hi, rising, amp, slope_scale, alpha):
    """Append the crossing of gamma = level in [lo, hi] (see _contact_root) with the mode after it."""
    phi, sin_phi, cos_phi = _contact_root(level, lo, hi, rising, amp, slope_scale, alpha)
    events[n, 0], events[n, 1], events[n, 2], events[n, 3] = phi, sin_phi, cos_phi, mode
    return n + 1


@_borrowing
def _level_crossings(level, up_mode, down_mode, amp, rate, psi, radius, alpha, crit, events, n):
    """Append every crossing of gamma = level on the rising half (v > 0), with the mode after it
    (up_mode rising through level, down_mode falling)."""
    slope_scale = rate * amp
    rising, falling = np.bool_(True), np.bool_(False)  # not literals: one compile of _push_crossing (_jit docs)
    # every crossing lies where y' = A sin phi + S cos phi >= alpha + level (from its rise, lo)
    # and x' = A sin phi <= alpha + level (up to hi); gamma < level below y', >= level beyond x'
    h = _arc(0.0, radius, alpha + level)[0]
    if h < 0.0:
        return n
    lo = -_HALF_PI if h >= math.pi else max(_HALF_PI - psi - h, -_HALF_PI)
    sin_x = (alpha + level) / amp
    phi_x = _HALF_PI if sin_x >= 1.0 else math.asin(max(sin_x, -1.0))
    hi = phi_x if h >= math.pi else min(phi_x, _HALF_PI - psi + h)
    if lo >= hi:
        return n
    above_hi = sin_x < 1.0 and hi >= phi_x
    above = lo <= -_HALF_PI and -amp - alpha >= level  # gamma at lo; at -pi/2 (v = 0) gamma = -A - alpha
    if lo < 0.0:  # gamma rises on [lo, 0]
        above_end = _top_above(level, amp, slope_scale, alpha) if hi > 0.0 else above_hi
        if above_end and not above:
            n = _push_crossing(events, n, up_mode, level, lo, min(hi, 0.0), rising, amp, slope_scale, alpha)
        if hi <= 0.0:
            return n
        lo, above = 0.0, above_end
    if critical_points(amp, rate, alpha, crit, np.bool_(True)) and crit[1] < hi:
        phi1, phi2 = crit[1], crit[3]
        if lo < phi1:  # gamma rises to its maximum
            above1 = crit[2] >= level
            if above1 != above:
                n = _push_crossing(events, n, up_mode, level, lo, phi1, rising, amp, slope_scale, alpha)
            lo, above = phi1, above1
        if lo < phi2:  # gamma falls to its minimum, or to hi
            above2 = crit[4] >= level if phi2 < hi else above_hi
            if above2 != above:
                n = _push_crossing(events, n, down_mode, level, lo, min(phi2, hi), falling, amp, slope_scale, alpha)
            if phi2 >= hi:
                return n
            lo, above = phi2, above2
    if above_hi != above:  # gamma rises on [lo, hi]
        n = _push_crossing(events, n, up_mode, level, lo, hi, rising, amp, slope_scale, alpha)
    return n


@_borrowing
def _rubber_side(amp, omega, bias, p, crit, stack, acc, events):
    """Right-side integrals of the rubber law (28)-(40), accumulated in acc[0:3] and returned.

    v > 0: free below the band |x - theta*| < beta / 2, rubber band in it, steel contact above
    (all three set by gamma against -+ beta / 2 - bias).  v <= 0: contact where x >= alpha +
    beta / 2 and y >= alpha, else the band of (28) second line where x > alpha - beta / 2 - 2 c v / k.
    """
    k, c, alpha, beta = p[STIFFNESS], p[DAMPING], p[HALF_GAP], p[RUBBER_THICKNESS]
    acc[0] = acc[1] = acc[2] = 0.0
    rate = c * omega / k
    cos_psi, sin_psi, psi = _rate_geometry(rate)
    radius = amp * math.sqrt(1.0 + rate * rate)
    hy, cos_hy, sin_hy = _arc(bias, radius, alpha)
    contact = (k * radius, _HALF_PI - psi, cos_psi, sin_psi, hy, cos_hy)
    low, high = -0.5 * beta - bias, 0.5 * beta - bias
    n = _level_crossings(low, 1.0, 0.0, amp, rate, psi, radius, alpha, crit, events, np.int64(0))
    n = _level_crossings(high, 2.0, 1.0, amp, rate, psi, radius, alpha, crit, events, n)
    _sort_events(events, n)
    gamma = -amp - alpha
    mode = 2 if gamma >= high else (1 if gamma > low else 0)
    a, sa, ca = -_HALF_PI, -1.0, 0.0
    for i in range(n):
        e = max(events[i, 0], a)
        _add_piece(mode, a, sa, ca, e, events[i, 1], events[i, 2], amp, omega, bias, p, contact, stack, acc)
        a, sa, ca, mode = e, events[i, 1], events[i, 2], int(events[i, 3])
    _add_piece(mode, a, sa, ca, _HALF_PI, 1.0, 0.0, amp, omega, bias, p, contact, stack, acc)
    hx, cos_hx, sin_hx = _arc(bias, amp, alpha + 0.5 * beta)
    cos_psi2, sin_psi2, psi2 = _rate_geometry(2.0 * rate)  # x + 2 c v / k = bias + R2 sin(phi + psi2)
    hz, cos_hz, sin_hz = _arc(bias, amp * math.sqrt(1.0 + 4.0 * rate * rate), alpha - 0.5 * beta)
    start, end = _HALF_PI, 1.5 * math.pi
    n = _add_arc_ends(events, np.int64(0), _HALF_PI, 1.0, 0.0, hx, cos_hx, sin_hx, start, end)
    n = _add_arc_ends(events, n, _HALF_PI - psi, cos_psi, sin_psi, hy, cos_hy, sin_hy, start, end)
    n = _add_arc_ends(events, n, _HALF_PI - psi2, cos_psi2, sin_psi2, hz, cos_hz, sin_hz, start, end)
    _sort_events(events, n)
    events[n, 0], events[n, 1], events[n, 2] = end, -1.0, 0.0
    a, sa, ca = start, 1.0, 0.0
    for i in range(n + 1):
        e, se, ce = events[i, 0], events[i, 1], events[i, 2]
        mid = 0.5 * (a + e)
        if _inside(mid, _HALF_PI, hx):
            mode = 2 if _inside(mid, _HALF_PI - psi, hy) else 0
        else:
            mode = 1 if _inside(mid, _HALF_PI - psi2, hz) else 0
        _add_piece(mode, a, sa, ca, e, se, ce, amp, omega, bias, p, contact, stack, acc)
        a, sa, ca = e, se, ce
    return acc[0], acc[1], acc[2]


@_jit
def _both_sides(amp, right, left):
    """(N, mean torque) from the right-contact integrals and the mirrored left ones (right
    contact of -bias): b1 and a1 add, a0 subtracts."""
    scale = 1.0 / (math.pi * amp)
    return complex((right[0] + left[0]) * scale, (right[1] + left[1]) * scale), (right[2] - left[2]) / _TWO_PI


@_jit
def _closed_form_point(law, p, amp, omega, bias):
    """(N, mean torque) of (24), (26) or (27) at one point."""
    k, c, alpha = p[STIFFNESS], p[DAMPING], p[HALF_GAP]
    if law == REVISED_DEAD_ZONE:
        right = _revised_side(amp, omega, bias, k, c, alpha)
        return _both_sides(amp, right, _revised_side(amp, omega, -bias, k, c, alpha) if bias != 0.0 else right)
    damped = law == DAMPED_DEAD_ZONE
    right = _dead_zone_side(damped, amp, omega, bias, k, c, alpha)
    return _both_sides(amp, right, _dead_zone_side(damped, amp, omega, -bias, k, c, alpha) if bias != 0.0 else right)


@_jit
def _elasto_point(p, amp, omega, bias, events):
    """(N, mean torque) of the ElastoBacklash law at one point."""
    right = _elasto_side(amp, omega, bias, p[STIFFNESS], p[DAMPING], p[HALF_GAP], events)
    left = _elasto_side(amp, omega, -bias, p[STIFFNESS], p[DAMPING], p[HALF_GAP], events) if bias != 0.0 else right
    return _both_sides(amp, right, left)


@_jit
def _phase_plane_point(p, amp, omega, bias, crit):
    """(N, mean torque) of the phase plane law (23) at one point (both sides share crit)."""
    crit[0] = -1.0
    right = _phase_plane_side(amp, omega, bias, p, crit)
    return _both_sides(amp, right, _phase_plane_side(amp, omega, -bias, p, crit) if bias != 0.0 else right)


@_borrowing
def _rubber_point(p, amp, omega, bias, crit, stack, acc, events):
    """(N, mean torque) of the rubber law (40) at one point (both sides share crit)."""
    crit[0] = -1.0
    right = _rubber_side(amp, omega, bias, p, crit, stack, acc, events)
    left = _rubber_side(amp, omega, -bias, p, crit, stack, acc, events) if bias != 0.0 else right
    return _both_sides(amp, right, left)


# One driver per family of laws, on one thread and on numba's threads (prange, by chunks of
# _CHUNK points that share their work arrays): a call compiles only its family's kernels.
_CHUNK = 256


@_jit
def _closed_form_balance(law, p, amp, omega, bias, n_out, mean_out):
    for i in range(amp.shape[0]):
        n_out[i], mean_out[i] = _closed_form_point(law, p, amp[i], omega[i], bias[i])


@numba.njit(cache=True, nogil=True, parallel=True)
def _closed_form_balance_parallel(law, p, amp, omega, bias, n_out, mean_out):
    for i in numba.prange(amp.shape[0]):
        n_out[i], mean_out[i] = _closed_form_point(law, p, amp[i], omega[i], bias[i])


@_jit
def _elasto_chunk(p, amp, omega, bias, n_out, mean_out, start, stop):
    events = np.empty((8, 3))
    for i in range(start, stop):
        n_out[i], mean_out[i] = _elasto_point(p, amp[i], omega[i], bias[i], events)


@_jit
def _elasto_balance(p, amp, omega, bias, n_out, mean_out):
    _elasto_chunk(p, amp, omega, bias, n_out, mean_out, 0, amp.shape[0])


@numba.njit(cache=True, nogil=True, parallel=True)
def _elasto_balance_parallel(p, amp, omega, bias, n_out, mean_out):
    for chunk in numba.prange((amp.shape[0] + _CHUNK - 1) // _CHUNK):
        _elasto_chunk(p, amp, omega, bias, n_out, mean_out, chunk * _CHUNK, min((chunk + 1) * _CHUNK, amp.shape[0]))


@_jit
def _phase_plane_chunk(p, amp, omega, bias, n_out, mean_out, start, stop):
    crit = np.empty(5)
    for i in range(start, stop):
        n_out[i], mean_out[i] = _phase_plane_point(p, amp[i], omega[i], bias[i], crit)


@_jit
def _phase_plane_balance(p, amp, omega, bias, n_out, mean_out):
    _phase_plane_chunk(p, amp, omega, bias, n_out, mean_out, 0, amp.shape[0])


@numba.njit(cache=True, nogil=True, parallel=True)
def _phase_plane_balance_parallel(p, amp, omega, bias, n_out, mean_out):
    for chunk in numba.prange((amp.shape[0] + _CHUNK - 1) // _CHUNK):
        _phase_plane_chunk(p, amp, omega, bias, n_out, mean_out, chunk * _CHUNK,
                           min((chunk + 1) * _CHUNK, amp.shape[0]))


@_jit
def _rubber_chunk(p, amp, omega, bias, n_out, mean_out, start, stop):
    crit, stack, acc, events = np.empty(5), np.empty((2 * _MAX_LEVEL + 8, 3)), np.zeros(3), np.empty((16, 4))
    for i in range(start, stop):
        n_out[i], mean_out[i] = _rubber_point(p, amp[i], omega[i], bias[i], crit, stack, acc, events)


@_jit
def _rubber_balance(p, amp, omega, bias, n_out, mean_out):
    _rubber_chunk(p, amp, omega, bias, n_out, mean_out, 0, amp.shape[0])


@numba.njit(cache=True, nogil=True, parallel=True)
def _rubber_balance_parallel(p, amp, omega, bias, n_out, mean_out):
    for chunk in numba.prange((amp.shape[0] + _CHUNK - 1) // _CHUNK):
        _rubber_chunk(p, amp, omega, bias, n_out, mean_out, chunk * _CHUNK, min((chunk + 1) * _CHUNK, amp.shape[0]))


def switch_exact_kernel(model, parallel):
    """The driver of a static model's switch-exact harmonic balance, called as
    ``driver(params, amp, omega, bias, n_out, mean_out)``; (40) with beta = 0 is (23)."""
    law = model.law
    if law == PHASE_PLANE or (law == RUBBER and model.rubber_thickness == 0.0):
        return _phase_plane_balance_parallel if parallel else _phase_plane_balance
    if law == RUBBER:
        return _rubber_balance_parallel if parallel else _rubber_balance
    if law == ELASTO_BACKLASH:
        return _elasto_balance_parallel if parallel else _elasto_balance
    return functools.partial(_closed_form_balance_parallel if parallel else _closed_form_balance, law)


# --------------------------------------------------------------------------- grid kernel


@_jit
def harmonic_balance(law, p, amp, omega, bias, nodes, weights, samples, n_out, mean_out):
    """N and mean torque of a static law at each point by the sampled walk (the reference)."""
    acc = np.zeros(3)
    stack = np.empty((2 * _MAX_LEVEL + 8, 3))
    for i in range(amp.shape[0]):
        a = amp[i]
        periods = static_harmonics(law, a, omega[i], bias[i], p, nodes, weights, samples, stack, acc)
        scale = 1.0 / (math.pi * periods)
        n_out[i] = complex(acc[0] * scale / a, acc[1] * scale / a)
        mean_out[i] = 0.5 * acc[2] * scale


@_jit
def exact_balance(p, amp, omega, bias, scan_step, n_out, mean_out):
    """N and mean torque of the exact model (1) + (14) at each point; at c w = 0 it is the
    dead-zone (the shaft relaxes at once), in closed form."""
    acc = np.zeros(3)
    for i in range(amp.shape[0]):
        a, w, b = amp[i], omega[i], bias[i]
        if p[DAMPING] > 0.0 and w > 0.0:
            scale = 1.0 / (math.pi * _exact_harmonics(a, w, b, p, scan_step, acc))
            n_out[i] = complex(acc[0] * scale / a, acc[1] * scale / a)
            mean_out[i] = 0.5 * acc[2] * scale
        else:
            n_out[i], mean_out[i] = _closed_form_point(np.int64(DEAD_ZONE), p, a, w, b)
