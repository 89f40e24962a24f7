"""Measurement files: reflection through the gear, the measured twist, one-line errors."""

import codecs
import importlib.util
import re

import numpy as np
import pytest

from backlash_df.config import Plant, load_rig
from backlash_df.identify import load_measurements, measurements_from_arrays, write_measurements
from backlash_df.identify.measurements import MAX_DECIMATED_INTERVAL, MIN_SAMPLES
from backlash_df.simulation import simulate_two_mass
from conftest import EXAMPLES, KUKA

N = 400
DT = 1e-3


def _columns(n=N, dt=DT):
    """A consistent record: angles are the exact integrals of the speeds."""
    t = np.arange(n) * dt
    w = 2 * np.pi
    return {
        "time": t,
        "motor_torque": 10.0 * np.sin(2 * np.pi * 3 * t),
        "motor_speed": 5.0 * np.sin(w * t),
        "load_speed": 4.9 * np.sin(w * t),
        "load_torque": np.full(n, 2.0),
        "motor_angle": 0.3 + 5.0 * (1 - np.cos(w * t)) / w,
        "load_angle": -0.1 + 4.9 * (1 - np.cos(w * t)) / w,
    }


def _write(path, columns, cells=None, encoding="utf-8", prefix=""):
    names = list(columns)
    rows = np.column_stack([columns[name] for name in names]).astype(object)
    for (row, name), value in (cells or {}).items():
        rows[row, names.index(name)] = value
    lines = [",".join(names)] + [",".join(str(cell) for cell in row) for row in rows]
    path.write_bytes(prefix.encode() + ("\n".join(lines) + "\n").encode(encoding))
    return path


def test_round_trip_keeps_every_value(tmp_path):
    columns = _columns()
    measurements = measurements_from_arrays(**columns)
    path = tmp_path / "record.csv"
    write_measurements(path, measurements, precision=17)
    loaded = load_measurements(path)
    for name, values in columns.items():
        np.testing.assert_array_equal(getattr(loaded, name), values)
    assert loaded.dt == pytest.approx(DT)
    assert loaded.speed_names == ("motor_speed", "load_speed")


def test_gear_ratio_reflects_the_motor_columns_and_round_trips(tmp_path):
    n = 120.0
    columns = _columns()
    measurements = measurements_from_arrays(**columns, gear_ratio=n)
    np.testing.assert_allclose(measurements.motor_torque, columns["motor_torque"] * n, rtol=1e-15)
    np.testing.assert_allclose(measurements.motor_speed, columns["motor_speed"] / n, rtol=1e-15)
    np.testing.assert_allclose(measurements.motor_angle, columns["motor_angle"] / n, rtol=1e-15)
    for name in ("load_speed", "load_torque", "load_angle", "time"):
        np.testing.assert_array_equal(getattr(measurements, name), columns[name])
    assert "reflected from the motor side" in measurements.sides()["motor_speed"]
    assert measurements.sides()["load_speed"] == "load side"
    path = tmp_path / "geared.csv"
    write_measurements(path, measurements, precision=17)
    again = load_measurements(path, gear_ratio=n)
    for name, values in measurements.columns().items():
        np.testing.assert_allclose(getattr(again, name), values, rtol=1e-15)


def test_measured_twist_is_motor_angle_over_n_minus_load_angle():
    n = 150.0
    columns = _columns()
    columns["motor_angle"] = columns["motor_angle"] * n  # the motor encoder turns n times as far
    columns["motor_speed"] = columns["motor_speed"] * n
    measurements = measurements_from_arrays(**columns, gear_ratio=n)
    expected = columns["motor_angle"] / n - columns["load_angle"]
    np.testing.assert_allclose(measurements.twist, expected, rtol=0, atol=1e-15)
    # in closed form: 0.4 rad of encoder offset plus 0.1 rad/s of speed difference integrated
    t = columns["time"]
    np.testing.assert_allclose(measurements.twist, 0.4 + 0.1 * (1 - np.cos(2 * np.pi * t)) / (2 * np.pi), atol=1e-13)


def test_twist_needs_both_angles():
    columns = _columns()
    del columns["load_angle"]
    assert measurements_from_arrays(**columns).twist is None


