"""Measurement files of a drive: loading, reflection through the gear, checks, writing.

The file is a CSV with a header row, SI units and uniform sampling (the contract page of the documentation):

=================  ======  ===========  ==============================================
column             unit    side (file)  holds
=================  ======  ===========  ==============================================
``time``           s                    sample instants, increasing, uniformly spaced
``motor_torque``   N m     motor        torque commanded to (or produced by) the motor
``motor_speed``    rad/s   motor        measured motor speed
``load_speed``     rad/s   load         measured load speed (optional)
``load_torque``    N m     load         known torque applied to the load (optional)
``motor_angle``    rad     motor        motor encoder angle (optional)
``load_angle``     rad     load         load (secondary) encoder angle (optional)
=================  ======  ===========  ==============================================

**Sides.** The rig file's plant is on the load side (``[plant] gear_ratio`` n
motor turns per load turn).  The motor columns of the file are on the motor side
and are reflected when the record is loaded: torque times n, speed and angle
divided by n (a lossless gear).  Every array of a :class:`Measurements` is
therefore on the **load side**; :attr:`Measurements.gear_ratio` says how it was
reflected, :meth:`Measurements.file_columns` gives the file's values back and
:meth:`Measurements.check_gear_ratio` refuses a record reflected with another
ratio than the rig's.  With gear ratio 1 (the default) nothing changes.

**Twist.** With both angle columns the shaft twist theta_d is measured:
``motor_angle / n - load_angle`` (:attr:`Measurements.twist`, rad, load side).
Encoders are zeroed independently, so it holds up to a constant offset.

A file with bad rows is refused with one line naming the file, the column and the
file lines; it is never silently trimmed.  A header name that looks like a
misspelt optional column absent from the header (``load_sped``, ``load_trq``,
``Load_Speed``: :data:`MISSPELLING_CUTOFF`) refuses the file in one line naming
both, unless ``load_measurements(..., allow_unknown_columns=True)``.  Any other
header name that is no column of the table above is not read: one line in
:attr:`Measurements.notes` lists every such name with the closest known one
(``load_trq: not a known column; did you mean load_torque?``), and
``load_measurements(..., strict=True)`` refuses the file with that line instead.
A record longer than
:data:`MAX_SAMPLES` is decimated by block means, with a note in
:attr:`Measurements.notes`, or refused when decimation would sample it too slowly.
"""

import csv
import dataclasses
import difflib
import math
import warnings
from pathlib import Path

import numpy as np

from .._json import json_ready
from ..plotting import ResultPlot, axes_or_new, legend_beside

__all__ = [
    "Measurements",
    "load_measurements",
    "read_columns",
    "measurements_from_arrays",
    "write_measurements",
    "measurements_csv",
    "REQUIRED_COLUMNS",
    "OPTIONAL_COLUMNS",
    "MOTOR_SIDE_COLUMNS",
    "MIN_SAMPLES",
    "MAX_SAMPLES",
    "MAX_SAMPLING_INTERVAL",
    "MAX_DECIMATED_INTERVAL",
    "MAX_PLAUSIBLE_SPEED",
    "ANGLE_TOLERANCE",
    "MISSPELLING_CUTOFF",
]

REQUIRED_COLUMNS = ("time", "motor_torque", "motor_speed")
OPTIONAL_COLUMNS = ("load_speed", "load_torque", "motor_angle", "load_angle")
#: Motor-side columns and the power of the gear ratio n that reflects them to the load side.
MOTOR_SIDE_COLUMNS = {"motor_torque": 1, "motor_speed": -1, "motor_angle": -1}
#: Fewest samples a record may have: estimation and validation parts need room.
MIN_SAMPLES = 200
#: Most samples kept; longer records are decimated (block means) or refused.
MAX_SAMPLES = 20_000
#: Longest sampling interval taken as seconds (s); longer steps look like milliseconds.
MAX_SAMPLING_INTERVAL = 0.02
#: Longest sampling interval decimation may produce (s, 250 Hz as the KUKA record).
MAX_DECIMATED_INTERVAL = 0.004
#: Speeds above this (rad/s, about 9550 rpm) are taken as a file written in rpm.
MAX_PLAUSIBLE_SPEED = 1000.0
#: Largest mismatch between an angle and its integrated speed, relative to the angle's range.
ANGLE_TOLERANCE = 0.05
#: Least similarity (:class:`difflib.SequenceMatcher` ratio, case ignored) at which an unknown column is taken
#: for a misspelt known one absent from the header: ``load_sped`` (0.95) and ``load_trq`` (0.84) are,
#: ``motor_current`` (0.64 to ``motor_torque``) and ``temperature`` are not.
MISSPELLING_CUTOFF = 0.8
_UNIFORM_TOLERANCE = 0.01  # relative deviation of a time step from the median step
_ANGLE_SPEEDS = {"motor_angle": "motor_speed", "load_angle": "load_speed"}
_UNITS = {"time": "s", "motor_torque": "N m", "load_torque": "N m", "motor_speed": "rad/s",
          "load_speed": "rad/s", "motor_angle": "rad", "load_angle": "rad"}


