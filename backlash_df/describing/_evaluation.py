"""N and the mean torque N0 at arrays of points: checks of the arguments, the closed forms
(24), (26), (27) and the dispatch to the compiled kernels (:mod:`._kernels`).

Private to the package; :func:`evaluate` is the one door of the public functions of
:mod:`backlash_df.describing` and of the tests' references (``samples``, ``gauss_order``,
``scan_step``).
"""

import math
from typing import NamedTuple

import numpy as np

from .._laws import DAMPED_DEAD_ZONE, DEAD_ZONE, EXACT, REVISED_DEAD_ZONE
from ..models import BacklashModel
from ._kernels import (
    SAMPLES,
    SCAN_STEP,
    exact_balance,
    harmonic_balance,
    switch_exact_kernel,
)


class Balance(NamedTuple):
    """What the harmonic balance gives at each point: N (N m/rad, complex) and the mean torque N0 (N m)."""

    n: np.ndarray
    mean: np.ndarray


def _tustin(excess):
    """Dead-zone DF over k, F = 1 - (2/pi)(asin r + r sqrt(1 - r^2)), r = alpha / A.

    Evaluated from ``excess = (A - alpha) / A`` as ``F = (u - sin u) / pi`` with
    ``u = 4 asin(sqrt(excess / 2))``, and a series for small u, so that F keeps
    full relative precision as A -> alpha (the printed form cancels).
    """
    d = np.clip(excess, 0.0, 1.0)
    u = 4.0 * np.arcsin(np.sqrt(0.5 * d))
    u2 = u * u
    series = u * u2 / 6.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0 * (1.0 - u2 / 72.0 * (1.0 - u2 / 110.0))))
    return np.where(u < 0.1, series, u - np.sin(u)) / np.pi


def _closed_form(model, amplitude, omega):
    """N of (24), (26), (27) without bias, or None for laws that have no closed form here."""
    k, c, alpha = model.stiffness, model.damping, model.half_gap
    if model.law == DEAD_ZONE:
        return k * _tustin((amplitude - alpha) / amplitude) + 0j * omega
    if model.law == DAMPED_DEAD_ZONE:
        return (k + 1j * c * omega) * _tustin((amplitude - alpha) / amplitude)
    if model.law == REVISED_DEAD_ZONE:
        radius = amplitude * np.sqrt(1.0 + (c * omega / k) ** 2)
        return (k + 1j * c * omega) * _tustin((radius - alpha) / radius)
    return None


# --------------------------------------------------------------------------- public API


#: Relative size (of |N| A) below which the mean torque at zero bias is round-off.
_MEAN_ROUND_OFF = 1e-10


def validated(name, values, positive=False):
    """``values`` as a float array; a one-line ``ValueError`` naming ``name`` unless finite (and > 0 if
    ``positive``; ``omega`` >= 0)."""
    array = np.asarray(values, dtype=float)
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    if positive and (array <= 0.0).any():
        raise ValueError(f"{name} must be > 0")
    if not positive and name == "omega" and (array < 0.0).any():
        raise ValueError("omega must be >= 0")
    return array


def as_model(model):
    if isinstance(model, BacklashModel):
        return model
    raise ValueError(f"model must be a model from make_model(), got {model!r}")


#: Largest |bias| / A: beyond it A sin(w t) drowns in the round-off of bias + A sin(w t)
#: (relative error ~1e-16 |bias| / A in N).
_MAX_BIAS_RATIO = 1e8


