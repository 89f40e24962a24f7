"""What users read: the pieces of the self-contained HTML reports, and number formats.

Reports have their figures inline and no external files or scripts; every
result's ``report_html(title="", rig_text="")`` builds its page from these.
"""

import base64
import html
import io
import math

__all__ = ["figure_png", "figure_html", "table_html", "html_page", "signed_percent", "BIAS_ROUND_OFF", "bias_text"]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 60em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.8em 0; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th { background: #eee; } td.text, th.text { text-align: left; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #555; }
.summary { background: #f4f8ff; border-left: 4px solid #36c; padding: 0.6em 1em; }
"""


def figure_png(fig, dpi=110):
    """A matplotlib figure as PNG bytes (tight bounding box); closes the figure."""
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buffer.getvalue()


def figure_html(fig, caption="", dpi=110):
    """A matplotlib figure as an inline PNG ``<figure>`` element; closes the figure."""
    data = base64.b64encode(figure_png(fig, dpi)).decode("ascii")
    alt = html.escape(caption or "figure")
    caption_html = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return f'<figure><img alt="{alt}" src="data:image/png;base64,{data}">{caption_html}</figure>'


def table_html(header, rows, text_columns=(0,)):
    """An HTML table; ``rows`` are sequences of already formatted cells."""
    def cell(tag, index, value):
        cls = ' class="text"' if index in text_columns else ""
        return f"<{tag}{cls}>{html.escape(str(value))}</{tag}>"

    head = "".join(cell("th", i, value) for i, value in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", i, value) for i, value in enumerate(row)) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def html_page(title, sections):
    """A complete HTML document from ``(heading, html_body)`` sections."""
    parts = [f"<h2>{html.escape(heading)}</h2>\n{body}" if heading else body for heading, body in sections]
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>\n"
        f"<body><h1>{html.escape(title)}</h1>\n" + "\n".join(parts) + "\n</body></html>\n"
    )


def signed_percent(value):
    """A relative value as ``+1.23 %``; ``""`` where it is not finite (no value to show)."""
    return "" if not math.isfinite(value) else f"{100.0 * value:+.2f} %"


#: A bias at most this fraction of the amplitude is round-off of a zero mean (printed as 0).
BIAS_ROUND_OFF = 1e-12


def bias_text(bias, amplitude, digits=4):
    """A cycle's bias (mean of theta_d, rad) as text; ``0`` where it is round-off.

    A symmetric cycle's computed mean is zero to round-off (``-5.9e-16`` rad on a
    0.11 rad cycle); a magnitude at most :data:`BIAS_ROUND_OFF` times the
    amplitude prints as ``0``.  The JSON documents keep the computed value.
    """
    if abs(bias) <= BIAS_ROUND_OFF * abs(amplitude):
        return "0"
    return f"{bias:.{digits}g}"
