"""Describing functions N(A, w, bias) of the backlash torque laws by harmonic balance.

Convention (the contract page of the documentation): the input is
``x(t) = bias + A sin(w t)``, ``v = dx/dt``;
with ``b1``, ``a1`` the sine and cosine Fourier coefficients of the steady-state
torque over one period,

    N(A, w, bias) = (b1 + j a1) / A        (N m / rad)

and the mean torque ``N0(A, w, bias) = (1 / 2 pi) int T dphi`` (N m) is the DC
term of the dual-input describing function (:func:`dual_input_describing_function`).
Under a constant load torque ``T_l`` the DC balance ``N0(A, w, b) = -T_l`` fixes the
bias (:func:`dc_bias`), and ``N(A, w, b(A, w))`` is the describing function of the
loaded loop (:class:`BiasedDescribing`).  Because the laws depend on the rate ``v``, N depends on
``w`` as well as on ``A``.

How each law is computed:

* Static laws, by default (the switch-exact kernels): every contact torque is
  affine in (1, sin phi, cos phi) along ``phi = w t`` and is integrated in closed
  form; every mode boundary but theta* is a sinusoid, ``b + R sin(phi + psi) = level``
  (x, y = x + (c/k) v, z = x - (c/k) v, x + 2 (c/k) v), crossed at phases in closed
  form.  Right contact is integrated for the bias, left contact as its mirror image
  (odd symmetry).  Contact of the phase plane law, once made at theta*, holds until
  the release (Theorem 1, ``backlash_df._laws.held_mode``): it spans the arc
  where y >= alpha from its first phase with ``x >= theta*(v)`` or ``v <= 0``.  The
  theta* boundaries ``x = theta*(v) (+- beta / 2)`` are located by Newton on (19) written
  with one exponential, in brackets where ``x - theta*(v)`` is monotone: it rises for
  ``v`` rising and, for ``v`` falling, rises or has one maximum and one minimum, found as
  the roots of a convex function of the contact fraction (``cot phi = (c w / k) D``,
  ``D = -d theta*/ds``).  The rubber band (36), not affine, is integrated by adaptive
  Gauss-Kronrod (7-15), the error test of ``_kernels.integrate_adaptive``.  No sample count enters.
* Static laws, reference (``_evaluation.evaluate(..., samples=..., gauss_order=...)``): the
  walk of earlier releases.  The mode is followed as the simulation follows it
  (``_laws.held_mode``).  The mode
  changes (contact, release, theta*, rubber band edges, the kink of the
  ElastoBacklash law) are bracketed by 64 phase samples, located to a few
  ulps as zeros of the law's boundary functions (regula falsi, Illinois) and
  settled by bisection on the mode itself, which has the last word (bisection
  alone where no boundary function fits).  Each smooth piece is integrated by
  adaptive Gauss-Kronrod (7-15) quadrature with a stated error test, or by a fixed
  Gauss-Legendre rule.
* The exact model (1) + (14): off contact the shaft relaxes as
  ``theta_b = x + (theta_b0 - x0) exp(-(phi - phi0) / (c w / k))`` (eq. 13),
  contact starts when that reaches ``+-alpha`` (located by bisection) and ends at
  the release phase where ``y = x + (c/k) v`` crosses ``+-alpha`` (closed form,
  Theorem 1).  The state at a release is always ``theta_b = +-alpha`` at a fixed
  phase, so the response is periodic from the first release on: the periodic
  steady state is reached exactly, after at most the periods it takes the
  free shaft to close the gap again (no convergence iteration is needed).
  In contact ``T = k (y -+ alpha)`` is a sinusoid plus a constant, integrated
  in closed form.
* Closed forms (no bias): classical dead-zone (24), Tustin's
  ``N = k F(alpha / A)`` with ``F(r) = 1 - (2/pi)(asin r + r sqrt(1 - r^2))``;
  damped dead-zone (26), ``N = (k + j c w) F(alpha / A)``; revised dead-zone
  (27), a dead-zone of ``y`` of amplitude ``R = A sqrt(1 + (c w / k)^2)``:
  ``N = (k + j c w) F(alpha / R)``.

The classical elements (saturation, dead zone, relay with hysteresis, the play) and
python-control's element objects have their closed forms in :mod:`.classical`,
re-exported here.
"""

