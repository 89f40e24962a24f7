"""A verdict for every loop: will this tuning hunt, settle, or run away?

The describing function answers a local question (is there a harmonic balance,
Loeb's criterion at it); a control engineer asks a global one.  The verdict
weighs three kinds of evidence for one rig and one torque law:

* **linear stability** of the loop with the gear *in contact* (the shaft as
  the spring-damper ``T = k theta_d + c dtheta_d``, the regime of large motions)
  and with the gear *open* (``T = 0``, inside the gap), from the closed-loop
  state matrix with the dead time replaced by its Pade approximation
  (:func:`control.pade`);
* the **DF cycles** of :func:`~backlash_df.limit_cycles.predict_limit_cycles`
  with Loeb stability;
* **time simulations** from rest disturbed by kicks of several sizes
  (``dtheta_d(0) = a w`` with theta_d(0) = 0 in the middle of the gap, so the
  shaft swings about ``a`` rad), each run until a steady state, an overflow or
  a blow-up (:func:`~backlash_df.simulation.measure_limit_cycle`).

and names one of

``no oscillation``
    every kick settles (the largest one is stated);
``limit cycle``
    every kick that brings the shaft into contact ends on a stable cycle;
``bistable``
    small kicks settle, larger ones start a cycle; the separating (unstable)
    cycle's amplitude is the disturbance that starts the hunting;
``unstable``
    the loop in contact is unstable and no stable cycle caps the growth;
``undetermined``
    the DF predicts a stable cycle that no simulation reaches, the motion does
    not settle, or a loop stable in contact diverges.

Where the simulations reach a cycle the DF misses or misplaces (nearly tangent
loci, a slow motion far from the DF's sinusoid), the verdict follows the
simulations and says ``DF UNRELIABLE`` in its reason (``df_agrees`` False).
"""

import dataclasses
import math
import warnings

import numpy as np

from .limit_cycles import default_ranges
from .loops import DriveLoop, drive_loop
from .orbits import exact_orbits
from .plotting import ResultPlot, axes_or_new, legend_beside, log_scale
from .report import roundoff_zero, signed_percent, text_table
from .simulation import simulated_limit_cycle
from .system import closed_loop_matrix, lti_linear_part, with_pade

__all__ = ["VERDICTS", "LinearStability", "Probe", "LoopVerdict", "linear_stability", "judge_loop", "judge",
           "verdict_rows", "orbit_rows", "VERDICT_NOTE", "ORBIT_NOTE"]

VERDICTS = ("no oscillation", "limit cycle", "bistable", "unstable", "undetermined")

PADE_ORDER = 8
DISTURBANCES = (1.1, 1.5, 3.0, 6.0, 12.0, 24.0)  # kick sizes a / alpha from rest
AMPLITUDE_MATCH, OMEGA_MATCH = 0.2, 0.1  # DF cycle "is" the simulated one within these relative errors
_SAME_CYCLE = 0.01  # relative amplitude difference of two runs that reached the same cycle


# --------------------------------------------------------------------------- linear loop


