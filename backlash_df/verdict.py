"""A verdict for every loop: will this tuning hunt, settle, or run away?

The describing function answers a local question (is there a harmonic balance,
Loeb's criterion at it); a control engineer asks a global one.  The verdict
works from the loop's rest points outward (:mod:`backlash_df.equilibria`):

* the **rests**: where the loop rests (in the gap without a load torque, on a
  flank under one, with the integrator carrying the load), the local stability
  of each (the eigenvalues of its mode's matrix, the dead time by its Pade
  approximant) and its reach (the largest disturbance of each kind that keeps
  the motion in the rest's mode);
* **linear stability** of the loop with the gear *in contact* (the shaft as the
  spring-damper ``T = k theta_d + c dtheta_d``, the regime of large motions) and
  with the gear *open* (``T = 0``, inside the gap);
* the **DF cycles** of :func:`~backlash_df.limit_cycles.predict_limit_cycles`
  with Loeb stability;
* **probes** (:func:`probe`): time simulations from a rest disturbed by one
  disturbance (:mod:`backlash_df.disturbances`: a released twist in rad, a
  motor-speed kick in rad/s): half the reach of each kind and 1.25 times it
  (just out of the rest's mode), the standard set of the rig (twists 1.5, 3,
  8, -20 alpha; kicks 2, 10, 50 alpha omega_n) and a twist onto each stable DF
  cycle, each run until a steady state, a confirmed decay, an overflow or a blow-up
  (:func:`~backlash_df.simulation.measure_limit_cycle`), a probe still unsettled at
  320 s run once more up to four times as long; an oscillation that
  holds its level is confirmed by a longer run from the same start or by another
  probe's at the same swing (``simulation.cycles.confirm_across_starts``);
* for a bistable loop, the **separating orbit**: the exact unstable periodic
  orbit by shooting (:mod:`backlash_df.orbits`) between rest and hunting;

and names one of

``no oscillation``
    every disturbance tried settles (the largest of each kind is stated), also
    where the loop in contact is unstable: each motion then leaves contact
    before it grows, and the reason says so;
``limit cycle``
    every disturbance that leaves the rest's mode ends on a stable cycle, or on
    a sustained oscillation without a period (a quasi-periodic or chaotic hunt;
    the reason gives its dominant harmonic), or stops on an unstable rest
    (creeping onto it from a stable side: any disturbance leaves it, and the
    reason says so);
``bistable``
    a locally stable rest, or disturbances that leave the rest's mode and
    settle, beside ones that end on a stable cycle; the separating (unstable)
    cycle's amplitude is where the hunting starts;
``unstable``
    the loop in contact is unstable and no stable cycle caps the growth (a
    disturbance diverges, or none leaves the rest's mode), or the loop has no
    rest (a torque limit below the load);
``undetermined``
    a motion does not settle, or a loop stable in contact diverges.

Where the simulations reach a cycle the DF misses or misplaces (nearly tangent
loci, a slow motion far from the DF's sinusoid), or settle where the DF
predicts a stable cycle (started on that cycle too), the verdict follows the
simulations and says ``DF UNRELIABLE`` in its reason (``df_agrees`` False).
The ladder depends on the rig alone: :func:`judge_loop` gives the same probes
for a prediction verified by simulation (``predict``) as for one that is not.
"""

import dataclasses
import enum
import math


from .disturbances import KINDS, TWIST, Disturbance, standard_disturbances
from .equilibria import LinearStability, contact_shaft, friction_band, linear_stability, loop_rests
from .loops import drive_loop
from .models import BacklashModel
from .orbits import exact_orbits, periodic_orbit
from .plotting import ResultPlot, axes_or_new, legend_beside, log_scale
from .render.verdict import reason_text
from .simulation import default_step, simulated_limit_cycle
from .simulation.cycles import confirm_across_starts
from .simulation.linear import longest_run
from .system import lti_linear_part

__all__ = ["Outcome", "VERDICTS", "RULES", "Evidence", "LONGER", "Probe", "LoopVerdict", "probe", "ladder", "judge_loop"]


class Outcome(enum.StrEnum):
    """A verdict's outcome (module docs); each compares equal to its word (``"limit cycle"``)."""

    NO_OSCILLATION = "no oscillation"
    LIMIT_CYCLE = "limit cycle"
    BISTABLE = "bistable"
    UNSTABLE = "unstable"
    UNDETERMINED = "undetermined"