import dataclasses

import numpy as np

from .._json import json_ready
from ..models import BacklashModel, make_model
from ..plotting import ResultPlot, axes_or_new, label_contours, legend_beside, log_scale
from ._evaluation import as_model, balance, check_scales, evaluate, validated
from .classical import (
    dead_zone_describing_function,
    nonlinearity_describing_function,
    play_describing_function,
    relay_describing_function,
    saturation_describing_function,
)

__all__ = [
    "describing_function",
    "dual_input_describing_function",
    "saturation_describing_function",
    "dead_zone_describing_function",
    "relay_describing_function",
    "play_describing_function",
    "nonlinearity_describing_function",
    "friction_describing_function",
    "dc_bias",
    "BiasedDescribing",
    "describing_function_grid",
    "DescribingFunctionResult",
    "phase_plane_validity",
    "ValidityMap",
]


def describing_function(model, amplitude, omega, *, bias=0.0, method="auto"):
    """Describing function N(A, w, bias) of a backlash torque law.

    Parameters
    ----------
    model : BacklashModel
        A law from :func:`~backlash_df.make_model`, the exact model included.
    amplitude : array_like
        First-harmonic amplitude A of theta_d, rad (> 0).
    omega : array_like
        Angular frequency w, rad/s (>= 0).
    bias : array_like, optional
        Mean of theta_d, rad.
    method : {"auto", "closed-form", "harmonic-balance"}
        ``auto`` uses the closed forms of (24), (26), (27) without bias and
        harmonic balance otherwise; the other two force one route.

    Returns
    -------
    complex ndarray
        N = (b1 + j a1) / A in N m/rad, broadcast over the arguments.

    Raises
    ------
    ValueError
        Amplitude not > 0, omega negative, any argument non-finite.

    See Also
    --------
    describing_function_grid : a grid with gain, phase, mean torque and plots.

    Examples
    --------
    Tustin's dead-zone: N = k F(alpha / A).

    >>> model = make_model("dead-zone", stiffness=100.0, half_gap=0.1)
    >>> complex(describing_function(model, 0.2, 10.0))
    (39.100...+0j)

    The damped laws lead in phase:

    >>> pp = make_model("phase-plane", stiffness=5895.0, damping=3.0, half_gap=0.05)
    >>> n = describing_function(pp, [0.06, 0.2], 100.0)
    >>> bool(np.all(np.angle(n) > 0))
    True
    """
    return evaluate(model, amplitude, omega, bias, method).n


def dual_input_describing_function(model, amplitude, omega, *, bias=0.0, method="auto"):
    """The dual-input describing function: N(A, w, bias) and the mean torque N0(A, w, bias).

    For ``x(t) = bias + A sin(w t)``: ``N = (b1 + j a1) / A`` (N m/rad) of the
    first harmonic and ``N0 = (1 / 2 pi) int T dphi`` (N m), the DC term.  At zero
    bias every law is odd and ``N0 = 0``.

    Parameters
    ----------
    model, amplitude, omega, bias, method
        As :func:`describing_function`.

    Returns
    -------
    n : complex ndarray
        N, N m/rad, broadcast over the arguments.
    mean_torque : ndarray
        N0, N m, same shape.

    Examples
    --------
    Resting on the right flank of a dead-zone (``bias - A > alpha``) the torque is
    ``k (x - alpha)``: ``N = k`` and ``N0 = k (bias - alpha)``.

    >>> model = make_model("dead-zone", stiffness=100.0, half_gap=0.1)
    >>> n, mean = dual_input_describing_function(model, 0.05, 10.0, bias=0.3)
    >>> round(float(n.real), 9), round(float(mean), 9)
    (100.0, 20.0)
    """
    return tuple(evaluate(model, amplitude, omega, bias, method))


