"""Figures a person can read (issue 23), checked from each figure's own layout.

Every ``.plot()`` of every result class (the ``results`` fixture of conftest.py,
which tests/test_result_protocol.py walks too), every torque law's ``.plot()``,
Figure 2 of the paper, the figures of the diagnosis report and notebook 03's
side-by-side overlay are drawn (Agg) and read back: the window extent of every
text (titles, axis labels, tick labels, offsets, annotations, contour labels,
suptitle, legends) must lie inside the figure, and a clipped text inside its
panel; no two texts overlap (titles included); a title overlaps no panel; a
legend overlaps no text outside it (no title); and a legend inside a panel
covers no drawn data (the lines' segments, stems and bars in display
coordinates; a legend outside the panels is free).  The design map's extent,
units and contour labels and the sampling of G(jw) in the Nyquist overlay are
checked on their own.  Every axis of the figures of the ``predict``, ``tune`` and
``diagnose`` reports shows at least two tick labels (a log axis labelled ``10^2`` alone
reads as no scale), the Nyquist overlay's view spans its data with short tick labels, and
the tuning plot draws no hunting tuning as data at bandwidth 0 and no negative amplitude.
"""

import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import LineCollection, QuadMesh  # noqa: E402
from matplotlib.container import BarContainer  # noqa: E402
from matplotlib.contour import ContourSet  # noqa: E402
from matplotlib.path import Path  # noqa: E402
from matplotlib.text import Text  # noqa: E402

import backlash_df as bd  # noqa: E402
from backlash_df import plotting  # noqa: E402
from backlash_df.config import RANGES  # noqa: E402
from backlash_df.limit_cycles import limit_cycle_plot  # noqa: E402
from backlash_df.models import MODEL_NAMES  # noqa: E402
from backlash_df.render.html import figure_html  # noqa: E402
from backlash_df.reproduce import figure2  # noqa: E402
from conftest import NOTEBOOKS, PLOTS, REPORTS, example_rig  # noqa: E402

TOLERANCE = 1.0  # px: extents touching by a pixel do not count as overlapping


# --------------------------------------------------------------------------- reading a figure's layout


def _drawn(artist):
    """Whether the artist and every parent axes are visible and it has text to show."""
    axes = getattr(artist, "axes", None)
    return artist.get_visible() and (axes is None or axes.get_visible()) and bool(artist.get_text().strip())


def _tick_labels(axis):
    """The tick labels the axis draws: visible ticks whose location lies in the view."""
    low, high = sorted(axis.get_view_interval())
    span = max(high - low, np.finfo(float).tiny)
    labels = []
    for tick in axis.get_major_ticks() + axis.get_minor_ticks():
        if low - 1e-9 * span <= tick.get_loc() <= high + 1e-9 * span:
            labels += [label for label in (tick.label1, tick.label2) if label.get_visible()]
    return labels


def figure_texts(figure):
    """``(kind, where, Text)`` of every text the figure shows; kind ``"title"`` or ``"text"``."""
    found = []
    for index, ax in enumerate(figure.axes):
        if not ax.get_visible():
            continue
        titles = {ax.get_title(loc) for loc in ("left", "center", "right")} - {""}
        for child in ax.get_children():
            if isinstance(child, Text):
                kind = "title" if child is ax.title or child.get_text() in titles else "text"
                found.append((kind, f"axes {index}", child))
        for axis in (ax.xaxis, ax.yaxis):
            found += [("text", f"axes {index}", text)
                      for text in [axis.label, axis.get_offset_text(), *_tick_labels(axis)]]
    suptitle = figure.get_suptitle()
    found += [("title" if suptitle and text.get_text() == suptitle else "text", "figure", text)
              for text in figure.texts]
    return [(kind, where, text) for kind, where, text in found if _drawn(text)]


def figure_legends(figure):
    """Every legend drawn: the axes' and the figure's."""
    legends = [ax.get_legend() for ax in figure.axes if ax.get_visible()] + list(figure.legends)
    return [legend for legend in legends if legend is not None and legend.get_visible()]


