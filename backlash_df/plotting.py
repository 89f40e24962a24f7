"""One plot contract: every ``.plot()`` of the package returns a :class:`ResultPlot`.

In the manner of python-control's ``ControlPlot``: the caller never guesses
whether it got an Axes or an array of them.  ``result.plot()`` draws into a new
figure, ``result.plot(ax=...)`` into the axes given (one Axes, or a sequence for
the results that draw several panels), and returns the figure and its axes::

    drawn = prediction.plot()
    drawn.figure.savefig("overlay.png")
    drawn.axes[0].set_xlim(-0.01, 0.0)

What the figures share lives here too: a legend beside the panel it explains, below
the panels or under one panel (:func:`legend_beside`, :func:`legend_below`,
:func:`legend_under`: never over the data), log axes whose labels do not crowd and
never fewer than two (:func:`log_scale`), linear axes of small numbers labelled
with a scale factor, ``-3.5`` and ``x10^-4`` instead of ``-0.00035`` (:func:`scaled_ticks`),
contour labels inside the panel
(:func:`label_contours`), the cell edges of a map drawn within
the values given (:func:`cell_edges`), and a parametric curve sampled densely where
it turns in the view (:func:`adaptive_curve`, the G(jw) of the Nyquist overlay).
"""


import numpy as np

__all__ = ["ResultPlot", "legend_beside", "legend_below", "legend_under", "log_scale"]


class ResultPlot:
    """What a result's ``.plot()`` drew: the figure and its axes.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
    axes : ndarray of matplotlib.axes.Axes
        The panels drawn, in the result's own layout (1-D, or 2-D for a design map:
        one row per torque law).
    legend : matplotlib.legend.Legend or None
        The figure's legend, where the plot placed one outside the axes.
    """

    def __init__(self, figure, axes, legend=None):
        self.figure = figure
        self.axes = np.asarray(axes, dtype=object).reshape(np.shape(axes) or (1,))
        self.legend = legend

    @property
    def ax(self):
        """The first panel."""
        return self.axes.flat[0]

    def __repr__(self):
        width, height = self.figure.get_size_inches()
        shape = " x ".join(str(n) for n in self.axes.shape)
        return f"<ResultPlot: {shape} axes in a {width:.3g} x {height:.3g} in figure>"


def axes_or_new(ax, shape=None, **subplots):
    """The axes to draw on: ``ax`` as given (one Axes or a sequence), or a new figure's.

    Parameters
    ----------
    ax : Axes, sequence of Axes, ResultPlot or None
    shape : (int, int), optional
        Rows and columns of a new figure (default one panel).
    **subplots
        Passed to ``matplotlib.pyplot.subplots`` for a new figure.

    Returns
    -------
    figure : Figure
    axes : ndarray of Axes
        Shaped ``shape`` for a new figure, else as given.
    """
    import matplotlib.pyplot as plt

    if isinstance(ax, ResultPlot):
        return ax.figure, ax.axes
    if ax is None:
        rows, columns = shape or (1, 1)
        figure, axes = plt.subplots(rows, columns, squeeze=False, **subplots)
        return figure, axes if shape is not None and min(shape) > 1 else axes.reshape(-1)
    axes = np.asarray(ax, dtype=object)
    return axes.flat[0].figure, axes.reshape(axes.shape or (1,))


def legend_beside(ax, **kwargs):
    """A legend to the right of ``ax``, outside the data; constrained layout makes room for it.

    Parameters
    ----------
    ax : Axes
    **kwargs
        Passed to ``Axes.legend`` (``handles``, ``ncols``, ``fontsize``; default "small").

    Returns
    -------
    matplotlib.legend.Legend
    """
    return ax.legend(**{"loc": "upper left", "bbox_to_anchor": (1.02, 1.0), "borderaxespad": 0.0,
                        "fontsize": "small", **kwargs})