def friction_describing_function(amplitude, coulomb, breakaway=0.0, stribeck_speed=1.0):
    """Describing function of dry friction on a speed ``w = A_w sin(w t)``: a real gain, N m s/rad.

    The friction ``(F_c + F_s exp(-(w / w_s)^2)) sign(w)`` of a side that slides
    through the whole period (a side that sticks has no such first harmonic) acts on
    the first harmonic as the viscous coefficient

        ``N_f = 4 F_c / (pi A_w) + 4 F_s D(a) / (pi a A_w)``,  ``a = A_w / w_s``,

    with Dawson's integral ``D`` (:func:`scipy.special.dawsn`): the Coulomb part is
    the relay's ``4 F_c / (pi A_w)``; the breakaway part follows from
    ``int_0^pi exp(-a^2 sin^2 phi) sin phi dphi = 2 D(a) / a``, and tends to the
    relay's as ``a -> 0``.

    Parameters
    ----------
    amplitude : array_like
        A_w, the speed's first-harmonic amplitude, rad/s (> 0).
    coulomb, breakaway : float
        F_c and F_s, N m (>= 0).
    stribeck_speed : float
        w_s, rad/s (> 0).

    Returns
    -------
    ndarray
        N_f, N m s/rad, the shape of ``amplitude``.

    Examples
    --------
    >>> bool(np.isclose(friction_describing_function(2.0, 3.0), 4 * 3.0 / (np.pi * 2.0)))
    True
    """
    from scipy.special import dawsn

    amplitude = np.asarray(amplitude, dtype=float)
    gain = 4.0 * coulomb / (np.pi * amplitude)
    if breakaway > 0.0:
        a = amplitude / stribeck_speed
        gain = gain + 4.0 * breakaway * dawsn(a) / (np.pi * a * amplitude)
    return gain


_BIAS_TOL = 1e-11  # relative to the bracket width (alpha + A + |T_l| / k) and to k times it


def dc_bias(model, amplitude, omega, load_torque, iterations=40):
    """Bias b (rad) of theta_d solving the DC balance ``N0(A, w, b) = -load_torque``.

    Parameters
    ----------
    model : BacklashModel
    amplitude, omega : array_like
        A (rad, > 0) and w (rad/s), broadcast together.
    load_torque : float
        T_l, N m, applied to the load (positive: the shaft carries ``-T_l``).
    iterations : int
        Most Newton steps (safeguarded by bisection); a point stops at its own tolerance.

    Returns
    -------
    ndarray
        b, rad, shape of the broadcast arguments.

    Examples
    --------
    A large amplitude with the shaft in contact most of the time needs about
    ``b = -alpha - T_l / k`` at small amplitude (resting on the left flank):

    >>> model = make_model("dead-zone", stiffness=1000.0, half_gap=0.05)
    >>> round(float(dc_bias(model, 1e-3, 10.0, 20.0)), 6)
    -0.07
    """
    return _balanced_bias(model, amplitude, omega, load_torque, iterations)[0]


