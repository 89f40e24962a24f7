"""Limit cycles measured in time simulations: amplitude, frequency, or why there is none."""

import dataclasses
import math

import numpy as np

from .._json import json_ready

__all__ = ["MeasuredCycle", "measure_limit_cycle", "upward_crossings"]


@dataclasses.dataclass(frozen=True)
class MeasuredCycle:
    """A limit cycle measured in a time simulation, or the finding that there is none.

    Attributes
    ----------
    found : bool
        True if the response settled to a sustained oscillation with shaft contact.
    amplitude : float
        First-harmonic amplitude of theta_d (rad), the DF's ``A``; NaN if none.
    peak : float
        Half the peak-to-peak excursion of theta_d (rad); NaN if none.
    omega : float
        Angular frequency of the cycle (rad/s); NaN if none.
    bias : float
        Mean of theta_d over the measured periods (rad); NaN if none.
    settled : bool
        True if a steady state was reached (a periodic cycle, or rest in the gap),
        or the run diverged (longer runs cannot change that).
    verdict : str
        ``"limit cycle"``, ``"no limit cycle"`` (rest: no shaft contact at the end),
        ``"decaying"``, ``"growing"``, ``"drifting in the gap"`` or ``"irregular"`` (not settled),
        or ``"diverged"`` (overflow, NaN, or theta_d beyond the bound of :func:`measure_limit_cycle`).
    periods : int
        Number of periods averaged.
    saturation : float
        With a torque limit: the share of the measured periods with the torque
        command on its limit (0 .. 1); NaN without a limit or without a cycle.
    """

    found: bool
    amplitude: float
    peak: float
    omega: float
    bias: float
    settled: bool
    verdict: str
    periods: int = 0
    saturation: float = math.nan

    def __repr__(self):
        if not self.found:
            return f"MeasuredCycle({self.verdict})"
        return (
            f"MeasuredCycle(amplitude={self.amplitude:.6g} rad, peak={self.peak:.6g} rad, "
            f"omega={self.omega:.6g} rad/s, bias={self.bias:.3g} rad, periods={self.periods})"
        )

    def __str__(self):
        """What a report prints: ``limit cycle: A = 0.151 rad, w = 95.9 rad/s (...)`` or the verdict."""
        if not self.found:
            return self.verdict
        limit = "" if math.isnan(self.saturation) else f", command on its limit {100 * self.saturation:.0f} % of the time"
        return (f"limit cycle: A = {self.amplitude:.4g} rad, w = {self.omega:.4g} rad/s "
                f"(peak {self.peak:.4g} rad, bias {self.bias:.3g} rad, {self.periods} periods averaged{limit})")

    def to_dict(self):
        """JSON-ready: verdict, settled, and the cycle (rad, rad/s; null where none was found)."""
        return json_ready({"verdict": self.verdict, "found": self.found, "settled": self.settled,
                           "amplitude": self.amplitude, "peak": self.peak, "omega": self.omega,
                           "bias": self.bias, "periods": self.periods, "saturation": self.saturation})

    @property
    def saturated(self):
        """True for a cycle whose torque command reaches its limit."""
        return self.found and self.saturation > 0.0

    def cycle_dict(self):
        """``{"amplitude", "omega"}`` (rad, rad/s) as in the ``predict`` JSON's ``simulated``, or ``None``.

        With a torque limit also ``saturation``, the share of the cycle with the command on its limit.
        """
        if not self.found:
            return None
        out = {"amplitude": float(self.amplitude), "omega": float(self.omega)}
        if not math.isnan(self.saturation):
            out["saturation"] = float(self.saturation)
        return out


def upward_crossings(time, signal):
    """Times (s) where ``signal`` crosses zero upwards, linearly interpolated."""
    below = signal[:-1] < 0.0
    above = signal[1:] >= 0.0
    i = np.nonzero(below & above)[0]
    frac = -signal[i] / (signal[i + 1] - signal[i])
    return time[i] + frac * (time[i + 1] - time[i])