def legend_below(figure, max_columns=2, **kwargs):
    """A figure legend below the panels, in as many columns (up to ``max_columns``) as fit its width.

    The figure needs constrained layout, which makes room for the legend.

    Parameters
    ----------
    figure : Figure
    max_columns : int
    **kwargs
        Passed to ``Figure.legend`` (``fontsize``).

    Returns
    -------
    matplotlib.legend.Legend
    """
    renderer = figure.canvas.get_renderer() if hasattr(figure.canvas, "get_renderer") else None
    for columns in range(max_columns if renderer is not None else 1, 0, -1):
        legend = figure.legend(loc="outside lower center", ncols=columns, **kwargs)
        if columns == 1 or legend.get_window_extent(renderer).width <= figure.bbox.width:
            return legend
        legend.remove()


def legend_under(ax, max_columns=2, **kwargs):
    """A legend under ``ax``, below its tick labels and x label, in as many columns (up to
    ``max_columns``) as fit the panel's width.

    For a panel among others (a column of overlays, say) where a legend beside it would
    take half the figure's width.  Constrained layout makes room for it.  Call it after
    the x label is set: the legend's top is placed that far below the panel.

    Parameters
    ----------
    ax : Axes
    max_columns : int
    **kwargs
        Passed to ``Axes.legend`` (``handles``, ``fontsize``; default "small").

    Returns
    -------
    matplotlib.legend.Legend
    """
    from matplotlib.transforms import offset_copy

    figure = ax.figure
    renderer = figure.canvas.get_renderer()
    panel = ax.get_window_extent(renderer)
    drop = panel.y0 - ax.get_tightbbox(renderer).y0  # px taken by the tick labels and the x label
    anchor = offset_copy(ax.transAxes, fig=figure, y=-(drop * 72.0 / figure.dpi + 4.0), units="points")
    options = {"loc": "upper center", "bbox_to_anchor": (0.5, 0.0), "bbox_transform": anchor, "borderaxespad": 0.0,
               "fontsize": "small", **kwargs}
    for columns in range(max(int(max_columns), 1), 0, -1):
        legend = ax.legend(ncols=columns, **options)
        if columns == 1 or legend.get_window_extent(renderer).width <= panel.width:
            return legend
        legend.remove()


def log_scale(axis, low, high):
    """A log scale on ``axis`` for a view from ``low`` to ``high``: at least two labels, none crowded.

    The labels depend on the span: over two decades or more, at the decades
    (``10^2``); over one to two decades, at 1, 2 and 5 times them; under a decade,
    where a decade may hold no tick at all (a view from 20 to 40), at 2 to 5 evenly
    spaced round numbers (20, 25, 30, 35, 40).  Below two decades the labels are
    plain numbers (``200``, not ``2 x 10^2``).  The minor ticks are left unlabelled
    (matplotlib's default labels 2, 3, 4 and 6 there, which collide on a narrow panel).

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        ``ax.xaxis`` or ``ax.yaxis``.
    low, high : float
        The view's ends, ``0 < low < high``.
    """
    from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation, LogLocator, MaxNLocator, NullFormatter

    (axis.axes.set_xscale if axis is axis.axes.xaxis else axis.axes.set_yscale)("log")
    if high >= 100.0 * low:
        axis.set_major_locator(LogLocator(subs=(1.0,)))
        axis.set_major_formatter(LogFormatterSciNotation(labelOnlyBase=False, minor_thresholds=(np.inf, np.inf)))
    else:
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)) if high >= 10.0 * low
                               else MaxNLocator(nbins=4, steps=[1, 2, 2.5, 5, 10]))
        axis.set_major_formatter(FuncFormatter(_plain))
    axis.set_minor_formatter(NullFormatter())


def _plain(value, position=None):
    """A tick label as a plain number, 3 significant digits (``25``, ``0.3``, ``2.5e-05``)."""
    return f"{value:.3g}"


