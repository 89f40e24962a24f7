"""A rig's closed loop driven by recorded inputs, written as a measurement record and compared with one.

The stage of the flow after the simulation: "simulate against a record".  The
inputs are a table (a CSV file or a mapping) of the reference and the load torque
against time; :func:`simulate_record` runs the rig's loop on them
(:func:`~backlash_df.simulation.simulate_rig`, the rig passed whole) and returns a
:class:`SimulatedRecord`: the responses as the columns of the measurement CSV
(:mod:`backlash_df.identify.measurements`), and with ``compare=`` the fit of each
response a measured record holds.  :func:`simulate` is :func:`backlash_df.simulate`:
:func:`simulate_rig` unless ``inputs`` or ``compare`` is given.

**The inputs file.** A CSV with a header row, SI units, on the load side (as the rig's
loop): ``time`` (s), ``reference`` (rad/s for a ``structure = "speed"`` rig, the
speed reference; rad for a cascade, the position reference) and optionally
``load_torque`` (N m, applied to the load; default the rig's ``[load] torque``).
Between rows the inputs are linear in time; beyond the last row they hold its
values.  The time column increases with a uniform step (each step within
:data:`TIME_TOLERANCE` of the mean step); the run starts at the first row.

This module reads the measurement format of :mod:`backlash_df.identify`, a floor
above the simulation's kernels and rig runs: the package's ``__init__`` does not
import it.
"""

import csv
import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._json import json_ready
from ..identify.measurements import Measurements, load_measurements, measurements_csv, write_measurements
from ..identify.predictors import fit_percent
from ..loops import drive_loop
from ..models import BacklashModel
from ..plotting import ResultPlot, axes_or_new, legend_beside
from .linear import SimulationResult, default_step, signal_trace, timed_inputs
from .rig import simulate_rig

__all__ = ["RecordedInputs", "SimulatedRecord", "read_inputs", "simulate_record", "simulate", "INPUT_COLUMNS",
           "TIME_TOLERANCE", "RESPONSE_COLUMNS"]

#: The columns of an inputs file: ``time`` and ``reference`` required, ``load_torque`` optional.
INPUT_COLUMNS = ("time", "reference", "load_torque")
#: Largest deviation of an inputs file's time step from its mean step, relative to the mean step.
TIME_TOLERANCE = 1e-3
#: The measurement columns a run gives, in the CSV's order; ``load_torque`` is an input, never compared.
RESPONSE_COLUMNS = ("motor_torque", "motor_speed", "load_speed", "motor_angle", "load_angle")
_ANGLES = ("motor_angle", "load_angle")


@dataclasses.dataclass(frozen=True, repr=False)
class RecordedInputs:
    """The inputs of a run as a table against time (load side, SI units; the module docs).

    Attributes
    ----------
    time : ndarray
        Instants, s, increasing with a uniform step.
    reference : ndarray
        The reference: rad/s (speed loop) or rad (cascade: the position reference).
    load_torque : ndarray or None
        Torque applied to the load, N m; None: the rig's ``[load] torque``.
    source : str
        The file, or ``<mapping>``, for messages.
    """

    time: np.ndarray
    reference: np.ndarray
    load_torque: np.ndarray | None
    source: str

    @property
    def step(self):
        """The mean time step, s."""
        return float((self.time[-1] - self.time[0]) / (self.time.size - 1))

    @property
    def duration(self):
        """Last instant minus first, s."""
        return float(self.time[-1] - self.time[0])

    def column(self, name):
        """The input ``name`` (``reference`` or ``load_torque``) as a function of the run's time (s from the first
        row): linear between rows, held beyond the last."""
        values = getattr(self, name)

        def value(t):
            return np.interp(self.time[0] + np.asarray(t, dtype=float), self.time, values)

        return value

    def __repr__(self):
        columns = ", ".join(name for name in INPUT_COLUMNS if getattr(self, name) is not None)
        return f"<RecordedInputs {self.source}: {self.time.size} rows, step {self.step:g} s, columns {columns}>"