def _overlap(one, other):
    """Width and height (px) of the intersection of two boxes, 0 where they do not meet."""
    width = min(one.x1, other.x1) - max(one.x0, other.x0)
    height = min(one.y1, other.y1) - max(one.y0, other.y0)
    return max(width, 0.0), max(height, 0.0)


def _overlaps(one, other):
    width, height = _overlap(one, other)
    return width > TOLERANCE and height > TOLERANCE


def _extent(artist, renderer):
    box = artist.get_window_extent(renderer)
    return None if box.width <= TOLERANCE and box.height <= TOLERANCE else box  # not drawn (an annotation off view)


def _data_paths(ax):
    """What a legend must not cover in ``ax``: display-coordinate paths (lines, stems, bars).

    Each entry: ``(path, filled)``; markers-only lines give their points as
    one-vertex paths.
    """
    paths = []
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), dtype=float))
        finite = np.all(np.isfinite(xy), axis=1)
        if line.get_linestyle() in ("None", "", " ", "none"):
            paths += [(Path(point[None, :]), False) for point in xy[finite]]
            continue
        for piece in np.split(xy, np.flatnonzero(~finite)):
            piece = piece[np.all(np.isfinite(piece), axis=1)]
            if len(piece):
                paths.append((Path(piece if len(piece) > 1 else np.repeat(piece, 2, axis=0)), False))
    for collection in ax.collections:
        if isinstance(collection, LineCollection) and collection.get_visible():
            paths += [(collection.get_transform().transform_path(path), False) for path in collection.get_paths()]
    for container in ax.containers:
        if isinstance(container, BarContainer):
            paths += [(bar.get_transform().transform_path(bar.get_path()), True) for bar in container
                      if np.all(np.isfinite(bar.get_path().vertices)) and bar.get_height() != 0]
    return paths


def _covers_data(box, ax, renderer):
    """Whether the legend box covers drawn data of ``ax`` (inside the panel)."""
    inside = box.intersection(box, ax.get_window_extent(renderer))
    if inside is None or inside.width <= TOLERANCE or inside.height <= TOLERANCE:
        return False
    inside = inside.padded(-TOLERANCE)
    for path, filled in _data_paths(ax):
        if len(path.vertices) == 1:
            (x, y), = path.vertices
            if inside.x0 <= x <= inside.x1 and inside.y0 <= y <= inside.y1:
                return True
        elif path.intersects_bbox(inside, filled=filled):
            return True
    return False


def _inside(box, frame):
    frame = frame.padded(TOLERANCE)
    return frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1


def _cut_off(figure, texts, legends):
    """Texts and legends that leave the figure, texts their own panel cuts (clipped)."""
    problems = [f"{kind} {text.get_text()!r} ({where}) leaves the figure: {box.bounds} outside {figure.bbox.bounds}"
                for kind, where, text, box in texts if not _inside(box, figure.bbox)]
    problems += [f"a legend leaves the figure: {box.bounds} outside {figure.bbox.bounds}"
                 for _, box in legends if not _inside(box, figure.bbox)]
    return problems + [f"{kind} {text.get_text()!r} ({where}) is cut by its panel" for kind, where, text, box in texts
                       if text.get_clip_on() and text.get_clip_box() is not None
                       and not _inside(box, text.get_clip_box())]


def _overlapping_texts(texts):
    """Pairs of texts that overlap (a title with anything, or any two other texts)."""
    problems = []
    for i, (kind, where, text, box) in enumerate(texts):
        for other_kind, other_where, other, other_box in texts[i + 1:]:
            if _overlaps(box, other_box):
                what = "titles" if kind == other_kind == "title" else f"{kind} and {other_kind}"
                problems.append(f"{what} {text.get_text()!r} ({where}) and {other.get_text()!r} ({other_where}) "
                                f"overlap")
    return problems


def _titles_over_panels(figure, texts, renderer):
    panels = [(index, ax.get_window_extent(renderer)) for index, ax in enumerate(figure.axes) if ax.get_visible()]
    return [f"title {text.get_text()!r} ({where}) overlaps the panel of axes {index}"
            for kind, where, text, box in texts if kind == "title"
            for index, panel in panels if _overlaps(box, panel)]