@dataclasses.dataclass(frozen=True)
class LinearStability:
    """Stability of the loop with the backlash replaced by a linear shaft.

    Attributes
    ----------
    regime : str
        ``"contact"`` (``T = k theta_d + c dtheta_d``) or ``"open"`` (``T = 0``).
    poles : ndarray of complex
        Closed-loop poles, 1/s, by decreasing real part (with the dead time's
        Pade poles when the loop has one).
    pade_order : int
        Order of the Pade approximation of the dead time (0 without one).
    """

    regime: str
    poles: np.ndarray
    pade_order: int

    @property
    def max_real(self):
        """Largest real part of the poles, 1/s."""
        return float(self.poles[0].real)

    @property
    def stable(self):
        """All poles in the open left half plane."""
        return self.max_real < -self._tolerance

    @property
    def marginal(self):
        """No pole on the right, one or more on the imaginary axis (e.g. a free load)."""
        return abs(self.max_real) <= self._tolerance

    @property
    def _tolerance(self):
        return 1e-9 * max(np.abs(self.poles).max(), 1.0)

    @property
    def status(self):
        """``"stable"``, ``"marginal"`` or ``"unstable"``."""
        return "stable" if self.stable else "marginal" if self.marginal else "unstable"

    def describe(self):
        """One phrase: status and the rightmost pole, e.g. ``unstable (pole 8.6 +- 262j 1/s)``."""
        pole = self.poles[0]
        text = f"{pole.real:.4g}" + (f" +- {abs(pole.imag):.4g}j" if abs(pole.imag) > 0 else "")
        return f"{self.status} (rightmost pole {text} 1/s)"

    def __repr__(self):
        return (f"LinearStability({self.regime}: {self.describe()}, {self.poles.size} poles, "
                f"Pade order {self.pade_order})")

    def to_dict(self, count=6):
        """JSON entry: status, the rightmost ``count`` poles as ``[re, im]`` (1/s), Pade order."""
        return {
            "stable": bool(self.stable),
            "status": self.status,
            "max_real": self.max_real,
            "poles": [[float(p.real), float(p.imag)] for p in self.poles[:count]],
            "pade_order": int(self.pade_order),
        }


def linear_stability(part, stiffness, damping, regime="contact", pade_order=PADE_ORDER):
    """Poles of a loop whose shaft is the linear spring-damper ``T = k theta_d + c dtheta_d``.

    Parameters
    ----------
    part : LinearPart
        The loop cut at the backlash (:meth:`DriveLoop.linear_part` or
        :func:`~backlash_df.loops.lti_linear_part`).
    stiffness, damping : float
        k (N m/rad) and c (N m s/rad); ``0, 0`` for the open gear.
    regime : str
        Label stored in the result (``"contact"`` or ``"open"``).
    pade_order : int
        Pade order for the dead time, realised by :func:`backlash_df.system.with_pade`
        (the realisation the exact orbits use).

    Returns
    -------
    LinearStability

    Examples
    --------
    >>> from backlash_df import Plant, Controller, DriveLoop
    >>> loop = DriveLoop(Plant(0.4, 5.6, 5895.0, 0.05, damping=3.0), Controller(kp=30.0, ti=0.5))
    >>> linear_stability(loop.linear_part(), 5895.0, 3.0).status
    'stable'
    """
    order = int(pade_order) if part.delay > 0.0 else 0
    matrix = closed_loop_matrix(with_pade(part, order) if order else part, stiffness, damping)
    poles = np.linalg.eigvals(matrix)
    return LinearStability(regime, poles[np.argsort(-poles.real, kind="stable")], order)


# --------------------------------------------------------------------------- simulations


@dataclasses.dataclass(frozen=True)
class Probe:
    """One simulation from rest with a kick.

    Attributes
    ----------
    disturbance : float
        a, rad: the swing of theta_d the kick starts (``kick = a w``).
    kick : float
        Initial dtheta_d, rad/s (theta_d(0) = 0).
    measured : MeasuredCycle
        What the run settled to.
    """

    disturbance: float
    kick: float
    measured: object

    @property
    def outcome(self):
        """``"cycle"``, ``"rest"``, ``"diverged"`` or ``"unsettled"``.

        No contact in the last quarter of the run (``drifting in the gap``) and
        a slow ``decaying`` count as rest.
        """
        verdict = self.measured.verdict
        if self.measured.found:
            return "cycle"
        if verdict in ("no limit cycle", "drifting in the gap", "decaying"):
            return "rest"
        return "diverged" if verdict == "diverged" else "unsettled"

    def __repr__(self):
        return f"Probe(disturbance={self.disturbance:.4g} rad, kick={self.kick:.4g} rad/s: {self.outcome})"

    def to_dict(self):
        """JSON entry: disturbance (rad), kick (rad/s), outcome, simulated cycle or null, measured verdict."""
        return {"disturbance": self.disturbance, "kick": self.kick, "outcome": self.outcome,
                "simulated": self.measured.cycle_dict(), "measured": self.measured.verdict}