VERDICTS = tuple(outcome.value for outcome in Outcome)

#: The rules that decide a verdict, each with its outcome (:class:`Evidence`).
RULES = {
    "no rest": Outcome.UNSTABLE,  # the loop has no rest (a torque limit below the load)
    "unsettled": Outcome.UNDETERMINED,  # a motion did not settle by the longest run
    "runaway in contact": Outcome.UNSTABLE,  # unstable in contact, no stable cycle caps the growth
    "diverged in stable contact": Outcome.UNDETERMINED,  # a run diverged though the loop in contact is stable
    "settles": Outcome.NO_OSCILLATION,  # every disturbance tried settles
    "hunts": Outcome.LIMIT_CYCLE,  # every disturbance that leaves the rest's mode ends on a cycle
    "bistable": Outcome.BISTABLE,  # a rest that holds, or settling motions, beside hunting ones
}

WITHIN, PAST = 0.5, 1.25  # probes at these multiples of a rest's reach: inside its mode, and just out of it
AMPLITUDE_MATCH, OMEGA_MATCH = 0.2, 0.1  # DF cycle "is" the simulated one within these relative errors
_SAME_CYCLE = 0.01  # relative amplitude difference of two runs that reached the same cycle
LONGER = 4.0  # a probe unsettled at the longest run is run again up to this many times as long (1280 s by default)


# --------------------------------------------------------------------------- probes


@dataclasses.dataclass(frozen=True)
class Probe:
    """One simulation from a rest disturbed by one disturbance, and what it ended in.

    Attributes
    ----------
    disturbance : Disturbance
        A released twist (rad) or a motor-speed kick (rad/s) from the rest.
    measured : MeasuredCycle
        What the run settled to (the evidence; ``measured.verdict`` its word).
    role : str
        ``"within reach"`` (half a rest's reach: the motion stays in the rest's
        mode), ``"past reach"`` (1.25 times it: just out) or ``"ladder"`` (the rig's
        standard set, or a disturbance given).
    scale : float
        The disturbance in the rig's scale: twist / alpha, kick / (alpha omega_n).
    duration : float
        Simulated time of the run that decided, s.
    rest : Rest
        The rest it started from.
    left_mode : bool
        The backlash switched at least once (a contact or a release; the
        command's limit not counted): a motion that never did stays in the mode
        it started in, and at a marginal rest (the gap of a free load) settles by
        construction, saturated command or not.
    """

    disturbance: object
    measured: object
    role: str = "ladder"
    scale: float = math.nan
    duration: float = math.nan
    rest: object = dataclasses.field(default=None, repr=False, compare=False)
    left_mode: bool = True

    @property
    def outcome(self):
        """``"cycle"``, ``"rest"``, ``"diverged"`` or ``"unsettled"``.

        Rest: ``measured.verdict`` is ``"no limit cycle"`` (decayed, or a decay
        that a longer run confirmed); unsettled: no steady state by the longest run.
        """
        if self.measured.found:
            return "cycle"
        verdict = self.measured.verdict
        return "rest" if verdict == "no limit cycle" else "diverged" if verdict == "diverged" else "unsettled"

    @property
    def amplitude(self):
        """The amplitude A (rad) of the cycle it ended on; NaN otherwise."""
        return self.measured.amplitude if self.measured.found else math.nan

    def __repr__(self):
        where = "" if self.rest is None else f" from the rest {self.rest.where}"
        end = f": cycle A = {self.amplitude:.4g} rad" if self.measured.found else f": {self.outcome}"
        return f"Probe({self.disturbance}{where}{end})"

    def to_dict(self):
        """JSON entry: the disturbance ``{"kind", "value", "unit"}``, role, outcome, simulated cycle or null, measured
        word, s, left_mode."""
        return {"disturbance": self.disturbance.to_dict(), "role": self.role, "outcome": self.outcome,
                "simulated": self.measured.cycle_dict(), "measured": self.measured.verdict,
                "duration": float(self.duration), "left_mode": bool(self.left_mode)}


