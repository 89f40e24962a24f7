"""A branch of periodic orbits in words: the tables of the orbits and the DF's cycles, the special points, the report.

Rendered from a :class:`~backlash_df.continuation.Branch` (its points, special
points and DF predictions); the branch's figure is drawn by
:func:`~backlash_df.continuation.branch_plot` and handed in.
"""

from .html import bias_text, figure_html, html_page, rig_sections, table_html
from .sweeps import value_label

__all__ = ["branch_tables", "branch_sentences", "branch_report"]


def branch_tables(branch):
    """The terminal's tables: ``[(title, header, rows), ...]``, the exact orbits, then the DF's cycles.

    Every header names its unit, the parameter's that of the rig file
    (:func:`~backlash_df.render.sweeps.value_label`: ``kp (N m s/rad)``).  Biases that
    are round-off of a zero mean print as 0 (:func:`~backlash_df.render.html.bias_text`).

    Parameters
    ----------
    branch : Branch

    Returns
    -------
    list of (str, list of str, list of list of str)
    """
    parameter = value_label(branch.parameter)
    orbits = [[f"{point.parameter:.6g}", f"{point.orbit.amplitude:.5g}", f"{point.orbit.omega:.5g}",
               f"{point.orbit.period:.5g}", bias_text(point.orbit.bias, point.orbit.amplitude),
               f"{point.orbit.max_multiplier:.4f}", "stable" if point.orbit.stable else "unstable"]
              for point in branch.points]
    cycles = []
    for value, prediction in branch.df:
        cycles += [[f"{value:.6g}", f"{cycle.amplitude:.5g}", f"{cycle.omega:.5g}",
                    bias_text(cycle.bias, cycle.amplitude), "stable" if cycle.stable else "unstable"]
                   for cycle in prediction.cycles] or [[f"{value:.6g}", "none", "", "", ""]]
    return [(f"exact periodic orbits of the {branch.model} law (shooting; stability by Floquet multipliers):",
             [parameter, "A (rad)", "w (rad/s)", "period (s)", "bias (rad)", "|mu| max", "Floquet"], orbits),
            (f"describing function at {len(branch.df)} values (stability by Loeb's criterion):",
             [parameter, "A DF (rad)", "w DF (rad/s)", "bias (rad)", "Loeb"], cycles)]


def branch_sentences(branch):
    """One line per special point: kind, where, and what happened.

    Parameters
    ----------
    branch : Branch

    Returns
    -------
    list of str
    """
    return [f"{s.kind} at {branch.parameter} = {s.parameter:.6g} (A = {s.amplitude:.4g} rad): {s.detail}"
            for s in branch.special]


def branch_report(branch, figure, title="", rig_text=""):
    """A self-contained HTML page: the branch figure and the special points.

    Parameters
    ----------
    branch : Branch
    figure : matplotlib.figure.Figure
        The branch's figure (:func:`~backlash_df.continuation.branch_plot`); closed here.
    title : str
        Page title (default "Continuation").
    rig_text : str
        The rig file's text, shown as it is.

    Returns
    -------
    str
    """
    rows = [[s.kind, f"{s.parameter:.6g}", f"{s.amplitude:.5g}", s.detail] for s in branch.special]
    return html_page(title or "Continuation", [
        ("", f'<div class="summary"><p>{len(branch.points)} exact periodic orbits (shooting, '
             f"Floquet multipliers) of the {branch.model} law continued in {branch.parameter}; solid: "
             "stable, dashed: unstable; markers: the describing function's cycles.</p></div>"),
        *rig_sections(rig_text),
        ("Branch", figure_html(figure, f"A and w against {branch.parameter}")),
        ("Special points", table_html(["kind", value_label(branch.parameter), "A (rad)", "detail"], rows,
                                      text_columns=(0, 3))),
    ])
