"""Limit cycles measured in time simulations: amplitude, frequency, or why there is none."""

import dataclasses
import itertools
import math

import numpy as np

from .._json import json_ready
from ..render.html import resolved

__all__ = ["MeasuredCycle", "measure_limit_cycle", "BIAS_RESOLUTION"]

#: The share of a measured cycle's amplitude below which its bias is not resolved: the text prints 0.
#: The bias is the mean of theta_d over the measured periods of a run taken as periodic once its
#: periods' lengths and half swings agree to ``rtol``, 1e-3 by default (:func:`measure_limit_cycle`).
#: What is left of the transient then moves every number measured from the run by up to about that
#: share of the swing: the cycle of ``predict examples/load_feedback.toml``, reached from a twist,
#: has an amplitude 5e-4 above the exact orbit's and a bias of 3e-7 rad (2e-6 A) where the orbit's
#: is 0.  The JSON (:meth:`MeasuredCycle.to_dict`) keeps the bias measured.
BIAS_RESOLUTION = 1e-3


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
        True if a steady state was reached (a periodic cycle, or rest), or the run
        diverged (longer runs cannot change that).
    verdict : str
        ``"limit cycle"`` (periodic), ``"sustained oscillation"`` (an oscillation that holds
        its level without a period; ``amplitude``, ``omega`` and ``bias`` are those of its
        dominant harmonic), ``"no limit cycle"`` (rest), ``"decaying"`` or ``"drifting in
        the gap"`` (dying out, to be confirmed by a longer run), ``"oscillating"`` (holding
        its level, to be confirmed likewise), ``"converging"``, ``"growing"`` or
        ``"irregular"`` (not settled), or ``"diverged"`` (overflow, NaN, or theta_d beyond
        the bound of :func:`measure_limit_cycle`).
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
            f"omega={self.omega:.6g} rad/s, bias={self._bias_text()} rad, periods={self.periods})"
        )

    def _bias_text(self):
        """The bias (rad) at the resolution of its measurement: ``0`` below :data:`BIAS_RESOLUTION` times the amplitude.

        Examples
        --------
        >>> cycle = MeasuredCycle(True, 0.1506, 0.1542, 95.87, 3.25e-07, True, "limit cycle", 6)
        >>> cycle._bias_text(), MeasuredCycle(True, 0.1467, 0.15, 95.0, -0.02077, True, "limit cycle", 6)._bias_text()
        ('0', '-0.0208')
        """
        return f"{resolved(self.bias, BIAS_RESOLUTION * self.amplitude):.3g}"

    def __str__(self):
        """What a report prints: ``limit cycle: A = 0.151 rad, w = 95.9 rad/s (...)`` or the verdict."""
        if not self.found:
            return self.verdict
        limit = "" if math.isnan(self.saturation) else f", command on its limit {100 * self.saturation:.0f} % of the time"
        if not self.periodic:
            return (f"sustained oscillation without a period: dominant harmonic A = {self.amplitude:.4g} rad, "
                    f"w = {self.omega:.4g} rad/s (peak {self.peak:.4g} rad, bias {self._bias_text()} rad, "
                    f"{self.periods} of its periods{limit})")
        return (f"limit cycle: A = {self.amplitude:.4g} rad, w = {self.omega:.4g} rad/s "
                f"(peak {self.peak:.4g} rad, bias {self._bias_text()} rad, {self.periods} periods averaged{limit})")

    @property
    def periodic(self):
        """True for a periodic cycle; False for a sustained oscillation without a period, or none."""
        return self.found and self.verdict == "limit cycle"

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
        """``{"amplitude", "omega", "periodic"}`` (rad, rad/s) as in the ``predict`` JSON's ``simulated``, or ``None``.

        ``periodic`` is false for a sustained oscillation without a period (its dominant
        harmonic's amplitude and frequency).  With a torque limit also ``saturation``,
        the share of the cycle with the command on its limit.
        """
        if not self.found:
            return None
        out = {"amplitude": float(self.amplitude), "omega": float(self.omega), "periodic": self.periodic}
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