def probe(rig, model, disturbance, rest=None, linear=None, t_end=10.0, max_t_end=320.0, role="ladder", dt=None):
    """Simulate the loop from a rest disturbed by one disturbance, until it has decided.

    The run starts at ``t_end`` and doubles (going on from its end) up to ``max_t_end``
    until :func:`~backlash_df.simulation.measure_limit_cycle` finds a steady cycle,
    rest, or divergence; a motion that dies out (its envelope falling, its
    switches thinning out) is rest once the next, longer run confirms it.

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel
        Torque law.
    disturbance : Disturbance
    rest : Rest, optional
        Where it starts (default: the loop's first rest, :func:`~backlash_df.equilibria.loop_rests`).
    linear : control.LTI, optional
        A user's linear part in place of the rig's loop.
    t_end, max_t_end : float
        First and largest simulated time, s.
    role : str
        Stored in the probe (:class:`Probe`).
    dt : float, optional
        Simulation step, s (default :func:`~backlash_df.simulation.default_step`).

    Returns
    -------
    Probe

    Raises
    ------
    ValueError
        The loop has no rest (the reason in one line), or the disturbance's state is not in it.

    Examples
    --------
    >>> import backlash_df as bd
    >>> from backlash_df.disturbances import Disturbance
    >>> rig = bd.load_rig("examples/loaded_feedback.toml")  # doctest: +SKIP
    >>> probe(rig, "phase-plane", Disturbance("twist", 0.01)).outcome  # doctest: +SKIP
    'rest'
    """
    if not isinstance(model, BacklashModel):
        model = rig.make_model(model)
    if rest is None:
        rests, note = loop_rests(rig, model, linear)
        if not rests:
            raise ValueError(f"probe: the loop has no rest: {note}")
        rest = rests[0]
    measured, result = simulated_limit_cycle(rig, model, t_end=t_end, max_t_end=max_t_end, dt=dt,
                                             initial=rest.initial(disturbance), linear=linear, theta_b0=rest.theta_b)
    return Probe(disturbance, measured, role, _scale(rig, disturbance, linear), float(result.time[-1]), rest,
                 left_mode=result.backlash_switched)


def _scale(rig, disturbance, linear):
    """The disturbance in the rig's scale (a user's linear part: twists in alpha)."""
    return abs(disturbance.value) / rig.plant.half_gap if linear is not None else disturbance.size(rig)


def ladder(rig, rests, disturbances=None, linear=None, prediction=None):
    """What the verdict probes: ``(disturbance, rest, role)`` for each rest's reach, then the ladder.

    For every rest and every kind with a reach ``d > 0``: ``0.5 d`` (inside the
    rest's mode; left out where such a disturbance is a rest itself) and ``1.25 d``
    (just out of it); then ``disturbances`` (default the rig's standard set,
    :func:`~backlash_df.disturbances.standard_disturbances`) from the first locally
    stable rest, or the first rest; then, for each stable cycle of ``prediction``, the
    twist from that rest onto the cycle's extremum (``theta_d = bias + A``: the run
    starts on the DF's own cycle; role ``"DF cycle"``).  A user's linear part has no
    motor speed: twists only.

    Returns
    -------
    list of (Disturbance, Rest, str)
    """
    kinds = (TWIST,) if linear is not None else KINDS
    out = []
    for rest in rests:
        for reach in rest.reach:
            if reach.value == 0.0 or reach.kind not in kinds:
                continue
            if reach.kind not in rest.still:
                out.append((reach.scaled(WITHIN), rest, "within reach"))
            out.append((reach.scaled(PAST), rest, "past reach"))
    start = next((rest for rest in rests if rest.stable), rests[0])
    for disturbance in standard_disturbances(rig) if disturbances is None else disturbances:
        if disturbance.kind in kinds:
            out.append((disturbance, start, "ladder"))
    for cycle in () if prediction is None else prediction.stable_cycles:
        out.append((Disturbance(TWIST, cycle.bias + cycle.amplitude - start.theta_d), start, "DF cycle"))
    return out


# --------------------------------------------------------------------------- verdict


