"""The verdict on a user's Lur'e loop: will it hunt, settle, or run away?

The describing function's cycles (:meth:`~backlash_df.lure.LureLoop.predict`), their
exact orbits with Floquet multipliers (:meth:`~backlash_df.lure.LureLoop.exact_orbits`)
and **probes**, exact simulations (:meth:`~backlash_df.lure.LureLoop.simulate`) started

* from rest with the output displaced to ``y0`` = 0.5, 1.5, 4 and 16 times the loop's
  scale (the element's threshold, else the smallest cycle's amplitude, else its own
  value), H's state the least-norm one with that output;
* 3 % inside and outside every unstable exact orbit (its state scaled about the origin),
  1 % off every stable one;

each run until it decides (a run that switches faster than it is sampled is run again over
400 switches, 40 samples each): **rest** (half the swing of ``y``, ``(max y - min y) / 2`` over
the last half period or more, below 1e-6 of the scale), **cycle** (the swing holds over
the last two such stretches, to 1 %, and is a stable exact orbit's
:attr:`~backlash_df.LureOrbit.peak` to 1e-3, each also to the run's sampling resolution (half
its largest step between samples: a cusp's sampled extreme is that close at worst); a run whose swing holds at no known orbit's is shot from, and the stable
orbit found joins the verdict's ``simulated_orbits``), **diverged**
(``|y|`` past 1e8 times the scale), else run again from where it stopped, up to four
times; then **diverged** if the last run's largest ``|y|`` is 100 times the start, the scale
and every exact orbit's peak (a polynomial runaway, integrators saturated), else **unsettled**.  The verdict, in the words of
:data:`backlash_df.VERDICTS`:

``no oscillation``
    every probe comes to rest;
``limit cycle``
    every probe ends on a stable cycle (or some run away from beyond an unstable one);
``bistable``
    some rest, some hunt: the largest unstable orbit below the smallest cycle reached
    is the disturbance that starts the hunting;
``unstable``
    no probe ends on a cycle and some run away: the **smallest** unstable orbit bounds
    the rest's basin (motions from just beyond it grow already);
``undetermined``
    a probe did not settle.

The disturbance that starts hunting (or the runaway) is the exact orbit's first-harmonic
amplitude where shooting found it, else the describing function's.
"""

import dataclasses
import math

import numpy as np

from ._json import json_ready
from ._threads import single_threaded_blas
from .lure import LureOrbit
from .orbits import OrbitNotFound
from .plotting import ResultPlot, axes_or_new, legend_beside
from .render.verdict import lure_reason_text

__all__ = ["LureProbe", "LureVerdict", "judge_lure_loop"]

#: The probes' starts from rest, in the loop's scale.
LADDER = (0.5, 1.5, 4.0, 16.0)
#: A start inside and outside an unstable orbit, off a stable one: the factor on its state.
AROUND_UNSTABLE, OFF_STABLE = 0.03, 0.01
#: A run whose |y| passes this many times the loop's scale has run away.
_RUNAWAY = 1e8
#: Samples per period of the slowest cycle (a sampled extreme within 1.2e-4 of the true one).
_SAMPLES = 200
#: A run switching more than this per sample is run again with this many samples per switch, over 400 switches.
_SWITCHES_PER_SAMPLE, _SAMPLES_PER_SWITCH = 0.05, 40
#: A swing and an orbit's peak: the same within this (relative).
_SAME = 1e-3
#: A swing that holds over the last two stretches: within this (a sampled cusp wanders by a few 1e-3).
_STEADY = 1e-2
#: An unsettled run whose largest |y| is this many times its start, the scale and every orbit's peak ran away.
_GROWN = 100.0
#: Runs of ``t_end`` a probe gets before it is unsettled.
RUNS = 4


@dataclasses.dataclass(frozen=True)
class LureProbe:
    """One exact simulation of a Lur'e loop and what it ended in.

    Attributes
    ----------
    start : str
        Where it started: ``"y0 = 1.5"`` or ``"3 % outside the unstable orbit A = 0.664"``.
    size : float
        The start's first-harmonic amplitude scale: ``|y0|``, or the orbit's amplitude times the factor.
    outcome : str
        ``"rest"``, ``"cycle"``, ``"diverged"`` or ``"unsettled"``.
    swing : float
        ``(max y - min y) / 2`` over the last stretch (the last period or so).
    orbit : LureOrbit or None
        The stable exact orbit a ``cycle`` ends on.
    duration : float
        Simulated time, s.
    run : LureSimulation
        The last run, for plots.
    steady : bool
        The swing held over the last two stretches (to 1 % and the sampling's resolution).
    resolution : float
        Half the largest change of ``y`` between two samples of the last stretch: how far a sampled
        extreme may be from the true one (a cusp's, where the element switches).
    """

    start: str
    size: float
    outcome: str
    swing: float
    orbit: object = None
    duration: float = 0.0
    run: object = dataclasses.field(repr=False, default=None)
    steady: bool = False
    resolution: float = 0.0

    def to_dict(self):
        """JSON-ready: start, outcome, swing, duration."""
        return json_ready({"start": self.start, "size": self.size, "outcome": self.outcome, "swing": self.swing,
                           "duration": self.duration})


