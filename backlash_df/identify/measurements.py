"""Measurement files of a drive: loading, checks with one-line errors, writing.

The file is a CSV with a header row, SI units and uniform sampling (DESIGN.md):

=================  ======  ========================================================
column             unit    holds
=================  ======  ========================================================
``time``           s       sample instants, increasing, uniformly spaced
``motor_torque``   N m     torque commanded to the motor (controller + test signal)
``motor_speed``    rad/s   measured motor speed
``load_speed``     rad/s   measured load speed (optional)
``load_torque``    N m     known torque applied to the load (optional)
=================  ======  ========================================================

A file with bad rows is refused with one line naming the column and the file
lines; it is never silently trimmed.
"""

import csv
import dataclasses
import math
from pathlib import Path

import numpy as np

__all__ = [
    "Measurements",
    "load_measurements",
    "measurements_from_arrays",
    "write_measurements",
    "REQUIRED_COLUMNS",
    "OPTIONAL_COLUMNS",
    "MIN_SAMPLES",
    "MAX_PLAUSIBLE_SPEED",
]

REQUIRED_COLUMNS = ("time", "motor_torque", "motor_speed")
OPTIONAL_COLUMNS = ("load_speed", "load_torque")
#: Fewest samples a record may have: estimation and validation parts need room.
MIN_SAMPLES = 200
#: Speeds above this (rad/s, about 9550 rpm) are taken as a file written in rpm.
MAX_PLAUSIBLE_SPEED = 1000.0
_UNIFORM_TOLERANCE = 0.01  # relative deviation of a time step from the median step


@dataclasses.dataclass(frozen=True, repr=False)
class Measurements:
    """A checked measurement record of a two-mass drive (SI units).

    Attributes
    ----------
    time : ndarray
        Sample instants, s, uniformly spaced.
    motor_torque : ndarray
        Commanded motor torque, N m.
    motor_speed : ndarray
        Measured motor speed, rad/s.
    load_speed : ndarray or None
        Measured load speed, rad/s, if the file has it.
    load_torque : ndarray or None
        Known load torque, N m, if the file has it (otherwise taken as zero).
    source : str
        Where the record came from (file name), for messages.
    """

    time: np.ndarray
    motor_torque: np.ndarray
    motor_speed: np.ndarray
    load_speed: np.ndarray | None = None
    load_torque: np.ndarray | None = None
    source: str = "<arrays>"

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
        """Measured speeds as columns, shape (N, 1 or 2), rad/s."""
        return np.column_stack([getattr(self, name) for name in self.speed_names])

    @property
    def load_torque_or_zero(self):
        """The known load torque (N m), zeros when the file has none."""
        return np.zeros_like(self.time) if self.load_torque is None else self.load_torque

    def columns(self):
        """The present columns as a name -> array dictionary, in file order."""
        names = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
        return {name: getattr(self, name) for name in names if getattr(self, name) is not None}

    def __repr__(self):
        return (
            f"Measurements({self.source!r}, {self.n_samples} samples, dt={self.dt:.6g} s, "
            f"columns={list(self.columns())})"
        )

    def plot(self, axes=None):
        """Plot torques and speeds against time; returns the two axes."""
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 4.5))
        axes[0].plot(self.time, self.motor_torque, label="motor_torque")
        if self.load_torque is not None:
            axes[0].plot(self.time, self.load_torque, label="load_torque")
        axes[0].set_ylabel("torque (N m)")
        for name in self.speed_names:
            axes[1].plot(self.time, getattr(self, name), label=name)
        axes[1].set_ylabel("speed (rad/s)")
        axes[1].set_xlabel("time (s)")
        for ax in axes:
            ax.legend(loc="upper right", fontsize="small")
        return axes


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
            f"({time[row - 1]!r} s then {time[row]!r} s)"
        )
    median = float(np.median(steps))
    uneven = np.flatnonzero(np.abs(steps - median) > _UNIFORM_TOLERANCE * median)
    if uneven.size:
        row = uneven[0] + 1
        raise ValueError(
            f"{source}: time is not uniformly sampled: step {steps[row - 1]:.6g} s before "
            f"{_line_list([row])}, median step {median:.6g} s ({uneven.size} uneven steps); "
            f"resample the record to a uniform grid"
        )