def _probes(rig, model, prediction, linear, t_end, max_t_end, disturbances):
    """Simulations from kicks: the ladder ``disturbances * alpha`` at the shaft mode, and the stable DF cycles."""
    _, (_, w_hi) = default_ranges(rig)
    w_n = w_hi / 3.0
    probes = [Probe(float(c.amplitude), float(c.amplitude * c.omega), c.simulated)
              for c in prediction.cycles if c.simulated is not None]
    for factor in disturbances:
        size = factor * model.half_gap
        measured, _ = simulated_limit_cycle(rig, model, t_end=t_end, max_t_end=max_t_end, kick=size * w_n,
                                            linear=linear)
        probes.append(Probe(size, size * w_n, measured))
    return tuple(sorted(probes, key=lambda p: p.disturbance))


# --------------------------------------------------------------------------- verdict


@dataclasses.dataclass(frozen=True)
class LoopVerdict:
    """The verdict on one loop with one torque law, and its evidence.

    Attributes
    ----------
    model : str
        Torque-law name.
    verdict : str
        One of :data:`VERDICTS`.
    reason : str
        One sentence: why.
    contact_loop, open_loop : LinearStability
        The loop with the gear in contact (shaft ``k + c s``) and open (``T = 0``).
    probes : tuple of Probe
        Simulations from rest with kicks, by increasing size.
    disturbance_to_start : float or None
        ``bistable`` (and ``unstable`` with a stable rest): the amplitude of
        theta_d (rad) beyond which the loop hunts or runs away.
    disturbance_source : str
        Where ``disturbance_to_start`` comes from: ``"DF unstable cycle"``,
        ``"exact orbit"`` or ``"simulations"`` (midway between the largest
        settling and the smallest cycling kick); ``""`` if none.
    settles_up_to : float or None
        ``no oscillation`` and ``bistable``: the largest tested disturbance
        (rad) from which the loop settled.
    cycle : MeasuredCycle or None
        The stable cycle the simulations reached (the smallest, if several).
    df_agrees : bool or None
        Whether the DF's stable cycles agree with the simulations (a stable DF
        cycle within 20 % in amplitude and 10 % in frequency of the simulated
        one, or none where none is simulated); None where the simulations
        decided nothing.  False flags nearly tangent loci or a motion far from
        the DF's sinusoid: the verdict rests on the simulations.
    orbits : tuple of PeriodicOrbit
        Exact periodic orbits by shooting (:func:`~backlash_df.orbits.exact_orbits`),
        if asked for; empty otherwise.
    orbit_note : str
        Why there are no exact orbits when they were asked for (unsupported law,
        shooting failed); ``""`` otherwise.
    saturated : bool
        The stable cycle the simulations reached has its torque command on the
        limit: with a contact loop that is unstable, the limit is what caps the growth.
    prediction : LimitCyclePrediction or None
        The (verified) DF prediction the verdict weighed.
    """

    model: str
    verdict: str
    reason: str
    contact_loop: LinearStability
    open_loop: LinearStability
    probes: tuple
    disturbance_to_start: float = None
    disturbance_source: str = ""
    settles_up_to: float = None
    cycle: object = None
    df_agrees: bool = None
    orbits: tuple = ()
    orbit_note: str = ""
    saturated: bool = False
    prediction: object = dataclasses.field(default=None, repr=False, compare=False)

    def __repr__(self):
        return f"LoopVerdict({self.model}: {self.verdict}; {self.reason})"

    def to_dict(self):
        """The verdict fields of a ``models`` entry of the ``predict`` JSON (contract page)."""
        return {
            "verdict": self.verdict,
            "reason": self.reason,
            "contact_loop": self.contact_loop.to_dict(),
            "open_loop": self.open_loop.to_dict(),
            "disturbance_to_start": self.disturbance_to_start,
            "disturbance_source": self.disturbance_source or None,
            "settles_up_to": self.settles_up_to,
            "simulated_cycle": None if self.cycle is None else self.cycle.cycle_dict(),
            "df_agrees": self.df_agrees,
            "saturated": bool(self.saturated),
            "probes": [probe.to_dict() for probe in self.probes],
            "exact_orbits": [orbit.to_dict() for orbit in self.orbits],
        }

    def plot(self, ax=None):
        """What each disturbance ended in: the probes' cycle amplitudes against their size.

        Each probe (a kick from rest, :attr:`probes`) is a marker at its
        disturbance (rad, log scale) and the amplitude A it ended on (rad; rest
        drawn at the bottom edge, divergence at the top); the DF cycles and the
        exact orbits are horizontal lines (solid: stable, dashed: unstable), so
        a bistable loop shows its separating cycle between the settling and the
        hunting kicks.

        Returns
        -------
        ResultPlot
            One panel; the legend beside it.
        """
        figure, axes = axes_or_new(ax, figsize=(9, 4), layout="constrained")
        ax = axes[0]
        sizes = [p.disturbance for p in self.probes]
        levels = [p.measured.amplitude for p in self.probes if p.outcome == "cycle"]
        levels += [c.amplitude for c in (self.prediction.cycles if self.prediction is not None else ())]
        levels += [o.amplitude for o in self.orbits]
        low, high = (min(levels + sizes) / 3.0, max(levels + sizes) * 3.0) if sizes else (1e-3, 1.0)
        marks = {"cycle": ("o", "C3", "ends on a cycle"), "rest": ("v", "C2", "settles"),
                 "diverged": ("^", "k", "diverges"), "unsettled": ("s", "0.5", "does not settle")}
        for outcome, (marker, colour, label) in marks.items():
            chosen = [p for p in self.probes if p.outcome == outcome]
            if chosen:
                y = [p.measured.amplitude if outcome == "cycle" else low if outcome == "rest" else high
                     for p in chosen]
                ax.plot([p.disturbance for p in chosen], y, marker, color=colour, ls="none", label=label)
        for cycle in () if self.prediction is None else self.prediction.cycles:
            ax.axhline(cycle.amplitude, color="C0", lw=1.0, ls="-" if cycle.stable else "--")
        for orbit in self.orbits:
            ax.axhline(orbit.amplitude, color="C1", lw=1.6, alpha=0.6, ls="-" if orbit.stable else "--")
        ax.plot([], [], color="C0", label="DF cycle (dashed: unstable)")
        if self.orbits:
            ax.plot([], [], color="C1", lw=1.6, alpha=0.6, label="exact orbit (dashed: unstable)")
        log_scale(ax.xaxis, min(sizes, default=low), max(sizes, default=high))
        log_scale(ax.yaxis, low, high)
        ax.set_ylim(low, high)
        ax.set_xlabel("disturbance: swing of theta_d the kick starts (rad)")
        ax.set_ylabel("amplitude A the run ends on (rad)")
        ax.set_title(f"{self.model}: {self.verdict}", fontsize="medium")
        legend = legend_beside(ax, fontsize=7)
        return ResultPlot(figure, axes, legend)


