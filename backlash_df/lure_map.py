"""A design map of a Lur'e loop: the verdict over two of its parameters.

:func:`lure_design_map` judges the loop (:func:`~backlash_df.lure_verdict.judge_lure_loop`:
exact orbits and exact runs) at every point of a grid of two parameters, a gain of H
(``"gain"``) or values of the element (:meth:`~backlash_df.lure.LureLoop.with_value`),
on any :class:`concurrent.futures.Executor` (Dask's ``Client.get_executor()`` included),
with the package's progress protocol and an optional checkpoint; the result does not
depend on the executor.
"""

import dataclasses
import functools
import json

import numpy as np

from ._json import json_ready
from .checkpoint import run_cells
from .lure_verdict import judge_lure_loop
from .plotting import ResultPlot, axes_or_new, legend_beside
from .verdict import VERDICTS

__all__ = ["LureDesignMap", "lure_design_map"]

_COLOURS = {"no oscillation": "#4daf4a", "limit cycle": "#e41a1c", "bistable": "#ff7f00", "unstable": "#984ea3",
            "undetermined": "#999999"}


@dataclasses.dataclass(frozen=True, eq=False)
class LureDesignMap:
    """The verdict of a Lur'e loop over a grid of two parameters.

    Attributes
    ----------
    model : str
        The element's label, or its kind where one of its values varies over the map.
    x_name, y_name : str
        The parameters along the columns and the rows.
    x, y : ndarray
        Their values.
    verdicts : ndarray of str, shape (len(y), len(x))
        One of :data:`backlash_df.VERDICTS` per point.
    amplitudes : ndarray, shape (len(y), len(x))
        The first-harmonic amplitude of ``y`` on the smallest stable orbit the runs reached (NaN where none).
    boundaries : ndarray, shape (len(y), len(x))
        The verdict's ``disturbance_to_start`` (NaN where it has none).
    reasons : ndarray of str
        The verdict's sentence per point.
    """

    model: str
    x_name: str
    y_name: str
    x: np.ndarray
    y: np.ndarray
    verdicts: np.ndarray
    amplitudes: np.ndarray = dataclasses.field(repr=False)
    boundaries: np.ndarray = dataclasses.field(repr=False)
    reasons: np.ndarray = dataclasses.field(repr=False)

    def __repr__(self):
        counts = ", ".join(f"{word} {int((self.verdicts == word).sum())}" for word in VERDICTS
                           if (self.verdicts == word).any())
        return f"<LureDesignMap {self.model}: {self.y.size} x {self.x.size} over {self.y_name}, {self.x_name}: {counts}>"

    def to_dict(self):
        """JSON-ready: the axes and, per point, the verdict, the cycle's amplitude, the boundary and the reason."""
        return json_ready({
            "model": self.model, "x": {"name": self.x_name, "values": self.x},
            "y": {"name": self.y_name, "values": self.y}, "verdicts": self.verdicts.tolist(),
            "amplitudes": self.amplitudes, "boundaries": self.boundaries, "reasons": self.reasons.tolist(),
        })

    def plot(self, ax=None):
        """The verdicts as coloured cells over the two parameters, the cycle's amplitude written in each hunting one."""
        from matplotlib.patches import Patch

        figure, axes = axes_or_new(ax, figsize=(8.0, 4.8), layout="constrained")
        ax = axes[0]
        for i, y in enumerate(self.y):
            for j, x in enumerate(self.x):
                ax.add_patch(_cell_patch(j, i, _COLOURS[self.verdicts[i, j]]))
                if np.isfinite(self.amplitudes[i, j]):
                    ax.text(j, i, f"{self.amplitudes[i, j]:.3g}", ha="center", va="center", fontsize="x-small")
        ax.set_xlim(-0.5, self.x.size - 0.5)
        ax.set_ylim(-0.5, self.y.size - 0.5)
        ax.set_xticks(range(self.x.size), [f"{v:.3g}" for v in self.x])
        ax.set_yticks(range(self.y.size), [f"{v:.3g}" for v in self.y])
        ax.set_xlabel(self.x_name)
        ax.set_ylabel(self.y_name)
        ax.set_title(f"{self.model}: the verdict (numbers: the cycle's A)", fontsize="medium")
        shown = [word for word in VERDICTS if (self.verdicts == word).any()]
        legend = legend_beside(ax, handles=[Patch(color=_COLOURS[w], label=w) for w in shown], fontsize="small")
        return ResultPlot(figure, axes, legend)


