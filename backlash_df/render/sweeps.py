"""A design map in words: the verdict grids of the terminal, their key and counts, and the report.

Rendered from a :class:`~backlash_df.sweeps.DesignMap` (its verdict arrays and
agreement); the map's figure is drawn by :func:`~backlash_df.sweeps.design_map_plot`
and handed in.  :func:`value_label` names a rig value with its unit, for tables and
axes alike.
"""

import html

import numpy as np

from ..config import RANGES
from .html import figure_html, html_page, rig_sections, table_html

__all__ = ["VERDICT_CODES", "map_tables", "map_sentences", "map_report"]

#: One character per verdict in the text grids of :func:`map_tables`.
VERDICT_CODES = {"no oscillation": ".", "limit cycle": "C", "bistable": "B", "unstable": "U", "undetermined": "?"}


def value_label(parameter):
    """A label for a rig value: its name and its rig-file unit (:data:`~backlash_df.config.RANGES`).

    Examples
    --------
    >>> value_label("ti"), value_label("load.torque"), value_label("gear_ratio")
    ('ti (s)', 'load.torque (N m)', 'gear_ratio')
    """
    unit = RANGES.get(parameter.rsplit(".", 1)[-1], (None, None, ""))[2]
    return f"{parameter} ({unit})" if unit else parameter


def grid_labels(values):
    """Grid values as labels: 4 significant digits, more where two values would read the same.

    Examples
    --------
    >>> grid_labels([0.1, 0.5]), grid_labels([1.0, 1.00001])
    (['0.1', '0.5'], ['1', '1.00001'])
    """
    for digits in range(4, 18):
        labels = [f"{value:.{digits}g}" for value in values]
        if len(set(labels)) == len(labels):
            return labels
    return [repr(float(value)) for value in values]


def map_tables(dmap):
    """The terminal's verdict grids: ``[(title, header, rows), ...]``, per law the DF's and the simulation's.

    A row per ``x`` value, a column per ``y`` value (labelled with the values),
    each cell one character of :data:`VERDICT_CODES`; :func:`map_sentences` holds the key.

    Parameters
    ----------
    dmap : DesignMap

    Returns
    -------
    list of (str, list of str, list of list of str)
    """
    xs, ys = grid_labels(dmap.x), grid_labels(dmap.y)
    tables = []
    for name in dmap.models:
        for kind, verdicts in (("DF", dmap.df_verdict), ("simulation", dmap.sim_verdict)):
            if name in verdicts:
                rows = [[x, *(VERDICT_CODES[v] for v in row)] for x, row in zip(xs, verdicts[name])]
                tables.append((f"{name}, {kind} verdicts:", [f"{dmap.x_name} \\ {dmap.y_name}", *ys], rows))
    return tables


def map_sentences(dmap):
    """The key of the grids' characters, then per law the DF's cells per verdict and the agreement.

    Parameters
    ----------
    dmap : DesignMap

    Returns
    -------
    list of str
    """
    lines = ["  ".join(f"{code} {verdict}" for verdict, code in VERDICT_CODES.items())]
    for name in dmap.models:
        counts = ", ".join(f"{v} {int((dmap.df_verdict[name] == v).sum())}" for v in dmap.verdicts)
        unsure = int((dmap.df_verdict[name] == "undetermined").sum())
        agree = (f"; agrees with simulation on {100 * dmap.agreement(name):.1f} %"
                 + (f" (its {unsure} undetermined cells count as no cycle there)" if unsure else "")
                 if name in dmap.sim_verdict else "")
        lines.append(f"{name}: DF {counts}{agree}")
    return lines + [f"note: {note}" for note in dmap.notes]


def map_report(dmap, figure, title="", rig_text=""):
    """A self-contained HTML page: the map, the DF's cells per verdict and the agreement per law, the grids.

    Parameters
    ----------
    dmap : DesignMap
    figure : matplotlib.figure.Figure
        The map's figure (:func:`~backlash_df.sweeps.design_map_plot`); closed here.
    title : str
        Page title (default "Design map").
    rig_text : str
        The rig file's text, shown as it is.

    Returns
    -------
    str
    """
    rows = []
    for name in dmap.models:
        counts = [int(np.sum(dmap.df_verdict[name] == v)) for v in dmap.verdicts]
        agree = f"{100 * dmap.agreement(name):.1f} %" if name in dmap.sim_verdict else ""
        rows.append([name, *counts, agree])
    sections = [("", '<div class="summary"><p>Each cell: the describing-function verdict (left) and the '
                     "closed-loop simulation with the same law (right); contours: amplitude A (rad, first "
                     "harmonic of theta_d) of the stable cycle.</p>"
                     + "".join(f"<p>Note: {html.escape(note)}.</p>" for note in dmap.notes) + "</div>"),
                *rig_sections(rig_text),
                ("Map", figure_html(figure, f"{dmap.x_name} x {dmap.y_name}")),
                ("DF verdicts (cells) and agreement with simulation",
                 table_html(["model", *dmap.verdicts, "agreement"], rows))]
    key = "; ".join(f"{code}: {verdict}" for verdict, code in VERDICT_CODES.items())
    for grid_title, header, grid in map_tables(dmap):
        sections.append((grid_title.rstrip(":"), f"<p>{html.escape(key)}</p>" + table_html(header, grid)))
    return html_page(title or "Design map", sections)
