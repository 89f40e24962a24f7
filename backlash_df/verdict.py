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
  a blow-up (:func:`~backlash_df.simulate.measure_limit_cycle`).

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

import numpy as np

__all__ = ["VERDICTS", "LinearStability", "Probe", "LoopVerdict", "linear_stability", "judge", "judge_loop"]

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

    def to_dict(self, count=6):
        """JSON entry: status, the rightmost ``count`` poles as ``[re, im]`` (1/s), Pade order."""
        return {
            "stable": bool(self.stable),
            "status": self.status,
            "max_real": self.max_real,
            "poles": [[float(p.real), float(p.imag)] for p in self.poles[:count]],
            "pade_order": int(self.pade_order),
        }


def _with_pade(part, matrix, order):
    """Closed-loop matrix with ``u_d = d z (t - delay)`` realised by a Pade system of ``order``."""
    import control as ct

    pade = ct.ss(ct.tf(*ct.pade(part.delay, order)))
    a_p, b_p, c_p, d_p = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (pade.A, pade.B, pade.C, pade.D))
    n, m = matrix.shape[0], a_p.shape[0]
    out = np.zeros((n + m, n + m))
    out[:n, :n] = matrix + d_p[0, 0] * np.outer(part.e_d, part.d)
    out[:n, n:] = np.outer(part.e_d, c_p[0])
    out[n:, :n] = np.outer(b_p[:, 0], part.d)
    out[n:, n:] = a_p
    return out


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
        Pade order for the dead time (:func:`control.pade`).

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
    matrix = part.A + np.outer(part.b, stiffness * part.c_x + damping * part.c_v)
    order = 0
    if part.delay > 0.0:
        order = int(pade_order)
        matrix = _with_pade(part, matrix, order)
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

    def to_dict(self):
        """JSON entry: disturbance (rad), kick (rad/s), outcome, simulated cycle or null, measured verdict."""
        return {"disturbance": self.disturbance, "kick": self.kick, "outcome": self.outcome,
                "simulated": self.measured.to_dict(), "measured": self.measured.verdict}


def _probes(rig, model, prediction, linear, t_end, max_t_end, disturbances):
    """Simulations from kicks: the ladder ``disturbances * alpha`` at the shaft mode, and the stable DF cycles."""
    from .limit_cycles import default_ranges
    from .simulate import simulated_limit_cycle

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

    def __repr__(self):
        return f"LoopVerdict({self.model}: {self.verdict}; {self.reason})"

    def to_dict(self):
        """The verdict fields of a ``models`` entry of the ``predict`` JSON (DESIGN.md)."""
        return {
            "verdict": self.verdict,
            "reason": self.reason,
            "contact_loop": self.contact_loop.to_dict(),
            "open_loop": self.open_loop.to_dict(),
            "disturbance_to_start": self.disturbance_to_start,
            "disturbance_source": self.disturbance_source or None,
            "settles_up_to": self.settles_up_to,
            "simulated_cycle": None if self.cycle is None else self.cycle.to_dict(),
            "df_agrees": self.df_agrees,
            "probes": [probe.to_dict() for probe in self.probes],
            "exact_orbits": [orbit.to_dict() for orbit in self.orbits],
        }


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
    fields = {"cycle": cycle, "df_agrees": agrees}
    confirmed = "; the exact orbit confirms it" if _exact_match(orbits, cycle) is not None else ""
    agrees = "DF agrees" if agrees else f"DF UNRELIABLE here: {_df_words(prediction)}"
    agrees += confirmed
    runaway = (f"; kicks from {min(p.disturbance for p in diverged):.3g} rad diverge (contact loop "
               f"{contact.describe()})" if diverged else "")
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
    from .orbits import exact_orbits
    from .simulate import simulated_limit_cycle

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
    from .loops import DriveLoop, drive_loop, lti_linear_part

    model = rig.make_model(prediction.model)
    user_linear = linear if linear is not None and not isinstance(linear, DriveLoop) else None
    part = drive_loop(rig).linear_part() if user_linear is None else lti_linear_part(user_linear)
    contact = linear_stability(part, model.stiffness, model.damping, "contact")
    opened = linear_stability(part, 0.0, 0.0, "open")
    probes = _probes(rig, model, prediction, user_linear, t_end, max_t_end, disturbances)
    orbits, note = _exact(rig, prediction, probes, t_end, max_t_end) if exact and user_linear is None else ((), "")
    verdict, reason, fields = _decide(prediction, contact, probes, orbits)
    return LoopVerdict(prediction.model, verdict, reason, contact, opened, probes, orbits=orbits, orbit_note=note,
                       **fields)


def judge(rig, prediction, **kwargs):
    """A copy of ``prediction`` carrying its :class:`LoopVerdict` (``prediction.verdict``).

    Keyword arguments go to :func:`judge_loop`.
    """
    return dataclasses.replace(prediction, verdict=judge_loop(rig, prediction, **kwargs))