def _cell_patch(column, row, colour):
    """A unit square centred on grid point (column, row)."""
    from matplotlib.patches import Rectangle

    return Rectangle((column - 0.5, row - 0.5), 1.0, 1.0, color=colour, ec="white", lw=1.0)


def lure_design_map(loop, x, y, *, executor=None, progress=None, checkpoint=None, t_end=None):
    """The verdict of ``loop`` at every point of a grid of two parameters (module docs).

    Parameters
    ----------
    loop : LureLoop
    x, y : (str, array_like)
        Each a parameter (``"gain"`` or a value of the element) and its values; ``x``
        along the columns, ``y`` along the rows.
    executor : concurrent.futures.Executor, optional
        Runs the points (default: one after the other here).
    progress : callable, optional
        ``progress(stage, done, total)``, the package's protocol; the stage is ``"points"``.
    checkpoint : Checkpoint, optional
        Opened for the run: the points it holds are not judged again.
    t_end : float, optional
        Each probe's run, s (:func:`~backlash_df.lure_verdict.judge_lure_loop`'s default).

    Returns
    -------
    LureDesignMap

    Raises
    ------
    ValueError
        The same parameter twice, an unknown one, values that are not finite or a value
        the element refuses: one line.
    """
    (x_name, x_values), (y_name, y_values) = x, y
    if x_name == y_name:
        raise ValueError(f"the two parameters must differ, got {x_name!r} twice")
    x_values, y_values = (np.asarray(v, dtype=float).reshape(-1) for v in (x_values, y_values))
    for name, values in ((x_name, x_values), (y_name, y_values)):
        if values.size == 0 or not np.all(np.isfinite(values)):
            raise ValueError(f"the values of {name!r} must be finite, at least one, got {values.tolist()!r}")
        for value in values:
            loop.with_value(name, value)  # an unknown name or a refused value fails here, in one line
    points = [(float(yv), float(xv)) for yv in y_values for xv in x_values]
    keys = [json.dumps({x_name: xv, y_name: yv, "t_end": t_end}, sort_keys=True) for yv, xv in points]
    cells = run_cells(functools.partial(_judge_point, loop, x_name, y_name, t_end), points, executor=executor,
                      checkpoint=checkpoint, keys=keys, progress=progress, stage="points")
    shape = (y_values.size, x_values.size)
    varied = {f.name for f in dataclasses.fields(loop.element)} & {x_name, y_name}
    return LureDesignMap(
        model=loop.element.kind if varied else loop.label, x_name=x_name, y_name=y_name, x=x_values, y=y_values,
        verdicts=np.array([c["verdict"] for c in cells]).reshape(shape),
        amplitudes=_numbers(cells, "amplitude", shape),
        boundaries=_numbers(cells, "boundary", shape),
        reasons=np.array([c["reason"] for c in cells]).reshape(shape),
    )


def _numbers(cells, key, shape):
    """The cells' ``key`` as a float array of ``shape``, NaN where a cell has None."""
    return np.array([np.nan if c[key] is None else c[key] for c in cells], dtype=float).reshape(shape)


def _judge_point(loop, x_name, y_name, t_end, point):
    """The verdict at one grid point ``(y, x)``, as a JSON-ready cell (a checkpoint keeps it)."""
    y_value, x_value = point
    verdict = judge_lure_loop(loop.with_value(x_name, x_value).with_value(y_name, y_value), t_end=t_end)
    reached = [p.orbit.amplitude for p in verdict.probes if p.outcome == "cycle"]
    return {"verdict": verdict.verdict, "amplitude": min(reached) if reached else None,
            "boundary": verdict.disturbance_to_start, "reason": verdict.reason}