#: Windows the second half of a record is split into for the trend of the motion.
TREND_WINDOWS = 8
#: Words of a motion that dies out without a steady state yet: a second, longer run confirms them as rest.
DYING = ("decaying", "drifting in the gap", "held by friction")
_ROUNDOFF = 1e-9  # a relative speed this far below the record's largest is round-off: rest
_LEVEL = 0.1  # an oscillation holding its level: the RMS of its second half's halves within 10 % ...
_SWING = 0.05  # ... and its swing within 5 % of the shorter run's
_SLEW_RATIO = 10.0  # a drive this many times faster than the shaft's relative speed turns as one body
_STANDING = 1e-6  # a level speed that turns its angle by less than this many gaps over the second half stands still


def _windows(time, count):
    """Index bounds of ``count`` equal windows tiling the second half of ``time``."""
    edges = np.searchsorted(time, np.linspace(0.5 * time[-1], time[-1], count + 1))
    edges[-1] = time.size
    return list(zip(edges[:-1], edges[1:]))


def motion_trend(result, count=TREND_WINDOWS):
    """The relative speed's envelope and the switches of the motion over successive windows.

    The second half of the record is split into ``count`` equal windows; in each,
    the largest ``|dtheta_d|`` (rad/s) and the number of switches (mode changes of
    the backlash, and of the torque command where it has a limit).

    Returns
    -------
    envelope : ndarray, shape (count,)
    switches : ndarray of int, shape (count,)
    """
    windows = _windows(result.time, count)
    changes = _changes(result)
    envelope = _per_window(windows, np.abs(result.dtheta_d), np.max)
    switches = np.array([int(changes[max(a - 1, 0):b - 1].sum()) for a, b in windows])
    return envelope, switches


def _changes(result):
    """Per sample interval: whether the backlash's mode (or the torque command's, where it has a limit) changed."""
    changes = np.diff(result.mode) != 0
    if result.command_mode is not None:
        changes |= np.diff(result.command_mode) != 0
    return changes


def _per_window(windows, values, reduce):
    """``reduce`` (``np.max``, say) of ``values`` over each window of :func:`_windows`."""
    return np.array([reduce(values[a:b]) for a, b in windows])