def read_inputs(inputs):
    """Read and check the inputs of a run: a CSV file or a mapping of columns (the module docs).

    Parameters
    ----------
    inputs : str, Path, Mapping or RecordedInputs
        The file's path, or ``{"time": ..., "reference": ..., "load_torque": ...}``
        (1-D arrays of one length; ``load_torque`` optional).

    Returns
    -------
    RecordedInputs

    Raises
    ------
    ValueError
        One line naming the source and the problem: a missing ``time`` or
        ``reference`` column, an unknown or repeated column, a cell that is not a
        number, NaN or infinite values, fewer than 2 rows, time not increasing or
        not uniformly sampled (:data:`TIME_TOLERANCE`).
    """
    if isinstance(inputs, RecordedInputs):
        return inputs
    if isinstance(inputs, Mapping):
        columns, source, where = dict(inputs), "inputs", "index"
        offset = 0
    elif isinstance(inputs, (str, Path)):
        columns, source, where = _read_csv(Path(inputs)), str(inputs), "line"
        offset = 2  # the header is line 1
    else:
        raise ValueError(f"inputs: give a CSV file's path or a mapping of columns, not {type(inputs).__name__}")
    _check_names(list(columns), source)
    arrays = {}
    for name, values in columns.items():
        try:
            arrays[name] = np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{source}: {name} must be numbers") from None
    n = arrays["time"].size
    for name, values in arrays.items():
        if values.ndim != 1 or values.size != n:
            raise ValueError(f"{source}: {name} must be 1-D with {n} values like time, got shape {values.shape}")
    if n < 2:
        raise ValueError(f"{source}: {n} row{'' if n == 1 else 's'}; the inputs need at least 2 (a run spans them)")
    for name, values in arrays.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(f"{source}: {name} is NaN or infinite at {where} {bad[0] + offset} "
                             f"({bad.size} value{'' if bad.size == 1 else 's'})")
    _check_time(arrays["time"], source, where, offset)
    return RecordedInputs(time=arrays["time"], reference=arrays["reference"], load_torque=arrays.get("load_torque"),
                          source=source)


def _check_names(names, source):
    """Refuse a table without ``time`` or ``reference``, or with an unknown or repeated column."""
    missing = [name for name in INPUT_COLUMNS[:2] if name not in names]
    if missing:
        raise ValueError(f"{source}: missing column {' and '.join(missing)}; the inputs have time (s) and reference "
                         f"(rad/s, or rad in a cascade), optionally load_torque (N m)")
    unknown = [name for name in names if name not in INPUT_COLUMNS]
    if unknown:
        raise ValueError(f"{source}: unknown column {unknown[0]!r}; the inputs' columns are {', '.join(INPUT_COLUMNS)}")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ValueError(f"{source}: column {repeated[0]} appears more than once in the header")


def _check_time(time, source, where, offset):
    steps = np.diff(time)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        row = back[0] + 1
        raise ValueError(f"{source}: time does not increase at {where} {row + offset} "
                         f"({time[row - 1]:.9g} s then {time[row]:.9g} s)")
    mean = (time[-1] - time[0]) / steps.size
    uneven = np.flatnonzero(np.abs(steps - mean) > TIME_TOLERANCE * mean)
    if uneven.size:
        row = uneven[0] + 1
        raise ValueError(f"{source}: time is not uniformly sampled: step {steps[row - 1]:.9g} s before {where} "
                         f"{row + offset}, mean step {mean:.9g} s (each step within {100 * TIME_TOLERANCE:g} % of it)")