def _matching_df_cycle(prediction, measured):
    """The stable DF cycle within AMPLITUDE_MATCH / OMEGA_MATCH of a simulated cycle, or None."""
    for cycle in prediction.stable_cycles:
        if (abs(cycle.amplitude / measured.amplitude - 1.0) <= AMPLITUDE_MATCH
                and abs(cycle.omega / measured.omega - 1.0) <= OMEGA_MATCH):
            return cycle
    return None


def _settling(rests, starts):
    """Largest kick (rad) from rest below which every kick settled (``starts``: the kicks that did not)."""
    first = min((p.disturbance for p in starts), default=math.inf)
    below = [p.disturbance for p in rests if p.disturbance < first]
    return max(below) if below else None


def _separating(prediction, orbits, rests, cycles):
    """Amplitude (rad) of the cycle between rest and hunting, and its source."""
    smallest_cycle = min(p.disturbance for p in cycles) if cycles else math.inf
    largest_rest = _settling(rests, cycles)
    target = min(p.measured.amplitude for p in cycles) if cycles else math.inf
    for source, found in (("exact orbit", orbits), ("DF unstable cycle", prediction.cycles)):
        unstable = [c.amplitude for c in found if not c.stable and c.amplitude < target]
        if unstable:
            return float(max(unstable)), source
    if math.isfinite(smallest_cycle) and largest_rest is not None:
        return float(math.sqrt(largest_rest * smallest_cycle)), "simulations"
    return None, ""


