"""A tuning in words: the answer, its verdict and margin, the front, and the report.

Rendered from a :class:`~backlash_df.tuning.Tuning` (its best
:class:`~backlash_df.tuning.Certificate`, the ``margin`` mapping, the front points
and the screened cells); ``backlash-df tune`` prints :func:`tuning_sentences` and
:func:`tuning_tables`, the report says the same in HTML.  The figure is drawn by
:meth:`~backlash_df.tuning.Tuning.plot` and handed in.
"""

import html
import math

from .html import figure_html, html_page, rig_sections, table_html

__all__ = ["tuning_sentences", "tuning_tables", "tuning_report"]


def values_text(tuning):
    """The best tuning's varied values with their units: ``kp = 216.95 N m s/rad, ti = 0.5 s``."""
    return ", ".join(f"{name} = {value:.5g} {tuning.units[name]}" for name, value in tuning.values().items())


def margin_text(margin):
    """A tuning's margin (:attr:`~backlash_df.tuning.Tuning.margin`) as a phrase: ``a factor 1.01 toward the
    nearest hunting tuning found (kp = 218.9, certificate)``."""
    toward = ", ".join(f"{name} = {value:.4g}" for name, value in margin["toward"].items())
    return f"a factor {margin['factor']:.3g} toward the nearest hunting tuning found ({toward}, {margin['source']})"


def tuning_sentences(tuning):
    """The answer, its verdict and why, and the margin: the lines ``backlash-df tune`` prints.

    Parameters
    ----------
    tuning : Tuning

    Returns
    -------
    list of str
    """
    best = tuning.best
    if tuning.feasible:
        lines = [f"certified: {values_text(tuning)}: bandwidth {best.bandwidth:.4g} rad/s"]
    elif best.amplitude == 0.0 and best.verdict.prediction is not None and best.verdict.prediction.note:
        lines = [f"no tuning certified: a certificate needs the describing function, and here "
                 f"{best.verdict.prediction.note}; the fastest tuning: {values_text(tuning)}: bandwidth "
                 f"{best.bandwidth:.4g} rad/s"]
    else:
        lines = [f"no tuning certified; least hunting: {values_text(tuning)}: bandwidth {best.bandwidth:.4g} "
                 f"rad/s, hunting at A = {best.amplitude:.4g} rad (simulated; the smallest of "
                 f"{len(tuning.simulated)} tunings simulated)"]
    lines.append(f"{tuning.model}: {best.verdict.verdict}: {best.verdict.reason}")
    if tuning.margin:
        lines.append(f"margin: {margin_text(tuning.margin)}")
    lines += [line for line in (gain_margin_text(tuning), plateau_text(tuning), bound_text(tuning),
                                uncertainty_text(tuning), friction_text(tuning)) if line]
    return lines


def friction_text(tuning):
    """What a certificate of a rig with dry friction rests on, or "" without dry friction."""
    prediction = tuning.best.verdict.prediction
    if prediction is None or prediction.rig is None or not prediction.rig.friction.dry:
        return ""
    friction = prediction.rig.friction
    if friction.breakaway_motor or friction.breakaway_load:
        return ("dry friction: its breakaway is not affine in the exact orbits' modes, so each certificate rests on "
                "the describing functions (the friction's included) and the probes' simulations (stick and slip)")
    if prediction.rig.controller.torque_limit > 0.0:
        return ("dry friction: the exact orbits do not model it with a torque limit, so each certificate rests on "
                "the describing functions (the friction's and the saturation's included) and the probes' "
                "simulations (stick and slip)")
    return ("dry friction: each certificate rests on the describing functions (the friction's included), the "
            "probes' simulations and the exact orbits (both with stick and slip)")


def uncertainty_text(tuning):
    """Over an uncertainty box: how many values and rigs, the worst bandwidth, where the next faster tuning's
    certificate fails (it hunts there, or its describing function predicts a cycle); "" without a box."""
    box = tuning.uncertainty
    if not box:
        return ""
    word = "certified" if tuning.feasible else "searched"
    count = len(box["box"])
    line = (f"uncertainty: {word} over the box of {count} value{'s' if count != 1 else ''} ({box['points']} rigs), "
            f"worst bandwidth {box['worst_bandwidth']:.4g} rad/s")
    if box["binding"] is not None:
        at = ", ".join(f"{name} = {value:.4g}" for name, value in box["binding"].items())
        line += f"; the next faster tuning is not certified at {at}"
    elif tuning.feasible:
        line += "; no faster tuning found hunting"
    return line


def gain_margin_text(tuning):
    """The gain margin requested and achieved per value, or "" where none is certified."""
    margin = tuning.gain_margin
    if not margin:
        return ""
    achieved = ", ".join(f"{name} up or down by {factor:.3g}" for name, factor in margin["achieved"].items())
    met = all(factor >= margin["requested"] for factor in margin["achieved"].values())
    word = "" if met else " NOT met (no tuning in range holds it; the fastest certified one)"
    return f"gain margin: requested {margin['requested']:.3g}{word}; certified with {achieved}"


