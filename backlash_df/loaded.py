"""Limit cycles under a constant load torque: the dual-input describing function.

A constant torque ``T_l`` on the load (``[load] torque``, N m) shifts the
oscillation of the shaft angle to ``theta_d = b + A sin(w t)``.  The PI
integrator removes any mean speed error, so over a period the mean
accelerations vanish: ``J_l <dw_l/dt> = <T> + T_l = 0`` and the mean shaft
torque carries the load.  With the dual-input describing function (DESIGN.md's
``N(A, w, bias)`` and its DC term ``N0``) the cycle solves

    N0(A, w, b) = -T_l                      (DC balance)
    1 + G(jw) N(A, w, b) = 0                (first harmonic, as without load)

The DC balance fixes ``b(A, w)`` (the mean torque grows monotonically with the
bias; it is solved by Newton's method kept inside a bracket, vectorised), and the
first-harmonic equation is then solved for (A, w) by
:func:`~backlash_df.limit_cycles.solve_harmonic_balance` exactly as for the
unloaded loop, with Loeb's criterion on the bias-slaved ``N``.  Treating the
bias as following A and w at once is the usual quasi-static assumption: the
integrator moves it slowly, over many periods.

A large enough load keeps the gear on one flank: the biased oscillation no
longer leaves contact, the loop is linear and (if stable) the cycle is gone.
:func:`load_limit` finds the load at which the DF's stable cycle disappears.
The amplitude search reaches below the half gap alpha: with a bias, a cycle
that only lifts off one flank can be smaller than alpha.
"""

import dataclasses

import numpy as np

from .describing import _evaluate
from .limit_cycles import LimitCyclePrediction, default_ranges, solve_harmonic_balance
from .loops import drive_loop, frequency_response_of
from .models import BacklashModel

