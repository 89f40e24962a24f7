"""Design maps: DF predictions and time simulation over a grid of two rig values.

Each cell of a map is a pure function of (rig, the two values): the rig with
those values (:meth:`~backlash_df.config.Rig.with_values`) is analysed by the describing function
(:func:`~backlash_df.limit_cycles.predict_limit_cycles`; with a load torque the
biased prediction of the dual-input describing function) and, optionally, simulated in
closed loop.  The cells run on any :class:`concurrent.futures.Executor` (a
process pool, or ``dask.distributed.Client.get_executor()``); ``None`` runs
them one after the other.  The results do not depend on the executor.  Each cell
is kept, as it finishes, in a checkpoint if one is given
(:class:`~backlash_df.checkpoint.Checkpoint`): a map that is stopped resumes with
the cells it has, and is identical to an uninterrupted one.

Every cell gets a verdict per model, the classes of ``predict``:

``no oscillation``
    the DF finds no cycle (and the loop with the shaft in contact is stable),
    or the simulation comes to rest;
``limit cycle``
    a stable cycle and nothing below it that a small motion must cross;
``bistable``
    an unstable cycle below the smallest stable one: small motions die out,
    larger ones grow to the stable cycle (DF only: the simulation starts from
    the predicted cycle and cannot tell);
``unstable``
    the loop with the shaft in contact (``T = k theta_d + c dtheta_d``) is
    unstable and no stable cycle caps the growth, or the simulated amplitude grows;
``undetermined``
    the DF finds only unstable cycles or cannot be applied to the cell's loop (its
    prediction's ``note``), or the simulation does not settle.

With dry friction (``[friction]`` Coulomb or breakaway values, or a swept one) the DF
takes the friction as a damper slaved to the sliding side's speed and the simulation
models stick and slip.  The DF cannot see stick-slip hunting (a breakaway excess over
Coulomb friction under integral action), and it is not applied with friction on both
sides and a torque limit, a load torque on a P speed loop or a load torque with a torque limit: the map's
``notes`` say so, and the simulation's cells are the ones to read there.
"""

import dataclasses
import functools
import math

import numpy as np

from ._json import json_ready
from .checkpoint import describe, opened, run_cells
from .equilibria import linear_stability
from .limit_cycles import predict_limit_cycles, verify_limit_cycles
from .loops import drive_loop
from .plotting import ResultPlot, axes_or_new, cell_edges, label_contours, legend_beside, log_scale
from .render.sweeps import map_report, map_sentences, map_tables, value_label
from .verdict import VERDICTS

__all__ = ["DesignMap", "design_map", "design_map_plot"]

_COLOURS = ("#d9f0d3", "#d6604d", "#f4a582", "#762a83", "#bababa")


# --------------------------------------------------------------------------- verdicts


def prediction_verdict(rig, prediction):
    """Verdict class of a DF prediction (module docs).

    Parameters
    ----------
    rig : Rig
    prediction : LimitCyclePrediction

    Returns
    -------
    str
        One of :data:`~backlash_df.verdict.VERDICTS`.
    """
    if prediction.note:  # the describing function was not applied to this loop: it says nothing
        return "undetermined"
    stable = prediction.stable_cycles
    if stable:
        lowest = stable[0].amplitude
        below = any(not cycle.stable and cycle.amplitude < lowest for cycle in prediction.cycles)
        return "bistable" if below else "limit cycle"
    rig, model, _ = prediction.loop(rig)
    # dry friction aside (bounded, it cannot hold a growth the loop in contact has)
    part = drive_loop(rig, dry_friction=True).linear_part()
    if linear_stability(part, model.stiffness, model.damping).status == "unstable":
        return "unstable"
    return "undetermined" if prediction.cycles else "no oscillation"


def simulation_verdict(measured):
    """Verdict class of a simulated run (:class:`~backlash_df.simulation.MeasuredCycle`)."""
    if measured is None:
        return "undetermined"
    if measured.found:
        return "limit cycle"
    unstable = {"growing": "unstable", "diverged": "unstable"}
    return {"no limit cycle": "no oscillation", **unstable}.get(measured.verdict, "undetermined")


# --------------------------------------------------------------------------- the map