def measure_limit_cycle(result, *, periods=6, rtol=1e-3, window=0.25, bound=None, previous=None):
    """Measure the limit cycle at the end of a closed-loop simulation, or name why there is none.

    The last ``periods`` full periods of theta_d (between upward crossings of its
    mean, located by linear interpolation) give the frequency; the first harmonic
    ``|2/T int theta_d e^{-jwt} dt|`` over them gives the amplitude (the DF
    convention of the contract page).  Steady state: the period lengths and per-period
    peak amplitudes agree to ``rtol``.  With no contact at the end of the record and
    theta_d drifting (a load coasting across the gap while the motor's loop, on its
    torque limit, hums), the periods are those of the relative speed ``dtheta_d``
    and the amplitude that of theta_d less its drift.

    Without a steady state the motion is judged from its trend over successive
    windows of the record's second half (:func:`motion_trend`), never from one
    window's amplitude:

    * **rest** (``"no limit cycle"``): the relative speed is round-off (1e-9 of
      its largest value, or a level without a switch too small to turn theta_d by
      a millionth of the gap over the second half: :func:`_standing`), or its
      envelope falls over a second half without a switch (contact, release,
      command limit) and in contact: one linear mode, decaying to its rest; never
      with the torque command on its limit in the second half (the drive may
      accelerate with the shaft still);
    * **held by friction** (``"held by friction"``): every rubbing side of a loop with
      dry friction stuck through the second half, the backlash in one mode
      (:func:`_held_by_friction`): integral action creeping to rest against the
      friction, however its slow wind-up moves the envelope; confirmed as rest by
      ``previous`` as a dying motion is (below);
    * **dying out** (``"decaying"``): the coasting speeds of the last three free
      flights across the gap fall by 20 % a flight at least (:func:`free_flights`),
      as when a free load bounces between the flanks ever more slowly (its speed
      decays like 1/t in time: theta_d sweeps the gap for as long as one
      simulates); or, in contact, the envelope falls and the switches thin out
      (15 % fewer in the last quarter than in the one before, the envelope
      still at its lowest at the end: :func:`_still_falling`; or about as many
      in each of the last three octaves of time, where a cycle has twice as many
      in each as in the one before: :func:`_slowing`); **drifting in the
      gap** (``"drifting in the gap"``): no contact in the last ``window`` of the
      record.  Neither is settled: ``previous``, the measurement of a shorter run
      from the same start that said either, confirms it as rest;
    * **holding its level** (``"oscillating"``): no period, but the envelope and
      the switch counts hold over the second half (:func:`_holds_level`): a
      quasi-periodic or chaotic hunt, or a slow drift onto a cycle.  Not settled:
      the shorter run of ``previous`` saying so with the same swing
      confirms it as ``"sustained oscillation"`` (``found``, with the dominant
      harmonic's amplitude and frequency; :attr:`MeasuredCycle.periodic` false);
    * ``"converging"``, ``"growing"`` or ``"irregular"``: the envelope falls
      with switches that do not thin out (a slowly settling cycle), rises, or
      neither; not settled.

    None of the rests and dying motions holds while the whole drive turns, motor
    and load together many times faster than the shaft's relative speed
    (:func:`_slewing`; a position loop slewing on its torque limit while theta_d
    rests on a flank): unless the relative speed has fallen over the second half
    without a switch (one linear mode), the motion is then ``"converging"``,
    ``"growing"`` or ``"irregular"`` by the drive's own speed envelope.

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
    previous : MeasuredCycle, optional
        The measurement of a shorter run from the same start (the runs of
        :func:`~backlash_df.simulation.simulated_limit_cycle`).

    Returns
    -------
    MeasuredCycle
    """
    time, x = result.time, result.theta_d
    bound = 1e3 * result.model.half_gap if bound is None else bound
    if not (np.all(np.isfinite(result.states)) and np.abs(x).max() <= bound):
        return _none("diverged", True)
    envelope, switches = motion_trend(result)
    # the command on its limit in the second half: the drive may accelerate while theta_d stands still
    limited = result.command_mode is not None and bool(np.any(result.command_mode[time >= 0.5 * time[-1]]))
    drive = _slewing(result, envelope)
    round_off = envelope[-1] <= _ROUNDOFF * np.abs(result.dtheta_d).max()
    still = round_off or (not switches.any() and _standing(result, envelope))
    if still and not limited and drive is None:
        return _none("no limit cycle", True)
    if not limited and _held_by_friction(result):
        word = "held by friction"
        confirmed = previous is not None and previous.verdict in DYING
        return _none("no limit cycle", True) if confirmed else _none(word, False)
    free_tail = np.all(result.mode[time >= time[-1] * (1.0 - window)] == 0)
    measured = _steady_cycle(result, periods, rtol)
    if measured is None and free_tail:  # a periodic motion carried by a load coasting across the gap
        measured = _steady_cycle(result, periods, rtol, drifting=True)
    if measured is not None:
        return measured
    half = TREND_WINDOWS // 2
    falling = _falling(envelope)
    if drive is None and _holds_level(result, switches):  # before the flights: a chaotic hunt has slow ones too
        return _oscillation(result, previous)
    if _bounces_die(result) and drive is None:
        word = "decaying"
    elif free_tail and not limited:
        word = "drifting in the gap"
    elif falling and not switches.any() and not limited:
        return _none("no limit cycle", True)  # one linear mode over the second half, decaying to its rest
    elif drive is not None:  # the drive turns as one body: its own speed gives the trend
        return _none(_trend(drive), False)
    elif falling and ((switches[half:].sum() <= 0.85 * switches[:half].sum() and _still_falling(envelope))
                      or _slowing(result)):
        word = "decaying"
    else:
        word = _trend(envelope)
    if word in DYING and previous is not None and previous.verdict in DYING:
        return _none("no limit cycle", True)
    return _none(word, False)