@dataclasses.dataclass(frozen=True, repr=False)
class Measurements:
    """A checked measurement record of a two-mass drive, every value on the load side (SI).

    Attributes
    ----------
    time : ndarray
        Sample instants, s, uniformly spaced.
    motor_torque : ndarray
        Motor torque reflected to the load side, N m (file value times ``gear_ratio``).
    motor_speed : ndarray
        Motor speed reflected to the load side, rad/s (file value / ``gear_ratio``).
    load_speed : ndarray or None
        Measured load speed, rad/s, if the file has it.
    load_torque : ndarray or None
        Known load torque, N m, if the file has it (otherwise taken as zero).
    motor_angle : ndarray or None
        Motor angle reflected to the load side, rad (file value / ``gear_ratio``).
    load_angle : ndarray or None
        Load angle, rad.
    source : str
        Where the record came from (file name), for messages.
    gear_ratio : float
        Motor turns per load turn n used to reflect the motor columns (1: none).
    notes : tuple of str
        What was done to the record on loading (unknown columns ignored,
        decimation), for reports.
    """

    time: np.ndarray
    motor_torque: np.ndarray
    motor_speed: np.ndarray
    load_speed: np.ndarray | None = None
    load_torque: np.ndarray | None = None
    motor_angle: np.ndarray | None = None
    load_angle: np.ndarray | None = None
    source: str = "<arrays>"
    gear_ratio: float = 1.0
    notes: tuple = ()

    @property
    def dt(self):
        """Sampling interval, s."""
        return float((self.time[-1] - self.time[0]) / (self.time.size - 1))

    @property
    def n_samples(self):
        """Number of samples."""
        return int(self.time.size)

    @property
    def duration(self):
        """Length of the record, s."""
        return float(self.time[-1] - self.time[0])

    @property
    def speed_names(self):
        """Names of the measured speeds: ``motor_speed`` and, if present, ``load_speed``."""
        return ("motor_speed", "load_speed") if self.load_speed is not None else ("motor_speed",)

    @property
    def speeds(self):
        """Measured speeds as columns, shape (N, 1 or 2), rad/s, load side."""
        return np.column_stack([getattr(self, name) for name in self.speed_names])

    @property
    def load_torque_or_zero(self):
        """The known load torque (N m), zeros when the file has none."""
        return np.zeros_like(self.time) if self.load_torque is None else self.load_torque

    @property
    def twist(self):
        """Measured shaft twist theta_d = motor_angle / n - load_angle (rad, load side), or None.

        None unless the file has both angle columns.  The encoders' zeros are
        independent, so the twist holds up to a constant offset; encoders read at
        slightly different instants add a part proportional to the speed (on the
        KUKA record, notebook 06, the link encoder reads about 3 ms late and that
        part is larger than the elastic twist).
        """
        if self.motor_angle is None or self.load_angle is None:
            return None
        return self.motor_angle - self.load_angle

    def columns(self):
        """The present columns as a name -> array dictionary (load side), in file order."""
        names = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
        return {name: getattr(self, name) for name in names if getattr(self, name) is not None}

    def file_columns(self):
        """The present columns as the file holds them (motor columns on the motor side)."""
        return {name: values * self.gear_ratio ** -MOTOR_SIDE_COLUMNS.get(name, 0)
                for name, values in self.columns().items()}

    def sides(self):
        """Where each present column's values are, as a name -> phrase dictionary."""
        reflected = f"load side (reflected from the motor side through gear ratio {self.gear_ratio:g})"
        return {name: reflected if name in MOTOR_SIDE_COLUMNS and self.gear_ratio != 1.0 else "load side"
                for name in self.columns() if name != "time"}

    def check_gear_ratio(self, gear_ratio, where="the rig"):
        """Refuse a record reflected through another gear ratio than ``gear_ratio``.

        Raises
        ------
        ValueError
            One line naming both ratios and how to load the record for the rig.
        """
        if not math.isclose(self.gear_ratio, gear_ratio, rel_tol=1e-9):
            raise ValueError(
                f"{self.source}: the record was reflected with gear ratio {self.gear_ratio:g} but {where} has "
                f"gear_ratio = {gear_ratio:g}; load it with load_measurements(path, gear_ratio={gear_ratio:g})"
            )

    def decimated(self, factor):
        """The record averaged over blocks of ``factor`` samples (a boxcar anti-alias filter).

        A trailing part shorter than a block is dropped; the time of a block is its
        mean.  The reason is added to :attr:`notes`.
        """
        factor = int(factor)
        n_blocks = self.n_samples // factor
        means = {name: values[: n_blocks * factor].reshape(n_blocks, factor).mean(axis=1)
                 for name, values in self.columns().items()}
        note = (f"decimated by {factor} (block means): {self.n_samples} samples at {self.dt:.6g} s "
                f"to {n_blocks} at {self.dt * factor:.6g} s")
        return dataclasses.replace(self, **means, notes=self.notes + (note,))

    def __repr__(self):
        return (
            f"Measurements({self.source!r}, {self.n_samples} samples, dt={self.dt:.6g} s, "
            f"gear_ratio={self.gear_ratio:g}, columns={list(self.columns())})"
        )

    def to_dict(self):
        """JSON-ready: source, sampling, gear ratio, notes and every column (load side, SI units)."""
        return json_ready({"source": str(self.source), "n_samples": self.n_samples, "dt": self.dt,
                           "gear_ratio": self.gear_ratio, "notes": list(self.notes),
                           "columns": {name: values for name, values in self.columns().items()}})

    def plot(self, ax=None):
        """Torques, speeds and (if measured) the twist against time, load side.

        Returns
        -------
        ResultPlot
            One panel per quantity, each with its legend beside it.
        """
        rows = 3 if self.twist is not None else 2
        figure, axes = axes_or_new(ax, (rows, 1), sharex=True, figsize=(9.5, 2.2 * rows), layout="constrained")
        axes[0].plot(self.time, self.motor_torque, label="motor_torque")
        if self.load_torque is not None:
            axes[0].plot(self.time, self.load_torque, label="load_torque")
        axes[0].set_ylabel("torque (N m)")
        for name in self.speed_names:
            axes[1].plot(self.time, getattr(self, name), label=name)
        axes[1].set_ylabel("speed (rad/s)")
        if rows == 3:
            axes[2].plot(self.time, 1e3 * self.twist, label="twist")
            axes[2].set_ylabel("twist (mrad)")
        axes[-1].set_xlabel("time (s)")
        for panel in axes:
            legend_beside(panel)
        return ResultPlot(figure, axes)