@dataclasses.dataclass(frozen=True)
class DesignMap:
    """Verdicts and cycle amplitudes over a grid of two rig values, DF and simulation.

    Attributes
    ----------
    x_name, y_name : str
        The swept rig values (e.g. ``"kp"``, ``"ti"``).
    x, y : ndarray
        Grid values, in the rig file's units.
    df_verdict, sim_verdict : dict
        Model name -> array of str, shape (len(x), len(y)): :data:`~backlash_df.verdict.VERDICTS`
        (``sim_verdict`` is empty without simulation).
    df_amplitude, sim_amplitude : dict
        Model name -> float array: amplitude A (rad, first harmonic of
        theta_d) of the largest stable predicted cycle / of the simulated cycle,
        NaN where there is none.
    df_bias, sim_bias : dict
        Model name -> float array: mean of theta_d (rad) of those cycles.
    notes : tuple of str
        What the map's verdicts cannot see on this grid (module docs: dry friction), in words.
    """

    x_name: str
    x: np.ndarray
    y_name: str
    y: np.ndarray
    df_verdict: dict
    df_amplitude: dict
    df_bias: dict
    sim_verdict: dict
    sim_amplitude: dict
    sim_bias: dict
    notes: tuple = ()

    @property
    def models(self):
        """Model names, in the order they were analysed."""
        return tuple(self.df_verdict)

    @property
    def verdicts(self):
        """The verdict classes a cell can have, in order (:data:`VERDICTS`)."""
        return VERDICTS

    @property
    def predicted(self):
        """Model name -> bool array: the DF predicts a stable cycle."""
        return {name: np.isin(v, ("limit cycle", "bistable")) for name, v in self.df_verdict.items()}

    @property
    def simulated(self):
        """Model name -> bool array: the simulation settled onto a cycle."""
        return {name: v == "limit cycle" for name, v in self.sim_verdict.items()}

    def agreement(self, name):
        """Fraction of cells where the DF and the simulation agree on whether there is a cycle."""
        return float(np.mean(self.predicted[name] == self.simulated[name]))

    def tables(self):
        """The terminal's verdict grids: ``[(title, header, rows), ...]``, per law the DF's and the simulation's
        (:func:`~backlash_df.render.sweeps.map_tables`)."""
        return map_tables(self)

    def sentences(self):
        """The key of the grids' characters, then per law the DF's cells per verdict and the agreement
        (:func:`~backlash_df.render.sweeps.map_sentences`)."""
        return map_sentences(self)

    def __repr__(self):
        sims = "with simulation" if self.sim_verdict else "DF only"
        return (f"<DesignMap {self.x_name} ({self.x.size}) x {self.y_name} ({self.y.size}), "
                f"{', '.join(self.models)}, {sims}>")

    def to_dict(self):
        """JSON-ready: grid, then per model the verdict and amplitude tables (rows along ``x``)."""
        def table(values):
            return json_ready(np.asarray(values).tolist())

        return {
            "x": {"parameter": self.x_name, "values": self.x.tolist()},
            "y": {"parameter": self.y_name, "values": self.y.tolist()},
            "verdicts": list(VERDICTS),
            "notes": list(self.notes),
            "models": [
                {"model": name,
                 "df": {"verdict": table(self.df_verdict[name]), "amplitude": table(self.df_amplitude[name]),
                        "bias": table(self.df_bias[name])},
                 "simulated": None if name not in self.sim_verdict else {
                     "verdict": table(self.sim_verdict[name]), "amplitude": table(self.sim_amplitude[name]),
                     "bias": table(self.sim_bias[name]), "agreement": self.agreement(name)}}
                for name in self.models
            ],
        }

    def plot(self, ax=None):
        """Verdict colours and amplitude contours, DF and simulation side by side; see :func:`design_map_plot`."""
        return design_map_plot(self, ax=ax)

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML page: the map and the agreement per model.

        Parameters
        ----------
        title : str
            Page title (default "Design map").
        rig_text : str
            The rig file's text, shown as it is.

        See Also
        --------
        backlash_df.render.sweeps.map_report
        """
        return map_report(self, self.plot().figure, title, rig_text)


def _scale(values):
    values = np.asarray(values)
    return "log" if values.size > 2 and np.all(values > 0) and values.max() / values.min() > 20 else "linear"


def design_map_plot(dmap, ax=None, levels=4):
    """Draw a design map: one row per model, DF verdicts left, simulation right.

    Each cell is coloured by its verdict (:data:`VERDICTS`) and spans halfway to
    its neighbours (geometric midpoints on a log axis), the outer cells ending at
    the outer values: the map covers the swept range and no more.  Black
    contours, labelled, are the amplitude A of theta_d (rad, first harmonic) of
    the stable cycle; the axes carry the rig values' units
    (:data:`~backlash_df.config.RANGES`).

    Parameters
    ----------
    dmap : DesignMap
    ax : array of Axes, optional
        Shape (n_models, 2) (or (n_models, 1) without simulation).
    levels : int
        Number of amplitude contour levels (about: they fall on round values).

    Returns
    -------
    ResultPlot
        Axes of shape (n_models, columns); the legend (verdicts and what the
        contours measure) beside the top right panel.
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    columns = 2 if dmap.sim_verdict else 1
    figure, axes = axes_or_new(ax, (len(dmap.models), columns), figsize=(4.6 * columns + 2.2, 3.8 * len(dmap.models)),
                               sharex=True, sharey=True, layout="constrained")
    axes = np.asarray(axes).reshape(len(dmap.models), columns)
    cmap, norm = ListedColormap(_COLOURS), BoundaryNorm(np.arange(len(VERDICTS) + 1) - 0.5, len(VERDICTS))
    x_order, y_order = np.argsort(dmap.x), np.argsort(dmap.y)
    x, y = dmap.x[x_order], dmap.y[y_order]
    x_edges, y_edges = cell_edges(x, _scale(x)), cell_edges(y, _scale(y))
    for row, name in enumerate(dmap.models):
        panels = [("DF", dmap.df_verdict, dmap.df_amplitude), ("simulation", dmap.sim_verdict, dmap.sim_amplitude)]
        for ax, (kind, verdicts, amplitudes) in zip(axes[row], panels[:columns]):
            codes = np.vectorize(VERDICTS.index)(verdicts[name])[np.ix_(x_order, y_order)]
            ax.pcolormesh(x_edges, y_edges, codes.T, cmap=cmap, norm=norm, shading="flat")
            amplitude = np.ma.masked_invalid(amplitudes[name][np.ix_(x_order, y_order)].T)
            for axis, values in ((ax.xaxis, x), (ax.yaxis, y)):
                if _scale(values) == "log":
                    log_scale(axis, values.min(), values.max())
            if amplitude.count() > 3 and np.ptp(amplitude.compressed()) > 0:
                label_contours(ax, ax.contour(x, y, amplitude, levels=levels, colors="k", linewidths=0.8))
            ax.set_title(f"{name}: {kind}", fontsize="medium")
        axes[row, 0].set_ylabel(value_label(dmap.y_name))
    for ax in axes[-1]:
        ax.set_xlabel(value_label(dmap.x_name))
    handles = [Patch(color=c, label=v) for c, v in zip(_COLOURS, VERDICTS)]
    handles.append(Line2D([], [], color="k", lw=0.8, label="contours: amplitude A\nof theta_d (rad)"))
    legend = legend_beside(axes[0, -1], handles=handles, fontsize=7)
    return ResultPlot(figure, axes, legend)