def scaled_ticks(axis, low=-2, high=3):
    """Tick labels of ``axis`` with a common scale factor, ``-3.5`` and ``x10^-4`` instead of ``-0.00035``.

    A linear axis whose values are all small (or all large) gets long labels that
    collide on a narrow panel; here every label is divided by a power of ten shown
    once at the axis' end (matplotlib's offset text), whenever the largest value is
    below ``10^low`` or at least ``10^high``.  No offset is subtracted: the labels
    stay the values themselves, scaled.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        ``ax.xaxis`` or ``ax.yaxis``.
    low, high : int
        Exponents beyond which the scale factor is used.
    """
    from matplotlib.ticker import ScalarFormatter

    formatter = ScalarFormatter(useOffset=False, useMathText=True)
    formatter.set_powerlimits((low, high))
    axis.set_major_formatter(formatter)


def label_contours(ax, contours, fmt="%.3g", fontsize=7, step=0.01):
    """Label every level of ``contours`` once, well inside the panel and apart from each other.

    Each level's label goes on its longest line, at the point farthest (in axes
    fractions) from the panel's edges and from the labels placed before it; a
    level whose lines all run within a label's height of an edge is left
    unlabelled (its neighbours' labels tell its value).  The labels are not
    clipped, so none is cut in half at an edge.

    Parameters
    ----------
    ax : Axes
    contours : matplotlib.contour.ContourSet
        Lines drawn by ``ax.contour``.
    fmt : str or callable
        The label of a level, as ``Axes.clabel`` takes it.
    fontsize : float or str
    step : float
        Spacing of the candidate points along each line, axes fraction.

    Returns
    -------
    list of matplotlib.text.Text
    """
    from matplotlib.font_manager import FontProperties

    ax.get_xlim(), ax.get_ylim()  # settle a pending autoscale: the positions are chosen in the final view
    to_axes = ax.transData + ax.transAxes.inverted()
    height = FontProperties(size=fontsize).get_size_in_points() * ax.figure.dpi / 72.0
    least = height / max(min(ax.bbox.width, ax.bbox.height), 1.0)  # a label's height, axes fraction
    positions, placed = [], []
    for path in contours.get_paths():
        lines = [to_axes.transform(line) for line in path.to_polygons(closed_only=False) if len(line) > 1]
        if not lines:
            continue
        line = max(lines, key=lambda xy: np.sum(np.hypot(*np.diff(xy, axis=0).T)))
        candidates = _along(line, step)
        margin = np.min(np.column_stack([candidates, 1.0 - candidates]), axis=1)
        if placed:
            apart = np.min(np.linalg.norm(candidates[:, None, :] - np.array(placed)[None, :, :], axis=2), axis=1)
            margin = np.minimum(margin, 0.5 * apart)
        best = candidates[np.argmax(margin)]
        if np.max(margin) < least:
            continue
        placed.append(best)
        positions.append(to_axes.inverted().transform(best))
    if not positions:
        return []
    texts = ax.clabel(contours, manual=positions, fmt=fmt, fontsize=fontsize)
    for text in texts:
        text.set_clip_on(False)
    return list(texts)


def _along(line, step):
    """Points every ``step`` along a polyline (and its vertices)."""
    length = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    at = np.union1d(np.arange(0.0, length[-1], step), length)
    return np.column_stack([np.interp(at, length, line[:, 0]), np.interp(at, length, line[:, 1])])