def _legends_over(figure, texts, legends, renderer):
    """Legends over a text outside them (a title included), or over the data of a panel."""
    problems = []
    for legend, box in legends:
        own = {id(text) for text in legend.get_texts()} | {id(legend.get_title())}
        problems += [f"a legend overlaps the {kind} {text.get_text()!r} ({where})"
                     for kind, where, text, text_box in texts if id(text) not in own and _overlaps(box, text_box)]
        problems += [f"a legend covers data of axes {index} ({ax.get_title() or ax.get_ylabel()!r})"
                     for index, ax in enumerate(figure.axes) if ax.get_visible() and _covers_data(box, ax, renderer)]
    return problems


def layout_problems(figure):
    """What a reader of ``figure`` would find cut off or covered: one line per problem."""
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    texts = [(kind, where, text, _extent(text, renderer)) for kind, where, text in figure_texts(figure)]
    texts = [item for item in texts if item[3] is not None]
    legends = [(legend, legend.get_window_extent(renderer)) for legend in figure_legends(figure)]
    return (_cut_off(figure, texts, legends) + _overlapping_texts(texts) + _titles_over_panels(figure, texts, renderer)
            + _legends_over(figure, texts, legends, renderer))


def shown_tick_labels(axis):
    """The tick labels of ``axis`` a reader sees: visible, inside the view, with text."""
    return [label for label in _tick_labels(axis) if label.get_visible() and label.get_text().strip()]


def thin_axes(figure):
    """The axes of ``figure`` with fewer than two tick labels shown: one line each.

    Not counted: an axis whose ticks are switched off (a ``NullLocator``), the short side
    of a colorbar, an axis of categories (one bar per name, by category units or ticks
    placed by hand, a ``FixedLocator``: one name is one label), and axes drawn without
    their axes.  An axis shared with others counts the labels of the
    one among them that shows most (inner panels of a column hide theirs).
    """
    from matplotlib.category import StrCategoryConverter
    from matplotlib.ticker import FixedLocator, NullLocator

    figure.canvas.draw()
    problems = []
    for index, ax in enumerate(figure.axes):
        if not ax.get_visible() or not ax.axison:
            continue
        box = ax.get_window_extent()
        for name, axis, shared in (("x", ax.xaxis, ax.get_shared_x_axes()), ("y", ax.yaxis, ax.get_shared_y_axes())):
            short_side = ax.get_label() == "<colorbar>" and (box.width < box.height) == (name == "x")
            if (isinstance(axis.get_major_locator(), NullLocator) or not axis.get_visible() or short_side
                    or isinstance(axis.get_converter(), StrCategoryConverter)
                    or isinstance(axis.get_major_locator(), FixedLocator)):
                continue
            count = max(len(shown_tick_labels(getattr(other, f"{name}axis"))) for other in shared.get_siblings(ax))
            if count < 2:
                labels = [label.get_text() for label in shown_tick_labels(axis)]
                problems.append(f"axes {index} ({ax.get_title() or ax.get_ylabel()!r}): its {name} axis shows "
                                f"{count} tick label(s) {labels}")
    return problems


def assert_readable(figure):
    problems = layout_problems(figure)
    plt.close(figure)
    assert not problems, "\n".join(problems)


# --------------------------------------------------------------------------- the checker itself can fail


def test_the_checker_finds_each_kind_of_problem():
    figure, axes = plt.subplots(1, 2, figsize=(5, 3))
    axes[0].plot([0.0, 1.0], [0.0, 1.0], label="a line")
    axes[0].set_title("a title much too long to fit above the left-hand panel of the figure")
    axes[1].set_title("a second title beside it", y=0.8)  # inside its panel
    axes[0].legend(loc="center")
    axes[1].text(0.9, 0.5, "cut by the panel", transform=axes[1].transAxes, clip_on=True)
    figure.suptitle("a figure title")
    figure.legend(handles=axes[0].get_lines(), loc="upper center")
    problems = layout_problems(figure)
    plt.close(figure)
    for kind in ("leaves the figure", "is cut by its panel", "overlaps the panel", "covers data"):
        assert any(kind in problem for problem in problems), kind
    assert any(problem.startswith("titles ") for problem in problems)
    assert any(problem.startswith("a legend overlaps the title 'a figure title'") for problem in problems)