@dataclasses.dataclass(frozen=True)
class Evidence:
    """Why a verdict is what it is, as data: the rule that decided and what it rests on.

    The sentence a person reads (:attr:`LoopVerdict.reason`) is rendered from it in
    :mod:`backlash_df.render.verdict`; a test of a decision checks ``rule`` and these
    fields, not words.

    Attributes
    ----------
    rule : str
        One of :data:`RULES` (which gives its outcome).
    contact : LinearStability
        The loop in contact (its status and rightmost pole).
    prediction : LimitCyclePrediction
        The DF prediction weighed (its stable cycles, or how far its loci miss).
    probe : Probe or None
        ``unsettled``: the run that did not settle; ``diverged in stable contact``:
        the run that diverged; ``bistable``: the smallest disturbance that hunts.
    settles : tuple of Disturbance
        Per kind, the largest disturbance up to which every one settled (``settles``,
        ``bistable``, ``runaway in contact`` with settling probes).
    smallest : tuple of Disturbance
        ``hunts``: per kind, the smallest disturbance that ends on the cycle.
    diverged : tuple of Disturbance
        Per kind, the smallest disturbance whose run diverged.
    cycle : MeasuredCycle or None
        The stable cycle the simulations reached (the smallest, if several).
    df_agrees : bool or None
        A stable DF cycle within 20 % in amplitude and 10 % in frequency of the
        simulated one (or none where none is simulated).
    exact_orbit : PeriodicOrbit or None
        The stable exact orbit on the simulated cycle (1 % in amplitude and frequency).
    other_cycle : MeasuredCycle or None
        A second cycle some disturbance ended on.
    inside : bool
        ``hunts``: smaller disturbances stay in the gap (the rest's mode).
    fragile : tuple of Probe
        ``hunts``: runs that stopped on an unstable rest (any disturbance leaves it).
    holding : Rest or None
        ``bistable``: the locally stable rest whose reach the probes confirmed.
    separating : float or None
        ``bistable`` (and ``runaway in contact`` with settling probes): amplitude of
        theta_d (rad) of the separating cycle; with ``separating_source``
        ``"simulations"``, no cycle's but the released twist between the largest that
        settled and the smallest that hunted (their geometric mean).
    separating_source : str
        ``"exact orbit"``, ``"DF unstable cycle"`` or ``"simulations"``; ``""`` if none.
    rest_note : str
        ``no rest``: why.
    """

    rule: str
    contact: LinearStability = None
    prediction: object = dataclasses.field(default=None, repr=False, compare=False)
    probe: Probe = None
    settles: tuple = ()
    smallest: tuple = ()
    diverged: tuple = ()
    cycle: object = None
    df_agrees: bool = None
    exact_orbit: object = None
    other_cycle: object = None
    inside: bool = False
    fragile: tuple = ()
    holding: object = None
    separating: float = None
    separating_source: str = ""
    rest_note: str = ""

    @property
    def outcome(self):
        """The :class:`Outcome` the rule gives."""
        return RULES[self.rule]