def _balanced_bias(model, amplitude, omega, load_torque, iterations=40):
    """(b, N) of :func:`dc_bias`: N at the bias found, from the balance that accepted it."""
    model = as_model(model)
    a, w = np.broadcast_arrays(validated("amplitude", amplitude, positive=True), validated("omega", omega))
    shape = a.shape
    target = -float(validated("load_torque", load_torque))
    # at b = +-width the oscillation never leaves a flank: N0 = k (b -+ alpha) passes the target
    width = model.half_gap + a + abs(target) / model.stiffness
    check_scales(model, a, w, width)  # every b of the bracket: |b| <= width
    lo, hi = (np.zeros(a.shape), width) if target > 0.0 else (-width, np.zeros(a.shape))
    # start as if always in contact: exact for small A, and Newton's steps stay inside the bracket
    b = np.clip(np.full(a.shape, target / model.stiffness + np.copysign(model.half_gap, target)), lo, hi)
    a, w, b, lo, hi, width = (np.array(x, dtype=float).ravel() for x in (a, w, b, lo, hi, width))
    n = np.empty(a.size, dtype=complex)
    step = 1e-7 * width
    active = np.arange(a.size)  # the points not converged yet: each stops at its own tolerance
    for _ in range(iterations):
        n_active, mean = balance(model, a[active], w[active], b[active])
        f = mean - target
        n[active] = n_active
        going = np.abs(f) > _BIAS_TOL * model.stiffness * width[active]
        active, f = active[going], f[going]
        if active.size == 0:
            break
        bb, low, high = b[active], lo[active], hi[active]
        slope = (balance(model, a[active], w[active], bb + step[active]).mean - target - f) / step[active]
        low, high = np.where(f < 0.0, bb, low), np.where(f > 0.0, bb, high)
        newton = bb - f / np.where(slope > 0.0, slope, 1.0)
        inside = (slope > 0.0) & (newton > low) & (newton < high)
        lo[active], hi[active] = low, high
        b[active] = np.where(inside, newton, 0.5 * (low + high))
    else:  # the last steps' points: N at the bias they ended on
        if active.size:
            n[active] = balance(model, a[active], w[active], b[active]).n
    return b.reshape(shape), n.reshape(shape)


@dataclasses.dataclass(frozen=True)
class BiasedDescribing:
    """``N(A, w, b(A, w))`` with the bias slaved to the DC balance: a callable ``(A, w) -> N``.

    The describing function of a loop under the constant load torque ``T_l``
    (:func:`dc_bias`; the PI integrator removes the mean speed error, so the mean
    shaft torque carries the load).

    Attributes
    ----------
    model : BacklashModel
    load_torque : float
        T_l, N m.
    """

    model: BacklashModel
    load_torque: float

    def __call__(self, amplitude, omega):
        return _balanced_bias(self.model, amplitude, omega, self.load_torque)[1]

    def bias(self, amplitude, omega):
        """b (rad) at (A, w); see :func:`dc_bias`."""
        return dc_bias(self.model, amplitude, omega, self.load_torque)