def _read_csv(path):
    """The columns of an inputs CSV by header name (unchecked but for the cells being numbers)."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            rows = list(csv.reader(handle))
    except OSError as error:
        raise ValueError(f"{path}: cannot read the inputs file ({error.strerror})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file; save the inputs as UTF-8 CSV") from None
    if not rows:
        raise ValueError(f"{path}: empty file; the inputs have a header row (time, reference[, load_torque])")
    header = [name.strip() for name in rows[0]]
    _check_names(header, path)
    table = []
    for line, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(header):
            raise ValueError(f"{path}: line {line} has {len(row)} fields, the header has {len(header)}")
        try:
            table.append([float(cell) if cell.strip() else math.nan for cell in row])
        except ValueError:
            bad = next(name for name, cell in zip(header, row) if not _is_number(cell))
            raise ValueError(f"{path}: line {line}, column {bad}: {row[header.index(bad)]!r} is not a number") from None
    values = np.array(table, dtype=float).reshape(-1, len(header))
    return {name: values[:, j] for j, name in enumerate(header)}


def _is_number(cell):
    try:
        float(cell)
    except ValueError:
        return not cell.strip()
    return True


@dataclasses.dataclass(frozen=True, repr=False)
class SimulatedRecord:
    """A run of a rig's loop as a measurement record, and its fit to a measured one.

    Attributes
    ----------
    simulated : Measurements
        The responses on the output grid, load side, as :class:`~backlash_df.identify.Measurements`
        holds a record (:meth:`~backlash_df.identify.Measurements.file_columns` gives the
        file's side): ``motor_torque`` the torque the motor applies (the torque-loop
        output with a lag, else the command after the torque limit), the speeds,
        ``load_torque`` as applied, ``load_angle`` (the loop's state in a cascade, else
        the integral of the load speed from 0) and ``motor_angle = load_angle +
        theta_d``.  Its time is that of the inputs (s).
    simulation : SimulationResult
        The run itself, on the simulation's step, time from 0.
    rig : Rig
    inputs : RecordedInputs or None
        None: the reference 0 (or ``speed_reference=``) and the rig's load torque.
    record : Measurements or None
        The measured record compared with.
    fit_percent : dict or None
        With a record: ``{column: fit}``, % (:func:`~backlash_df.identify.fit_percent`,
        free run), for each response column the record holds, on the record's
        samples (the run interpolated linearly onto them).  Angles are compared up
        to the encoder's zero: the simulated angle is shifted to the record's first
        sample.
    """

    simulated: Measurements
    simulation: SimulationResult
    rig: object
    inputs: RecordedInputs | None = None
    record: Measurements | None = None
    fit_percent: dict | None = None

    @property
    def reference_kind(self):
        """``"position"`` for a cascade (the reference is an angle, rad), else ``"speed"`` (rad/s)."""
        return "position" if self.rig.controller.cascade else "speed"

    @property
    def steps(self):
        """Integration steps of the run."""
        return int(self.simulation.time.size - 1)

    @property
    def dt(self):
        """The simulation's step, s."""
        return float(self.simulation.time[1] - self.simulation.time[0])

    def __repr__(self):
        fits = "" if self.fit_percent is None else ", fit " + ", ".join(
            f"{name} {value:.1f} %" for name, value in self.fit_percent.items())
        return (f"<SimulatedRecord {self.simulation.model.name}: {self.simulated.duration:g} s, {self.steps} steps, "
                f"{self.simulated.n_samples} samples{fits}>")

    def to_csv(self, path=None):
        """The responses as a measurement CSV (motor columns on the motor side, through the gear ratio).

        Parameters
        ----------
        path : str or Path, optional
            Where to write it.

        Returns
        -------
        str or None
            The file's text when no ``path`` is given.
        """
        if path is None:
            return measurements_csv(self.simulated)
        return write_measurements(path, self.simulated)

    def to_dict(self):
        """JSON-ready (the contract page's ``simulate --json``): the run, its inputs, the columns on the file's side
        and, with a record, the fit of each compared column (%)."""
        inputs = None if self.inputs is None else {
            "source": self.inputs.source, "rows": int(self.inputs.time.size), "step": self.inputs.step,
            "columns": [name for name in INPUT_COLUMNS if getattr(self.inputs, name) is not None]}
        record = None if self.record is None else {"source": str(self.record.source),
                                                   "samples": self.record.n_samples}
        return json_ready({
            "rig": str(self.rig.source),
            "model": self.simulation.model.name,
            "reference": self.reference_kind,
            "duration": self.simulated.duration,
            "dt": self.dt,
            "steps": self.steps,
            "events": int(self.simulation.events),
            "sample_interval": self.simulated.dt,
            "samples": self.simulated.n_samples,
            "gear_ratio": self.simulated.gear_ratio,
            "inputs": inputs,
            "columns": self.simulated.file_columns(),
            "record": record,
            "fit_percent": self.fit_percent,
        })

    def plot(self, ax=None):
        """Torques, speeds and angles against time, on the file's side; with a record, measured beside simulated.

        The measured lines are the broad pale ones; a compared angle is drawn from the
        record's first sample (the encoder's zero, as :attr:`fit_percent` takes it).

        Parameters
        ----------
        ax : sequence of 3 matplotlib Axes, optional

        Returns
        -------
        ResultPlot
            Axes ``[torques, speeds, angles]``, each with its legend beside it.
        """
        figure, axes = axes_or_new(ax, (3, 1), sharex=True, figsize=(9.5, 6.6), layout="constrained")
        panels = {"motor_torque": 0, "load_torque": 0, "motor_speed": 1, "load_speed": 1, "motor_angle": 2,
                  "load_angle": 2}
        simulated = self.simulated.file_columns()
        measured = {} if self.record is None else self.record.file_columns()
        for name, panel in panels.items():
            values = simulated[name]
            if name in _ANGLES and name in measured:  # to the encoder's zero, as compared
                values = values + (measured[name][0] - np.interp(measured["time"][0], simulated["time"], values))
            fit = "" if name not in (self.fit_percent or {}) else f", fit {self.fit_percent[name]:.1f} %"
            line, = axes[panel].plot(simulated["time"], values, lw=1.0,
                                     label=f"{name} (simulated{fit})" if name in measured else name)
            if name in measured:
                axes[panel].plot(measured["time"], measured[name], color=line.get_color(), lw=3.0, alpha=0.35,
                                 label=f"{name} (measured)", zorder=line.get_zorder() - 0.1)
        for panel, unit in zip(axes, ("torque (N m)", "speed (rad/s)", "angle (rad)")):
            panel.set_ylabel(unit)
            legend_beside(panel)
        axes[-1].set_xlabel("time (s)")
        axes[0].set_title(f"{self.simulation.model.name}, {self.reference_kind} reference")
        return ResultPlot(figure, axes)