def _num(value):
    """A number for a message: plain digits, never a numpy repr."""
    return f"{float(value):.9g}"


def _line_list(bad_rows, header_lines=1):
    """File line numbers (1-based, header counted) of data rows, shortened for a message."""
    lines = [int(row) + 1 + header_lines for row in bad_rows]
    shown = ", ".join(str(line) for line in lines[:8])
    more = f" and {len(lines) - 8} more" if len(lines) > 8 else ""
    return f"line{'s' if len(lines) > 1 else ''} {shown}{more}"


def _check_time(time, source):
    steps = np.diff(time)
    backwards = np.flatnonzero(steps <= 0.0)
    if backwards.size:
        row = backwards[0] + 1
        raise ValueError(
            f"{source}: time is not increasing at {_line_list([row])} "
            f"({_num(time[row - 1])} s then {_num(time[row])} s)"
        )
    median = float(np.median(steps))
    uneven = np.flatnonzero(np.abs(steps - median) > _UNIFORM_TOLERANCE * median)
    if uneven.size:
        row = uneven[0] + 1
        raise ValueError(
            f"{source}: time is not uniformly sampled: step {_num(steps[row - 1])} s before "
            f"{_line_list([row])}, median step {_num(median)} s ({uneven.size} uneven steps); "
            f"resample the record to a uniform grid"
        )
    if median > MAX_SAMPLING_INTERVAL:
        unit = "milliseconds" if median / 1e3 <= MAX_SAMPLING_INTERVAL else "microseconds or another unit"
        raise ValueError(
            f"{source}: time steps of {_num(median)} s over a record of {_num(time[-1] - time[0])} s: "
            f"time looks like {unit}, it must be in seconds (a drive record samples faster "
            f"than every {MAX_SAMPLING_INTERVAL:g} s)"
        )