def test_the_checker_passes_a_clean_figure_and_a_legend_beside_the_data():
    figure, ax = plt.subplots(figsize=(5, 3), layout="constrained")
    ax.plot([0.0, 1.0], [0.0, 1.0], label="a line")
    ax.set(title="short", xlabel="x (s)", ylabel="y (m)")
    ax.legend(loc="upper left")  # the line runs from the lower left to the upper right
    assert layout_problems(figure) == []
    figure.legend(loc="outside right upper")
    assert layout_problems(figure) == []
    plt.close(figure)


# --------------------------------------------------------------------------- every figure of the package


def test_every_result_class_with_a_plot_is_walked(results):
    drawing = {name for name, result in results.items() if callable(getattr(result, "plot", None))}
    assert drawing == set(PLOTS)


@pytest.mark.parametrize("name", PLOTS)
def test_result_plot_is_readable(results, name):
    assert_readable(results[name].plot().figure)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_torque_law_plot_is_readable(name):
    model = bd.make_model(name, stiffness=5895.0, damping=3.0, half_gap=0.05, rubber_thickness=0.01)
    assert_readable(model.plot().figure)


def test_figure2_is_readable():
    figure, _ = figure2(n=61)
    assert_readable(figure)


@pytest.mark.parametrize("name", REPORTS)
def test_report_figures_are_readable(results, name, monkeypatch):
    """The figures a report embeds, as it draws them (suptitles included), read before they are closed."""
    problems = report_figure_problems(results[name], layout_problems, monkeypatch)
    assert not problems, "\n".join(problems)


def report_figure_problems(result, check, monkeypatch):
    """``check(figure)``'s problems over the figures ``result.report_html()`` embeds, read before they are closed."""
    problems = []

    def checked(figure, *args, **kwargs):
        problems.extend(check(figure))
        return figure_html(figure, *args, **kwargs)

    for module in list(sys.modules.values()):
        if module.__name__.startswith("backlash_df") and getattr(module, "figure_html", None) is figure_html:
            monkeypatch.setattr(module, "figure_html", checked)
    result.report_html()
    plt.close("all")
    return problems


def _notebook_cell(notebook, starts):
    """The source of the first code cell of ``notebook`` that starts with ``starts``."""
    cells = json.loads((NOTEBOOKS / notebook).read_text(encoding="utf-8"))["cells"]
    return next("".join(cell["source"]) for cell in cells
                if cell["cell_type"] == "code" and "".join(cell["source"]).startswith(starts))


def test_notebook_03_overlays_of_several_laws_are_readable():
    """The notebook's own cell (two overlays in one figure), run on the rig of its first cell."""
    scope = {"plt": plt, "limit_cycle_plot": limit_cycle_plot, "predict_limit_cycles": bd.predict_limit_cycles,
             "rig": example_rig("load_feedback")}
    exec(_notebook_cell("03_limit_cycles.ipynb", "models = "), scope)
    assert_readable(scope["fig"])


# --------------------------------------------------------------------------- the design map's extent, units, contours


def test_cell_edges_are_midpoints_within_the_values():
    assert np.allclose(plotting.cell_edges([0.1, 0.5, 2.0]), [0.1, 0.3, 1.25, 2.0])
    assert np.allclose(plotting.cell_edges([1.0, 4.0, 100.0], "log"), [1.0, 2.0, 20.0, 100.0])  # sqrt(1 4), sqrt(4 100)
    with pytest.raises(ValueError, match="increasing"):
        plotting.cell_edges([0.5, 0.1])
    with pytest.raises(ValueError, match="> 0"):
        plotting.cell_edges([0.0, 1.0], "log")


