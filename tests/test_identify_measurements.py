"""Loading of measurement files: one test per error, each a one-line ValueError."""

import numpy as np
import pytest

from backlash_df.identify import load_measurements, measurements_from_arrays, write_measurements
from backlash_df.identify.measurements import MIN_SAMPLES

N = 400


def _columns(n=N, dt=1e-3):
    t = np.arange(n) * dt
    return {
        "time": t,
        "motor_torque": 10.0 * np.sin(2 * np.pi * 3 * t),
        "motor_speed": 5.0 * np.sin(2 * np.pi * t),
        "load_speed": 4.9 * np.sin(2 * np.pi * t),
        "load_torque": np.full(n, 2.0),
    }


def _write(path, columns, cells=None):
    names = list(columns)
    rows = np.column_stack([columns[name] for name in names]).astype(object)
    for (row, name), value in (cells or {}).items():
        rows[row, names.index(name)] = value
    lines = [",".join(names)] + [",".join(str(cell) for cell in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def _one_line_error(path, match):
    with pytest.raises(ValueError, match=match) as info:
        load_measurements(path)
    assert "\n" not in str(info.value)
    return str(info.value)


def test_round_trip_keeps_every_value(tmp_path):
    columns = _columns()
    measurements = measurements_from_arrays(**columns)
    path = tmp_path / "record.csv"
    write_measurements(path, measurements, precision=17)
    loaded = load_measurements(path)
    for name, values in columns.items():
        np.testing.assert_array_equal(getattr(loaded, name), values)
    assert loaded.dt == pytest.approx(1e-3)
    assert loaded.speed_names == ("motor_speed", "load_speed")


def test_optional_columns_may_be_absent(tmp_path):
    columns = {key: value for key, value in _columns().items() if key in ("time", "motor_torque", "motor_speed")}
    loaded = load_measurements(_write(tmp_path / "motor_only.csv", columns))
    assert loaded.load_speed is None and loaded.speeds.shape == (N, 1)
    np.testing.assert_array_equal(loaded.load_torque_or_zero, 0.0)


def test_missing_column(tmp_path):
    columns = {key: value for key, value in _columns().items() if key != "motor_speed"}
    _one_line_error(_write(tmp_path / "m.csv", columns), "missing column motor_speed")


def test_nan_rows_are_named_not_trimmed(tmp_path):
    path = _write(tmp_path / "m.csv", _columns(), {(10, "load_speed"): "nan", (57, "load_speed"): ""})
    message = _one_line_error(path, "load_speed has NaN or infinite values")
    # data row 10 is file line 12 (header is line 1, data row 0 is line 2)
    assert "lines 12, 59" in message and "not trimmed" in message


def test_infinite_value(tmp_path):
    path = _write(tmp_path / "m.csv", _columns(), {(3, "motor_torque"): "inf"})
    assert "line 5" in _one_line_error(path, "motor_torque has NaN or infinite values")


def test_text_cell(tmp_path):
    path = _write(tmp_path / "m.csv", _columns(), {(7, "motor_speed"): "fast"})
    _one_line_error(path, r"line 9, column motor_speed: 'fast' is not a number")


def test_time_not_increasing(tmp_path):
    columns = _columns()
    columns["time"] = columns["time"].copy()
    columns["time"][100] = columns["time"][98]
    _one_line_error(_write(tmp_path / "m.csv", columns), "time is not increasing at line 102")


def test_time_not_uniform(tmp_path):
    columns = _columns()
    columns["time"] = columns["time"].copy()
    columns["time"][200:] += 0.5e-3  # one step of 1.5 ms among 1 ms steps
    _one_line_error(_write(tmp_path / "m.csv", columns), "time is not uniformly sampled")


def test_too_few_samples(tmp_path):
    _one_line_error(_write(tmp_path / "m.csv", _columns(n=MIN_SAMPLES - 1)), f"only {MIN_SAMPLES - 1} samples")


def test_speeds_in_rpm(tmp_path):
    columns = _columns()
    columns["motor_speed"] = columns["motor_speed"] * 0 + 1438.0  # the paper's 150.6 rad/s in rpm
    _one_line_error(_write(tmp_path / "m.csv", columns), "speeds must be in rad/s")


def test_unreadable_file(tmp_path):
    _one_line_error(tmp_path / "absent.csv", "cannot read measurement file")