@dataclasses.dataclass(frozen=True, eq=False)
class LureVerdict:
    """The verdict on a Lur'e loop (module docs).

    Attributes
    ----------
    model : str
        The element's label.
    verdict : str
        One of :data:`backlash_df.VERDICTS`.
    prediction : LimitCyclePrediction
    orbits : tuple of (LimitCycle, LureOrbit or str)
        Each DF cycle with its exact orbit, or why shooting failed.
    probes : tuple of LureProbe
    disturbance_to_start : float or None
        ``bistable``: the amplitude of ``y`` beyond which the loop hunts; ``unstable``: beyond
        which it runs away; None otherwise.
    disturbance_source : str
        ``"exact orbit"``, ``"DF unstable cycle"``, or ``""``.
    df_agrees : bool
        The DF's stable cycles are the exact stable orbits (as many, each within 10 % in A and w).
    simulated_orbits : tuple of LureOrbit
        Stable orbits shot from runs that settled on a swing no DF cycle's orbit has.
    """

    model: str
    verdict: str
    prediction: object = dataclasses.field(repr=False)
    orbits: tuple = dataclasses.field(repr=False)
    probes: tuple = dataclasses.field(repr=False)
    disturbance_to_start: float = None
    disturbance_source: str = ""
    df_agrees: bool = True
    simulated_orbits: tuple = dataclasses.field(repr=False, default=())

    @property
    def reason(self):
        """One sentence: why (:func:`~backlash_df.render.verdict.lure_reason_text`)."""
        return lure_reason_text(self)

    @property
    def exact(self):
        """The exact orbits found, by amplitude."""
        found = [o for _, o in self.orbits if isinstance(o, LureOrbit)] + list(self.simulated_orbits)
        return tuple(sorted(found, key=lambda o: o.amplitude))

    def __repr__(self):
        return f"LureVerdict({self.model}: {self.verdict}; {self.reason})"

    def to_dict(self):
        """JSON-ready: verdict, reason, the DF cycles with their exact orbits, the probes."""
        return json_ready({
            "model": self.model, "verdict": self.verdict, "reason": self.reason,
            "disturbance_to_start": self.disturbance_to_start, "disturbance_source": self.disturbance_source or None,
            "df_agrees": self.df_agrees,
            "cycles": [{**cycle.to_dict(), "exact": orbit.to_dict() if isinstance(orbit, LureOrbit) else None,
                        "exact_note": None if isinstance(orbit, LureOrbit) else orbit}
                       for cycle, orbit in self.orbits],
            "simulated_orbits": [orbit.to_dict() for orbit in self.simulated_orbits],
            "probes": [probe.to_dict() for probe in self.probes],
        })

    def plot(self, ax=None):
        """Every probe's ``|y|`` against time on a log axis, coloured by outcome, the exact orbits' peaks dashed."""
        figure, axes = axes_or_new(ax, figsize=(8.5, 4.2), layout="constrained")
        ax = axes[0]
        colours = {"rest": "C0", "cycle": "C3", "diverged": "C1", "unsettled": "C7"}
        shown = set()
        for probe in self.probes:
            label = None if probe.outcome in shown else probe.outcome
            shown.add(probe.outcome)
            magnitude = np.abs(probe.run.y)
            ax.plot(probe.run.time, np.where(magnitude > 0, magnitude, np.nan), color=colours[probe.outcome],
                    lw=0.8, alpha=0.8, label=label)
        for orbit in self.exact:
            ax.axhline(orbit.peak, color="k", ls="--" if not orbit.stable else "-", lw=0.8,
                       label=f"{'stable' if orbit.stable else 'unstable'} orbit, peak {orbit.peak:.4g}")
        ax.set_yscale("log")
        top = 3.0 * max([float(np.abs(p.run.y).max()) for p in self.probes] + [o.peak for o in self.exact])
        bottom = 1e-3 * min([p.size for p in self.probes] + [o.peak for o in self.exact])
        ax.set_ylim(bottom, top)  # a rest decays to round-off: three decades below the starts show it leave
        ax.set_xlabel("time of the last run (s)")
        ax.set_ylabel("|y|")
        ax.set_title(f"{self.model}: {self.verdict}", fontsize="medium")
        legend = legend_beside(ax, fontsize="small")
        return ResultPlot(figure, axes, legend)