def _check_excitation(arrays, source):
    for name in ("motor_torque", "motor_speed", "load_speed"):
        values = arrays.get(name)
        if values is not None and np.ptp(values) <= 1e-12 * np.max(np.abs(values)):
            raise ValueError(
                f"{source}: {name} is constant ({_num(values[0])} {_UNITS[name]} in all {values.size} rows): "
                f"no excitation; a diagnosis needs a record where torque and speeds vary"
            )


def _check_speed_units(name, values, source):
    peak = float(np.max(np.abs(values)))
    if peak > MAX_PLAUSIBLE_SPEED:
        raise ValueError(
            f"{source}: {name} reaches {peak:.6g}, more than {MAX_PLAUSIBLE_SPEED:g} rad/s: "
            f"speeds must be in rad/s (if the file is in rpm, multiply by pi/30)"
        )


def _check_angle(name, angle, speed, dt, source):
    """The angle's increments must match the trapezoidal integral of its speed (same side)."""
    from scipy.integrate import cumulative_trapezoid  # lazy: keeps `import backlash_df` quick

    integral = cumulative_trapezoid(speed, dx=dt, initial=0.0)
    mismatch = np.abs(angle - angle[0] - integral)
    worst = int(np.argmax(mismatch))
    scale = max(np.ptp(angle), np.ptp(integral))
    if mismatch[worst] > ANGLE_TOLERANCE * scale:
        raise ValueError(
            f"{source}: {name} does not match the integrated {_ANGLE_SPEEDS[name]}: they differ by "
            f"{mismatch[worst]:.3g} rad at {_line_list([worst])}, {100 * mismatch[worst] / scale:.0f} % of "
            f"the angle's range (tolerance {100 * ANGLE_TOLERANCE:g} %); angles must be in rad, speeds in "
            f"rad/s, each angle on the side of its speed"
        )


def _check_gear_ratio(gear_ratio, source):
    if isinstance(gear_ratio, bool) or not isinstance(gear_ratio, (int, float)) or not (
            math.isfinite(gear_ratio) and gear_ratio > 0.0):
        raise ValueError(f"{source}: gear_ratio must be a finite number > 0, got {gear_ratio!r}")


def _bounded(measurements, max_samples):
    """The record itself, decimated to at most ``max_samples`` samples, or a refusal."""
    n = measurements.n_samples
    if n <= max_samples:
        return measurements
    factor = math.ceil(n / max_samples)
    if factor * measurements.dt > MAX_DECIMATED_INTERVAL:
        longest = max_samples * max(measurements.dt, MAX_DECIMATED_INTERVAL)
        raise ValueError(
            f"{measurements.source}: {n} samples over {measurements.duration:.6g} s, more than the limit of "
            f"{max_samples} samples even when decimated to every {MAX_DECIMATED_INTERVAL:g} s; "
            f"cut a window of at most {longest:.6g} s"
        )
    return measurements.decimated(factor)


