"""A limit-cycle prediction in words: the table of predicted and simulated cycles, and its report.

Rendered from :class:`~backlash_df.limit_cycles.LimitCyclePrediction` objects (their
cycles, near misses and simulations); the Nyquist overlay is drawn by the result
(:func:`~backlash_df.limit_cycles.limit_cycle_plot`) and handed in as a figure.
"""

import html
import math

from .html import figure_html, html_page, rig_sections, roundoff_zero, signed_percent, table_html, text_table

__all__ = ["prediction_rows", "prediction_report"]

#: Which run the table's simulated numbers come from (text).
SIMULATED_NOTE = (
    "A sim, w sim: the first harmonic of theta_d in the closed-loop simulation started on that predicted cycle "
    "(theta_d = 0, dtheta_d/dt = A w), with the same torque law, once it repeats; A error and w error compare the "
    "prediction with it."
)
#: Why a verdict's simulated cycle may differ from the table's in the last digits (text).
VERDICT_RUNS_NOTE = (
    "A verdict's simulated cycle is another run: the smallest cycle that the simulations from rest, each with the "
    "disturbance the verdict names, settle on. Where they reach the same cycle as the run from the predicted cycle, "
    "the two differ only within the 1e-3 to which a simulated cycle must repeat to count as steady."
)
#: What a prediction report's numbers are (HTML).
PREDICTION_NOTE = (
    "Solutions of G(jw) N(A, w) = -1 (A: first-harmonic amplitude of "
    "theta_d), stability by Loeb's criterion, each stable cycle checked by closed-loop time "
    "simulation with the same torque law. A near miss is the smallest |1 + G N|: the relative "
    "change of G that would create a cycle."
)


def prediction_rows(predictions):
    """One row per predicted cycle (or per model without a stable one): predicted next to simulated.

    A model without a stable cycle gets a row ``none`` (or ``(unstable only)``)
    holding what its simulation settled to.  The bias column is shown where the
    DF solved the DC balance under a load torque
    (:attr:`~backlash_df.limit_cycles.LimitCyclePrediction.balanced`; round-off
    printed as 0, :func:`~backlash_df.render.html.roundoff_zero`); columns empty in
    every row (no simulation, no near miss) are left out.

    With a torque limit, the command's first-harmonic amplitude U of each cycle
    and whether it saturates.

    Parameters
    ----------
    predictions : sequence of LimitCyclePrediction

    Returns
    -------
    header : list of str
    rows : list of list of str
    """
    header = ["model", "A pred (rad)", "w pred (rad/s)", "bias pred (rad)", "Loeb", "A sim (rad)", "w sim (rad/s)",
              "A error", "w error", "closest miss", "command U (N m)"]
    rows = []
    for prediction in predictions:
        miss = f"{100 * prediction.near_misses[0].distance:.2f} %" if prediction.near_misses else ""
        for cycle in prediction.cycles:
            command = "" if math.isnan(cycle.command_amplitude) else (
                f"{cycle.command_amplitude:.4g}" + (" (saturated)" if cycle.saturated else ""))
            rows.append({
                "model": prediction.model, "A pred (rad)": f"{cycle.amplitude:.5g}",
                "w pred (rad/s)": f"{cycle.omega:.5g}",
                "bias pred (rad)": f"{roundoff_zero(cycle.bias, cycle.amplitude):.4g}" if prediction.balanced else "",
                "Loeb": "stable" if cycle.stable else "unstable", **_simulated_cells(cycle.simulated),
                "A error": signed_percent(cycle.amplitude_error), "w error": signed_percent(cycle.omega_error),
                "closest miss": miss, "command U (N m)": command,
            })
        if not prediction.stable_cycles:
            said = "no DF (see the verdict)" if prediction.note else ("(unstable only)" if prediction.cycles else "none")
            rows.append({"model": prediction.model, "A pred (rad)": said, **_simulated_cells(prediction.simulation),
                         "closest miss": miss})
    return text_table(header, rows)