def judge_lure_loop(loop, prediction=None, *, t_end=None):
    """The verdict on a Lur'e loop (module docs).

    Parameters
    ----------
    loop : LureLoop
    prediction : LimitCyclePrediction, optional
        The loop's own (default ``loop.predict()``).
    t_end : float, optional
        Each run, s (default 60 periods of the slowest cycle, or of the middle of the
        searched band); a probe gets up to four.

    Returns
    -------
    LureVerdict
    """
    prediction = loop.predict() if prediction is None else prediction
    orbits = loop.exact_orbits(prediction)
    exact = [o for _, o in orbits if isinstance(o, LureOrbit)]
    omegas = [c.omega for c in prediction.cycles] + [o.omega for o in exact]
    slowest = min(omegas) if omegas else math.sqrt(prediction.omega_range[0] * prediction.omega_range[1])
    t_end = 60.0 * 2.0 * math.pi / slowest if t_end is None else float(t_end)
    if not (t_end > 0.0 and math.isfinite(t_end)):
        raise ValueError(f"t_end must be finite and > 0, got {t_end!r}")
    scale = _scale(loop, prediction, exact)
    with single_threaded_blas():
        probes = [_probe(loop, start, size, state, mode, t_end, slowest, scale, exact)
                  for start, size, state, mode in _starts(loop, exact, scale)]
    found = _shot_from_runs(loop, probes, exact)
    if found:
        probes = [_on(p, found) for p in probes]
    exact = exact + found
    verdict, boundary = _decide(probes, prediction, exact)
    return LureVerdict(
        model=loop.label, verdict=verdict, prediction=prediction, orbits=orbits, probes=tuple(probes),
        disturbance_to_start=boundary[0], disturbance_source=boundary[1], df_agrees=_df_agrees(prediction, exact),
        simulated_orbits=tuple(found),
    )


def _shot_from_runs(loop, probes, exact):
    """Stable orbits shot from the unsettled runs whose swing held (one per distinct swing), none already known."""
    found = []
    for probe in probes:
        if probe.outcome != "unsettled" or not probe.steady:
            continue
        if any(_matches(probe.swing, probe.resolution, o) for o in exact + found):
            continue
        try:
            orbit = loop.periodic_orbit(probe.run)
        except OrbitNotFound:
            continue
        if orbit.stable and _matches(probe.swing, probe.resolution, orbit):
            found.append(orbit)
    return found


def _on(probe, orbits):
    """An unsettled probe whose steady swing is a stable orbit's, as a ``cycle`` on it."""
    for orbit in orbits:
        if probe.outcome == "unsettled" and probe.steady and _matches(probe.swing, probe.resolution, orbit):
            return dataclasses.replace(probe, outcome="cycle", orbit=orbit)
    return probe


def _scale(loop, prediction, exact):
    """The loop's scale of y: the element's threshold, else the smallest cycle's amplitude, else its value."""
    threshold = loop.element.threshold
    if threshold > 0.0:
        return threshold
    amplitudes = [c.amplitude for c in prediction.cycles] + [o.amplitude for o in exact]
    if amplitudes:
        return min(amplitudes)
    return getattr(loop.element, "limit", None) or loop.element.level


def _starts(loop, exact, scale):
    """``(label, size, state, mode)`` of every probe (module docs)."""
    for factor in LADDER:
        state, mode = loop.start(y0=factor * scale)
        yield f"y0 = {factor * scale:.4g}", factor * scale, state, mode
    for orbit in exact:
        shifts = (-AROUND_UNSTABLE, AROUND_UNSTABLE) if not orbit.stable else (OFF_STABLE,)
        for shift in shifts:
            state = orbit.state * (1.0 + shift)
            y, dy, m, _ = loop.signals(orbit.mode, state)
            mode = loop.element.mode_at(float(y), float(dy), float(m), 1)
            where = "inside" if shift < 0 else "outside"
            kind = "stable" if orbit.stable else "unstable"
            yield (f"{100 * abs(shift):.0f} % {where} the {kind} orbit A = {orbit.amplitude:.4g}",
                   orbit.amplitude * (1.0 + shift), state, mode)


