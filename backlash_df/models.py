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

The scalar kernels are compiled with numba (in the package's private
``backlash_df._laws``) and shared by the vectorised ``torque`` methods, the time
simulation and the describing functions, so that there is exactly one
implementation of every law.
"""

import functools
import math

import numba
import numpy as np

from ._jit import jit as _jit
from ._laws import (DAMPED_DEAD_ZONE, DEAD_ZONE, EXACT, LAW_CODES, PHASE_PLANE, REVISED_DEAD_ZONE, RUBBER, SHAFT_KEYS,
                    exact_step, exact_torque, static_mode, static_torque, theta_star_kernel)
from .plotting import ResultPlot, axes_or_new

__all__ = ["MODEL_NAMES", "EQUATIONS", "BacklashModel", "StaticModel", "ExactModel", "make_model", "theta_star"]

#: Model names accepted by :func:`make_model`.
MODEL_NAMES = tuple(LAW_CODES)

#: The paper's equations of each law, by model name.
EQUATIONS = {
    "dead-zone": "(24)-(25)",
    "damped-dead-zone": "(26)",
    "revised-dead-zone": "(27)",
    "phase-plane": "(19)-(23)",
    "rubber": "(28)-(40)",
    "elasto-backlash": "Modelica ElastoBacklash",
    "exact": "(1), (14)",
}


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


_SIG = "(int64, float64, float64, float64, float64, float64, float64)"


@_lazy_ufunc("float64" + _SIG)
def _torque_ufunc(law, x, v, k, c, alpha, beta):
    return static_torque(law, x, v, k, c, alpha, beta)


@_lazy_ufunc("int64" + _SIG)
def _mode_ufunc(law, x, v, k, c, alpha, beta):
    return static_mode(law, x, v, k, c, alpha, beta)


# --------------------------------------------------------------------------- exact model


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
        return np.array([getattr(self, key) for key in SHAFT_KEYS])

    @property
    def plant_params(self):
        """The shaft parameters as keyword arguments of :func:`make_model`."""
        return {key: getattr(self, key) for key in SHAFT_KEYS}

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
    same compiled step (``backlash_df._laws.exact_step``).
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
    unknown = sorted(set(plant_params) - set(SHAFT_KEYS))
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