def _check_speed_units(name, values, source):
    peak = float(np.max(np.abs(values)))
    if peak > MAX_PLAUSIBLE_SPEED:
        raise ValueError(
            f"{source}: {name} reaches {peak:.6g}, more than {MAX_PLAUSIBLE_SPEED:g} rad/s: "
            f"speeds must be in rad/s (if the file is in rpm, multiply by pi/30)"
        )


def measurements_from_arrays(time, motor_torque, motor_speed, load_speed=None, load_torque=None, source="<arrays>"):
    """Check measurement arrays and bundle them as :class:`Measurements`.

    Parameters
    ----------
    time : array_like
        Sample instants, s: increasing and uniformly spaced (1 % tolerance).
    motor_torque, motor_speed : array_like
        Commanded motor torque (N m) and measured motor speed (rad/s).
    load_speed, load_torque : array_like, optional
        Measured load speed (rad/s) and known load torque (N m).
    source : str
        Name used in error messages.

    Returns
    -------
    Measurements

    Raises
    ------
    ValueError
        One line naming the problem: lengths differ, NaN or infinite values (with
        the file lines), time not increasing or not uniform, fewer than
        :data:`MIN_SAMPLES` samples, speeds beyond :data:`MAX_PLAUSIBLE_SPEED`
        (probably rpm).

    Examples
    --------
    >>> t = np.arange(400) * 1e-3
    >>> m = measurements_from_arrays(t, np.zeros(400), np.ones(400))
    >>> m.n_samples, m.dt
    (400, 0.001)
    """
    given = {"time": time, "motor_torque": motor_torque, "motor_speed": motor_speed,
             "load_speed": load_speed, "load_torque": load_torque}
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
    for name in ("motor_speed", "load_speed"):
        if name in arrays:
            _check_speed_units(name, arrays[name], source)
    return Measurements(source=source, **arrays)


def _parse_rows(reader, header, path):
    data = {name: [] for name in header}
    for row_index, row in enumerate(reader):
        if len(row) != len(header):
            raise ValueError(
                f"{path}: {_line_list([row_index])} has {len(row)} fields, the header has {len(header)}"
            )
        for name, cell in zip(header, row):
            try:
                data[name].append(float(cell) if cell.strip() else math.nan)
            except ValueError:
                raise ValueError(
                    f"{path}: {_line_list([row_index])}, column {name}: {cell!r} is not a number"
                ) from None
    return data


def load_measurements(path):
    """Read and check a measurement CSV file (see the module docs for the columns).

    Parameters
    ----------
    path : str or Path
        CSV file with a header row; extra columns are ignored.

    Returns
    -------
    Measurements

    Raises
    ------
    ValueError
        One line naming the file and the problem: unreadable file, missing
        columns, a cell that is not a number, NaN or infinite values (naming the
        file lines), time not increasing or not uniform, too few samples, speeds
        that look like rpm.
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            reader = csv.reader(handle)
            header = [name.strip() for name in next(reader, [])]
            missing = [name for name in REQUIRED_COLUMNS if name not in header]
            if missing:
                raise ValueError(
                    f"{path}: missing column{'s' if len(missing) > 1 else ''} {', '.join(missing)}; "
                    f"the header must name {', '.join(REQUIRED_COLUMNS)} "
                    f"(optional: {', '.join(OPTIONAL_COLUMNS)})"
                )
            duplicated = sorted({name for name in header if header.count(name) > 1})
            if duplicated:
                raise ValueError(f"{path}: column {duplicated[0]} appears more than once in the header")
            data = _parse_rows(reader, header, path)
    except OSError as error:
        raise ValueError(f"{path}: cannot read measurement file ({error.strerror})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    columns = {name: data[name] for name in REQUIRED_COLUMNS + OPTIONAL_COLUMNS if name in data}
    return measurements_from_arrays(source=str(path), **columns)


def write_measurements(path, measurements, precision=9):
    """Write a record as a measurement CSV file (the format :func:`load_measurements` reads).

    Parameters
    ----------
    path : str or Path
    measurements : Measurements
    precision : int
        Significant digits per value.
    """
    columns = measurements.columns()
    table = np.column_stack(list(columns.values()))
    lines = [",".join(columns)]
    lines += [",".join(f"{value:.{precision}g}" for value in row) for row in table]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