def simulate_record(rig, model=None, *, inputs=None, t_end=None, dt=None, compare=None, speed_reference=0.0,
                    load_torque=None, initial=None, kick=0.0, theta_b0=0.0, progress=None):
    """Run a rig's closed loop on recorded inputs and give the responses as a measurement record.

    Parameters
    ----------
    rig : Rig
        Plant and ``[controller]``; passed whole to :func:`~backlash_df.simulation.simulate_rig`.
    model : str or BacklashModel, optional
        Torque law (default: the rig's ``[model] backlash``).
    inputs : str, Path, Mapping or RecordedInputs, optional
        The reference (rad/s, or rad in a cascade) and load torque (N m) against
        time (:func:`read_inputs`).  Without: ``speed_reference`` and ``load_torque``.
    t_end : float, optional
        Length of the run, s, from the inputs' first row (default: the inputs'
        span; without inputs, the record's; one of the three is needed).
    dt : float, optional
        Simulation step, s.  Default :func:`~backlash_df.simulation.default_step`,
        shortened to divide the inputs' step, so that every row is a step's end.
    compare : str, Path or Measurements, optional
        A measured record (:func:`~backlash_df.identify.load_measurements`, reflected
        through the rig's gear ratio): the fit of each response it holds.  Its time
        must lie within the run's.
    speed_reference, load_torque : float or callable
        Without ``inputs``: as :func:`~backlash_df.simulation.simulate_rig`.
    initial, kick, theta_b0
        As :func:`~backlash_df.simulation.simulate_rig`.
    progress : callable, optional
        ``progress(stage, done, total)``: stage ``"simulate"``, integration steps
        done of the run's; the run is then made in tenths, each going on from the
        last (:meth:`~backlash_df.SimulationResult.continued`: the same to the bit).

    Returns
    -------
    SimulatedRecord
        Output samples at the inputs' instants (without inputs, at every step).

    Raises
    ------
    ValueError
        Bad inputs (:func:`read_inputs`), a record that cannot be read or
        reaches beyond the run, ``inputs`` with ``speed_reference`` or
        ``load_torque``, or no ``t_end`` to be had.
    """
    recorded = None if inputs is None else read_inputs(inputs)
    if recorded is not None and (callable(speed_reference) or np.ndim(speed_reference) or speed_reference != 0.0
                                 or load_torque is not None):
        raise ValueError("inputs holds the reference and the load torque: pass no speed_reference or load_torque")
    record = _record(compare, rig)
    if t_end is None:
        if recorded is None and record is None:
            raise ValueError("t_end: give the run's length (s), or inputs or a record for it to span")
        t_end = recorded.duration if recorded is not None else float(record.time[-1])
    if not (t_end > 0.0 and math.isfinite(t_end)):
        raise ValueError(f"t_end must be finite and > 0 s, got {t_end!r}")
    law = model if isinstance(model, BacklashModel) else rig.make_model(model)
    loop = drive_loop(rig, dry_friction=True)
    system = loop.linear_part()
    if dt is None:
        dt = default_step(system, law)
        if recorded is not None:
            dt = recorded.step / math.ceil(recorded.step / dt)
    if recorded is not None:
        speed_reference = recorded.column("reference")
        if recorded.load_torque is not None:
            load_torque = recorded.column("load_torque")
    load_torque = rig.load.torque if load_torque is None else load_torque
    result = _run(rig, law, t_end, dt, progress, speed_reference=speed_reference, load_torque=load_torque,
                  initial=initial, kick=kick, theta_b0=theta_b0)
    applied = timed_inputs(speed_reference, load_torque)(result.time)
    columns = _responses(result, system, loop, applied)
    step = recorded.step if recorded is not None else dt
    out = np.arange(int(round(result.time[-1] / step)) + 1) * step
    out = out[out <= result.time[-1] * (1.0 + 1e-12)]
    start = 0.0 if recorded is None else float(recorded.time[0])
    simulated = Measurements(time=start + out, source=f"simulation of {rig.source}", gear_ratio=rig.plant.gear_ratio,
                             **{name: np.interp(out, result.time, values) for name, values in columns.items()})
    fits = None if record is None else _fits(simulated, record)
    return SimulatedRecord(simulated=simulated, simulation=result, rig=rig, inputs=recorded, record=record,
                           fit_percent=fits)


