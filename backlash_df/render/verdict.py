"""A verdict in words: its reason as one sentence, and the verdict and orbit tables.

Every sentence is rendered from the verdict's :class:`~backlash_df.verdict.Evidence`
(the rule that decided, the probes, cycles and numbers it rests on), every disturbance
in its own unit (a twist in rad, a motor-speed kick in rad/s).
"""

import math

from ..disturbances import kind_words
from .html import roundoff_zero, signed_percent, text_table

__all__ = ["reason_text", "lure_reason_text"]


def reason_text(evidence):
    """The verdict's reason, one sentence, from its evidence (:class:`~backlash_df.verdict.Evidence`)."""
    return _SENTENCES[evidence.rule](evidence)


def lure_reason_text(verdict):
    """A Lur'e loop's verdict in one sentence (:class:`~backlash_df.lure_verdict.LureVerdict`)."""
    probes = verdict.probes
    by = {kind: [p for p in probes if p.outcome == kind] for kind in ("rest", "cycle", "diverged", "unsettled")}
    if by["unsettled"]:
        probe = by["unsettled"][0]
        return f"the start {probe.start} did not settle in {probe.duration:.4g} s (swing {probe.swing:.4g})"
    boundary = ("" if verdict.disturbance_to_start is None else
                f"the {verdict.disturbance_source} A = {verdict.disturbance_to_start:.4g}")
    if verdict.verdict == "no oscillation":
        text = f"every start settles, up to {max(p.size for p in probes):.4g}"
        return text + ("" if verdict.df_agrees else "; DF UNRELIABLE: its stable cycle is not there")
    orbits = sorted({id(p.orbit): p.orbit for p in by["cycle"]}.values(), key=lambda o: o.amplitude)
    cycles = " or ".join(f"A = {o.amplitude:.4g}, w = {o.omega:.4g} rad/s" for o in orbits)
    df = "" if verdict.df_agrees else "; DF UNRELIABLE: its stable cycles are not the exact ones"
    runaway = (f"; starts from {min(p.size for p in by['diverged']):.4g} run away" if by["diverged"] else "")
    if verdict.verdict == "limit cycle":
        return f"every start ends on the stable orbit {cycles}{runaway}{df}"
    if verdict.verdict == "bistable":
        return (f"starts up to {max(p.size for p in by['rest']):.4g} settle, others end on the stable orbit "
                f"{cycles}{runaway}" + (f"; {boundary} is the disturbance that starts hunting" if boundary else "")
                + df)
    return (f"no start ends on a cycle and starts from {min(p.size for p in by['diverged']):.4g} run away"
            + (f"; {boundary} bounds the rest's basin" if boundary else ""))


# --------------------------------------------------------------------------- pieces


def _list(disturbances, prefix):
    """``twists up to 0.4 rad and motor-speed kicks up to 12.6 rad/s`` (``prefix`` "up to", "from", "below")."""
    return " and ".join(f"{kind_words(d.kind)} {prefix} {abs(d.value):.4g} {d.unit}" for d in disturbances)


def _one(disturbance):
    """``a twist of 0.075 rad``, ``a motor-speed kick of -12.6 rad/s``."""
    return f"a {kind_words(disturbance.kind, 1)} of {disturbance.value:.4g} {disturbance.unit}"


def _either(disturbances):
    """``a twist of 0.0625 rad or a motor-speed kick of 12.57 rad/s``: the smallest of each kind."""
    return " or ".join(_one(d) for d in disturbances)


def _df_words(prediction):
    """What the DF predicts, in words: its stable cycles, or how far its loci miss."""
    if prediction.note:
        return f"no DF prediction ({prediction.note})"
    stable = prediction.stable_cycles
    if stable:
        return "the DF predicts a stable cycle at " + ", ".join(
            f"A = {c.amplitude:.4g} rad, w = {c.omega:.4g} rad/s" for c in stable)
    if prediction.near_misses:
        return f"the DF predicts none (loci {100 * prediction.near_misses[0].distance:.3g} % apart)"
    return "the DF predicts no stable cycle"