def _df_words(prediction):
    if prediction.note:
        return f"no DF prediction ({prediction.note})"
    stable = prediction.stable_cycles
    if stable:
        return "the DF predicts a stable cycle at " + ", ".join(
            f"A = {c.amplitude:.4g} rad, w = {c.omega:.4g} rad/s" for c in stable)
    if prediction.near_misses:
        return f"the DF predicts none (loci {100 * prediction.near_misses[0].distance:.1f} % apart)"
    return "the DF predicts no stable cycle"


def _exact_match(orbits, measured):
    """The stable exact orbit on the simulated cycle (1 % in amplitude and frequency), or None."""
    for orbit in orbits:
        if (orbit.stable and abs(orbit.amplitude / measured.amplitude - 1.0) <= 0.01
                and abs(orbit.omega / measured.omega - 1.0) <= 0.01):
            return orbit
    return None


def _decide(prediction, contact, probes, orbits=()):
    """(verdict, reason, fields) from the evidence."""
    by = {kind: [p for p in probes if p.outcome == kind] for kind in ("rest", "cycle", "diverged", "unsettled")}
    rests, cycles, diverged = by["rest"], by["cycle"], by["diverged"]
    largest = max(p.disturbance for p in probes)
    if by["unsettled"]:
        p = by["unsettled"][0]
        return "undetermined", (f"the motion from a kick of {p.disturbance:.3g} rad did not settle "
                                f"({p.measured.verdict})"), {}
    runaway_in_contact = contact.status == "unstable"  # a marginal pole (a free integrator) is no runaway
    if runaway_in_contact and not cycles:
        fields = {}
        if rests:
            amplitude, source = _separating(prediction, orbits, rests, diverged)
            fields = {"disturbance_to_start": amplitude, "disturbance_source": source,
                      "settles_up_to": _settling(rests, diverged)}
        return "unstable", (f"the loop in contact is {contact.describe()} and no stable cycle caps the growth"
                            + (f": kicks from {min(p.disturbance for p in diverged):.3g} rad diverged"
                               if diverged else "")), fields
    if diverged and not runaway_in_contact:
        return "undetermined", (f"the loop in contact is {contact.status}, yet the run from "
                                f"{diverged[0].disturbance:.3g} rad diverged"), {}
    if not cycles:
        if prediction.stable_cycles:
            return "undetermined", (f"{_df_words(prediction)}, but every simulated kick up to {largest:.3g} rad "
                                    "settles"), {"settles_up_to": largest, "df_agrees": False}
        return "no oscillation", f"settles from every kick up to {largest:.3g} rad; {_df_words(prediction)}", \
            {"settles_up_to": largest, "df_agrees": True}
    cycle = min((p.measured for p in cycles), key=lambda m: m.amplitude)
    agrees = _matching_df_cycle(prediction, cycle) is not None
    fields = {"cycle": cycle, "df_agrees": agrees, "saturated": cycle.saturated}
    confirmed = "; the exact orbit confirms it" if _exact_match(orbits, cycle) is not None else ""
    agrees = "DF agrees" if agrees else f"DF UNRELIABLE here: {_df_words(prediction)}"
    agrees += confirmed
    runaway = (f"; kicks from {min(p.disturbance for p in diverged):.3g} rad diverge (contact loop "
               f"{contact.describe()})" if diverged else "")
    if cycle.saturated:
        runaway += (f"; the torque command is on its limit {100 * cycle.saturation:.0f} % of the cycle"
                    + (f" and caps the growth of the loop in contact, {contact.describe()}"
                       if runaway_in_contact else ""))
    distinct = [p.measured for p in cycles if abs(p.measured.amplitude / cycle.amplitude - 1.0) > _SAME_CYCLE]
    others = f"; another cycle at A = {distinct[0].amplitude:.4g} rad" if distinct else ""
    what = f"a stable cycle A = {cycle.amplitude:.4g} rad, w = {cycle.omega:.4g} rad/s (simulated; {agrees})"
    if not rests:
        return "limit cycle", f"every kick from {min(p.disturbance for p in probes):.3g} rad ends on {what}" \
            + others + runaway, fields
    amplitude, source = _separating(prediction, orbits, rests, cycles)
    settles = _settling(rests, cycles)
    fields.update(disturbance_to_start=amplitude, disturbance_source=source, settles_up_to=settles)
    calm = f"kicks up to {settles:.3g} rad settle" if settles is not None else "some kicks settle"
    start = f"; hunting starts beyond A = {amplitude:.4g} rad ({source})" if amplitude is not None else ""
    return "bistable", (f"{calm}, a kick of {min(p.disturbance for p in cycles):.3g} rad ends on {what}"
                        + start + others + runaway), fields