def check_scales(model, a, w, b):
    """Refuse arguments whose harmonic balance floating point cannot carry (one-line ``ValueError``)."""
    if a.size == 0:
        return
    magnitude = np.abs(b)
    ratio = magnitude / a
    if (ratio > _MAX_BIAS_RATIO).any():
        i = np.unravel_index(np.argmax(ratio), ratio.shape)
        raise ValueError(f"bias = {b[i]:g} rad is more than {_MAX_BIAS_RATIO:g} times the amplitude {a[i]:g} rad: "
                         f"A sin(w t) is lost in the round-off of bias + A sin(w t)")
    # a bound on every point's torque scale in Python floats (inf, no warning, on overflow)
    if math.isfinite((model.stiffness + model.damping * float(w.max())) * (float(a.max()) + float(magnitude.max()))):
        return
    with np.errstate(over="ignore"):
        scale = (model.stiffness + model.damping * w) * (a + np.abs(b))
    if not np.all(np.isfinite(scale)):
        i = np.unravel_index(np.argmax(~np.isfinite(scale)), scale.shape)
        raise ValueError(f"amplitude = {a[i]:g} rad at omega = {w[i]:g} rad/s: the torque (k + c w)(A + |bias|) "
                         f"overflows floating point")


def evaluate(model, amplitude, omega, bias, method, samples=None, gauss_order=None, scan_step=SCAN_STEP,
              parallel=False):
    """N and mean torque, a :class:`Balance`.

    The harmonic balance of a static law runs the switch-exact kernels, unless ``samples`` or
    ``gauss_order`` is given: then the sampled walk (:func:`static_harmonics`) with
    ``samples`` phase samples (64 if None) and adaptive Gauss-Kronrod (``gauss_order=None``)
    or that Gauss-Legendre order on fixed sub-intervals, the independent reference of the
    tests.  ``scan_step`` sets the exact model's search for re-contact; ``parallel`` shares
    the points of a static law among numba's threads.
    """
    model = as_model(model)
    amplitude = validated("amplitude", amplitude, positive=True)
    omega = validated("omega", omega)
    bias = validated("bias", bias)
    if method not in ("auto", "closed-form", "harmonic-balance"):
        raise ValueError(f"method must be 'auto', 'closed-form' or 'harmonic-balance', got {method!r}")
    a, w, b = np.broadcast_arrays(amplitude, omega, bias)
    check_scales(model, a, w, b)
    return balance(model, a, w, b, method, samples, gauss_order, scan_step, parallel)


def balance(model, a, w, b, method="auto", samples=None, gauss_order=None, scan_step=SCAN_STEP, parallel=False):
    """:func:`evaluate` on arguments it has checked (``a``, ``w``, ``b`` float arrays of one shape): for a
    solver that has checked its range once and calls it in a loop (:func:`backlash_df.describing.dc_bias`)."""
    closed = _closed_form(model, a, w) if method != "harmonic-balance" and not b.any() else None
    if method == "closed-form" and closed is None:
        raise ValueError(f"no closed-form describing function for {model.name!r} (or with a bias)")
    if closed is not None:
        return Balance(np.asarray(closed, dtype=complex), np.zeros(a.shape))
    n_out = np.empty(a.size, dtype=complex)
    mean_out = np.empty(a.size)
    # np.array copies: broadcast views are flagged "warn on write", and numba's typeof
    # reads that flag (a FutureWarning on every call with numpy >= 2.4)
    points = tuple(np.array(x, dtype=float).ravel() for x in (a, w, b))
    if model.law == EXACT:
        exact_balance(model.params, *points, float(scan_step), n_out, mean_out)
    elif samples is None and gauss_order is None:
        switch_exact_kernel(model, parallel)(model.params, *points, n_out, mean_out)
    else:
        nodes, weights = np.polynomial.legendre.leggauss(gauss_order) if gauss_order else (np.empty(0), np.empty(0))
        harmonic_balance(model.law, model.params, *points, nodes, weights, int(samples or SAMPLES), n_out, mean_out)
    n_out, mean_out = n_out.reshape(a.shape), mean_out.reshape(a.shape)
    # Every law is odd, T(-x, -v) = -T(x, v): at zero bias the mean torque is zero, and
    # what the quadrature returns is round-off relative to the torque's scale |N| A.
    unbiased = b == 0.0
    if unbiased.any():
        mean_out = np.where(unbiased & (np.abs(mean_out) <= _MEAN_ROUND_OFF * np.abs(n_out) * a), 0.0, mean_out)
    return Balance(n_out, mean_out)