# --------------------------------------------------------------------------- cells


@dataclasses.dataclass(frozen=True)
class _Settings:
    """What every cell of one map shares (picklable)."""

    rig: object
    x_name: str
    y_name: str
    models: tuple
    simulate: bool
    grid: tuple
    t_end: float
    max_t_end: float


def _largest_stable(prediction):
    stable = prediction.stable_cycles
    return (stable[-1].amplitude, getattr(stable[-1], "bias", 0.0)) if stable else (math.nan, math.nan)


def _cell(settings, point):
    """One cell: per model (DF verdict, A, bias, simulated verdict, A, bias); a pure function of its inputs."""
    tuned = settings.rig.with_values(**{settings.x_name: point[0], settings.y_name: point[1]})
    out = []
    for name in settings.models:
        prediction = predict_limit_cycles(tuned, name, grid=settings.grid)
        result = (prediction_verdict(tuned, prediction), *_largest_stable(prediction))
        if settings.simulate:
            checked = verify_limit_cycles(tuned, prediction, t_end=settings.t_end, max_t_end=settings.max_t_end)
            sims = [c.simulated for c in checked.stable_cycles if c.simulated is not None and c.simulated.found]
            measured = sims[-1] if sims else checked.simulation
            found = measured is not None and measured.found
            result += (simulation_verdict(measured), measured.amplitude if found else math.nan,
                       measured.bias if found else math.nan)
        out.append(result)
    return out


