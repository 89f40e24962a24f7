"""Torque laws of an elastic shaft with backlash (Nordin, Galic and Gutman, 1997).

Every law gives the shaft torque ``T`` (N m) from the displacement
``theta_d = theta_motor - theta_load`` (rad) and its rate ``dtheta_d`` (rad/s).
Equation numbers refer to the paper in ``shared/paper``.

=====================  ==========  ==================================================
name                   equations   what it assumes
=====================  ==========  ==================================================
``dead-zone``          (24)-(25)   pure spring, no damping: ``T = k D_alpha(x)``
``damped-dead-zone``   (26)        spring and damper switched on at ``|x| > alpha``
``revised-dead-zone``  (27)        ``T = k D_alpha(x + c v / k)``: exact release only
``phase-plane``        (19)-(23)   exact release, re-contact at ``theta*(v)``
``rubber``             (28)-(40)   phase plane law with a rubber band of width beta
``elasto-backlash``    Modelica    damping clipped so it never pulls, contact at alpha
``exact``              (1), (14)   limited integrator for theta_b: a dynamic element
=====================  ==========  ==================================================

The static laws are built from one right-contact function per law and the odd
symmetry ``T(-x, -v) = -T(x, v)`` (reading notes, item 3): the left side is the
mirror image of the right side.  Each law is split into *modes* (0 free, 1 rubber
band, 2 steel contact; negative on the left) inside which the torque is smooth;
the simulation integrates with the mode frozen and locates the switches.

The scalar kernels are compiled with numba and shared by the vectorised
``torque`` methods, the time simulation and the describing functions, so that
there is exactly one implementation of every law.
"""

import functools
import math

import numba
import numpy as np

from .plotting import ResultPlot, axes_or_new

__all__ = [
    "MODEL_NAMES",
    "BacklashModel",
    "StaticModel",
    "ExactModel",
    "make_model",
    "theta_star",
    # law codes and the compiled scalar kernels the describing functions, the
    # simulation, the orbits and the identification share
    "LAW_CODES",
    "EQUATIONS",
    "DEAD_ZONE",
    "DAMPED_DEAD_ZONE",
    "REVISED_DEAD_ZONE",
    "PHASE_PLANE",
    "RUBBER",
    "ELASTO_BACKLASH",
    "EXACT",
    "theta_star_kernel",
    "right_mode",
    "right_torque",
    "static_mode",
    "held_mode",
    "theta_star_partials",
    "mode_torque",
    "static_torque",
    "exact_torque",
    "exact_step",
]

DEAD_ZONE, DAMPED_DEAD_ZONE, REVISED_DEAD_ZONE, PHASE_PLANE, RUBBER, ELASTO_BACKLASH, EXACT = range(7)

#: Model names accepted by :func:`make_model`, with their law codes.
LAW_CODES = {
    "dead-zone": DEAD_ZONE,
    "damped-dead-zone": DAMPED_DEAD_ZONE,
    "revised-dead-zone": REVISED_DEAD_ZONE,
    "phase-plane": PHASE_PLANE,
    "rubber": RUBBER,
    "elasto-backlash": ELASTO_BACKLASH,
    "exact": EXACT,
}
MODEL_NAMES = tuple(LAW_CODES)

EQUATIONS = {
    "dead-zone": "(24)-(25)",
    "damped-dead-zone": "(26)",
    "revised-dead-zone": "(27)",
    "phase-plane": "(19)-(23)",
    "rubber": "(28)-(40)",
    "elasto-backlash": "Modelica ElastoBacklash",
    "exact": "(1), (14)",
}

_jit = numba.njit(cache=True, nogil=True)


def _lazy_ufunc(signature):
    """``numba.vectorize([signature], cache=True)``, built at the first call instead of at import."""

    def decorate(kernel):
        build = functools.cache(lambda: numba.vectorize([signature], cache=True)(kernel))

        @functools.wraps(kernel)
        def call(*args):
            return build()(*args)

        return call

    return decorate


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


@_lazy_ufunc("float64(float64, float64, float64, float64)")
def _theta_star_ufunc(v, k, c, alpha):
    return theta_star_kernel(v, k, c, alpha)