def _window_integral(time, values, t0, t1):
    """Trapezoid integral of sampled ``values`` over [t0, t1] with interpolated ends."""
    inside = (time > t0) & (time < t1)
    t = np.concatenate(([t0], time[inside], [t1]))
    y = np.concatenate(([np.interp(t0, time, values.real)], values.real[inside], [np.interp(t1, time, values.real)]))
    if np.iscomplexobj(values):
        y = y + 1j * np.concatenate(
            ([np.interp(t0, time, values.imag)], values.imag[inside], [np.interp(t1, time, values.imag)])
        )
    return np.trapezoid(y, t)


def measure_limit_cycle(result, periods=6, rtol=1e-3, window=0.25, bound=None):
    """Measure the limit cycle at the end of a closed-loop simulation.

    The last ``periods`` full periods of theta_d (between upward crossings of its
    mean, located by linear interpolation) give the frequency; the first harmonic
    ``|2/T int theta_d e^{-jwt} dt|`` over them gives the amplitude (the DF
    convention of the contract page).  Steady state: the period lengths and per-period
    peak amplitudes agree to ``rtol``.  A relative speed dtheta_d below ``rtol``
    times its largest value over the last ``window`` of the record means the
    motion decayed: no limit cycle, whether it came to rest in the gap (with a
    free load the last contacts come ever more rarely) or at a side of it, where
    round-off can leave a periodic-looking wobble of 1e-15 rad.  The test is
    relative: after a kick 1000 times faster than a small cycle, the cycle is
    taken for rest (``benchmarks/bench_verdicts.py`` meets three such runs).

    Parameters
    ----------
    result : SimulationResult
    periods : int
        Number of full periods to average (at least 2).
    rtol : float
        Relative tolerance of the steady-state test.
    window : float
        Fraction of the record (at its end) examined for shaft contact.
    bound : float, optional
        Largest ``|theta_d|`` (rad) of a run that has not diverged (default ``1e3
        alpha``, five times the largest amplitude the DF search considers).  A run
        that exceeds it, overflows or turns NaN is ``"diverged"``: never a cycle or rest.

    Returns
    -------
    MeasuredCycle
    """
    time, x = result.time, result.theta_d
    bound = 1e3 * result.model.half_gap if bound is None else bound
    if not (np.all(np.isfinite(result.states)) and np.abs(x).max() <= bound):
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, True, "diverged")
    tail = time >= time[-1] * (1.0 - window)
    # decayed: the relative speed has fallen below rtol of its largest value
    resting = np.abs(result.dtheta_d[tail]).max() < rtol * np.abs(result.dtheta_d).max()
    if resting:
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, True, "no limit cycle")
    if np.all(result.mode[tail] == 0):
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, "drifting in the gap")
    half = time >= 0.5 * time[-1]
    center = 0.5 * (x[half].max() + x[half].min())
    crossings = upward_crossings(time[half], x[half] - center)
    if crossings.size < periods + 1:
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, "irregular")
    edges = crossings[-(periods + 1):]
    lengths = np.diff(edges)
    peaks = np.array([np.ptp(x[(time >= a) & (time <= b)]) for a, b in zip(edges[:-1], edges[1:])]) / 2.0
    period = (edges[-1] - edges[0]) / periods
    omega = 2.0 * math.pi / period
    bias = _window_integral(time, x, edges[0], edges[-1]) / (edges[-1] - edges[0])
    c1 = 2.0 * _window_integral(time, x * np.exp(-1j * omega * time), edges[0], edges[-1]) / (edges[-1] - edges[0])
    settled = np.ptp(lengths) <= rtol * period and np.ptp(peaks) <= rtol * peaks.mean()
    if not settled:
        verdict = "decaying" if peaks[-1] < peaks[0] else "growing" if peaks[-1] > peaks[0] else "irregular"
        return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, False, verdict)
    saturation = math.nan
    if result.command_mode is not None:
        saturation = float(np.mean(result.command_mode[(time >= edges[0]) & (time <= edges[-1])] != 0))
    return MeasuredCycle(True, float(abs(c1)), float(peaks.mean()), float(omega), float(bias), True, "limit cycle",
                         periods, saturation)