@dataclasses.dataclass(frozen=True)
class DescribingFunctionResult:
    """Describing function of one law on an (amplitude x omega) grid.

    Attributes
    ----------
    model : BacklashModel
    amplitude : ndarray
        Amplitudes A (rad), shape (n_A,).
    omega : ndarray
        Angular frequencies w (rad/s), shape (n_w,).
    bias : float
        Mean of theta_d (rad).
    N : complex ndarray
        Describing function (N m/rad), shape (n_A, n_w).
    mean_torque : ndarray
        DC term of the torque (N m), shape (n_A, n_w); zero without bias.
    """

    model: BacklashModel
    amplitude: np.ndarray
    omega: np.ndarray
    bias: float
    N: np.ndarray
    mean_torque: np.ndarray

    @property
    def gain(self):
        """Gain ``|N|``, N m/rad."""
        return np.abs(self.N)

    @property
    def phase_deg(self):
        """Phase of N in degrees (positive: a lead)."""
        return np.degrees(np.angle(self.N))

    @property
    def rate(self):
        """Dimensionless rate c w / k of each column."""
        return self.model.damping * self.omega / self.model.stiffness

    def __repr__(self):
        return (
            f"DescribingFunctionResult(model={self.model.name!r}, {self.amplitude.size} amplitudes x "
            f"{self.omega.size} frequencies, bias={self.bias!r})"
        )

    def to_dict(self):
        """JSON-ready: the law and one entry per (A, w) point, as ``backlash-df df --json`` writes them.

        Each point: ``amplitude`` (rad), ``omega`` (rad/s), ``gain`` (N m/rad),
        ``phase_deg``, ``real`` and ``imag`` of N, ``mean_torque`` N0 (N m).
        """
        points = []
        for i, amplitude in enumerate(self.amplitude):
            for j, omega in enumerate(self.omega):
                points.append({
                    "amplitude": float(amplitude), "omega": float(omega),
                    "gain": float(self.gain[i, j]), "phase_deg": float(self.phase_deg[i, j]),
                    "real": float(self.N[i, j].real), "imag": float(self.N[i, j].imag),
                    "mean_torque": float(self.mean_torque[i, j]),
                })
        return {"model": self.model.name, "shaft": self.model.plant_params, "bias": self.bias, "points": points}

    def plot(self, ax=None):
        """Gain (normalised by k) and phase against A / alpha, one line per c w / k.

        Returns
        -------
        ResultPlot
            Axes ``[gain, phase]``; the legend (one entry per c w / k) beside the gain.
        """
        figure, axes = axes_or_new(ax, (2, 1), sharex=True, figsize=(8, 5.5), layout="constrained")
        ratio = self.amplitude / self.model.half_gap
        for j, rate in enumerate(self.rate):
            label = f"c w / k = {rate:.3g}"
            axes[0].plot(ratio, self.gain[:, j] / self.model.stiffness, label=label)
            axes[1].plot(ratio, self.phase_deg[:, j], label=label)
        for panel in axes:  # log over a decade or more
            if ratio.max() > 10.0 * ratio.min():
                log_scale(panel.xaxis, ratio.min(), ratio.max())
        axes[0].set_ylabel("|N| / k")
        axes[1].set_ylabel("phase of N (deg)")
        axes[1].set_xlabel("A / alpha")
        axes[0].set_title(f"describing function: {self.model.name}", fontsize="medium")
        legend_beside(axes[0])
        for panel in axes:
            panel.grid(True, which="both", alpha=0.3)
        return ResultPlot(figure, axes)


def describing_function_grid(model, amplitude, omega, *, bias=0.0):
    """Describing function and mean torque on the grid ``amplitude x omega``.

    Parameters
    ----------
    model : BacklashModel
    amplitude, omega : array_like
        1-D arrays of amplitudes (rad, > 0) and angular frequencies (rad/s, >= 0).
    bias : float, optional
        Mean of theta_d, rad.

    Returns
    -------
    DescribingFunctionResult

    Examples
    --------
    >>> model = make_model("phase-plane", stiffness=5895.0, damping=3.0, half_gap=0.05)
    >>> result = describing_function_grid(model, [0.06, 0.1], [10.0, 100.0])
    >>> result.N.shape
    (2, 2)
    """
    amplitude = np.atleast_1d(np.asarray(amplitude, dtype=float))
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if amplitude.ndim != 1 or omega.ndim != 1:
        raise ValueError("amplitude and omega must be 1-D arrays")
    n, mean = evaluate(model, amplitude[:, None], omega[None, :], float(bias), "auto", parallel=True)
    return DescribingFunctionResult(as_model(model), amplitude, omega, float(bias), n, mean)