def _held_by_friction(result):
    """True if dry friction holds every rubbing side stuck through the record's second half, the backlash in one mode.

    The loop then stands still but for its controller winding up against the friction:
    integral action creeping to rest breaks the side away ever later, each slide ending
    nearer the rest (Olsson and Astrom), and the shaft's slow wind-up would be read as a
    growing or irregular envelope from the round-off of its speed.  A stick-slip cycle, or
    a motor hunting in the gap against a locked load, breaks away or switches the backlash
    in every half of a run long against its period; a second, longer run confirms it
    (:data:`DYING`).
    """
    if result.friction_mode is None or result.friction_mode.shape[1] == 0:
        return False
    later = result.time >= 0.5 * result.time[-1]
    return bool(np.all(result.friction_mode[later] == 0) and np.all(result.mode[later] == result.mode[-1]))


def _slowing(result, least=4, ratio=1.5, falls=(0.35, 0.8)):
    """True if the motion dies like a power of time: as many switches per octave of time, not per second.

    Of the record's last three octaves of time, ``[T/8, T/4]``, ``[T/4, T/2]`` and
    ``[T/2, T]``, the first holds ``least`` switches (:func:`motion_trend`) or more
    and each later one at most ``ratio`` times as many, and the peak relative speed
    of each later octave is ``falls[0]`` to ``falls[1]`` times the one before (a
    speed falling like ``t**-p``, ``p`` about 0.3 to 1.5).  A motion that dies so (a
    load nudged off a flank ever more slowly, its relative speed halving with every
    doubling of time) switches about equally often in every octave, whatever the
    run's length; a cycle switches at its constant rate, four times as often in the
    last octave as in the first, and a motion approaching one from a larger, slower
    swing two to four times as often.  A hard kick's swing collapsing onto a cycle
    can switch about as often in three octaves, but its peak falls faster, to a
    third or less per octave.
    """
    time, changes, speed = result.time[1:], _changes(result), np.abs(result.dtheta_d[1:])
    octaves = [(time >= low * time[-1]) & (time < 2.0 * low * time[-1]) for low in (0.125, 0.25)]
    octaves.append(time >= 0.5 * time[-1])
    counts = [int(changes[octave].sum()) for octave in octaves]
    peaks = [speed[octave].max(initial=0.0) for octave in octaves]
    power_law = all(falls[0] * earlier <= later <= falls[1] * earlier for earlier, later in itertools.pairwise(peaks))
    return counts[0] >= least and max(counts[1:]) <= ratio * counts[0] and power_law


def _holds_level(result, switches):
    """True if the second half's motion neither grows nor dies: an oscillation holding its level.

    In :func:`motion_trend`'s windows: every one switches 4 times or more; the root
    mean square of the relative speed over the last half of them is within
    :data:`_LEVEL` of the first half's, as are their switch counts; no
    window's RMS is 30 % above another's.  (The RMS, not the largest speed: a
    chaotic hunt's peaks wander by several per cent from window to window.)
    """
    rms = np.sqrt(_per_window(_windows(result.time, switches.size), result.dtheta_d**2, np.mean))
    half = switches.size // 2
    return bool(switches.min() >= 4 and rms.max() <= 1.3 * rms.min()
                and abs(np.sqrt(np.mean(rms[half:] ** 2) / np.mean(rms[:half] ** 2)) - 1.0) <= _LEVEL
                and abs(switches[half:].sum() / switches[:half].sum() - 1.0) <= _LEVEL)


def _oscillation(result, previous):
    """An oscillation that holds its level but has no period: ``"oscillating"``, or confirmed ``"sustained oscillation"``.

    Its dominant harmonic over the record's second half (theta_d resampled on a
    uniform grid, Hann window, the spectrum's largest peak refined by a parabola
    through its log magnitudes) gives ``amplitude``, ``omega`` and ``bias``; ``peak``
    is half theta_d's swing there.  It is confirmed (settled, ``found``) where
    ``previous``, the shorter run from the same start, said ``"oscillating"`` with a
    swing (``peak``) within :data:`_SWING` of this one's (the swing holds where the
    dominant harmonic of a chaotic hunt wanders by several per cent).
    """
    time = result.time
    grid = np.linspace(0.5 * time[-1], time[-1], 2**16)
    x = np.interp(grid, time, result.theta_d)
    bias = float(x.mean())
    window = np.hanning(grid.size)
    spectrum = np.abs(np.fft.rfft((x - bias) * window))
    k = int(np.argmax(spectrum[1:-1])) + 1
    a, b, c = np.log(spectrum[k - 1:k + 2] + 1e-300)
    shift = 0.5 * (a - c) / (a - 2.0 * b + c) if a - 2.0 * b + c < 0.0 else 0.0
    span = grid[-1] - grid[0]
    omega = 2.0 * math.pi * (k + shift) * (grid.size - 1) / grid.size / span
    amplitude = 2.0 * spectrum[k] / window.sum()
    saturation = math.nan
    if result.command_mode is not None:
        saturation = float(np.mean(result.command_mode[time >= 0.5 * time[-1]] != 0))
    peak = float(np.ptp(x)) / 2.0
    confirmed = previous is not None and previous.verdict == "oscillating" and abs(peak / previous.peak - 1.0) <= _SWING
    return MeasuredCycle(confirmed, float(amplitude), peak, float(omega), bias, confirmed,
                         "sustained oscillation" if confirmed else "oscillating", int(omega * span / (2.0 * math.pi)),
                         saturation)