def test_design_map_covers_the_values_given_with_units_and_labelled_contours(results):
    dmap = results["DesignMap"]
    drawn = dmap.plot()
    drawn.figure.canvas.draw()
    for ax in drawn.axes.flat:
        mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
        edges = mesh.get_coordinates()
        assert edges[..., 0].min() == pytest.approx(dmap.x.min()) and edges[..., 0].max() == pytest.approx(dmap.x.max())
        assert edges[..., 1].min() == pytest.approx(dmap.y.min()) and edges[..., 1].max() == pytest.approx(dmap.y.max())
        assert dmap.x.min() <= min(ax.get_xlim()) + 1e-12 and max(ax.get_xlim()) <= dmap.x.max() + 1e-12
        contours = [c for c in ax.collections if isinstance(c, ContourSet)]
        assert contours, "the map of a cycling loop draws amplitude contours"
        levels = {f"{level:.3g}" for c in contours for level in c.levels}
        labels = [text.get_text() for text in ax.texts]
        assert labels and set(labels) <= levels  # every label names a contour level
    assert drawn.axes[-1, 0].get_xlabel() == f"{dmap.x_name} ({RANGES[dmap.x_name][2]})"
    assert drawn.axes[0, 0].get_ylabel() == f"{dmap.y_name} ({RANGES[dmap.y_name][2]})"
    entries = " ".join(text.get_text() for text in drawn.legend.get_texts())
    assert "amplitude A" in entries and "theta_d (rad)" in entries
    plt.close(drawn.figure)


# --------------------------------------------------------------------------- G(jw) sampled where it turns


def _largest_turn_in_view(ax, line):
    """Largest turning angle (degrees) between successive drawn segments at points inside the panel,
    and the longest segment (px) with an end inside."""
    xy = line.get_transform().transform(line.get_xydata())
    box = ax.get_window_extent()
    inside = (xy[:, 0] >= box.x0) & (xy[:, 0] <= box.x1) & (xy[:, 1] >= box.y0) & (xy[:, 1] <= box.y1)
    step = np.diff(xy, axis=0)
    heading = np.arctan2(step[:, 1], step[:, 0])
    turn = np.degrees(np.abs(np.angle(np.exp(1j * np.diff(heading)))))
    length = np.hypot(step[:, 0], step[:, 1])
    return turn[inside[1:-1]].max(), length[inside[1:] | inside[:-1]].max()


def test_g_is_smooth_through_the_resonance_in_the_overlay(results):
    """The motor-lag loop's G sweeps through the view near the shaft mode (a kink of 120 degrees at 2000
    log-spaced points): drawn, it turns by less than 5 degrees between segments of a few pixels."""
    drawn = results["LimitCyclePrediction"].plot()
    drawn.figure.canvas.draw()
    g = next(line for line in drawn.ax.get_lines() if line.get_label() == "G(jw)")
    turn, length = _largest_turn_in_view(drawn.ax, g)
    plt.close(drawn.figure)
    assert turn < 5.0 and length < 10.0, (turn, length)


def test_adaptive_curve_resolves_a_sharp_resonance():
    """z = 1 / (1 - u^2 + 2 j zeta u), u = w / w0, zeta = 1e-3: a circle of diameter 1 / (2 zeta) = 500 swept
    within u = 1 +- zeta.  In a view of the circle the samples turn by at most 3 degrees and step by at most
    0.4 % of the view; in a view far from the curve the sampling stays as it started."""
    zeta, w0 = 1e-3, 100.0

    def response(w):
        u = np.asarray(w) / w0
        return 1.0 / (1.0 - u ** 2 + 2j * zeta * u)

    view = (-300.0, 300.0, -550.0, 50.0)
    w, z = plotting.adaptive_curve(response, 1.0, 1e4, view)
    assert np.all(np.diff(w) > 0) and np.allclose(z, response(w))
    u = np.column_stack([(z.real - view[0]) / 600.0, (z.imag - view[2]) / 600.0])
    seen = np.all((u >= 0.0) & (u <= 1.0), axis=1)
    step = np.diff(u, axis=0)
    heading = np.arctan2(step[:, 1], step[:, 0])
    turn = np.degrees(np.abs(np.angle(np.exp(1j * np.diff(heading)))))
    assert turn[seen[1:-1]].max() <= 3.0 + 1e-9
    assert np.hypot(*step[seen[1:] & seen[:-1]].T).max() <= 0.004 + 1e-12
    assert np.sum(np.abs(w / w0 - 1.0) < 2 * zeta) > 100  # crowded at the resonance
    far, _ = plotting.adaptive_curve(response, 1.0, 1e4, (1e6, 2e6, 1e6, 2e6))
    assert far.size == 256