def _simulated_cells(simulated):
    """The simulation's cells of a prediction row: its cycle, or its verdict where it found none."""
    if simulated is None:
        return {}
    if not simulated.found:
        return {"A sim (rad)": simulated.verdict}
    irregular = "" if simulated.periodic else " (no period: dominant harmonic)"
    return {"A sim (rad)": f"{simulated.amplitude:.5g}{irregular}", "w sim (rad/s)": f"{simulated.omega:.5g}"}


def _simulation_words(prediction):
    """Which run a prediction's simulated numbers come from, and what it found: one phrase."""
    sim = prediction.simulation
    if sim is None:
        return "simulation: not run"
    if prediction.stable_cycles:
        return f"simulation started on the predicted cycle (theta_d = 0, dtheta_d/dt = A w): {sim}"
    return f"simulation from a kick of dtheta_d/dt (no stable cycle predicted): {sim}"


def _overlay_caption(predictions):
    """The Nyquist overlay's caption, naming the marks it draws."""
    marks = [("o stable cycle", any(c.stable for p in predictions for c in p.cycles)),
             ("x unstable cycle", any(not c.stable for p in predictions for c in p.cycles)),
             ("diamond near miss", any(p.near_misses for p in predictions))]
    return "G(jw) (black) and -1/N(A, w) per model at several frequencies" + "".join(
        f"; {words}" for words, drawn in marks if drawn)


def prediction_sections(predictions, figure, rig_text="", notes=None):
    """The HTML sections of a prediction report: summary, rig, Nyquist overlay, cycle table.

    Each model's summary line names the run its simulated numbers come from: the
    table's ``A sim`` and ``w sim``, and the summary's, are those of the run started
    on each predicted stable cycle (:func:`~backlash_df.limit_cycles.verify_limit_cycles`,
    :data:`SIMULATED_NOTE`).  With ``notes`` (verdicts) the summary says that a
    verdict's simulated cycle comes from other runs, from rest, disturbed as the
    verdict names (:func:`~backlash_df.verdict.judge_loop`, :data:`VERDICT_RUNS_NOTE`).

    Parameters
    ----------
    predictions : sequence of LimitCyclePrediction
    figure : matplotlib.figure.Figure
        Their Nyquist overlay (:func:`~backlash_df.limit_cycles.limit_cycle_plot`); closed here.
    rig_text : str
        The rig file's text, shown as it is under "Rig" when given.
    notes : dict of str to str, optional
        Model name -> HTML appended to that model's summary line (a verdict, say).

    Returns
    -------
    list of (heading, html)
    """
    header, rows = prediction_rows(predictions)
    lines = []
    for prediction in predictions:
        stable = prediction.stable_cycles
        said = f"{len(stable)} stable and {len(prediction.cycles) - len(stable)} unstable predicted cycle(s)"
        seen = html.escape(_simulation_words(prediction))
        seen += (notes or {}).get(prediction.model, "")
        lines.append(f"<li><b>{prediction.model}</b>: {said}; {seen}</li>")
    runs = f"<p>{html.escape(VERDICT_RUNS_NOTE)}</p>" if notes else ""
    summary = f'<div class="summary"><p>{PREDICTION_NOTE}</p><ul>{"".join(lines)}</ul>{runs}</div>'
    return [("", summary), *rig_sections(rig_text),
            ("Nyquist overlay", figure_html(figure, _overlay_caption(predictions))),
            ("Predicted and simulated limit cycles",
             table_html(header, rows, text_columns=("model", "Loeb", "A sim (rad)"))
             + f"<p>{html.escape(SIMULATED_NOTE)}</p>")]


def prediction_report(predictions, figure, title="Limit-cycle prediction", rig_text=""):
    """A self-contained HTML page of :func:`prediction_sections`.

    Parameters
    ----------
    predictions : sequence of LimitCyclePrediction
    figure : matplotlib.figure.Figure
        Their Nyquist overlay; closed here.
    title : str
    rig_text : str

    Returns
    -------
    str
    """
    return html_page(title, prediction_sections(predictions, figure, rig_text))