def _exact(rig, prediction, probes, t_end, max_t_end):
    """Exact orbits seeded by the DF cycles and the first simulated cycle, and a note if there are none."""
    seed = None
    cycling = [p for p in probes if p.measured.found]
    if cycling:  # the run again, for a state on the cycle
        _, seed = simulated_limit_cycle(rig, prediction.model, t_end=t_end, max_t_end=max_t_end,
                                        kick=cycling[0].kick)
    try:
        orbits = exact_orbits(rig, prediction, simulated=seed)
    except ValueError as error:  # a law shooting does not handle
        return (), " ".join(str(error).split())
    return tuple(orbits), "" if orbits else "shooting found no periodic orbit from the DF and simulated cycles"


def judge_loop(rig, prediction, linear=None, t_end=20.0, max_t_end=160.0, disturbances=DISTURBANCES, exact=False):
    """The verdict on a rig's loop with one torque law (module docs).

    Parameters
    ----------
    rig : Rig
    prediction : LimitCyclePrediction
        Preferably verified (:func:`~backlash_df.limit_cycles.verify_limit_cycles`):
        its simulated stable cycles are reused as probes.
    linear : control.LTI, optional
        The user's linear part, if the prediction used one.
    t_end, max_t_end : float
        First and largest simulated time of each probe, s.
    disturbances : sequence of float
        Kick sizes from rest, in units of the half gap alpha.
    exact : bool
        Also find the exact periodic orbits (:mod:`backlash_df.orbits`; the
        rig's own loop only): an unstable one gives the disturbance that
        starts a bistable loop hunting, a stable one on the simulated cycle
        confirms it.

    Returns
    -------
    LoopVerdict
    """
    model = rig.make_model(prediction.model)
    user_linear = linear if linear is not None and not isinstance(linear, DriveLoop) else None
    part = drive_loop(rig).linear_part() if user_linear is None else lti_linear_part(user_linear)
    contact = linear_stability(part, model.stiffness, model.damping, "contact")
    opened = linear_stability(part, 0.0, 0.0, "open")
    probes = _probes(rig, model, prediction, user_linear, t_end, max_t_end, disturbances)
    orbits, note = _exact(rig, prediction, probes, t_end, max_t_end) if exact and user_linear is None else ((), "")
    verdict, reason, fields = _decide(prediction, contact, probes, orbits)
    return LoopVerdict(prediction.model, verdict, reason, contact, opened, probes, orbits=orbits, orbit_note=note,
                       prediction=prediction, **fields)


def judge(rig, prediction, **kwargs):
    """Deprecated: a copy of ``prediction`` carrying its :class:`LoopVerdict` as ``prediction.verdict``.

    Use :func:`judge_loop` (the verdict holds its prediction) or
    :func:`backlash_df.analyse_loop` (predict, verify and judge in one call).
    Keyword arguments go to :func:`judge_loop`.
    """
    warnings.warn("backlash_df.verdict.judge is deprecated: use judge_loop(rig, prediction) (the verdict holds "
                  "its prediction) or backlash_df.analyse_loop", DeprecationWarning, stacklevel=2)
    return dataclasses.replace(prediction, verdict=judge_loop(rig, prediction, **kwargs))