def _runaway(evidence):
    return evidence.contact.status == "unstable"


# --------------------------------------------------------------------------- the rules' sentences


def _no_rest(evidence):
    return f"the loop has no rest: {evidence.rest_note}"


def _unsettled(evidence):
    p = evidence.probe
    return f"the motion from {_one(p.disturbance)} did not settle ({p.measured.verdict} after {p.duration:.3g} s)"


def _runaway_in_contact(evidence):
    diverged = f": {_list(evidence.diverged, 'from')} diverged" if evidence.diverged else ""
    return f"the loop in contact is {evidence.contact.describe()} and no stable cycle caps the growth{diverged}"


def _diverged_in_stable_contact(evidence):
    return (f"the loop in contact is {evidence.contact.status}, yet the run from "
            f"{_one(evidence.probe.disturbance)} diverged")


def _settles(evidence):
    contact = (f"; the loop in contact is {evidence.contact.describe()}, but every motion leaves contact before "
               "it grows" if _runaway(evidence) else "")
    tried = f"settles from every disturbance tried ({_list(evidence.settles, 'up to')})"
    if not evidence.df_agrees:  # started on the DF's cycle (a probe of the ladder), the loop settled too
        return f"{tried}, a twist onto the DF's cycle too{contact}; DF UNRELIABLE here: {_df_words(evidence.prediction)}"
    return f"{tried}{contact}; {_df_words(evidence.prediction)}"


def _cycle_words(evidence):
    """The simulated cycle, the DF's agreement and what else the probes found: ``(what, after)``."""
    cycle = evidence.cycle
    agrees = ("DF agrees" if evidence.df_agrees else f"DF UNRELIABLE here: {_df_words(evidence.prediction)}") + (
        "; the exact orbit confirms it" if evidence.exact_orbit is not None else "")
    if cycle.periodic:
        what = f"a stable cycle A = {cycle.amplitude:.4g} rad, w = {cycle.omega:.4g} rad/s (simulated; {agrees})"
    else:
        what = (f"a sustained oscillation without a period, its dominant harmonic A = {cycle.amplitude:.4g} rad, "
                f"w = {cycle.omega:.4g} rad/s (simulated over {cycle.periods} of its periods; {agrees})")
    other = evidence.other_cycle
    after = (f"; another cycle at A = {other.amplitude:.4g} rad" + ("" if other.periodic else " (without a period)")
             if other is not None else "")
    if evidence.diverged:
        after += f"; {_list(evidence.diverged, 'from')} diverge (contact loop {evidence.contact.describe()})"
    if cycle.saturated:
        after += (f"; the torque command is on its limit {100 * cycle.saturation:.0f} % of the "
                  + ("cycle" if cycle.periodic else "time")
                  + (f" and caps the growth of the loop in contact, {evidence.contact.describe()}"
                     if _runaway(evidence) else ""))
    return what, after


def _hunts(evidence):
    what, after = _cycle_words(evidence)
    start = "every disturbance tried"
    if evidence.fragile:
        rest = evidence.fragile[0].rest
        start = (" and ".join(_one(p.disturbance) for p in evidence.fragile)
                 + (" stops" if len(evidence.fragile) == 1 else " stop")
                 + f" on the rest {rest.where}, which is {rest.stability.describe()}: any disturbance leaves it; "
                 "every other disturbance tried")
    which = "disturbance that ends" if len(evidence.smallest) == 1 else "disturbances that end"
    return (f"{start} ends on {what}; the smallest {which} on it: {_either(evidence.smallest)}"
            + (" (smaller ones stay in the gap)" if evidence.inside else "") + after)


def _bistable(evidence):
    what, after = _cycle_words(evidence)
    rest = evidence.holding
    if rest is not None:
        reach = [d for d in rest.reach if d.value != 0.0]
        keeps = "keeps contact" if rest.side else "stays in the gap"
        calm = f"the rest {rest.where} (theta_d = {rest.theta_d:.4g} rad) is stable" + (
            f" and {keeps} against {_list(reach, 'below')}" if reach else "")
        if evidence.settles:
            calm += f"; {_list(evidence.settles, 'up to')} settle"
    else:
        calm = f"{_list(evidence.settles, 'up to')} settle" if evidence.settles else "some disturbances settle"
    return f"{calm}; {_one(evidence.probe.disturbance)} ends on {what}" + _separation(evidence) + after


