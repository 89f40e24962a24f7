"""A loop's analysis in words: the ``backlash-df predict`` tables and lines, and its report.

Rendered from a :class:`~backlash_df.analysis.LoopAnalysis` (its predictions and
verdicts) with the pieces of :mod:`~backlash_df.render.prediction` and
:mod:`~backlash_df.render.verdict`.
"""

import html

from .html import html_page, table_html
from .prediction import prediction_rows, prediction_sections
from .verdict import ORBIT_NOTE, VERDICT_NOTE, orbit_rows, verdict_rows

__all__ = ["analysis_tables", "analysis_sentences", "analysis_report"]


def analysis_tables(analysis):
    """The terminal's tables: ``[(header, rows), ...]`` (predicted cycles, verdicts, and orbits if sought).

    Parameters
    ----------
    analysis : LoopAnalysis

    Returns
    -------
    list of (list of str, list of list of str)
    """
    tables = [prediction_rows(analysis.predictions), verdict_rows(analysis.verdicts)]
    return tables + [orbit_rows(analysis.verdicts)] if analysis.exact else tables


def analysis_sentences(analysis):
    """One line per law: the verdict and why (and why there are no exact orbits, where so).

    Parameters
    ----------
    analysis : LoopAnalysis

    Returns
    -------
    list of str
    """
    lines = []
    for verdict in analysis.verdicts:
        note = f" (exact orbits: {verdict.orbit_note})" if verdict.orbit_note else ""
        lines.append(f"{verdict.model}: {verdict.verdict}: {verdict.reason}{note}")
        if verdict.rest_band:
            lines.append(f"{verdict.model}: {rest_band_text(verdict.rest_band)}")
    return lines


def rest_band_text(band):
    """The rests a load's dry friction holds, as a sentence: ``the load's dry friction holds a rest anywhere in
    load_angle -0.0667 .. 0.0667 rad, theta_d ... rad``."""
    spans = ", ".join(f"{name} {low:.4g} .. {high:.4g} rad" for name, (low, high) in band.items())
    return f"the load's dry friction holds a rest anywhere in {spans} (a band, not a point)"


def analysis_report(analysis, figure, title="", rig_text=""):
    """A self-contained HTML page: summary with verdicts, Nyquist overlay, cycles, verdicts, orbits.

    Parameters
    ----------
    analysis : LoopAnalysis
    figure : matplotlib.figure.Figure
        The Nyquist overlay of its predictions (:meth:`~backlash_df.analysis.LoopAnalysis.plot`); closed here.
    title : str
        Page title (default: "Limit cycles: " and the rig's source).
    rig_text : str
        The rig file's text, shown as it is.

    Returns
    -------
    str
    """
    notes = {v.model: f"<br><b>verdict: {v.verdict}</b>: {html.escape(v.reason)}" for v in analysis.verdicts}
    sections = prediction_sections(analysis.predictions, figure, rig_text, notes)
    header, rows = verdict_rows(analysis.verdicts)
    sections.append(("Verdict and linear stability",
                     VERDICT_NOTE + table_html(header, rows, text_columns=header)))  # words, every column
    header, rows = orbit_rows(analysis.verdicts)
    if rows:
        sections.append(("Exact periodic orbits",
                         ORBIT_NOTE + table_html(header, rows, text_columns=("model", "Floquet"))))
    return html_page(title or f"Limit cycles: {analysis.source}", sections)
