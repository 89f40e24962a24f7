"""The paper's Table I and Figure 2 in words: the aligned text ``backlash-df reproduce`` prints.

Rendered from a :class:`~backlash_df.reproduce.TableOne` (its rows and
comparisons) and the data of :func:`~backlash_df.reproduce.figure2_maps`;
:data:`LAW_LABELS` names each law by the paper's equations, in the text and in
the figures' legends alike.
"""

import textwrap

import numpy as np

__all__ = ["table_one_text", "figure2_summary"]

#: Each law by the paper's equations.
LAW_LABELS = {
    "exact": "exact (1), (14)",
    "phase-plane": "phase plane (23)",
    "damped-dead-zone": "dead-zone (26)",
    "revised-dead-zone": "revised dead-zone (27)",
    "elasto-backlash": "ElastoBacklash",
    "dead-zone": "dead-zone (24)",
    "rubber": "rubber (40)",
}

#: What Table I holds (the text's first line, the JSON's ``quantity``).
TABLE_ONE_QUANTITY = ("Table I: integral of the shaft torque T over one disturbance cycle (N m s) of each law, "
                      "evaluated along the same simulated trajectory, against the exact model (1), (14); "
                      "RMS of T - T_exact over that cycle (N m).")


def _cell(value, spec):
    """``value`` formatted by ``spec`` (``"+11.2f"``), or ``n/a`` in the same width where it is None."""
    width = int(spec.lstrip("+").split(".")[0])
    return f"{'n/a':>{width}}" if value is None else format(value, spec)


def table_one_text(table):
    """Table I as aligned text, one block per setup, after a line saying what is integrated.

    Parameters
    ----------
    table : TableOne

    Returns
    -------
    str
    """
    lines = [textwrap.fill(TABLE_ONE_QUANTITY, 100), ""]
    for comparison in table.comparisons:
        setup = comparison.setup
        lines.append(f"setup {setup.name}: T_preload = {setup.preload:g} N m, a_dist = {setup.amplitude:g} N m "
                     f"at {setup.frequency:g} Hz, c = {setup.damping_ratio:g} k")
        lines.append(f"  {setup.description}")
        lines.append(f"  simulated with the {comparison.driver} law, dt = {comparison.dt:g} s; "
                     f"periodicity {comparison.periodicity:.1e}")
        lines.append(f"  {'model':<24}{'integral (1e-3 N m s)':>22}{'error (%)':>11}{'RMS error (N m)':>17}"
                     f"{'RMS error (%)':>15}")
        for row in (r for r in table.rows if r["setup"] == setup.name):
            cells = [f"{1e3 * row['integral']:22.4f}"]
            if row["model"] == "exact":
                cells += [f"{'-':>11}", f"{'-':>17}", f"{'-':>15}"]
            else:
                cells += [_cell(row["error_percent"], "+11.2f"), f"{row['rms_error']:17.3f}",
                          _cell(row["rms_error_percent"], "15.1f")]
            lines.append(f"  {LAW_LABELS[row['model']]:<24}" + "".join(cells))
        lines.append("")
    return "\n".join(lines)


def figure2_summary(maps):
    """Figure 2 in text: the share of the plotted plane where each map pushes, pulls or is zero.

    Parameters
    ----------
    maps : dict
        :func:`~backlash_df.reproduce.figure2_maps`.

    Returns
    -------
    str
    """
    lines = [f"{'map':<26}{'T > 0 (%)':>11}{'T = 0 (%)':>11}{'T < 0 (%)':>11}"]
    regions = maps["regions"]
    lines.append(f"{'(a) exact (5): A_+/A_r/A_-':<26}{100 * np.mean(regions > 0):11.1f}"
                 f"{100 * np.mean(regions == 0):11.1f}{100 * np.mean(regions < 0):11.1f}")
    for name, torque in maps["torque"].items():
        lines.append(f"{LAW_LABELS[name]:<26}{100 * np.mean(torque > 0):11.1f}"
                     f"{100 * np.mean(torque == 0):11.1f}{100 * np.mean(torque < 0):11.1f}")
    lines.append(f"(26) pulls (A1 + A2) on {100 * np.mean(maps['pull']):.1f} % of the plotted plane, "
                 f"where (5) allows no such torque")
    return "\n".join(lines)
