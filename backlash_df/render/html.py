"""What users read: the pieces of the self-contained HTML reports, and number formats.

Reports have their figures inline and no external files or scripts; every
result's ``report_html(title="", rig_text="")`` builds its page from these (through
the other modules of :mod:`backlash_df.render`).  The module imports nothing of the
package: the floor under every module that writes a number for a person.
"""

import base64
import html
import io
import math

__all__ = ["figure_html", "table_html", "html_page", "signed_percent", "ROUNDOFF", "roundoff_zero"]

#: Relative size below which a computed value is round-off: printed as 0 (the JSON keeps the value).
ROUNDOFF = 1e-12

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 60em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.8em 0; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th { background: #eee; } td.text, th.text { text-align: left; }
td.number { text-align: right; font-variant-numeric: tabular-nums; } td.number span, td.word { white-space: nowrap; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #555; }
.summary { background: #f4f8ff; border-left: 4px solid #36c; padding: 0.6em 1em; }
"""


#: The file formats a figure is written in, by the suffix that names each.
FIGURE_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def figure_bytes(fig, format="png", dpi=110):
    """A matplotlib figure as the bytes of a file of ``format`` (tight bounding box); closes the figure.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    format : {"png", "pdf", "svg"}
        The file format (:data:`FIGURE_FORMATS`).
    dpi : float
        Resolution of the PNG, and of any raster part of a PDF or SVG.

    Returns
    -------
    bytes
    """
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format=format, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def figure_png(fig, dpi=110):
    """A matplotlib figure as PNG bytes (tight bounding box); closes the figure."""
    return figure_bytes(fig, "png", dpi)


def figure_html(fig, caption="", dpi=110):
    """A matplotlib figure as an inline PNG ``<figure>`` element; closes the figure."""
    data = base64.b64encode(figure_png(fig, dpi)).decode("ascii")
    alt = html.escape(caption or "figure")
    caption_html = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return f'<figure><img alt="{alt}" src="data:image/png;base64,{data}">{caption_html}</figure>'


def table_html(header, rows, text_columns=(0,)):
    """An HTML table; ``rows`` are sequences of already formatted cells.

    ``text_columns``: indices or header names of the columns aligned left (words).
    A cell that holds only numbers (:func:`number_cell`) is aligned right in any
    column, and no number of it wraps: ``+10.16 %`` stays on one line, an interval
    ``3.27e+06 .. 3.86e+06`` breaks (where the column is narrow) only after its
    ``..``; the numbers of a column of words (``A sim``: a cycle's amplitude or ``no
    limit cycle``) line up, under a heading aligned right where every cell of the
    column is a number.  A word without spaces (``phase-plane``) is not broken at
    its hyphen either.
    """
    def texts(index):
        words = index in text_columns or header[index] in text_columns
        return words and not all(number_cell(str(row[index])) for row in rows if str(row[index]))

    def cell(tag, index, value):
        text = str(value)
        if tag == "td" and number_cell(text):
            return f'<td class="number">{_number_spans(text)}</td>'
        if tag == "th":
            cls = ' class="text"' if texts(index) else ""
        else:
            word = " word" if text and " " not in text.strip() and len(text) <= 24 else ""
            cls = f' class="text{word}"' if index in text_columns or header[index] in text_columns else ""
        return f"<{tag}{cls}>{html.escape(text)}</{tag}>"

    head = "".join(cell("th", i, value) for i, value in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", i, value) for i, value in enumerate(row)) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _number_spans(text):
    """A cell of numbers as HTML: each number with the separator after it in one unbreakable ``<span>``."""
    parts = text.strip().replace(" / ", " /\0").replace(" .. ", " ..\0").replace(", ", ",\0").split("\0")
    return " ".join(f"<span>{html.escape(part)}</span>" for part in parts)


def number_cell(text):
    """Whether a table cell holds numbers only: one, or several joined by `` / ``, `` .. `` or ``, ``,
    the last optionally followed by ``%``.

    Examples
    --------
    >>> number_cell("+10.16 %"), number_cell("98.87 / 99.31"), number_cell("0.0131 .. 0.0134"), number_cell("1e-05")
    (True, True, True, True)
    >>> number_cell("0.05303 (exact orbit)"), number_cell("stable"), number_cell("")
    (False, False, False)
    """
    text = text.strip().removesuffix("%").strip()
    if not text:
        return False
    parts = text.replace(" / ", "\0").replace(" .. ", "\0").replace(", ", "\0").split("\0")
    try:
        return all(part.strip() == part and math.isfinite(float(part)) for part in parts)
    except ValueError:
        return False


def html_page(title, sections):
    """A complete HTML document from ``(heading, html_body)`` sections."""
    parts = [f"<h2>{html.escape(heading)}</h2>\n{body}" if heading else body for heading, body in sections]
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>\n"
        f"<body><h1>{html.escape(title)}</h1>\n" + "\n".join(parts) + "\n</body></html>\n"
    )


def rig_sections(rig_text):
    """A report's "Rig" section, the rig file's text as it is: ``[("Rig", html)]``, none without a text."""
    return [("Rig", f"<pre>{html.escape(rig_text)}</pre>")] if rig_text else []


def signed_percent(value):
    """A relative value as ``+1.23 %``; ``0.00 %``, without a sign, where it rounds to zero; ``""`` where it is
    not finite (no value to show).

    Examples
    --------
    >>> signed_percent(0.0123), signed_percent(-0.0123), signed_percent(-4e-6), signed_percent(float("nan"))
    ('+1.23 %', '-1.23 %', '0.00 %', '')
    """
    if not math.isfinite(value):
        return ""
    text = f"{100.0 * value:+.2f}"
    return f"{'0.00' if float(text) == 0.0 else text} %"


def percent_text(value, digits=1):
    """A relative value in per cent with ``digits`` decimals, ``0.0`` (no sign) where it rounds to zero.

    Examples
    --------
    >>> percent_text(-0.0004), percent_text(0.1234), percent_text(-0.05)
    ('0.0', '12.3', '-5.0')
    """
    return f"{round(100.0 * value, digits) + 0.0:.{digits}f}"


def roundoff_zero(value, scale):
    """``value``, or 0.0 where it is round-off: ``|value| <= ROUNDOFF |scale|`` (for the text only).

    Parameters
    ----------
    value : float
        A computed value that is zero in exact arithmetic in some cases (the bias
        of an unloaded cycle, the phase of a static law).
    scale : float
        The size it is computed from, same unit (the cycle's amplitude, say).

    Examples
    --------
    >>> roundoff_zero(-5.9e-16, 0.15), roundoff_zero(-0.0208, 0.147), roundoff_zero(-0.0, 1.0)
    (0.0, -0.0208, 0.0)
    """
    return 0.0 if abs(value) <= ROUNDOFF * abs(scale) else float(value)


def resolved(value, resolution):
    """``value``, or 0.0 where it is below the resolution of the computation that made it (for the text only).

    :func:`roundoff_zero` is the case of an exact computation, whose resolution is
    floating point's; a measured value (the mean of a simulated cycle) is resolved
    only as finely as its measurement, which its caller states.

    Parameters
    ----------
    value : float
    resolution : float
        The smallest magnitude the computation resolves, same unit; ``|value| <=
        resolution`` prints as 0.

    Examples
    --------
    >>> resolved(3.25e-07, 1.5e-4), resolved(-0.0208, 1.5e-4), resolved(float("nan"), 1.0)
    (0.0, -0.0208, nan)
    """
    return 0.0 if abs(value) <= abs(resolution) else float(value)


def below_text(value, bound, decimals=1):
    """``value`` with ``decimals`` decimals, or as many more as it takes to read below ``bound``.

    For a sentence that says a value is below a bound: rounded to the bound, ``1.96``
    would print ``t 2.0 below 2``.  A value at or above ``bound``, or not finite, gets
    ``decimals`` decimals.

    Examples
    --------
    >>> below_text(1.96, 2.0), below_text(1.5, 2.0), below_text(1.99996, 2.0), below_text(2.04, 2.0)
    ('1.96', '1.5', '1.99996', '2.0')
    """
    text = f"{value:.{decimals}f}"
    while value < bound and float(text) >= bound:
        decimals += 1
        text = f"{value:.{decimals}f}"
    return text


def text_table(header, rows):
    """A table of formatted cells from rows given as ``{column: cell}``, without the columns empty in every row.

    A cell a row does not give is ``""``; a column whose cells are all ``""`` is
    left out, except the first (the row's name).  Every row has one cell per
    column of the header returned.

    Parameters
    ----------
    header : list of str
    rows : list of dict of str to str
        Keys from ``header``.

    Returns
    -------
    header : list of str
    rows : list of list of str

    Examples
    --------
    >>> text_table(["model", "A (rad)", "miss"], [{"model": "exact", "A (rad)": "0.15"}, {"model": "rubber"}])
    (['model', 'A (rad)'], [['exact', '0.15'], ['rubber', '']])
    """
    unknown = {key for row in rows for key in row} - set(header)
    if unknown:
        raise ValueError(f"cells for columns not in the header: {', '.join(sorted(unknown))}")
    kept = [name for index, name in enumerate(header) if index == 0 or any(row.get(name, "") for row in rows)]
    return kept, [[row.get(name, "") for name in kept] for row in rows]


def bias_text(bias, amplitude, digits=4):
    """A cycle's bias (mean of theta_d, rad) as text; ``0`` where it is round-off (:func:`roundoff_zero`).

    A symmetric cycle's computed mean is zero to round-off (``-5.9e-16`` rad on a
    0.11 rad cycle); the JSON documents keep the computed value.
    """
    return f"{roundoff_zero(bias, amplitude):.{digits}g}"