def confirm_across_starts(measured):
    """The measurements of runs from different starts, each ``"oscillating"`` one confirmed by another at its swing.

    Two runs from different starts that each hold their level with swings
    (``peak``, rad) within :data:`_SWING` of each other are on one sustained
    oscillation, as two runs from one start are (:func:`measure_limit_cycle`'s
    ``previous``).  A chaotic hunt's runs from one start can call it ``"irregular"``
    in one run and ``"oscillating"`` in the next as their windows catch its bursts;
    across starts it confirms itself.  Other measurements are returned as they are.

    Parameters
    ----------
    measured : sequence of MeasuredCycle

    Returns
    -------
    list of MeasuredCycle
    """
    holding = [m for m in measured if m.verdict in ("oscillating", "sustained oscillation")]

    def confirmed(m):
        return any(o is not m and abs(m.peak / o.peak - 1.0) <= _SWING for o in holding)

    return [dataclasses.replace(m, found=True, settled=True, verdict="sustained oscillation")
            if m.verdict == "oscillating" and confirmed(m) else m for m in measured]


def _still_falling(envelope):
    """True if the last window of :func:`motion_trend`'s envelope is the lowest of the record's last quarter.

    A dying motion is still falling at the end; a hard kick's swing that has
    collapsed onto a cycle levels off there while its switches thin out.
    """
    return bool(envelope[-1] <= envelope[envelope.size // 2:-1].min())


def _falling(envelope):
    half = envelope.size // 2
    return bool(envelope[-1] < envelope[half] < envelope[0])


def _trend(envelope):
    """``"converging"``, ``"growing"`` or ``"irregular"``: an unsettled motion's envelope falls, rises, or neither."""
    return "converging" if _falling(envelope) else "growing" if envelope[-1] > envelope[0] else "irregular"


def free_flights(result):
    """The motion's free flights: coasting speed (median ``|dtheta_d|``, rad/s) and whether each crossed the gap.

    A free flight is a stretch of samples in the free mode (mode 0) between two
    contacts; it crossed the gap when the contacts are on opposite flanks.  A flight
    still under way at the end of the record is left out.

    Returns
    -------
    speeds : ndarray
    crossed : ndarray of bool
    """
    free = np.concatenate(([False], result.mode == 0, [False]))
    edges = np.flatnonzero(np.diff(free.astype(np.int8)))
    speed = np.abs(result.dtheta_d)
    flights = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if a > 0 and b < result.mode.size and b - a >= 3]
    speeds = np.array([np.median(speed[a:b]) for a, b in flights])
    crossed = np.array([result.mode[a - 1] * result.mode[b] < 0 for a, b in flights], dtype=bool)
    return speeds, crossed


def _slewing(result, envelope):
    """The drive's speed envelope (:func:`motion_trend`'s windows) if the whole drive moves, else None.

    The drive moves where the larger of ``|w_m|`` and ``|w_l|`` (rad/s) over the
    last window is more than :data:`_SLEW_RATIO` times the relative speed's
    ``envelope`` (:func:`motion_trend`) there,
    and neither round-off of its own largest nor standing (:func:`_standing`): motor and load turn together, in contact
    (a position loop slewing on its torque limit), while the shaft's relative speed
    stands still.  Such a motion is no rest, and the relative speed says nothing of
    its trend.  None where the states hold no motor and load speed (a user's linear
    part).
    """
    if not {"motor_speed", "load_speed"} <= set(result.state_names):
        return None
    speed = np.maximum(np.abs(result.state("motor_speed")), np.abs(result.state("load_speed")))
    drive = _per_window(_windows(result.time, envelope.size), speed, np.max)
    moves = drive[-1] > _ROUNDOFF * speed.max() and not _standing(result, drive)
    return drive if drive[-1] > _SLEW_RATIO * envelope[-1] and moves else None


def _standing(result, envelope):
    """True if a speed's envelope (rad/s, :func:`motion_trend`'s windows) holds a level within
    :data:`_LEVEL` too small to turn its angle by :data:`_STANDING` times the gap ``alpha`` over
    the record's second half: the round-off floor of a rest, not a motion.

    A rest computed in floating point sits off the true one by about ``eps |z| / (dt
    |p|)`` (``p`` the slowest pole): on a stiff loop with a slow integrator, speeds of
    1e-12 rad/s that hold for ever, whatever the disturbance was.  Measured against
    the run's largest speed (:data:`_ROUNDOFF`), they look like motion after a small
    disturbance.
    """
    level = envelope.max() <= (1.0 + _LEVEL) * envelope.min()
    return bool(level and envelope[-1] * 0.5 * result.time[-1] <= _STANDING * result.model.half_gap)


def _bounces_die(result, loss=0.8):
    """True if the load bounces from flank to flank ever slower, towards rest.

    The last three free flights that cross the gap are each at most ``loss`` times
    as fast as the one before (flights that return to the flank they left, a load
    brushing a flank between crossings, are passed over): bounces that lose a share
    of their speed at every contact (speeds ``s r^k``, the 1/t decay in time of a
    free load).  A cycle forming has
    flights whose speeds tend to its own, their ratios to 1; one still far from it
    may look the same for a while, which the longer run that must confirm the decay
    tells apart.
    """
    speeds, crossed = free_flights(result)
    speeds = speeds[crossed][-3:]
    return bool(speeds.size == 3 and np.all(speeds[1:] <= loss * speeds[:-1]))


def _none(verdict, settled):
    return MeasuredCycle(False, math.nan, math.nan, math.nan, math.nan, settled, verdict)


def _steady_cycle(result, periods, rtol, drifting=False):
    """The periodic steady state at the end of the record (module docs), or None.

    ``drifting``: the periods are those of the relative speed, and theta_d is taken
    less its mean drift over them (a motion inside the gap while the load coasts).
    """
    time, x = result.time, result.theta_d
    signal = result.dtheta_d if drifting else x
    half = time >= 0.5 * time[-1]
    center = 0.5 * (signal[half].max() + signal[half].min())
    crossings = upward_crossings(time[half], signal[half] - center)
    if crossings.size < periods + 1:
        return None
    edges = crossings[-(periods + 1):]
    lengths = np.diff(edges)
    windows = [(time >= a) & (time <= b) for a, b in zip(edges[:-1], edges[1:])]
    peaks = np.array([np.ptp(signal[inside]) for inside in windows]) / 2.0
    period = (edges[-1] - edges[0]) / periods
    if not (np.ptp(lengths) <= rtol * period and np.ptp(peaks) <= rtol * peaks.mean()):
        return None
    span = edges[-1] - edges[0]
    omega = 2.0 * math.pi / period
    bias = _window_integral(time, x, edges[0], edges[-1]) / span
    if drifting:
        x = x - (np.interp(edges[-1], time, x) - np.interp(edges[0], time, x)) / span * time
    peak = float(np.mean([np.ptp(x[inside]) for inside in windows])) / 2.0
    c1 = 2.0 * _window_integral(time, x * np.exp(-1j * omega * time), edges[0], edges[-1]) / span
    saturation = math.nan
    if result.command_mode is not None:
        saturation = float(np.mean(result.command_mode[(time >= edges[0]) & (time <= edges[-1])] != 0))
    return MeasuredCycle(True, float(abs(c1)), peak, float(omega), float(bias), True, "limit cycle", periods,
                         saturation)