def test_reflection_matches_a_drive_simulated_on_the_load_side():
    """A geared drive simulated on the motor side, reflected by the loader, equals the same drive
    simulated with every value referred to the load side (J_m n^2, T_m n, speeds / n)."""
    n, dt, t_end = 50.0, 2e-4, 0.4
    load_side = Plant(motor_inertia=0.02 * n**2, load_inertia=3.0, stiffness=2.0e4, damping=20.0, half_gap=0.01)
    motor_side = Plant(motor_inertia=0.02, load_inertia=3.0 / n**2, stiffness=2.0e4 / n**2, damping=20.0 / n**2,
                       half_gap=0.01 * n)

    def torque(time):  # N m at the motor
        return 8.0 * np.sin(2 * np.pi * 4 * time) + 3.0 * np.sign(np.sin(2 * np.pi * 11 * time))

    motor = simulate_two_mass(motor_side, "phase-plane", t_end, dt, motor_torque=torque)
    load = simulate_two_mass(load_side, "phase-plane", t_end, dt, motor_torque=lambda time: n * torque(time))
    motor_speed, load_speed_motor_side = motor.state("motor_speed"), motor.state("load_speed")
    load_speed = load_speed_motor_side / n  # the load shaft's own speed, what a load encoder sees
    load_angle = np.concatenate([[0.0], np.cumsum(0.5 * (load_speed[1:] + load_speed[:-1])) * dt])
    record = measurements_from_arrays(
        motor.time, torque(motor.time), motor_speed, load_speed=load_speed,
        motor_angle=motor.theta_d + n * load_angle, load_angle=load_angle, gear_ratio=n)
    scale = np.max(np.abs(load.state("motor_speed")))
    np.testing.assert_allclose(record.motor_speed, load.state("motor_speed"), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(record.load_speed, load.state("load_speed"), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(record.motor_torque, n * torque(load.time), rtol=1e-15)
    np.testing.assert_allclose(record.twist, load.theta_d, rtol=0, atol=1e-9 * np.max(np.abs(load.theta_d)))
    assert np.ptp(load.theta_d) > 2 * load_side.half_gap  # the record crosses the gap


def test_optional_columns_may_be_absent(tmp_path):
    columns = {key: value for key, value in _columns().items() if key in ("time", "motor_torque", "motor_speed")}
    loaded = load_measurements(_write(tmp_path / "motor_only.csv", columns))
    assert loaded.load_speed is None and loaded.speeds.shape == (N, 1) and loaded.twist is None
    np.testing.assert_array_equal(loaded.load_torque_or_zero, 0.0)


def test_excel_byte_order_mark_is_accepted(tmp_path):
    path = _write(tmp_path / "excel.csv", _columns(), prefix=codecs.BOM_UTF8.decode("utf-8"))
    assert path.read_bytes().startswith(codecs.BOM_UTF8)
    np.testing.assert_array_equal(load_measurements(path).time, _columns()["time"])


def test_long_record_is_decimated_with_a_note():
    columns = _columns(n=1000, dt=1e-4)
    record = measurements_from_arrays(**columns, max_samples=400)
    assert record.n_samples == 333 and record.dt == pytest.approx(3e-4)
    assert record.notes == ("decimated by 3 (block means): 1000 samples at 0.0001 s to 333 at 0.0003 s",)
    # block means: the first sample is the mean of the first three
    assert record.motor_speed[0] == pytest.approx(columns["motor_speed"][:3].mean(), rel=1e-15)
    assert record.time[0] == pytest.approx(1e-4)


def test_check_gear_ratio_refuses_another_ratio():
    record = measurements_from_arrays(**_columns(), gear_ratio=2.0)
    record.check_gear_ratio(2.0)
    with pytest.raises(ValueError, match=r"reflected with gear ratio 2 but the rig has gear_ratio = 3") as info:
        record.check_gear_ratio(3.0)
    assert "\n" not in str(info.value)


# ---- bad input: each a ValueError of one line naming the file, the column or row and the problem


def _drop(name):
    return lambda columns: {key: value for key, value in columns.items() if key != name}


def _set(name, values):
    return lambda columns: columns | {name: values(columns)}


def _repeat_time(columns):
    time = columns["time"].copy()
    time[100] = time[98]
    return columns | {"time": time}


def _uneven_time(columns):
    time = columns["time"].copy()
    time[200:] += 0.5e-3  # one step of 1.5 ms among 1 ms steps
    return columns | {"time": time}


BAD_FILES = {
    "missing column": (_drop("motor_speed"), None, "missing column motor_speed"),
    "NaN rows named, not trimmed": (
        None, {(10, "load_speed"): "nan", (57, "load_speed"): ""},
        r"load_speed has NaN or infinite values at lines 12, 59 \(2 rows\).*not trimmed"),
    "infinite value": (None, {(3, "motor_torque"): "inf"}, "motor_torque has NaN or infinite values at line 5"),
    "text cell": (None, {(7, "motor_speed"): "fast"}, r"line 9, column motor_speed: 'fast' is not a number"),
    "short row": (None, {(20, "load_angle"): "1.0,2.0"}, "line 22 has 8 fields, the header has 7"),
    "time not increasing": (_repeat_time, None, r"time is not increasing at line 102 \(0.099 s then 0.098 s\)"),
    "time not uniform": (_uneven_time, None, r"time is not uniformly sampled: step 0.0015 s before line 202"),
    "too few samples": (lambda c: {k: v[: MIN_SAMPLES - 1] for k, v in c.items()}, None,
                        f"only {MIN_SAMPLES - 1} samples"),
    "time in milliseconds": (_set("time", lambda c: 1e3 * c["time"]), None,
                             r"time steps of 1 s over a record of 399 s: time looks like milliseconds"),
    "time in microseconds": (_set("time", lambda c: 1e6 * c["time"]), None,
                             r"time steps of 1000 s over a record of 399000 s: time looks like microseconds"),
    "all-zero torque": (_set("motor_torque", lambda c: 0.0 * c["time"]), None,
                        r"motor_torque is constant \(0 N m in all 400 rows\): no excitation"),
    "all-zero speeds": (_set("motor_speed", lambda c: 0.0 * c["time"]), None,
                        r"motor_speed is constant \(0 rad/s in all 400 rows\): no excitation"),
    "constant speed": (_set("load_speed", lambda c: 0.0 * c["time"] + 3.0), None,
                       r"load_speed is constant \(3 rad/s in all 400 rows\): no excitation"),
    "speeds in rpm": (_set("motor_speed", lambda c: 0.0 * c["time"] + 1438.0 + c["motor_torque"]), None,
                      "speeds must be in rad/s"),
    "motor angle in degrees": (_set("motor_angle", lambda c: np.degrees(c["motor_angle"])), None,
                               "motor_angle does not match the integrated motor_speed: they differ by "
                               f"{(180 / np.pi - 1) * 5.0 * (1 - np.cos(2 * np.pi * 0.399)) / (2 * np.pi):.3g} rad "
                               "at line 401, 98 % of the angle's range"),
    "load angle of the wrong sign": (_set("load_angle", lambda c: -c["load_angle"]), None,
                                     r"load_angle does not match the integrated load_speed: .* 200 % of the angle"),
    "angle columns swapped with speeds": (
        lambda c: c | {"motor_angle": c["motor_speed"], "motor_speed": c["motor_angle"]}, None,
        "motor_angle does not match the integrated motor_speed"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_bad_file_gives_one_line(tmp_path, case):
    change, cells, match = BAD_FILES[case]
    columns = (change or (lambda c: c))(_columns())
    path = _write(tmp_path / "bad.csv", columns, cells)
    with pytest.raises(ValueError, match=match) as info:
        load_measurements(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)) and "np.float64" not in message


@pytest.mark.parametrize("separator", [";", "\t"])
def test_other_separator_is_named(tmp_path, separator):
    path = tmp_path / "excel.csv"
    path.write_text(_write(tmp_path / "m.csv", _columns()).read_text().replace(",", separator))
    with pytest.raises(ValueError, match=re.escape(f"excel.csv: the columns are separated by {separator!r}; "
                                                   "the format is comma-separated")):
        load_measurements(path)


def test_windows_line_ends_are_read(tmp_path):
    path = tmp_path / "crlf.csv"
    path.write_bytes(_write(tmp_path / "m.csv", _columns()).read_bytes().replace(b"\n", b"\r\n"))
    np.testing.assert_array_equal(load_measurements(path).load_angle, _columns()["load_angle"])


def test_file_that_is_not_utf8_is_named(tmp_path):
    path = _write(tmp_path / "latin.csv", _columns(), encoding="utf-16")
    with pytest.raises(ValueError, match=r"latin.csv: not a UTF-8 text file \(byte 0xff cannot be decoded\)") as info:
        load_measurements(path)
    assert "\n" not in str(info.value)


def test_header_without_rows(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("time,motor_torque,motor_speed\n")
    with pytest.raises(ValueError, match=f"empty.csv: only 0 samples; a diagnosis needs at least {MIN_SAMPLES}"):
        load_measurements(path)


def test_unreadable_file(tmp_path):
    with pytest.raises(ValueError, match=r"absent.csv: cannot read measurement file \(No such file"):
        load_measurements(tmp_path / "absent.csv")


@pytest.mark.parametrize("ratio", [0.0, -2.0, float("nan"), float("inf"), "256"])
def test_gear_ratio_must_be_positive_and_finite(tmp_path, ratio):
    path = _write(tmp_path / "m.csv", _columns())
    with pytest.raises(ValueError, match=r"m.csv: gear_ratio must be a finite number > 0, got "):
        load_measurements(path, gear_ratio=ratio)


def test_record_too_long_to_decimate_is_refused():
    columns = _columns(n=1000, dt=MAX_DECIMATED_INTERVAL)
    with pytest.raises(ValueError, match=r"<arrays>: 1000 samples over 3.996 s, more than the limit of 400 samples "
                                         r"even when decimated to every 0.004 s; cut a window of at most 1.6 s"):
        measurements_from_arrays(**columns, max_samples=400)


def test_mismatching_lengths():
    columns = _columns()
    columns["load_speed"] = columns["load_speed"][:-1]
    with pytest.raises(ValueError, match=r"load_speed must be 1-D with 400 samples like time, got shape \(399,\)"):
        measurements_from_arrays(**columns)


def test_decimation_keeps_the_side_and_ratio():
    columns = _columns(n=1000, dt=1e-4)
    record = measurements_from_arrays(**columns, gear_ratio=4.0, max_samples=500)
    assert record.gear_ratio == 4.0 and record.n_samples == 500
    assert record.motor_speed[1] == pytest.approx(columns["motor_speed"][2:4].mean() / 4.0, rel=1e-14)
    assert record.motor_torque[1] == pytest.approx(columns["motor_torque"][2:4].mean() * 4.0, rel=1e-14)


def test_extra_columns_are_not_read_even_text_and_are_named_in_a_note(tmp_path):
    columns = _columns()
    path = _write(tmp_path / "extra.csv", columns | {"note": np.full(N, "ok", dtype=object)})
    loaded = load_measurements(path)
    assert list(loaded.columns()) == list(columns)
    np.testing.assert_array_equal(loaded.motor_angle, columns["motor_angle"])
    known = "time, motor_torque, motor_speed, load_speed, load_torque, motor_angle, load_angle"
    assert loaded.notes == (f"{path}: note: not a known column; known: {known}",)


# ---- unknown columns: one notice line with the closest known name; strict=True refuses with that line;
# ---- a misspelt optional column refuses the file unless allow_unknown_columns=True


def _misspelled(tmp_path, old, new):
    """examples/diagnose_rubber.csv with one header name changed."""
    text = (EXAMPLES / "diagnose_rubber.csv").read_text()
    header, body = text.split("\n", 1)
    assert old in header.split(",")
    path = tmp_path / "misspelled.csv"
    path.write_text(",".join(new if name == old else name for name in header.split(",")) + "\n" + body)
    return path


def test_a_misspelled_column_is_named_with_the_closest_known_name(tmp_path):
    path = _misspelled(tmp_path, "load_torque", "load_trq")
    right = load_measurements(EXAMPLES / "diagnose_rubber.csv")
    loaded = load_measurements(path, allow_unknown_columns=True)
    line = f"{path}: load_trq: not a known column; did you mean load_torque?"
    assert right.notes == () and loaded.notes == (line,)
    assert loaded.load_torque is None and right.load_torque is not None  # the column is not read
    np.testing.assert_array_equal(loaded.load_speed, right.load_speed)
    with pytest.raises(ValueError) as info:
        load_measurements(path, strict=True)
    assert str(info.value) == line
    assert load_measurements(EXAMPLES / "diagnose_rubber.csv", strict=True).notes == ()


def test_several_unknown_columns_are_one_line(tmp_path):
    # case ignored in the match; a name matching nothing gets the known list; an unnamed column is numbered
    columns = _columns()
    columns = {"Load_Speed" if name == "load_speed" else name: values for name, values in columns.items()}
    path = _write(tmp_path / "odd.csv", columns | {"temperature": np.full(N, 20.0), "": np.zeros(N)})
    (note,) = load_measurements(path, allow_unknown_columns=True).notes
    assert note == (f"{path}: not known columns: Load_Speed (did you mean load_speed?), temperature, column 9 "
                    "(no name); known: time, motor_torque, motor_speed, load_speed, load_torque, motor_angle, "
                    "load_angle")
    with pytest.raises(ValueError) as info:
        load_measurements(path, strict=True)
    assert str(info.value) == note


@pytest.mark.parametrize("old, new", [("load_speed", "load_sped"), ("load_torque", "load_trq"),
                                      ("load_speed", "Load_Speed"), ("load_torque", "loadtorque")])
def test_a_misspelled_optional_column_refuses_the_file_in_one_line(tmp_path, old, new):
    path = _misspelled(tmp_path, old, new)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: column '{new}' looks like a misspelling of "
                                         rf"'{old}' \(pass --allow-unknown-columns, or allow_unknown_columns=True "
                                         r"in Python, to read such a column as an unknown one\)$"):
        load_measurements(path)


def test_allow_unknown_columns_reads_a_misspelled_column_as_an_unknown_one(tmp_path):
    path = _misspelled(tmp_path, "load_speed", "load_sped")
    loaded = load_measurements(path, allow_unknown_columns=True)
    assert loaded.notes == (f"{path}: load_sped: not a known column; did you mean load_speed?",)
    assert loaded.load_speed is None and loaded.load_torque is not None


def test_strict_refuses_a_misspelled_column_with_the_notice(tmp_path):
    path = _misspelled(tmp_path, "load_speed", "load_sped")
    for allow in (False, True):
        with pytest.raises(ValueError, match=r"load_sped: not a known column; did you mean load_speed\?$"):
            load_measurements(path, strict=True, allow_unknown_columns=allow)


def test_several_misspelled_columns_are_one_refusal(tmp_path):
    columns = {"load_sped" if name == "load_speed" else "load_trq" if name == "load_torque" else name: values
               for name, values in _columns().items()}
    path = _write(tmp_path / "two.csv", columns)
    with pytest.raises(ValueError, match=r"columns look like misspellings: 'load_sped' of 'load_speed', "
                                         r"'load_trq' of 'load_torque' \(pass --allow-unknown-columns"):
        load_measurements(path)


@pytest.mark.parametrize("name", ["temperature", "current", "motor_current", "load_tq", "note"])
def test_an_unrelated_unknown_column_is_only_noted(tmp_path, name):
    # motor_current: 0.64 like motor_torque, below the cutoff; load_tq: 0.78 like load_torque, a suggestion only
    columns = {name if key == "load_torque" else key: values for key, values in _columns().items()}
    (note,) = load_measurements(_write(tmp_path / "unrelated.csv", columns)).notes
    assert note.startswith(f"{tmp_path / 'unrelated.csv'}: {name}: not a known column; ")


def test_a_known_name_present_is_not_suggested(tmp_path):
    path = _write(tmp_path / "both.csv", _columns() | {"load_torq": np.zeros(N)})
    assert load_measurements(path).notes[0].endswith("load_torq: not a known column; known: time, motor_torque, "
                                                     "motor_speed, load_speed, load_torque, motor_angle, load_angle")


def test_a_misspelled_required_column_is_named_in_the_refusal(tmp_path):
    path = _misspelled(tmp_path, "motor_speed", "motor_sped")
    with pytest.raises(ValueError) as info:
        load_measurements(path)
    assert str(info.value) == (f"{path}: missing column motor_speed; the header must name time, motor_torque, "
                               "motor_speed (optional: load_speed, load_torque, motor_angle, load_angle); "
                               "motor_sped: not a known column; did you mean motor_speed?")


def _example_script(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["diagnose_rubber.csv", "diagnose_friction.csv"])
def test_bundled_diagnosis_records_are_what_their_script_writes(tmp_path, name):
    """The bundled records' recipe (examples/make_diagnose_records.py) reproduces them byte for byte, and each
    is long enough for the diagnosis' 20 independent estimation segments (issue 23: the bundled example warned
    "record longer")."""
    _example_script("make_diagnose_records").write(name, tmp_path)
    assert (tmp_path / name).read_bytes() == (EXAMPLES / name).read_bytes()
    assert load_measurements(EXAMPLES / name).n_samples == 4001


# ---- the real record: KUKA KR300 axis 1 (examples/kuka)


def _converter():
    spec = importlib.util.spec_from_file_location("convert_kuka", KUKA / "convert_kuka.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_kuka_csv_is_the_converted_mat_record(tmp_path):
    _converter().main([str(KUKA / "record_A.mat"), str(tmp_path / "axis1.csv")])
    assert (tmp_path / "axis1.csv").read_bytes() == (KUKA / "kuka_axis1.csv").read_bytes()


def test_kuka_record_reflected_through_the_rig_gear_ratio():
    rig = load_rig(KUKA / "kuka_rig.toml")
    record = load_measurements(KUKA / "kuka_axis1.csv", gear_ratio=rig.plant.gear_ratio)
    record.check_gear_ratio(rig.plant.gear_ratio)
    assert record.n_samples == 2501 and record.dt == pytest.approx(0.004, rel=1e-6)
    # two independent encoders: reflected through 1798/7, the motor turns with the link (a stiff gear),
    # least-squares slope 1 to 0.1 % in speed and in angle, and to 2.5 % RMS sample by sample
    speed_slope = np.dot(record.motor_speed, record.load_speed) / np.dot(record.load_speed, record.load_speed)
    angle_slope = np.polyfit(record.load_angle, record.motor_angle, 1)[0]
    assert speed_slope == pytest.approx(1.0, abs=1e-3) and angle_slope == pytest.approx(1.0, abs=1e-3)
    rms = np.sqrt(np.mean((record.motor_speed - record.load_speed) ** 2)) / np.sqrt(np.mean(record.load_speed ** 2))
    assert rms < 0.025
    # the measured twist: positive offset of the encoders' zeros, elastic part a fraction of a mrad
    twist = record.twist
    assert 0.0 < twist.min() and np.ptp(twist) < 3e-3


# ---- the command line: the same one line, exit code 2, before any computation

CLI_CASES = {
    "time in milliseconds": (_set("time", lambda c: 1e3 * c["time"]), "time looks like milliseconds"),
    "no excitation": (_set("motor_torque", lambda c: 0.0 * c["time"]), "motor_torque is constant"),
    "angle in degrees": (_set("load_angle", lambda c: np.degrees(c["load_angle"])),
                         "load_angle does not match the integrated load_speed"),
}


@pytest.mark.parametrize("case", list(CLI_CASES))
def test_diagnose_command_refuses_bad_records(tmp_path, monkeypatch, case):
    import backlash_df.cli.diagnose
    from click.testing import CliRunner

    from backlash_df.cli import main

    def never(*args, **kwargs):
        raise AssertionError("diagnosis reached although the record is bad")

    monkeypatch.setattr(backlash_df.cli.diagnose, "run_diagnosis", never)
    change, words = CLI_CASES[case]
    data = _write(tmp_path / "data.csv", change(_columns()))
    result = CliRunner().invoke(main, ["diagnose", str(data), "--rig", str(KUKA / "kuka_rig.toml")])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"backlash-df: error: {data}: ") and words in lines[0]