def plateau_text(tuning):
    """Where the bandwidth plateaued: the value taken at the knee, or ""."""
    parts = [f"{name} = {entry['reached_at']:.4g} {tuning.units[name]} (bandwidth within 1 % of its plateau "
             f"{entry['bandwidth']:.4g} rad/s)" for name, entry in tuning.plateau.items()]
    return f"plateau: the gentlest tuning on it: {'; '.join(parts)}" if parts else ""


def bound_text(tuning):
    """The values at a bound of their range, or ""."""
    if not tuning.on_bound:
        return ""
    return (f"on a bound: {', '.join(tuning.on_bound)} at the end of its range; the best may lie beyond it "
            f"(widen the range)")


def front_table(tuning):
    """The front: the best bandwidth for each accepted hunting amplitude, a column per varied value.

    Returns
    -------
    title : str
    header : list of str
    rows : list of list of str
    """
    header = ["tolerance (rad)", *tuning.names, "bandwidth (rad/s)", "amplitude (rad)"]
    rows = [[f"{p.tolerance:.4g}", *(f"{v:.4g}" for v in p.values), f"{p.bandwidth:.4g}", f"{p.amplitude:.4g}"]
            for p in tuning.front]
    return "front: the best bandwidth for each accepted hunting amplitude", header, rows


def tuning_tables(tuning):
    """The terminal's tables: ``[(title, header, rows)]``, the front (:func:`front_table`)."""
    return [front_table(tuning)]


def range_caption(tuning):
    """The report's caption of :meth:`~backlash_df.tuning.Tuning.plot`, naming only what the plot draws."""
    hunts = [c for c in tuning.screen if c.hunts]
    if len(tuning.names) == 1:
        left = "Left: bandwidth over the range, the loop in contact"
        if any(math.isfinite(c.bandwidth) for c in hunts):
            left += "; x: the DF says it hunts"
        if any(not math.isfinite(c.bandwidth) for c in hunts):
            left += "; shaded: the loop in contact is unstable (no bandwidth)"
        if tuning.boundary:
            left += "; dotted lines and dots: the DF boundary (the last tunings it clears)"
    else:
        left = "Left: bandwidth over the grid" + ("; hatched: the DF says it hunts" if hunts else "")
        if tuning.boundary:
            left += "; dots: the DF boundary (the last tunings it clears)"
    star = ("star: the best certified tuning" if tuning.feasible
            else "star: no tuning certified; the least hunting (the smallest simulated hunting amplitude)")
    return f"{left}; {star}. Right: the best bandwidth against the accepted hunting amplitude."


def _answer_html(tuning):
    """The report's summary: the answer, its verdict and why, the margin."""
    verdict = tuning.best.verdict
    answer = (f"<b>{'Certified' if tuning.feasible else 'No tuning certified; least hunting'}: "
              f"{html.escape(values_text(tuning))}</b>, bandwidth {tuning.best.bandwidth:.4g} rad/s; verdict "
              f"<b>{verdict.verdict}</b>: {html.escape(verdict.reason)}")
    if tuning.margin:
        answer += f"<br>Margin: {html.escape(margin_text(tuning.margin))}."
    for line in (gain_margin_text(tuning), plateau_text(tuning), bound_text(tuning), uncertainty_text(tuning)):
        if line:
            answer += f"<br>{html.escape(line[0].upper() + line[1:])}."
    return f'<div class="summary"><p>{answer}</p></div>'


def _probes_html(verdict):
    """The certificate's probes: disturbance, outcome and, where any probe found one, the cycle's amplitude."""
    probes = [[str(p.disturbance), p.outcome, f"{p.measured.amplitude:.4g}" if p.measured.found else ""]
              for p in verdict.probes]
    header = ["disturbance", "outcome", "cycle A (rad)"]
    if not any(row[2] for row in probes):  # no probe found a cycle: no empty column
        header, probes = header[:2], [row[:2] for row in probes]
    return table_html(header, probes, text_columns=(0, 1))


def _front_html(tuning):
    """The front's table (:func:`front_table`), the varied values in one column (``kp, ti``)."""
    _, header, rows = front_table(tuning)
    count = len(tuning.names)

    def joined(cells):
        return [cells[0], ", ".join(cells[1:1 + count]), *cells[1 + count:]]

    return table_html(joined(header), [joined(row) for row in rows])


def tuning_report(tuning, figure, title="", rig_text=""):
    """A self-contained HTML page: the answer and its certificate, the map with the boundary, the front.

    Parameters
    ----------
    tuning : Tuning
    figure : matplotlib.figure.Figure
        :meth:`~backlash_df.tuning.Tuning.plot`'s figure; closed here.
    title : str
        Page title (default "Tuning" and the rig's source).
    rig_text : str
        The rig file's text, shown as it is.

    Returns
    -------
    str
    """
    return html_page(title or f"Tuning: {tuning.source}", [
        ("", _answer_html(tuning)), *rig_sections(rig_text),
        ("Searched range, boundary and front", figure_html(figure, range_caption(tuning))),
        ("Certificate: the probes", _probes_html(tuning.best.verdict)),
        ("Front: bandwidth bought by accepted hunting", _front_html(tuning)),
    ])