def _record(compare, rig):
    """The record to compare with, reflected through the rig's gear ratio; None without one."""
    if compare is None:
        return None
    if isinstance(compare, Measurements):
        compare.check_gear_ratio(rig.plant.gear_ratio)
        return compare
    return load_measurements(compare, gear_ratio=rig.plant.gear_ratio)


def _run(rig, law, t_end, dt, progress, **options):
    """:func:`simulate_rig` to ``t_end``; with ``progress``, in tenths (each going on from the last)."""
    if progress is None:
        return simulate_rig(rig, law, t_end=t_end, dt=dt, **options)
    total = int(round(t_end / dt))
    ends = sorted({max(1, total * part // 10) for part in range(1, 11)})
    progress("simulate", 0, total)
    result = simulate_rig(rig, law, t_end=ends[0] * dt, dt=dt, **options)
    progress("simulate", ends[0], total)
    for steps in ends[1:]:
        result = result.continued(steps * dt)
        progress("simulate", steps, total)
    return result


def _responses(result, system, loop, applied):
    """The record's columns of a run (load side) on its grid: motor torque, speeds, load torque, angles."""
    names = result.state_names
    if "motor_torque" in names:
        torque = result.state("motor_torque")
    elif result.command is not None:
        torque = result.command
    else:
        torque = signal_trace(system, loop.command_row(), result.time, result.states, applied)
    if "load_angle" in names:
        load_angle = result.state("load_angle")
    else:
        from scipy.integrate import cumulative_trapezoid  # lazy: keeps `import backlash_df` quick

        load_angle = cumulative_trapezoid(result.state("load_speed"), result.time, initial=0.0)
    return {"motor_torque": torque, "motor_speed": result.state("motor_speed"),
            "load_speed": result.state("load_speed"), "load_torque": applied[:, 1],
            "motor_angle": load_angle + result.theta_d, "load_angle": load_angle}


def _fits(simulated, record):
    """The fit (%) of each response column ``record`` holds, the run interpolated onto its samples."""
    first, last = simulated.time[0], simulated.time[-1]
    slack = 0.5 * record.dt
    if record.time[0] < first - slack or record.time[-1] > last + slack:
        raise ValueError(f"{record.source}: the record spans {record.time[0]:.6g} .. {record.time[-1]:.6g} s, beyond "
                         f"the run's {first:.6g} .. {last:.6g} s; give a t_end (--t-end) that covers it")
    fits = {}
    for name in RESPONSE_COLUMNS:
        measured = getattr(record, name)
        if measured is None:
            continue
        values = np.interp(record.time, simulated.time, getattr(simulated, name))
        if name in _ANGLES:
            values = values + (measured[0] - values[0])
        fits[name] = fit_percent(measured, values)
    return fits


def simulate(rig, model=None, *, inputs=None, compare=None, **options):
    """Closed-loop time simulation of a rig: :func:`backlash_df.simulate`.

    Without ``inputs`` and ``compare``, :func:`~backlash_df.simulation.simulate_rig`
    (its keywords, its :class:`~backlash_df.SimulationResult`); with either,
    :func:`simulate_record` (its keywords, a :class:`SimulatedRecord`).

    Parameters
    ----------
    rig : Rig
    model : str or BacklashModel, optional
        Torque law (default: the rig's ``[model] backlash``).
    inputs : str, Path or Mapping, optional
        Recorded reference and load torque against time (the module docs).
    compare : str, Path or Measurements, optional
        A measured record to compare the run with.
    **options
        The keywords of :func:`~backlash_df.simulation.simulate_rig` or :func:`simulate_record`.

    Returns
    -------
    SimulationResult or SimulatedRecord

    Examples
    --------
    >>> from backlash_df import rig_from_dict, simulate
    >>> rig = rig_from_dict({"plant": {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0,
    ...     "damping": 3.0, "half_gap": 0.05}, "controller": {"kp": 30.0, "ti": 0.5, "feedback": "motor"}})
    >>> run = simulate(rig, inputs={"time": [0.0, 0.5, 1.0], "reference": [0.0, 1.0, 1.0]})
    >>> run.simulated.n_samples, list(run.fit_percent or {})
    (3, [])
    """
    if inputs is None and compare is None:
        return simulate_rig(rig, model, **options)
    return simulate_record(rig, model, inputs=inputs, compare=compare, **options)