def _probe(loop, start, size, state, mode, t_end, slowest, scale, orbits):
    """Run from ``state`` in ``mode`` until the motion decides (module docs)."""
    dt = min(t_end / 4000.0, 2.0 * math.pi / slowest / _SAMPLES)
    window = min(max(2.0 * math.pi / slowest * 1.5, 0.1 * t_end), 0.5 * t_end)
    duration, swings = 0.0, []
    start_state, start_mode = state, mode
    for _ in range(RUNS):
        run = loop.run(state, mode, t_end, dt, bound=_RUNAWAY * scale)
        if run.switches > _SWITCHES_PER_SAMPLE * run.time.size:  # faster than the samples: again, finer
            per_switch = run.time[-1] / run.switches
            dt, t_end = per_switch / _SAMPLES_PER_SWITCH, min(t_end, 400.0 * per_switch)
            window = 0.25 * t_end  # a hundred switches: a cusp's sampled extreme within 1e-3
            state, mode, duration = start_state, start_mode, 0.0
            run = loop.run(state, mode, t_end, dt, bound=_RUNAWAY * scale)
        duration += run.time[-1]
        if run.diverged:
            return LureProbe(start, size, "diverged", math.inf, None, duration, run)
        last = run.time >= run.time[-1] - window
        early, late = (_half_swing(run.y[(run.time >= run.time[-1] - window * f) & (run.time < run.time[-1] - window * g)])
                       for f, g in ((1.0, 0.5), (0.5, -1.0)))
        if late < 1e-6 * scale:
            return LureProbe(start, size, "rest", late, None, duration, run)
        resolution = 0.5 * float(np.abs(np.diff(run.y[last])).max())  # a sampled extreme is this close at worst
        steady = abs(early - late) <= _STEADY * late + resolution
        for orbit in (o for o in orbits if o.stable):
            if steady and _matches(late, resolution, orbit):
                return LureProbe(start, size, "cycle", late, orbit, duration, run, True, resolution)
        swings.append(float(np.abs(run.y).max()))
        state, mode = run.states[-1], int(run.modes[-1])
    if swings[-1] > _GROWN * max(size, scale, *(o.peak for o in orbits)):
        return LureProbe(start, size, "diverged", late, None, duration, run)  # a polynomial runaway (integrators)
    return LureProbe(start, size, "unsettled", late, None, duration, run, steady, resolution)


def _matches(swing, resolution, orbit):
    """Whether a sampled swing is ``orbit``'s peak: to 1e-3, and to the sampling's ``resolution``."""
    return abs(swing - orbit.peak) <= _SAME * orbit.peak + resolution


def _half_swing(y):
    """``(max y - min y) / 2``."""
    return 0.5 * float(y.max() - y.min())


def _decide(probes, prediction, exact):
    """The verdict word and ``(disturbance_to_start, source)`` (module docs)."""
    outcomes = {p.outcome for p in probes}
    if "unsettled" in outcomes:
        return "undetermined", (None, "")
    reached = [p.orbit for p in probes if p.outcome == "cycle"]
    if reached and "rest" in outcomes:
        smallest = min(o.amplitude for o in reached)
        return "bistable", _unstable(prediction, exact, below=smallest, pick=max)
    if reached:
        return "limit cycle", (None, "")
    if "diverged" in outcomes:
        return "unstable", _unstable(prediction, exact, below=math.inf, pick=min)
    return "no oscillation", (None, "")


def _unstable(prediction, exact, below, pick):
    """``pick`` of the unstable cycles' amplitudes below ``below``: exact orbits first, else the DF's."""
    for source, found in (("exact orbit", exact), ("DF unstable cycle", prediction.cycles)):
        amplitudes = [c.amplitude for c in found if not c.stable and c.amplitude < below]
        if amplitudes:
            return float(pick(amplitudes)), source
    return None, ""


def _df_agrees(prediction, exact):
    """As many stable DF cycles as stable exact orbits, each within 10 % of one in A and w."""
    stable = [o for o in exact if o.stable]
    cycles = prediction.stable_cycles
    return len(cycles) == len(stable) and all(
        any(abs(c.amplitude / o.amplitude - 1.0) <= 0.1 and abs(c.omega / o.omega - 1.0) <= 0.1 for o in stable)
        for c in cycles)