def measurements_from_arrays(time, motor_torque, motor_speed, load_speed=None, load_torque=None,
                             motor_angle=None, load_angle=None, source="<arrays>", gear_ratio=1.0,
                             max_samples=MAX_SAMPLES):
    """Check measurement arrays, reflect the motor side and bundle them as :class:`Measurements`.

    Parameters
    ----------
    time : array_like
        Sample instants, s: increasing and uniformly spaced (1 % tolerance).
    motor_torque, motor_speed : array_like
        Motor torque (N m) and measured motor speed (rad/s), **motor side**.
    load_speed, load_torque : array_like, optional
        Measured load speed (rad/s) and known load torque (N m), load side.
    motor_angle, load_angle : array_like, optional
        Encoder angles (rad), motor angle on the motor side.  Each must match its
        integrated speed (:data:`ANGLE_TOLERANCE`); with both, :attr:`~Measurements.twist`
        is measured.
    source : str
        Name used in error messages.
    gear_ratio : float
        Motor turns per load turn n (``[plant] gear_ratio``): motor torque is
        multiplied by n, motor speed and angle divided by n.
    max_samples : int
        Longer records are decimated by block means (noted in ``notes``), or refused
        when the decimated sampling would be slower than :data:`MAX_DECIMATED_INTERVAL`.

    Returns
    -------
    Measurements
        Every array on the load side.

    Raises
    ------
    ValueError
        One line naming the problem: lengths differ, NaN or infinite values (with
        the file lines), fewer than :data:`MIN_SAMPLES` samples, time not
        increasing, not uniform or in milliseconds, a constant torque or speed (no
        excitation), speeds beyond :data:`MAX_PLAUSIBLE_SPEED` (probably rpm),
        angles that do not match the speeds, a non-positive gear ratio, a record
        too long to decimate.

    Examples
    --------
    >>> t = np.arange(400) * 1e-3
    >>> m = measurements_from_arrays(t, np.sin(t), 100.0 * np.cos(t), gear_ratio=100.0)
    >>> m.n_samples, m.dt, float(m.motor_speed[0]), m.twist is None
    (400, 0.001, 1.0, True)
    """
    _check_gear_ratio(gear_ratio, source)
    given = {"time": time, "motor_torque": motor_torque, "motor_speed": motor_speed,
             "load_speed": load_speed, "load_torque": load_torque, "motor_angle": motor_angle,
             "load_angle": load_angle}
    arrays = {name: np.asarray(value, dtype=float) for name, value in given.items() if value is not None}
    n = arrays["time"].size
    for name, values in arrays.items():
        if values.ndim != 1 or values.size != n:
            raise ValueError(f"{source}: {name} must be 1-D with {n} samples like time, got shape {values.shape}")
    for name, values in arrays.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(
                f"{source}: {name} has NaN or infinite values at {_line_list(bad)} "
                f"({bad.size} rows); fix or remove those rows, the file is not trimmed"
            )
    if n < MIN_SAMPLES:
        raise ValueError(f"{source}: only {n} samples; a diagnosis needs at least {MIN_SAMPLES}")
    _check_time(arrays["time"], source)
    _check_excitation(arrays, source)
    for name in ("motor_speed", "load_speed"):
        if name in arrays:
            _check_speed_units(name, arrays[name], source)
    dt = (arrays["time"][-1] - arrays["time"][0]) / (n - 1)
    for name, speed in _ANGLE_SPEEDS.items():
        if name in arrays and speed in arrays:
            _check_angle(name, arrays[name], arrays[speed], dt, source)
    reflected = {name: values * gear_ratio ** MOTOR_SIDE_COLUMNS.get(name, 0) for name, values in arrays.items()}
    return _bounded(Measurements(source=source, gear_ratio=float(gear_ratio), **reflected), max_samples)


def _unknown_columns(header):
    """The header's names that are no known column, each with the closest known name absent from the header.

    Returns
    -------
    dict of str to str or None
        Name (``column N (no name)`` for an empty one) -> suggestion, None where
        no known name is close (:func:`difflib.get_close_matches`, case ignored).
    """
    known = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    absent = [name for name in known if name not in header]
    unknown = {}
    for index, name in enumerate(header):
        if name not in known:
            matches = difflib.get_close_matches(name.lower(), absent, n=1)
            unknown[name or f"column {index + 1} (no name)"] = matches[0] if matches else None
    return unknown