# --------------------------------------------------------------------------- log axes


def test_log_scale_labels_decades_and_2_and_5_where_matplotlib_crowds():
    """A view of 0.017 to 0.55 on a 5 in panel: matplotlib labels 2, 3, 4 and 6 times 10^-2 and 10^-1,
    which collide; log_scale labels 0.02, 0.05, 0.1, 0.2 and 0.5, apart."""
    figure, ax = plt.subplots(figsize=(5, 2), layout="constrained")
    ax.plot([0.017, 0.55], [1.0, 2.0])
    ax.set_xscale("log")
    assert any(problem.startswith("text and text") for problem in layout_problems(figure))
    plotting.log_scale(ax.xaxis, 0.017, 0.55)
    assert layout_problems(figure) == []
    shown = sorted(tick.get_loc() for tick in ax.xaxis.get_major_ticks() if 0.017 <= tick.get_loc() <= 0.55)
    assert np.allclose(shown, [0.02, 0.05, 0.1, 0.2, 0.5])
    plt.close(figure)


def test_the_tick_label_count_sees_a_lone_decade():
    """matplotlib's log axis from 20 to 400 with unlabelled minor ticks shows ``10^2`` alone (the tuning plot
    before issue 49); :func:`~backlash_df.plotting.log_scale` labels 20, 50, 100 and 200."""
    from matplotlib.ticker import NullFormatter

    figure, ax = plt.subplots(figsize=(5, 3), layout="constrained")
    ax.plot([20.0, 400.0], [1.0, 2.0])
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())
    (problem,) = thin_axes(figure)
    assert "x axis shows 1 tick label" in problem
    plotting.log_scale(ax.xaxis, 20.0, 400.0)
    assert thin_axes(figure) == []
    assert [label.get_text() for label in shown_tick_labels(ax.xaxis)] == ["20", "50", "100", "200"]
    plt.close(figure)


@pytest.mark.parametrize("low, high", [(20.0, 40.0), (20.0, 400.0), (1.5, 2.5), (0.017, 0.55), (3.0, 9.0),
                                       (1e-3, 10.0), (0.1, 0.35)])
def test_log_scale_shows_at_least_two_plain_labels(low, high):
    """Over less than a decade (kp from 20 to 40: matplotlib shows no label at all) and up to a few, at least
    two labels, plain numbers below two decades."""
    figure, ax = plt.subplots(figsize=(4, 2.5), layout="constrained")
    ax.plot([low, high], [1.0, 2.0])
    plotting.log_scale(ax.xaxis, low, high)
    assert thin_axes(figure) == [] and layout_problems(figure) == []
    if high < 100.0 * low:
        for label in shown_tick_labels(ax.xaxis):
            assert float(label.get_text()) == pytest.approx(label.get_position()[0], rel=1e-2)
    plt.close(figure)


@pytest.mark.parametrize("name", PLOTS)
def test_every_axis_of_a_result_plot_shows_two_tick_labels(results, name):
    drawn = results[name].plot()
    problems = thin_axes(drawn.figure)
    plt.close(drawn.figure)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("name", ["LoopAnalysis", "Tuning", "Diagnosis"])
def test_every_axis_of_the_report_figures_shows_two_tick_labels(results, name, monkeypatch):
    """The figures of the ``predict``, ``tune`` and ``diagnose`` reports, as the reports draw them."""
    problems = report_figure_problems(results[name], thin_axes, monkeypatch)
    assert not problems, "\n".join(problems)