# --------------------------------------------------------------------------- tables


def verdict_rows(verdicts):
    """One row per verdict: the verdict, linear stability in contact and open, disturbance that starts hunting.

    The column ``hunts beyond (rad)`` is left out where no verdict has such a
    disturbance.

    Returns
    -------
    header : list of str
    rows : list of list of str
    """
    header = ["model", "verdict", "contact loop (k + c s)", "open loop (T = 0)", "hunts beyond (rad)",
              "torque command"]
    rows = []
    for verdict in verdicts:
        start = "" if verdict.disturbance_to_start is None else (
            f"{verdict.disturbance_to_start:.4g} ({verdict.disturbance_source})")
        limit = f"saturated {100 * verdict.cycle.saturation:.0f} % of the cycle" if verdict.saturated else ""
        rows.append({"model": verdict.model, "verdict": verdict.verdict,
                     "contact loop (k + c s)": verdict.contact_loop.describe(),
                     "open loop (T = 0)": verdict.open_loop.describe(), "hunts beyond (rad)": start,
                     "torque command": limit})
    return text_table(header, rows)


def orbit_rows(verdicts):
    """One row per exact periodic orbit (:mod:`backlash_df.orbits`) next to the DF cycle it continues.

    The DF error compares the orbit with the predicted cycle of the same
    stability nearest in amplitude; the DF columns are left out where no orbit
    has such a cycle.  The bias is the orbit's mean of theta_d, round-off
    printed as 0 (:func:`~backlash_df.report.roundoff_zero`): 0 by symmetry
    without a load torque.

    Returns
    -------
    header : list of str
    rows : list of list of str
    """
    header = ["model", "A exact (rad)", "peak (rad)", "bias (rad)", "period (s)", "w (rad/s)", "Floquet",
              "|mu| max", "A DF (rad)", "A DF error", "w DF error"]
    rows = []
    for verdict in verdicts:
        cycles = verdict.prediction.cycles if verdict.prediction is not None else ()
        for orbit in verdict.orbits:
            same = [c for c in cycles if c.stable == orbit.stable]
            df = min(same, key=lambda c: abs(math.log(c.amplitude / orbit.amplitude)), default=None)
            row = {"model": verdict.model, "A exact (rad)": f"{orbit.amplitude:.6g}",
                   "peak (rad)": f"{orbit.peak:.6g}", "bias (rad)": f"{roundoff_zero(orbit.bias, orbit.amplitude):.4g}",
                   "period (s)": f"{orbit.period:.6g}", "w (rad/s)": f"{orbit.omega:.6g}",
                   "Floquet": "stable" if orbit.stable else "unstable", "|mu| max": f"{orbit.max_multiplier:.4f}"}
            if df is not None:
                row.update({"A DF (rad)": f"{df.amplitude:.5g}",
                            "A DF error": signed_percent(df.amplitude / orbit.amplitude - 1.0),
                            "w DF error": signed_percent(df.omega / orbit.omega - 1.0)})
            rows.append(row)
    return text_table(header, rows)


#: What the verdict table of a report holds (HTML).
VERDICT_NOTE = (
    "<p>Contact loop: the PI loop with the shaft as the spring-damper k + c s (large motions); open loop: "
    "shaft torque 0 (inside the gap); poles from the state matrix, dead time by its Pade approximant. "
    "The verdict also weighs simulations from rest with kicks of several sizes (JSON: <code>probes</code>).</p>"
)
#: What the orbit table of a report holds (HTML).
ORBIT_NOTE = (
    "<p>Periodic orbits of the piecewise-smooth loop by shooting, switching events located exactly; "
    "stability from the Floquet multipliers (saltation matrices at contact and release). "
    "The DF errors are those of the predicted cycle of the same stability nearest in amplitude.</p>"
)