def _unknown_columns_text(header):
    """What the notice on the header's unknown columns says ("" if there are none), without the file name.

    ``load_trq: not a known column; did you mean load_torque?`` for one column;
    for several, ``not known columns: load_trq (did you mean load_torque?), temp;
    known: time, ...``.  The known names are listed where a column matches none.

    Examples
    --------
    >>> _unknown_columns_text(["time", "motor_torque", "motor_speed", "load_trq"])
    'load_trq: not a known column; did you mean load_torque?'
    """
    unknown = _unknown_columns(header)
    if not unknown:
        return ""
    known = f"known: {', '.join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)}"
    if len(unknown) == 1:
        ((name, match),) = unknown.items()
        return f"{name}: not a known column; " + (f"did you mean {match}?" if match else known)
    names = ", ".join(name if match is None else f"{name} (did you mean {match}?)" for name, match in unknown.items())
    return f"not known columns: {names}" + (f"; {known}" if None in unknown.values() else "")


def _misspellings(header):
    """The header's unknown names that look like a misspelt known column absent from it, each with that column."""
    return {name: match for name, match in _unknown_columns(header).items()
            if match and difflib.SequenceMatcher(None, name.lower(), match).ratio() >= MISSPELLING_CUTOFF}


def _check_misspellings(header, path):
    """Refuse a header with a name that looks like a misspelt known column (:data:`MISSPELLING_CUTOFF`).

    Examples
    --------
    >>> _check_misspellings(["time", "motor_torque", "motor_speed", "load_sped"], "data.csv")
    Traceback (most recent call last):
    ...
    ValueError: data.csv: column 'load_sped' looks like a misspelling of 'load_speed' (pass ...)
    """
    misspelt = _misspellings(header)
    if not misspelt:
        return
    if len(misspelt) == 1:
        ((name, match),) = misspelt.items()
        what = f"column '{name}' looks like a misspelling of '{match}'"
    else:
        what = "columns look like misspellings: " + ", ".join(f"'{name}' of '{match}'"
                                                              for name, match in misspelt.items())
    raise ValueError(f"{path}: {what} (pass --allow-unknown-columns, or allow_unknown_columns=True in Python, "
                     f"to read such a column as an unknown one)")


def _check_header(header, path):
    """Refuse a header without the required columns (naming a close unknown name) or with a name twice."""
    missing = [name for name in REQUIRED_COLUMNS if name not in header]
    separator = next((sep for sep in (";", "\t") if len(header) == 1 and sep in header[0]), None)
    if missing and separator:
        raise ValueError(f"{path}: the columns are separated by {separator!r}; the format is comma-separated "
                         f"with a decimal point (save as CSV with ',' as separator)")
    if missing:
        unknown = _unknown_columns_text(header)
        raise ValueError(
            f"{path}: missing column{'s' if len(missing) > 1 else ''} {', '.join(missing)}; "
            f"the header must name {', '.join(REQUIRED_COLUMNS)} (optional: {', '.join(OPTIONAL_COLUMNS)})"
            + (f"; {unknown}" if unknown else "")
        )
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        raise ValueError(f"{path}: column {duplicated[0]} appears more than once in the header")


def _parse_rows(reader, header, known, path):
    """The known columns row by row (the slow path): names the line of the first bad row."""
    data = {name: [] for name in known}
    indices = [header.index(name) for name in known]
    for row_index, row in enumerate(reader):
        if len(row) != len(header):
            raise ValueError(
                f"{path}: {_line_list([row_index])} has {len(row)} fields, the header has {len(header)}"
            )
        for name, index in zip(known, indices):
            cell = row[index]
            try:
                data[name].append(float(cell) if cell.strip() else math.nan)
            except ValueError:
                raise ValueError(
                    f"{path}: {_line_list([row_index])}, column {name}: {cell!r} is not a number"
                ) from None
    return data


def read_columns(path):
    """The known columns of a CSV file as arrays, unchecked beyond the header (:func:`load_measurements` checks).

    numpy's C parser reads the table; where it fails, a row-by-row parse names the
    bad cell.

    Parameters
    ----------
    path : Path

    Returns
    -------
    dict of str to ndarray
        The columns of the module docs that the header holds, in file units (an
        unknown column, misspelt or not, is left out).
    """
    return _read_table(path, strict=False, allow_unknown_columns=True)[0]