__all__ = ["BiasedDescribing", "dc_bias", "predict_loaded", "LoadLimit", "load_limit"]

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
        Most Newton steps (safeguarded by bisection).

    Returns
    -------
    ndarray
        b, rad, shape of the broadcast arguments.

    Examples
    --------
    A large amplitude with the shaft in contact most of the time needs about
    ``b = -alpha - T_l / k`` at small amplitude (resting on the left flank):

    >>> from backlash_df import make_model
    >>> model = make_model("dead-zone", stiffness=1000.0, half_gap=0.05)
    >>> round(float(dc_bias(model, 1e-3, 10.0, 20.0)), 6)
    -0.07
    """
    a, w = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(omega, dtype=float))
    target = -float(load_torque)
    # at b = +-width the oscillation never leaves a flank: N0 = k (b -+ alpha) passes the target
    width = model.half_gap + a + abs(target) / model.stiffness
    lo, hi = (np.zeros(a.shape), width) if target > 0.0 else (-width, np.zeros(a.shape))
    # start as if always in contact: exact for small A, and Newton's steps stay inside the bracket
    b = np.clip(np.full(a.shape, target / model.stiffness + np.copysign(model.half_gap, target)), lo, hi)
    step = 1e-7 * width
    for _ in range(iterations):
        f = _evaluate(model, a, w, b, "auto")[1] - target
        if np.all(np.abs(f) <= _BIAS_TOL * model.stiffness * width):
            break
        slope = (_evaluate(model, a, w, b + step, "auto")[1] - target - f) / step
        lo, hi = np.where(f < 0.0, b, lo), np.where(f > 0.0, b, hi)
        newton = b - f / np.where(slope > 0.0, slope, 1.0)
        inside = (slope > 0.0) & (newton > lo) & (newton < hi)
        b = np.where(f == 0.0, b, np.where(inside, newton, 0.5 * (lo + hi)))
    return b


@dataclasses.dataclass(frozen=True)
class BiasedDescribing:
    """``N(A, w, b(A, w))`` with the bias slaved to the DC balance: a callable ``(A, w) -> N``.

    Attributes
    ----------
    model : BacklashModel
    load_torque : float
        T_l, N m.
    """

    model: BacklashModel
    load_torque: float

    def __call__(self, amplitude, omega):
        a, w = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(omega, dtype=float))
        bias = dc_bias(self.model, a, w, self.load_torque)
        return _evaluate(self.model, a, w, bias, "auto")[0]

    def bias(self, amplitude, omega):
        """b (rad) at (A, w); see :func:`dc_bias`."""
        return dc_bias(self.model, amplitude, omega, self.load_torque)


def predict_loaded(rig, model=None, load_torque=None, linear=None, amplitude_range=None, omega_range=None,
                   grid=(60, 80), near_miss_cutoff=0.5):
    """Biased limit cycles of a rig's loop under a constant load torque (module docs).

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
        Torque law (default the rig's).
    load_torque : float, optional
        T_l, N m (default ``rig.load.torque``).
    linear : DriveLoop, control.LTI or callable, optional
        The linear part (default the rig's PI loop).
    amplitude_range, omega_range : (float, float), optional
        Search box, rad and rad/s (default A from alpha / 50 to 200 alpha,
        w as :func:`~backlash_df.limit_cycles.default_ranges`).
    grid : (int, int)
        Scan points in A and w.
    near_miss_cutoff : float
        Largest ``|1 + G N|`` reported as a near miss.

    Returns
    -------
    LimitCyclePrediction
        Its cycles carry ``bias`` (rad), the mean of theta_d.
    """
    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    load_torque = rig.load.torque if load_torque is None else float(load_torque)
    linear = drive_loop(rig) if linear is None else linear
    (_, hi_a), default_w = default_ranges(rig)
    amplitude_range = (0.02 * model.half_gap, hi_a) if amplitude_range is None else tuple(amplitude_range)
    omega_range = default_w if omega_range is None else tuple(omega_range)
    n_of = BiasedDescribing(model, load_torque)
    cycles, near = solve_harmonic_balance(lambda omega: frequency_response_of(linear, omega), n_of, 0.0,
                                          amplitude_range, omega_range, grid=grid, near_miss_cutoff=near_miss_cutoff)
    cycles = [dataclasses.replace(c, bias=float(n_of.bias(c.amplitude, c.omega))) for c in cycles]
    return LimitCyclePrediction(model=model.name, cycles=tuple(cycles), near_misses=tuple(near),
                                amplitude_range=amplitude_range, omega_range=omega_range, linear=linear,
                                describing=n_of, half_gap=0.0)


@dataclasses.dataclass(frozen=True)
class LoadLimit:
    """The load torque above which the DF predicts no stable cycle, and where simulation loses it.

    Attributes
    ----------
    model : str
    torque : float
        T_l* (N m, signed as the load): the DF predicts a stable cycle below
        it and none above (to ``rtol``).
    below : LimitCyclePrediction
        The prediction at the largest load that still has the cycle.
    simulated : float or None
        The same limit in closed-loop simulation (started on the biased DF
        cycle at each load), N m; ``None`` if not simulated.
    """

    model: str
    torque: float
    below: LimitCyclePrediction
    simulated: float | None = None

    def __repr__(self):
        cycle = self.below.stable_cycles[-1]
        sim = "" if self.simulated is None else f", simulation: {self.simulated:.4g} N m"
        return (f"LoadLimit({self.model}: DF cycle gone above T_l = {self.torque:.4g} N m{sim}; "
                f"last DF cycle A={cycle.amplitude:.4g} rad, bias={cycle.bias:.4g} rad)")


def _bisect(has_cycle, lo, hi, rtol):
    """Largest load with a cycle, by bisection of [lo, hi] (``has_cycle(lo)`` true, ``has_cycle(hi)`` false)."""
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if has_cycle(mid) else (lo, mid)
    return lo, hi


def load_limit(rig, model=None, upper=None, sign=1.0, rtol=0.01, grid=(20, 30), simulate=False, t_end=10.0,
               max_t_end=40.0):
    """Find the load torque at which the stable limit cycle disappears.

    The DF limit is bisected between no load (where the loop must cycle) and
    ``upper`` (where it must not); assumes one transition in between.

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
    upper : float, optional
        Largest load considered, N m (default ``2 k alpha``).
    sign : {1.0, -1.0}
        Direction of the load.
    rtol : float
        Relative width of the final bracket.
    grid : (int, int)
        Scan grid of every prediction.
    simulate : bool
        Also bisect the load at which the closed-loop simulation loses the cycle.
    t_end, max_t_end : float
        Simulated times, s.

    Returns
    -------
    LoadLimit or None
        ``None`` when the unloaded DF has no stable cycle or the cycle survives ``upper``.
    """
    from .simulate import simulated_limit_cycle

    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    upper = 2.0 * model.stiffness * model.half_gap if upper is None else float(upper)
    found = {}

    def predicted(torque):
        found[torque] = predict_loaded(rig, model, sign * torque, grid=grid)
        return bool(found[torque].stable_cycles)

    if not predicted(0.0) or predicted(upper):
        return None
    lo, hi = _bisect(predicted, 0.0, upper, rtol)
    simulated = None
    if simulate:
        def cycles(torque):
            cycle = predict_loaded(rig, model, sign * torque, grid=grid).stable_cycles
            start = cycle[-1] if cycle else found[lo].stable_cycles[-1]
            measured, _ = simulated_limit_cycle(rig, model, t_end=t_end, max_t_end=max_t_end, load_torque=sign * torque,
                                                initial={"theta_d": start.bias}, kick=start.amplitude * start.omega)
            return measured.found

        simulated = sign * 0.5 * sum(_bisect(cycles, 0.0, hi, rtol)) if cycles(0.0) and not cycles(hi) else None
    return LoadLimit(model.name, sign * 0.5 * (lo + hi), found[lo], simulated)