@dataclasses.dataclass(frozen=True)
class LoopVerdict:
    """The verdict on one loop with one torque law, and its evidence.

    Attributes
    ----------
    model : str
        Torque-law name.
    evidence : Evidence
        Why: the rule that decided and what it rests on.  :attr:`verdict`,
        :attr:`reason`, :attr:`disturbance_to_start`, :attr:`disturbance_source`,
        :attr:`settles_up_to`, :attr:`cycle`, :attr:`df_agrees` and :attr:`saturated`
        are read from it.
    contact_loop, open_loop : LinearStability
        The loop with the gear in contact (shaft ``k + c s``; ``k`` alone for the
        dead zone (24)) and open (``T = 0``).
    probes : tuple of Probe
        Simulations from the rests, each with one disturbance: the rests' reach
        probes, then the ladder, in the order :func:`ladder` gives.
    orbits : tuple of PeriodicOrbit
        Exact periodic orbits by shooting (:func:`~backlash_df.orbits.exact_orbits`),
        if asked for; empty otherwise.
    orbit_note : str
        Why there are no exact orbits when they were asked for (unsupported law,
        shooting failed); ``""`` otherwise.
    rests : tuple of Rest
        The loop's rest points (:func:`~backlash_df.equilibria.loop_rests`).
    rest_note : str
        Why the loop has no rest (a torque limit below the load); ``""`` otherwise.
    separatrix : PeriodicOrbit or None
        ``bistable``: the exact unstable orbit between rest and hunting, by shooting
        from the DF's unstable cycles (whether or not ``exact`` was asked for).
    prediction : LimitCyclePrediction or None
        The DF prediction the verdict weighed.
    rest_band : dict
        With dry friction on the load: the band its rests span, ``{state: (low, high)}``
        (rad; :func:`~backlash_df.equilibria.friction_band`): the loop rests anywhere in it,
        the probes' rest one point of it; empty otherwise.
    """

    model: str
    evidence: Evidence
    contact_loop: LinearStability
    open_loop: LinearStability
    probes: tuple
    orbits: tuple = ()
    orbit_note: str = ""
    rests: tuple = ()
    rest_note: str = ""
    separatrix: object = None
    prediction: object = dataclasses.field(default=None, repr=False, compare=False)
    rest_band: dict = dataclasses.field(default_factory=dict)

    @property
    def verdict(self):
        """One of :data:`VERDICTS` (an :class:`Outcome`, equal to its word)."""
        return self.evidence.outcome

    @property
    def reason(self):
        """One sentence: why, every disturbance in its own unit (rendered from :attr:`evidence`)."""
        return reason_text(self.evidence)

    @property
    def disturbance_to_start(self):
        """``bistable`` (and ``unstable`` with settling probes): the amplitude of theta_d (rad) of the
        separating cycle, beyond which the loop hunts or runs away; None otherwise."""
        return self.evidence.separating

    @property
    def disturbance_source(self):
        """Where :attr:`disturbance_to_start` comes from: ``"exact orbit"`` (the unstable periodic orbit by
        shooting, :attr:`separatrix`), ``"DF unstable cycle"`` or ``"simulations"`` (the geometric mean of
        the largest settling and the smallest cycling twist); ``""`` if none."""
        return self.evidence.separating_source

    @property
    def settles_up_to(self):
        """Per kind, the largest disturbance tried up to which every one of that kind settled; empty where
        none did."""
        return self.evidence.settles

    @property
    def cycle(self):
        """The stable cycle the simulations reached (the smallest, if several), or None."""
        return self.evidence.cycle

    @property
    def df_agrees(self):
        """Whether the DF's stable cycles agree with the simulations (a stable DF cycle within 20 % in
        amplitude and 10 % in frequency of the simulated one, or none where none is simulated); None where
        the simulations decided nothing.  False flags nearly tangent loci or a motion far from the DF's
        sinusoid: the verdict rests on the simulations."""
        return self.evidence.df_agrees

    @property
    def saturated(self):
        """The stable cycle the simulations reached has its torque command on the limit: with a contact
        loop that is unstable, the limit is what caps the growth."""
        return self.cycle is not None and bool(self.cycle.saturated)

    def __repr__(self):
        return f"LoopVerdict({self.model}: {self.verdict}; {self.reason})"

    def to_dict(self):
        """The verdict fields of a ``models`` entry of the ``predict`` JSON (contract page)."""
        return {
            "verdict": str(self.verdict),
            "reason": self.reason,
            "rule": self.evidence.rule,
            "contact_loop": self.contact_loop.to_dict(),
            "open_loop": self.open_loop.to_dict(),
            "rests": [rest.to_dict() for rest in self.rests],
            "rest_note": self.rest_note or None,
            "disturbance_to_start": self.disturbance_to_start,
            "disturbance_source": self.disturbance_source or None,
            "separatrix": None if self.separatrix is None else self.separatrix.to_dict(),
            "settles_up_to": [d.to_dict() for d in self.settles_up_to],
            "simulated_cycle": None if self.cycle is None else self.cycle.cycle_dict(),
            "df_agrees": self.df_agrees,
            "saturated": bool(self.saturated),
            "probes": [probe.to_dict() for probe in self.probes],
            "exact_orbits": [orbit.to_dict() for orbit in self.orbits],
            **({"rest_band": {name: list(span) for name, span in self.rest_band.items()}} if self.rest_band else {}),
        }

    def plot(self, ax=None):
        """What each disturbance ended in: the probes' cycle amplitudes against their size.

        Each probe (a disturbance from a rest, :attr:`probes`) is a marker at its
        size in the rig's scale (:attr:`Probe.scale`, log) and the amplitude A it ended on (rad; rest
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
        sizes = [p.scale for p in self.probes]
        levels = [p.measured.amplitude for p in self.probes if p.outcome == "cycle"]
        levels += [c.amplitude for c in (self.prediction.cycles if self.prediction is not None else ())]
        levels += [o.amplitude for o in self.orbits]
        low, high = (min(levels) / 3.0, max(levels) * 3.0) if levels else (1e-3, 1.0)
        marks = {"cycle": ("o", "C3", "ends on a cycle"), "rest": ("v", "C2", "settles"),
                 "diverged": ("^", "k", "diverges"), "unsettled": ("s", "0.5", "does not settle")}
        for outcome, (marker, colour, label) in marks.items():
            chosen = [p for p in self.probes if p.outcome == outcome]
            if chosen:
                y = [p.measured.amplitude if outcome == "cycle" else low if outcome == "rest" else high
                     for p in chosen]
                ax.plot([p.scale for p in chosen], y, marker, color=colour, ls="none", label=label,
                        clip_on=outcome == "cycle")  # the marks on an edge drawn whole
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
        ax.set_xlabel("disturbance: twist / alpha, motor-speed kick / (alpha w_n)")
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


def _settling(probes):
    """Per kind, the largest disturbance up to which every probe of that kind settled (by size)."""
    out = []
    for kind in KINDS:
        settled = None
        for p in sorted((p for p in probes if p.disturbance.kind == kind), key=lambda p: abs(p.disturbance.value)):
            if p.outcome != "rest":
                break
            settled = p.disturbance
        if settled is not None:
            out.append(settled)
    return tuple(out)


def _smallest(probes):
    """Per kind, the smallest disturbance among ``probes`` (by size)."""
    out = []
    for kind in KINDS:
        chosen = [p.disturbance for p in probes if p.disturbance.kind == kind]
        if chosen:
            out.append(min(chosen, key=lambda d: abs(d.value)))
    return tuple(out)


def _separating(prediction, orbits, rests, starts):
    """Amplitude (rad) of the cycle between rest and hunting (or runaway), and its source.

    Below the smallest stable cycle the probes reached, the largest unstable cycle
    bounds its basin; where they reached none (a runaway), the smallest unstable cycle
    bounds the rest's: motions from beyond it already grow.
    """
    target = min((p.measured.amplitude for p in starts if p.measured.found), default=math.inf)
    pick = max if math.isfinite(target) else min
    for source, found in (("exact orbit", orbits), ("DF unstable cycle", prediction.cycles)):
        unstable = [c.amplitude for c in found if not c.stable and c.amplitude < target]
        if unstable:
            return float(pick(unstable)), source
    twists = [abs(p.disturbance.value) for p in starts if p.disturbance.kind == TWIST]
    calm = [abs(p.disturbance.value) for p in rests if p.disturbance.kind == TWIST]
    below = [size for size in calm if size < min(twists, default=math.inf)]
    if twists and below:
        return float(math.sqrt(max(below) * min(twists))), "simulations"
    return None, ""


def _exact_match(orbits, measured):
    """The stable exact orbit on the simulated cycle (1 % in amplitude and frequency), or None."""
    for orbit in orbits:
        if (orbit.stable and abs(orbit.amplitude / measured.amplitude - 1.0) <= 0.01
                and abs(orbit.omega / measured.omega - 1.0) <= 0.01):
            return orbit
    return None


def _holding(rests, probes):
    """The locally stable rests whose probes within reach all settled."""
    return [rest for rest in rests if rest.stable
            and all(p.outcome == "rest" for p in probes if p.rest is rest and p.role == "within reach")]


def _calm(probe):
    """Whether a probe that came to rest is evidence that the loop settles.

    Not where it stays inside a marginal rest's mode (the gap of a free load settles by
    construction), nor where its rest is unstable: a motion that creeps onto such a rest
    from a stable side (a flank's edge, reached in contact) stops there only because the
    simulation carries no disturbance to push it off.
    """
    return (probe.left_mode or probe.rest.stable) and not _on_unstable_rest(probe)


def _on_unstable_rest(probe):
    return probe.rest.stability.status == "unstable"


def _fragile(probes):
    """The probes that came to rest on an unstable rest (:func:`_calm`)."""
    return [p for p in probes if p.outcome == "rest" and _on_unstable_rest(p)]


def _decide(prediction, contact, rests, probes, orbits=()):
    """The :class:`Evidence` of the probes (module docs): the rule that decides and what it rests on."""
    by = {kind: [p for p in probes if p.outcome == kind] for kind in ("rest", "cycle", "diverged", "unsettled")}
    cycles, diverged = by["cycle"], by["diverged"]
    calm = [p for p in by["rest"] if _calm(p)]
    seen = dict(contact=contact, prediction=prediction)
    if by["unsettled"]:
        return Evidence("unsettled", probe=by["unsettled"][0], **seen)
    runaway_in_contact = contact.status == "unstable"  # a marginal pole (a free integrator) is no runaway
    # every motion that left the rest settling, none diverging: contact does not last long enough to grow
    if runaway_in_contact and not cycles and (diverged or not calm):
        if calm:
            amplitude, source = _separating(prediction, orbits, calm, diverged)
            seen.update(settles=_settling(probes), separating=amplitude, separating_source=source)
        return Evidence("runaway in contact", diverged=_smallest(diverged), **seen)
    if diverged and not runaway_in_contact:
        return Evidence("diverged in stable contact", probe=diverged[0], **seen)
    if not cycles:  # a DF cycle, started on by a probe of the ladder, settled too: df_agrees False
        return Evidence("settles", settles=_settling(probes), df_agrees=not prediction.stable_cycles, **seen)
    return _cycling(prediction, contact, rests, probes, orbits, calm)


def _cycling(prediction, contact, rests, probes, orbits, calm):
    """The evidence where some probe ends on a stable cycle: ``hunts`` (limit cycle) or ``bistable``."""
    cycles = [p for p in probes if p.outcome == "cycle"]
    cycle = min((p.measured for p in cycles), key=lambda m: m.amplitude)
    # a sustained oscillation's dominant harmonic wanders from run to run: only a periodic one is another cycle
    distinct = [p.measured for p in cycles if p.measured.periodic != cycle.periodic
                or (cycle.periodic and abs(p.measured.amplitude / cycle.amplitude - 1.0) > _SAME_CYCLE)]
    seen = dict(contact=contact, prediction=prediction, cycle=cycle,
                df_agrees=_matching_df_cycle(prediction, cycle) is not None,
                exact_orbit=_exact_match(orbits, cycle), other_cycle=distinct[0] if distinct else None,
                diverged=_smallest([p for p in probes if p.outcome == "diverged"]))
    holding = _holding(rests, probes)
    if not holding and not calm:
        inside = any(p.outcome == "rest" and not p.left_mode for p in probes)
        return Evidence("hunts", smallest=_smallest(cycles), inside=inside, fragile=tuple(_fragile(probes)), **seen)
    amplitude, source = _separating(prediction, orbits, calm, cycles)
    return Evidence("bistable", probe=min(cycles, key=lambda p: p.scale), settles=_settling(probes),
                    holding=holding[0] if holding else None, separating=amplitude, separating_source=source,
                    **seen)


def _exact(rig, prediction, probes, t_end, max_t_end, dt=None, near_misses=1):
    """Exact orbits seeded by the DF cycles and the first simulated cycle, and a note if there are none."""
    seed = None
    cycling = [p for p in probes if p.measured.periodic]
    if cycling:  # the run again, for a state on the cycle
        first = cycling[0]
        _, seed = simulated_limit_cycle(rig, prediction.law, t_end=t_end, max_t_end=max_t_end, dt=dt,
                                        initial=first.rest.initial(first.disturbance), theta_b0=first.rest.theta_b)
    try:
        orbits = exact_orbits(rig, prediction, simulated=seed, near_misses=near_misses)
    except ValueError as error:  # a law shooting does not handle
        return (), " ".join(str(error).split())
    return tuple(orbits), "" if orbits else "shooting found no periodic orbit from the DF and simulated cycles"


def _separatrix(rig, prediction, orbits, cycle):
    """The exact unstable orbit below the simulated cycle: from the orbits found, else by shooting from the DF."""
    below = [o for o in orbits if not o.stable and o.amplitude < cycle.amplitude]
    for seed in () if below else [c for c in prediction.cycles if not c.stable]:
        try:
            orbit = periodic_orbit(rig, prediction.law, seed)
        except ValueError:  # shooting failed, or a law it does not handle
            continue
        if not orbit.stable and orbit.amplitude < cycle.amplitude:
            below.append(orbit)
    return max(below, key=lambda o: o.amplitude, default=None)


def judge_loop(rig, prediction, *, linear=None, t_end=10.0, max_t_end=320.0, disturbances=None, exact=False,
               refinement=1):
    """The verdict on a rig's loop with one torque law (module docs).

    Parameters
    ----------
    rig : Rig
        The prediction's rig (another is refused: :meth:`~backlash_df.limit_cycles.LimitCyclePrediction.loop`).
    prediction : LimitCyclePrediction
        Verified (:func:`~backlash_df.limit_cycles.verify_limit_cycles`) or not:
        the probes are the same.  Its law and linear part are the ones judged.
    linear : control.LTI, optional
        The prediction's own linear part (read from the prediction; another is refused;
        twists only: it has no motor speed).
    t_end, max_t_end : float
        First and largest simulated time of each probe, s; a probe still unsettled at
        ``max_t_end`` runs again from its start, for ``2 max_t_end`` and ``LONGER max_t_end``.
    disturbances : sequence of Disturbance, optional
        The ladder from the rest (default the rig's standard set,
        :func:`~backlash_df.disturbances.standard_disturbances`); the rests' reach
        probes come first either way (:func:`ladder`).
    exact : bool
        Also find the exact periodic orbits (:mod:`backlash_df.orbits`; the
        rig's own loop only): a stable one on the simulated cycle confirms it.
        A bistable loop's separating orbit is sought either way.
    refinement : int
        Divide every probe's simulation step by this and seed the shooting from
        this many near misses (1: the defaults); a verdict that holds at 2 holds
        under refinement.

    Returns
    -------
    LoopVerdict
    """
    rig, model, user_linear = prediction.loop(rig, linear)
    part = drive_loop(rig, dry_friction=True).linear_part() if user_linear is None else lti_linear_part(user_linear)
    contact = linear_stability(part, *contact_shaft(model), "contact")
    opened = linear_stability(part, 0.0, 0.0, "open")
    rests, rest_note = loop_rests(rig, model, user_linear)
    if not rests:
        evidence = Evidence("no rest", contact=contact, prediction=prediction, rest_note=rest_note)
        return LoopVerdict(prediction.model, evidence, contact, opened, (), rest_note=rest_note, prediction=prediction)
    dt = None if refinement == 1 else default_step(part, model) / refinement
    probes = _confirmed_across_starts([probe(rig, model, disturbance, rest, user_linear, t_end, max_t_end, role, dt)
                                       for disturbance, rest, role in ladder(rig, rests, disturbances, user_linear,
                                                                             prediction)])
    step = default_step(part, model) if dt is None else dt
    probes = _confirmed_across_starts([_longer(rig, model, p, user_linear, max_t_end, step) for p in probes])
    orbits, note = (_exact(rig, prediction, probes, t_end, max_t_end, dt, refinement)
                    if exact and user_linear is None else ((), ""))
    evidence = _decide(prediction, contact, rests, probes, orbits)
    separatrix = None
    if evidence.outcome == Outcome.BISTABLE and user_linear is None:
        separatrix = _separatrix(rig, prediction, orbits, evidence.cycle)
        if separatrix is not None and separatrix not in orbits:
            evidence = _decide(prediction, contact, rests, probes, orbits + (separatrix,))
    band = friction_band(rig, model) if user_linear is None and part.sticking is not None else {}
    return LoopVerdict(prediction.model, evidence, contact, opened, probes, orbits=orbits, orbit_note=note,
                       rests=rests, rest_note=rest_note, separatrix=separatrix, prediction=prediction, rest_band=band)


def _longer(rig, model, unsettled, linear, max_t_end, dt):
    """A probe still unsettled at ``max_t_end`` run again from its start, doubling on to ``LONGER * max_t_end``.

    A decay with a time constant of a few hundred seconds, or a slow loop still
    converging onto its cycle, decides only on a longer run; a probe that has
    decided, or whose step ``dt`` (s) allowed no longer run, is returned as it is.
    """
    t_end = min(2.0 * max_t_end, longest_run(dt))
    if unsettled.outcome != "unsettled" or t_end <= unsettled.duration:
        return unsettled
    return probe(rig, model, unsettled.disturbance, unsettled.rest, linear, t_end, LONGER * max_t_end,
                 unsettled.role, dt)


def _confirmed_across_starts(probes):
    """The probes, an oscillation that held its level confirmed by another probe's at its swing (:func:`confirm_across_starts`)."""
    measured = confirm_across_starts([p.measured for p in probes])
    return tuple(dataclasses.replace(p, measured=m) for p, m in zip(probes, measured))