def _separation(evidence):
    """Where hunting starts: beyond a separating cycle (an exact or DF one), or, with none found, from released
    twists of about the size between the settling and the hunting ones the probes tried (not a cycle's A)."""
    if evidence.separating is None:
        return ""
    if evidence.separating_source == "simulations":
        return (f"; hunting starts from released twists of about {evidence.separating:.4g} rad (between those "
                f"simulated to settle and to hunt; no separating cycle found)")
    return (f"; hunting starts beyond the separating cycle A = {evidence.separating:.4g} rad "
            f"({evidence.separating_source})")


_SENTENCES = {
    "no rest": _no_rest,
    "unsettled": _unsettled,
    "runaway in contact": _runaway_in_contact,
    "diverged in stable contact": _diverged_in_stable_contact,
    "settles": _settles,
    "hunts": _hunts,
    "bistable": _bistable,
}


# --------------------------------------------------------------------------- tables


def verdict_rows(verdicts):
    """One row per verdict: the verdict, the rest off the gap, linear stability in contact and open, where hunting starts.

    The columns ``rest`` (a rest on a flank, under a load torque) and ``hunts
    beyond (rad)`` are left out where no verdict has one.

    Returns
    -------
    header : list of str
    rows : list of list of str
    """
    header = ["model", "verdict", "rest", "contact loop (k + c s)", "open loop (T = 0)", "hunts beyond (rad)",
              "torque command"]
    rows = []
    for verdict in verdicts:
        start = "" if verdict.disturbance_to_start is None else (
            f"{verdict.disturbance_to_start:.4g} ({verdict.disturbance_source})")
        limit = ((f"saturated {100 * verdict.cycle.saturation:.0f} % of the "
                  + ("cycle" if verdict.cycle.periodic else "time")) if verdict.saturated else "")
        rest = "none" if verdict.rest_note else "; ".join(
            f"{r.where.removeprefix('on the ')} {r.theta_d:.4g} rad, {r.stability.status}"
            for r in verdict.rests if r.side != 0)
        rows.append({"model": verdict.model, "verdict": str(verdict.verdict), "rest": rest,
                     "contact loop (k + c s)": verdict.contact_loop.describe(),
                     "open loop (T = 0)": verdict.open_loop.describe(), "hunts beyond (rad)": start,
                     "torque command": limit})
    return text_table(header, rows)


def orbit_rows(verdicts):
    """One row per exact periodic orbit (:mod:`backlash_df.orbits`) next to the DF cycle it continues.

    The DF error compares the orbit with the predicted cycle of the same
    stability nearest in amplitude; the DF columns are left out where no orbit
    has such a cycle.  The bias is the orbit's mean of theta_d, round-off
    printed as 0 (:func:`~backlash_df.render.html.roundoff_zero`): 0 by symmetry
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
    "<p>Rest: where the loop rests off the gap (on a flank under a load torque) and its local stability. "
    "Contact loop: the loop with the shaft as the spring-damper k + c s (large motions); open loop: "
    "shaft torque 0 (inside the gap); poles from the state matrix, dead time by its Pade approximant. "
    "The verdict also weighs simulations from the rest, each disturbed by a released twist (rad) or a motor-speed "
    "kick (rad/s): within and just past the rest's reach, and the standard set (JSON: <code>probes</code>).</p>"
)
#: What the orbit table of a report holds (HTML).
ORBIT_NOTE = (
    "<p>Periodic orbits of the piecewise-smooth loop by shooting, switching events located exactly; "
    "stability from the Floquet multipliers (saltation matrices at contact and release). "
    "The DF errors are those of the predicted cycle of the same stability nearest in amplitude.</p>"
)