def cell_edges(values, scale="linear"):
    """Edges of the cells centred on sorted grid ``values``, within the values' range.

    Inner edges are the midpoints of neighbouring values (geometric midpoints on a
    log axis); the outer edges are the first and last values themselves, so a map
    drawn with ``pcolormesh(cell_edges(x), cell_edges(y), ...)`` covers exactly the
    range swept (no half cell beyond it, no ``ti < 0`` on a linear axis).

    Parameters
    ----------
    values : array_like
        Increasing grid values, at least one (> 0 on a log axis).
    scale : {"linear", "log"}

    Returns
    -------
    ndarray
        ``len(values) + 1`` edges; a single value gets a cell of +-0.5 (a factor
        sqrt(2) on a log axis) around it.

    Examples
    --------
    >>> cell_edges([0.1, 0.5, 2.0])
    array([0.1 , 0.3 , 1.25, 2.  ])
    >>> cell_edges([1.0, 100.0], "log")
    array([  1.,  10., 100.])
    """
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size == 0 or np.any(np.diff(values) <= 0):
        raise ValueError("cell_edges needs an increasing 1-D grid of values")
    if scale == "log":
        if np.any(values <= 0):
            raise ValueError("cell_edges on a log axis needs values > 0")
        return np.exp(cell_edges(np.log(values), "linear") if values.size > 1
                      else np.log(values[0]) + np.array([-0.5, 0.5]) * np.log(2.0))
    if values.size == 1:
        return values[0] + np.array([-0.5, 0.5])
    return np.concatenate([values[:1], 0.5 * (values[1:] + values[:-1]), values[-1:]])


def adaptive_curve(function, low, high, view, start=256, max_turn_deg=3.0, max_step=0.004, min_step=1e-5,
                   max_points=50000):
    """A complex curve ``z(w)`` over ``low <= w <= high``, sampled densely where it turns in the view.

    Starting from ``start`` log-spaced values of w, every interval whose chord
    meets the view is halved (at its geometric mean) while its chord is longer
    than ``max_step`` or the curve turns at one of its ends by more than
    ``max_turn_deg`` (and the chord is longer than ``min_step``); lengths are
    fractions of the view's width and height.  Near a lightly damped resonance,
    where G(jw) sweeps a large arc over a small band of w, the points crowd there;
    outside the view the curve keeps its coarse sampling.

    Parameters
    ----------
    function : callable
        ``function(w)`` -> complex ndarray, vectorised over w (rad/s).
    low, high : float
        The band of w, ``0 < low < high`` (rad/s).
    view : (float, float, float, float)
        ``(x0, x1, y0, y1)``: the real and imaginary limits of the plot.
    start, max_turn_deg, max_step, min_step, max_points
        Initial points, the largest turning angle (degrees) between successive
        chords, the longest and shortest chords (view fractions), and the
        budget of points.

    Returns
    -------
    w : ndarray
        Increasing frequencies, rad/s.
    z : ndarray
        ``function(w)``.
    """
    x0, x1, y0, y1 = view
    w = np.geomspace(low, high, start)
    z = np.asarray(function(w), dtype=complex)
    while w.size < max_points:
        split = _intervals_to_split(z, (x0, x1, y0, y1), np.radians(max_turn_deg), max_step, min_step)
        if not split.any():
            break
        middle = np.sqrt(w[:-1][split] * w[1:][split])
        w, z = _merged(w, z, middle, np.asarray(function(middle), dtype=complex))
    return w, z


def _intervals_to_split(z, view, max_turn, max_step, min_step):
    """Intervals of a sampled curve too long or too bent in the view (see :func:`adaptive_curve`)."""
    x0, x1, y0, y1 = view
    u = np.column_stack([(z.real - x0) / (x1 - x0), (z.imag - y0) / (y1 - y0)])
    chord = np.diff(u, axis=0)
    length = np.hypot(chord[:, 0], chord[:, 1])
    low, high = np.minimum(u[:-1], u[1:]), np.maximum(u[:-1], u[1:])
    seen = np.all(np.isfinite(chord), axis=1) & np.all(high >= 0.0, axis=1) & np.all(low <= 1.0, axis=1)
    heading = np.arctan2(chord[:, 1], chord[:, 0])
    turn = np.abs(np.angle(np.exp(1j * np.diff(heading))))
    bent = np.zeros(length.size, dtype=bool)
    bent[:-1] |= turn > max_turn
    bent[1:] |= turn > max_turn
    return seen & ((length > max_step) | (bent & (length > min_step)))


def _merged(w, z, new_w, new_z):
    order = np.argsort(np.concatenate([w, new_w]), kind="stable")
    return np.concatenate([w, new_w])[order], np.concatenate([z, new_z])[order]