def theta_star(dtheta_d, stiffness, damping, half_gap):
    """Displacement theta*(v) at which the phase plane law closes the gap, eq. (19).

    Closed form (reading notes, item 1): with ``K = 2 alpha k / (c v)``,
    ``theta* = alpha + (c v / k) W0(-exp(-1 - K))``, evaluated without
    cancellation near the branch point.  Lies in ``[alpha - c v / k, alpha]``.

    Parameters
    ----------
    dtheta_d : array_like
        Rate of the displacement, rad/s.  For ``v <= 0`` the result is ``alpha``.
    stiffness, damping, half_gap : float
        k (N m/rad), c (N m s/rad), alpha (rad).

    Returns
    -------
    ndarray
        theta* in rad, broadcast to the shape of ``dtheta_d``.

    Examples
    --------
    >>> float(theta_star(0.0, 5895.0, 3.0, 0.05))
    0.05
    """
    return _theta_star_ufunc(np.asarray(dtheta_d, dtype=float), stiffness, damping, half_gap)


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


_SIG = "(int64, float64, float64, float64, float64, float64, float64)"


@_lazy_ufunc("float64" + _SIG)
def _torque_ufunc(law, x, v, k, c, alpha, beta):
    return static_torque(law, x, v, k, c, alpha, beta)


@_lazy_ufunc("int64" + _SIG)
def _mode_ufunc(law, x, v, k, c, alpha, beta):
    return static_mode(law, x, v, k, c, alpha, beta)


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


@_jit
def _exact_trajectory(x, v, dt, theta_b0, k, c, alpha, theta_out, torque_out):
    theta = theta_b0
    theta_out[0] = theta
    torque_out[0] = exact_torque(x[0], v[0], theta, k, c, alpha)
    for i in range(1, x.shape[0]):
        theta = exact_step(theta, x[i - 1], v[i - 1], x[i], v[i], dt, k, c, alpha)
        theta_out[i] = theta
        torque_out[i] = exact_torque(x[i], v[i], theta, k, c, alpha)


# --------------------------------------------------------------------------- public classes


def _check_positive(name, value, allow_zero=False):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value < 0.0 or (value == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be {bound}, got {value!r}")
    return value


class BacklashModel:
    """An elastic shaft with backlash: parameters and law shared by all models.

    Parameters
    ----------
    stiffness : float
        k, N m/rad, > 0.
    damping : float, optional
        c, N m s/rad, >= 0 (shaft internal damping).
    half_gap : float
        alpha, rad, > 0: HALF the total play.
    rubber_thickness : float, optional
        beta, rad, in [0, 2 alpha]; used by the ``rubber`` law only.
    """

    name = None
    is_static = True

    def __init__(self, *, stiffness, half_gap, damping=0.0, rubber_thickness=0.0):
        self.stiffness = _check_positive("stiffness", stiffness)
        self.damping = _check_positive("damping", damping, allow_zero=True)
        self.half_gap = _check_positive("half_gap", half_gap)
        self.rubber_thickness = _check_positive("rubber_thickness", rubber_thickness, allow_zero=True)
        if self.rubber_thickness > 2.0 * self.half_gap:
            raise ValueError(
                f"rubber_thickness must be <= 2 * half_gap = {2.0 * self.half_gap!r}, "
                f"got {self.rubber_thickness!r}"
            )

    @property
    def law(self):
        """Integer law code used by the compiled kernels."""
        return LAW_CODES[self.name]

    @property
    def mode_law(self):
        """The law code whose modes the model follows: :attr:`law`, except that the rubber law without
        rubber is the phase plane law (40), and that without damping the damped laws and the exact
        model are the dead zone (24) (Remark 2 for the exact model)."""
        law = self.law
        if law == RUBBER and self.rubber_thickness == 0.0:
            law = PHASE_PLANE
        if self.damping == 0.0 and law in (DAMPED_DEAD_ZONE, REVISED_DEAD_ZONE, PHASE_PLANE, EXACT):
            law = DEAD_ZONE
        return law

    @property
    def params(self):
        """``(k, c, alpha, beta)`` as a float64 array, the kernels' parameter vector."""
        return np.array([self.stiffness, self.damping, self.half_gap, self.rubber_thickness])

    @property
    def plant_params(self):
        """The shaft parameters as keyword arguments of :func:`make_model`."""
        return dict(
            stiffness=self.stiffness,
            damping=self.damping,
            half_gap=self.half_gap,
            rubber_thickness=self.rubber_thickness,
        )

    def __repr__(self):
        params = ", ".join(f"{key}={value!r}" for key, value in self.plant_params.items())
        return f"make_model({self.name!r}, {params})"

    def plot(self, ax=None, extent=3.0, n=241):
        """The law over the phase plane: T(theta_d, dtheta_d) as a colour map (as Figure 2 (b)-(d)).

        The black line encloses the set where the law transmits no torque.  The
        exact model is drawn in contact (theta_b = +-alpha), where its torque (1)
        is a function of the state; which side is in contact is its memory (14).

        Parameters
        ----------
        ax : matplotlib Axes, optional
        extent : float
            theta_d spans +-extent alpha (rad); dtheta_d spans +-extent k alpha / c
            (rad/s), where the boundaries k theta_d + c dtheta_d = +-k alpha cross
            the axis (+-extent alpha per second if c = 0).
        n : int
            Grid points per axis.

        Returns
        -------
        ResultPlot
            One panel (titled with the law, its equation and the shaft on a second
            line); the colour bar beside it.
        """
        from matplotlib.colors import TwoSlopeNorm

        figure, axes = axes_or_new(ax, figsize=(6.5, 4.5), layout="constrained")
        ax = axes[0]
        x_max = extent * self.half_gap
        v_max = extent * self.half_gap * (self.stiffness / self.damping if self.damping > 0.0 else 1.0)
        x, v = np.meshgrid(np.linspace(-x_max, x_max, n), np.linspace(-v_max, v_max, n))
        torque = self._map(x, v)
        limit = max(float(np.abs(torque).max()), np.finfo(float).tiny)
        mesh = ax.pcolormesh(x, v, torque, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -limit, limit), shading="auto")
        ax.contour(x, v, (torque != 0.0).astype(float), levels=[0.5], colors="k", linewidths=0.8)
        ax.figure.colorbar(mesh, ax=ax, label="shaft torque T (N m)")
        ax.set_xlabel("theta_d (rad)")
        ax.set_ylabel("dtheta_d/dt (rad/s)")
        beta = f", beta = {self.rubber_thickness:.4g} rad" if self.name == "rubber" else ""
        ax.set_title(f"{self.name} {EQUATIONS[self.name]}\nk = {self.stiffness:.4g} N m/rad, "
                     f"c = {self.damping:.4g} N m s/rad, alpha = {self.half_gap:.4g} rad{beta}", fontsize="medium")
        return ResultPlot(figure, axes)

    def __eq__(self, other):
        return type(self) is type(other) and self.plant_params == other.plant_params

    def __hash__(self):
        return hash((self.name, tuple(self.plant_params.values())))