def _read_table(path, strict, allow_unknown_columns):
    """The known columns (as :func:`read_columns`) and the notice on unknown ones.

    With ``strict`` an unknown column refuses the file with the notice; else, without
    ``allow_unknown_columns``, a misspelt known one refuses it (:func:`_check_misspellings`).
    """
    with path.open(newline="", encoding="utf-8-sig") as handle:
        header = [name.strip() for name in next(csv.reader([handle.readline()]), [])]
        _check_header(header, path)
        unknown = _unknown_columns_text(header)
        notice = f"{path}: {unknown}" if unknown else ""
        if notice and strict:
            raise ValueError(notice)
        if not allow_unknown_columns:
            _check_misspellings(header, path)
        known = [name for name in REQUIRED_COLUMNS + OPTIONAL_COLUMNS if name in header]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # "input contained no data"
                table = np.loadtxt(handle, delimiter=",", comments=None, ndmin=2, dtype=float)
            if table.size == 0:  # a header without rows: too few samples, said below
                table = np.empty((0, len(header)))
            return {name: table[:, header.index(name)] for name in known}, notice
        except ValueError:  # a bad cell, a short row, a text column: find and name it
            handle.seek(0)
            reader = csv.reader(handle)
            next(reader)
            return _parse_rows(reader, header, known, path), notice


def load_measurements(path, *, gear_ratio=1.0, max_samples=MAX_SAMPLES, strict=False, allow_unknown_columns=False):
    """Read and check a measurement CSV file and reflect it to the load side.

    Parameters
    ----------
    path : str or Path
        CSV file (UTF-8, a byte-order mark is accepted) with a header row; the
        columns are in the module docs.
    gear_ratio : float
        The rig's ``[plant] gear_ratio`` (motor turns per load turn): the motor
        columns are reflected through it.  Pass ``rig.plant.gear_ratio``.
    max_samples : int
        Longer records are decimated by block means, with a note (see
        :func:`measurements_from_arrays`).
    strict : bool
        Refuse a header name that is no known column.  Otherwise such a column is
        not read, and :attr:`Measurements.notes` starts with one line naming
        every such column and the closest known name (the module docs).
    allow_unknown_columns : bool
        Read a header name that looks like a misspelt optional column absent from
        the header (``load_sped`` for ``load_speed``, :data:`MISSPELLING_CUTOFF`) as
        an unknown column, with the note.  By default such a file is refused.

    Returns
    -------
    Measurements
        Every array on the load side.

    Raises
    ------
    ValueError
        One line naming the file and the problem: unreadable or not UTF-8,
        missing or duplicated columns (a missing one with the close unknown
        name, if any), an unknown column with ``strict``, a misspelt optional
        column without ``allow_unknown_columns`` (``data.csv: column 'load_sped'
        looks like a misspelling of 'load_speed' (pass ...)``), a cell that is
        not a number, and every problem :func:`measurements_from_arrays` names.
    """
    path = Path(path)
    try:
        columns, notice = _read_table(path, strict, allow_unknown_columns)
    except OSError as error:
        raise ValueError(f"{path}: cannot read measurement file ({error.strerror})") from None
    except UnicodeDecodeError as error:
        raise ValueError(f"{path}: not a UTF-8 text file (byte {error.object[error.start]:#04x} cannot be "
                         f"decoded); save it as UTF-8 CSV") from None
    record = measurements_from_arrays(source=str(path), gear_ratio=gear_ratio, max_samples=max_samples, **columns)
    return dataclasses.replace(record, notes=(notice, *record.notes)) if notice else record


def write_measurements(path, measurements, precision=9):
    """Write a record as a measurement CSV file (the format :func:`load_measurements` reads).

    The motor columns are written on the motor side, so that
    ``load_measurements(path, gear_ratio=measurements.gear_ratio)`` gives the record back.

    Parameters
    ----------
    path : str or Path
    measurements : Measurements
    precision : int
        Significant digits per value.
    """
    Path(path).write_text(measurements_csv(measurements, precision), encoding="utf-8")


def measurements_csv(measurements, precision=9):
    """A record as the text of a measurement CSV file (:func:`write_measurements` writes it).

    Parameters
    ----------
    measurements : Measurements
    precision : int
        Significant digits per value.

    Returns
    -------
    str
        The header row and one line a sample, motor columns on the motor side.
    """
    columns = measurements.file_columns()
    table = np.column_stack(list(columns.values()))
    lines = [",".join(columns)]
    lines += [",".join(f"{value:.{precision}g}" for value in row) for row in table]
    return "\n".join(lines) + "\n"