def design_map(rig, x_values, y_values, *, x="kp", y="ti", models=None, simulate=True, grid=(30, 40), t_end=10.0,
               max_t_end=40.0, executor=None, progress=None, checkpoint=None):
    """Scan two rig values: DF verdicts and amplitudes of each model and, optionally, time simulation.

    Parameters
    ----------
    rig : Rig
        Plant, controller, load; ``x`` and ``y`` are replaced by the grid values.
    x_values, y_values : array_like
        Grid values of ``x`` and ``y`` (the rig file's units).
    x, y : str
        Rig values to sweep (keys of :meth:`~backlash_df.config.Rig.with_values`); default the PI tuning (kp, ti).
    models : sequence of str, optional
        Torque laws (default: the rig's ``[model] backlash``).
    simulate : bool
        Also simulate each cell with each law
        (:func:`~backlash_df.limit_cycles.verify_limit_cycles`).
    grid : (int, int)
        Scan grid of :func:`~backlash_df.limit_cycles.solve_harmonic_balance`.
    t_end, max_t_end : float
        Simulated times, s.
    executor : concurrent.futures.Executor, optional
        Runs the cells (a ``ProcessPoolExecutor``, or a Dask client's
        ``get_executor()``, which runs a cell whose worker dies again on
        another worker); ``None``: serially.  Results are identical.
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol), stage
        ``"cells"``, as the cells finish.
    checkpoint : str, Path or Checkpoint, optional
        Keeps each finished cell, keyed by its two values, in this file
        (:class:`~backlash_df.checkpoint.Checkpoint`; a path: a new file).
        ``Checkpoint(path, resume=True)`` continues a stopped map: the cells kept
        are not computed again and the map is identical to an uninterrupted one.
        The file stays when the map is done.

    Returns
    -------
    DesignMap

    Raises
    ------
    ValueError
        A bad rig value name or value (before any cell runs); a checkpoint that
        exists without ``resume`` or that belongs to another map (one line naming
        the inputs that differ).
    """
    rig = rig.without_uncertainty(x, y)  # the grid explores its two values, boxed or not
    rig.require_modelled(dry_friction=True)
    x_values = np.atleast_1d(np.asarray(x_values, dtype=float))
    y_values = np.atleast_1d(np.asarray(y_values, dtype=float))
    models = tuple(models) if models is not None else (rig.model,)
    settings = _Settings(rig, x, y, models, bool(simulate), tuple(grid), float(t_end), float(max_t_end))
    rig.with_values(**{x: x_values[0], y: y_values[0]})  # bad names fail here, not in a worker
    points = [(float(a), float(b)) for a in x_values for b in y_values]
    inputs = describe(settings, omit={"source"})
    with opened(checkpoint, "map", inputs) as kept:
        cells = run_cells(functools.partial(_cell, settings), points, executor=executor, checkpoint=kept,
                          progress=progress)
    shape = (x_values.size, y_values.size)
    fields = [{}, {}, {}, {}, {}, {}]
    for m, name in enumerate(settings.models):
        columns = list(zip(*(cell[m] for cell in cells)))
        for k, column in enumerate(columns):
            dtype = object if k % 3 == 0 else float
            fields[k][name] = np.array(column, dtype=dtype).reshape(shape)
    for k in (0, 3):
        for name in fields[k]:
            fields[k][name] = fields[k][name].astype(str)
    return DesignMap(x, x_values, y, y_values, fields[0], fields[1], fields[2], fields[3], fields[4], fields[5],
                     notes=_notes(settings.rig.with_values(**{x: x_values.max(), y: y_values.max()})))


#: :attr:`DesignMap.notes` of a grid with dry friction in its cells (module docs).
DRY_FRICTION_NOTE = ("dry friction: the DF takes it as a damper of the sliding side and cannot see stick-slip "
                     "hunting (a breakaway excess over Coulomb friction under integral action), nor is it applied "
                     "with friction on both sides and a torque limit, a load torque on a P speed loop or a load "
                     "torque with a torque limit (those cells: undetermined); the simulation models stick and slip")


def _notes(corner):
    """The map's notes from the rig at its largest values: a friction value is never negative, so a cell has
    dry friction where that corner has."""
    return (DRY_FRICTION_NOTE,) if corner.friction.dry else ()