class StaticModel(BacklashModel):
    """A torque law ``T(theta_d, dtheta_d)`` without state (all laws but ``exact``)."""

    def __init__(self, name, **plant_params):
        self.name = name
        super().__init__(**plant_params)

    def torque(self, theta_d, dtheta_d):
        """Shaft torque (N m) at displacement ``theta_d`` (rad) and rate ``dtheta_d`` (rad/s).

        Broadcasts its arguments like a numpy ufunc.

        Examples
        --------
        >>> model = make_model("phase-plane", stiffness=5895.0, damping=3.0, half_gap=0.05)
        >>> float(model.torque(0.06, 0.0))  # k (x - alpha)
        58.95...
        """
        k, c, alpha, beta = self.params
        return _torque_ufunc(self.law, _as_float(theta_d, "theta_d"), _as_float(dtheta_d, "dtheta_d"), k, c, alpha, beta)

    def mode(self, theta_d, dtheta_d):
        """Contact mode: 0 free, +-1 rubber band, +-2 steel contact (sign = side)."""
        k, c, alpha, beta = self.params
        return _mode_ufunc(self.law, _as_float(theta_d, "theta_d"), _as_float(dtheta_d, "dtheta_d"), k, c, alpha, beta)

    def __call__(self, theta_d, dtheta_d):
        return self.torque(theta_d, dtheta_d)

    def _map(self, theta_d, dtheta_d):
        """The torque drawn by :meth:`plot`."""
        return self.torque(theta_d, dtheta_d)