# --------------------------------------------------------------------------- the Nyquist view


def _drawn_points(ax):
    """Every finite data point of the panel's lines, display coordinates."""
    points = [line.get_transform().transform(np.asarray(line.get_xydata(), dtype=float)) for line in ax.get_lines()]
    points = np.concatenate(points)
    return points[np.all(np.isfinite(points), axis=1)]


@pytest.mark.parametrize("rig_name", ["load_feedback", "motor_lag_feedback", "loaded_feedback"])
def test_the_nyquist_view_spans_its_data_with_short_labels(rig_name):
    """What is drawn within the view's width fills its height (load_feedback: the loci and G lie in
    0 < Im < 7e-5 rad/(N m), the view ran from -1.25e-4, its lower half empty), and no tick label is longer
    than 5 characters (a scale factor, not -0.00035)."""
    prediction = bd.predict_limit_cycles(example_rig(rig_name))
    drawn = limit_cycle_plot([prediction])
    drawn.figure.canvas.draw()
    box = drawn.ax.get_window_extent()
    points = _drawn_points(drawn.ax)
    inside = points[(points[:, 0] >= box.x0) & (points[:, 0] <= box.x1)
                    & (points[:, 1] >= box.y0) & (points[:, 1] <= box.y1)]
    filled = np.ptp(inside[:, 1]) / box.height
    labels = [label.get_text().removeprefix("$\\mathdefault{").removesuffix("}$")  # mathtext: the number itself
              for axis in (drawn.ax.xaxis, drawn.ax.yaxis) for label in shown_tick_labels(axis)]
    offsets = [axis.get_offset_text().get_text() for axis in (drawn.ax.xaxis, drawn.ax.yaxis)]
    assert_readable(drawn.figure)
    assert filled > 0.8, filled
    assert max(len(label) for label in labels) <= 5, labels
    assert all("10^" in offset or "10^{" in offset for offset in offsets), offsets  # the scale factor, shown


# --------------------------------------------------------------------------- the tuning plot


def _range_lines(drawn):
    return [line for line in drawn.axes[0].get_lines() if not line.get_label().startswith("_")]


def test_tuning_plot_draws_no_hunting_tuning_at_bandwidth_zero(results):
    """Tunings whose loop in contact is unstable have no bandwidth (NaN): their cells are shaded and listed in
    the legend, never marked at bandwidth 0; a front of one point keeps its amplitude axis at 0 and above."""
    import dataclasses

    tuning = results["Tuning"]
    lost = {c.values for c in tuning.screen[-3:]}
    screen = tuple(dataclasses.replace(c, bandwidth=float("nan"), hunts=True) if c.values in lost else c
                   for c in tuning.screen)
    drawn = dataclasses.replace(tuning, screen=screen, front=tuning.front[:1]).plot()
    drawn.figure.canvas.draw()
    for line in drawn.axes[0].get_lines():
        y = np.asarray(line.get_ydata(), dtype=float)
        if line.get_transform() is drawn.axes[0].transData and y.size:
            assert not np.any(y[np.isfinite(y)] <= 0.0), line.get_label()
    entries = [text.get_text() for text in drawn.legend.get_texts()]
    assert any("unstable in contact" in entry for entry in entries), entries
    assert "least hunting (none certified)" in entries and "best certified" not in entries
    low, high = drawn.axes[1].get_xlim()
    assert low == 0.0 and high > 0.0
    assert thin_axes(drawn.figure) == []
    assert_readable(drawn.figure)


def test_tuning_report_caption_fits_the_case(results):
    """Nothing certified: the caption names the least hunting tuning, not a best certified one, and speaks
    of no hatching where one varied value draws none."""
    tuning = results["Tuning"]
    assert not tuning.feasible and len(tuning.names) == 1
    page = tuning.report_html()
    caption = page.split("<figcaption>")[1].split("</figcaption>")[0]
    assert "least hunting" in caption and "certified tuning" not in caption.replace("none in the range is certified", "")
    assert "hatch" not in caption
    plt.close("all")
