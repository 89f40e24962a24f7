"""One plot contract: every ``.plot()`` of the package returns a :class:`ResultPlot`.

In the manner of python-control's ``ControlPlot``: the caller never guesses
whether it got an Axes or an array of them.  ``result.plot()`` draws into a new
figure, ``result.plot(ax=...)`` into the axes given (one Axes, or a sequence for
the results that draw several panels), and returns the figure and its axes::

    drawn = prediction.plot()
    drawn.figure.savefig("overlay.png")
    drawn.axes[0].set_xlim(-0.01, 0.0)
"""

import warnings

import numpy as np

__all__ = ["ResultPlot", "axes_or_new"]


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

    Notes
    -----
    Until version 0.2 a ``.plot()`` returned its Axes, or an ndarray of them.  For
    one release a ResultPlot still behaves like those: indexing, iteration and
    ``len`` reach :attr:`axes`, and an Axes method called on a one-panel plot
    reaches that Axes; each use warns with a ``DeprecationWarning``.
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

    # ---------------------------------------------------------------- the old returns, for one release

    def _old(self, what):
        warnings.warn(f"{what} of what .plot() returns: it is a ResultPlot now; use .axes (or .ax, .figure)",
                      DeprecationWarning, stacklevel=3)

    def __getitem__(self, index):
        self._old("indexing")
        return self.axes[index]

    def __iter__(self):
        self._old("iterating")
        return iter(self.axes)

    def __len__(self):
        self._old("len()")
        return len(self.axes)

    def __getattr__(self, name):
        axes = self.__dict__.get("axes")
        if name.startswith("_") or axes is None or axes.size != 1 or not hasattr(axes.flat[0], name):
            raise AttributeError(f"'ResultPlot' object has no attribute {name!r}")
        self._old(f"the Axes method {name!r}")
        return getattr(axes.flat[0], name)


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