class ExactModel(BacklashModel):
    """The exact model: torque (1) with the limited integrator (14) for theta_b.

    Not a function of ``(theta_d, dtheta_d)``: the backlash angle ``theta_b`` (rad,
    ``|theta_b| <= alpha``) is a state.  ``torque_along`` integrates it along a
    sampled trajectory; the simulation and the describing functions use the
    same compiled step :func:`exact_step`.
    """

    name = "exact"
    is_static = False

    def torque(self, theta_d, dtheta_d, theta_b):
        """Torque (N m) from displacement, rate and the state theta_b (rad)."""
        k, c, alpha, _ = self.params
        x = _as_float(theta_d, "theta_d")
        v = _as_float(dtheta_d, "dtheta_d")
        tb = _as_float(theta_b, "theta_b")
        return np.vectorize(lambda a, b, s: exact_torque(a, b, s, k, c, alpha), otypes=[float])(x, v, tb)

    def _map(self, theta_d, dtheta_d):
        """Torque (1) in contact, drawn by :meth:`plot`: k theta_d + c dtheta_d -+ k alpha outside
        the release set (5), zero inside it."""
        k, c, alpha, _ = self.params
        y = k * theta_d + c * dtheta_d
        return np.where(y >= k * alpha, y - k * alpha, np.where(y <= -k * alpha, y + k * alpha, 0.0))

    def torque_along(self, time, theta_d, dtheta_d, theta_b0=0.0):
        """Integrate (14) along a uniformly sampled trajectory.

        Parameters
        ----------
        time : array_like
            Uniform sample times, s.
        theta_d, dtheta_d : array_like
            Displacement (rad) and its rate (rad/s) at those times.
        theta_b0 : float
            Backlash angle at ``time[0]``, rad, in ``[-alpha, alpha]``.

        Returns
        -------
        torque, theta_b : ndarray
            Shaft torque (N m) and backlash angle (rad) at each sample.
        """
        time = _as_float(time, "time")
        x = np.ascontiguousarray(np.broadcast_to(_as_float(theta_d, "theta_d"), time.shape))
        v = np.ascontiguousarray(np.broadcast_to(_as_float(dtheta_d, "dtheta_d"), time.shape))
        if time.ndim != 1 or time.size < 2:
            raise ValueError("time must be a 1-D array of at least 2 samples")
        steps = np.diff(time)
        dt = steps[0]
        if not dt > 0 or not np.allclose(steps, dt, rtol=1e-9, atol=0.0):
            raise ValueError("time must be uniformly sampled and increasing")
        if abs(theta_b0) > self.half_gap:
            raise ValueError(f"theta_b0 must lie in [-half_gap, half_gap], got {theta_b0!r}")
        theta_b = np.empty_like(x)
        torque = np.empty_like(x)
        k, c, alpha, _ = self.params
        _exact_trajectory(x, v, dt, float(theta_b0), k, c, alpha, theta_b, torque)
        return torque, theta_b


def _as_float(values, name):
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite")
    return array


_SHAFT_KEYS = ("stiffness", "damping", "half_gap", "rubber_thickness")


def make_model(name, **plant_params):
    """Build a backlash torque law by name.

    Parameters
    ----------
    name : str
        One of :data:`MODEL_NAMES`: ``dead-zone``, ``damped-dead-zone``,
        ``revised-dead-zone``, ``phase-plane``, ``rubber``, ``elasto-backlash``,
        ``exact``.
    **plant_params
        Shaft parameters with the rig file's names: ``stiffness`` (k, N m/rad),
        ``damping`` (c, N m s/rad, default 0), ``half_gap`` (alpha, rad),
        ``rubber_thickness`` (beta, rad, default 0).

    Returns
    -------
    StaticModel or ExactModel

    Raises
    ------
    ValueError
        Unknown model name, a parameter negative, non-finite or out of range, or
        ``rubber`` without a ``rubber_thickness`` (with beta = 0 the rubber law (40)
        is the phase plane law (23), and a result labelled ``rubber`` would silently
        be that one; the rig loader refuses it likewise).
    TypeError
        A keyword that is not a shaft parameter.

    Examples
    --------
    >>> model = make_model("dead-zone", stiffness=100.0, half_gap=0.1)
    >>> model.torque([0.0, 0.3], 0.0).tolist()
    [0.0, 20.0...]
    """
    if name not in LAW_CODES:
        raise ValueError(f"unknown model {name!r}; choose one of: {', '.join(MODEL_NAMES)}")
    unknown = sorted(set(plant_params) - set(_SHAFT_KEYS))
    if unknown:
        raise TypeError(f"unknown shaft parameter(s): {', '.join(unknown)}")
    missing = [key for key in ("stiffness", "half_gap") if key not in plant_params]
    if missing:
        raise ValueError(f"missing shaft parameter(s): {', '.join(missing)}")
    if name == "rubber" and plant_params.get("rubber_thickness", 0.0) == 0.0:
        raise ValueError("model 'rubber' needs rubber_thickness > 0 (beta, rad); with beta = 0 the rubber law (40) "
                         "is the phase plane law (23): set beta or choose 'phase-plane'")
    if name == "exact":
        return ExactModel(**plant_params)
    return StaticModel(name, **plant_params)