@dataclasses.dataclass(frozen=True)
class ValidityMap:
    """Where the phase plane law's DF departs from the exact model's (reading notes, item 10).

    Attributes
    ----------
    amplitude_ratio : ndarray
        A / alpha, shape (n_A,).
    rate : ndarray
        c w / k, shape (n_r,).
    relative_error : ndarray
        ``|N_phase - N_exact| / |N_exact|``, shape (n_A, n_r); NaN where ``N_exact = 0``.
    early_contact : ndarray of bool
        Where the phase plane law transmits torque although A < alpha: it closes
        the gap at theta* < alpha, an artefact of its approximation (ii).
    """

    amplitude_ratio: np.ndarray
    rate: np.ndarray
    relative_error: np.ndarray
    early_contact: np.ndarray

    def __repr__(self):
        worst = float(np.nanmax(self.relative_error, initial=0.0))
        return (f"ValidityMap({self.amplitude_ratio.size} amplitudes x {self.rate.size} rates, largest relative "
                f"difference {100 * worst:.3g} %)")

    def to_dict(self):
        """JSON-ready: A / alpha, c w / k, the relative difference (null where N_exact = 0), early contact."""
        return json_ready({"amplitude_ratio": self.amplitude_ratio, "rate": self.rate,
                           "relative_error": self.relative_error, "early_contact": self.early_contact})

    def plot(self, ax=None, levels=(0.01, 0.05, 0.2)):
        """Contours of the relative difference at ``levels`` (1 %, 5 %, 20 %) and the early-contact region.

        Returns
        -------
        ResultPlot
            One panel: filled bands between the levels, the contours labelled with
            their level, the early-contact region hatched; the colour bar beside it.
        """
        figure, axes = axes_or_new(ax, figsize=(7, 4.5), layout="constrained")
        ax = axes[0]
        err = np.where(np.isfinite(self.relative_error), self.relative_error, np.nan)
        bounds = [0.0, *levels, max(float(np.nanmax(err, initial=0.0)), 2.0 * levels[-1])]
        colours = ["#f7fbff", "#c6dbef", "#6baed6", "#08519c", "#08306b"][: len(bounds) - 1]
        filled = ax.contourf(self.rate, self.amplitude_ratio, err, levels=bounds, colors=colours)
        lines = ax.contour(self.rate, self.amplitude_ratio, err, levels=list(levels), colors="k", linewidths=0.8)
        label_contours(ax, lines, fmt=lambda level: f"{level:.0%}")
        if np.any(self.early_contact):
            ax.contourf(self.rate, self.amplitude_ratio, self.early_contact.astype(float), levels=[0.5, 1.5],
                        colors="none", hatches=["//"])
        log_scale(ax.xaxis, self.rate.min(), self.rate.max())
        log_scale(ax.yaxis, self.amplitude_ratio.min(), self.amplitude_ratio.max())
        ax.set_xlabel("c w / k")
        ax.set_ylabel("A / alpha")
        ax.set_title("|N_phase-plane - N_exact| / |N_exact|\nhatched: contact although A < alpha", fontsize="medium")
        colorbar = ax.figure.colorbar(filled, ax=ax, spacing="uniform")
        colorbar.set_ticks(bounds)
        colorbar.set_ticklabels(["0", *[f"{level:.0%}" for level in levels], f"{bounds[-1]:.0%}"])
        return ResultPlot(figure, axes)


def phase_plane_validity(stiffness, damping, half_gap, amplitude_ratio, rate):
    """Relative difference between the phase plane and exact describing functions.

    Parameters
    ----------
    stiffness, damping, half_gap : float
        k (N m/rad), c (N m s/rad, > 0), alpha (rad).
    amplitude_ratio : array_like
        A / alpha values.
    rate : array_like
        c w / k values (dimensionless).

    Returns
    -------
    ValidityMap
    """
    if not damping > 0.0:
        raise ValueError("damping must be > 0 for a validity map (with c = 0 both laws are the dead-zone)")
    shaft = dict(stiffness=stiffness, damping=damping, half_gap=half_gap)
    ratio = np.atleast_1d(np.asarray(amplitude_ratio, dtype=float))
    rate = np.atleast_1d(np.asarray(rate, dtype=float))
    amplitude = ratio[:, None] * half_gap
    omega = rate[None, :] * stiffness / damping
    n_phase = describing_function(make_model("phase-plane", **shaft), amplitude, omega)
    n_exact = describing_function(make_model("exact", **shaft), amplitude, omega)
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.where(np.abs(n_exact) > 0.0, np.abs(n_phase - n_exact) / np.abs(n_exact), np.nan)
    early = (np.abs(n_phase) > 0.0) & (amplitude < half_gap)
    return ValidityMap(ratio, rate, error, early)
