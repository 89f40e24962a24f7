"""The bundled EMPS record (examples/emps): the CSVs, the rig, and the conversion checked against the data set.

The raw record ``DATA_EMPS.mat`` is not bundled; the tests that read it look in the folder
named by the environment variable ``BACKLASH_DF_EMPS_DATA`` (default ``/work/shared/data/emps``)
and are skipped without it.  The others read the bundled CSVs only.
"""

import importlib.util
import math
import os
from pathlib import Path

import numpy as np
import pytest

from backlash_df import load_rig
from backlash_df.config import MAX_SHAFT_MODE
from backlash_df.identify import load_measurements
from conftest import EMPS

MAT = Path(os.environ.get("BACKLASH_DF_EMPS_DATA", "/work/shared/data/emps")) / "DATA_EMPS.mat"
needs_mat = pytest.mark.skipif(not MAT.is_file(), reason=f"the raw EMPS record {MAT} is not here "
                                                         "(set BACKLASH_DF_EMPS_DATA to its folder)")
#: The data set's gains, as its README and the .mat give them.
GTAU = 35.15065188248547   # N/V
KV_DATA = 243.45           # V/(m/s), the speed gain
KP_DATA = 160.18           # 1/s, the position gain
#: The data set's reference model (IDIM-LS on the whole record): M (kg), viscous (N s/m), Coulomb (N), offset (N).
REFERENCE_MODEL = {"mass": 95.11, "viscous": 203.5, "coulomb": 20.39, "offset": -3.16}


def _converter():
    spec = importlib.util.spec_from_file_location("convert_emps", EMPS / "convert_emps.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _table(name):
    return np.genfromtxt(EMPS / name, delimiter=",", names=True)


@needs_mat
def test_bundled_csvs_are_the_converted_mat_record(tmp_path):
    _converter().main([str(MAT), str(tmp_path / "record.csv"), str(tmp_path / "reference.csv")])
    assert (tmp_path / "record.csv").read_bytes() == (EMPS / "emps_record.csv").read_bytes()
    assert (tmp_path / "reference.csv").read_bytes() == (EMPS / "emps_reference.csv").read_bytes()


def test_record_loads_at_1_khz_with_the_rig():
    rig = load_rig(EMPS / "emps_rig.toml")
    record = load_measurements(EMPS / "emps_record.csv", gear_ratio=rig.plant.gear_ratio)
    record.check_gear_ratio(rig.plant.gear_ratio)
    assert not record.notes
    assert record.n_samples == 6225 and record.dt == pytest.approx(1e-3, rel=1e-9)
    assert np.array_equal(record.time, np.arange(6225) / 1000.0)
    assert record.load_speed is None and record.motor_angle is not None
    assert record.file_columns().keys() == {"time", "motor_torque", "motor_speed", "motor_angle"}


def test_reference_csv_is_the_position_reference_on_the_record_instants():
    reference, record = _table("emps_reference.csv"), _table("emps_record.csv")
    assert reference.dtype.names == ("time", "reference")
    assert np.array_equal(reference["time"], record["time"])
    # one round trip of the 0.2464 m stroke: out from 0.1 mm, back to 0 at the last sample
    assert reference["reference"][0] == pytest.approx(1.0782208e-4)
    assert reference["reference"][-1] == 0.0 and reference["reference"].max() == pytest.approx(0.24635661)
    # the loop follows it: the encoder stays within 2 mm of the reference (the P loops' lag and friction)
    assert np.max(np.abs(record["motor_angle"] - reference["reference"])) < 2e-3


def test_rig_is_the_data_sets_cascade():
    rig = load_rig(EMPS / "emps_rig.toml")
    plant, controller = rig.plant, rig.controller
    assert controller.structure == "cascade" and controller.feedback == "motor"
    assert controller.position_feedback == "motor" and math.isinf(controller.ti)
    assert controller.kp == pytest.approx(KV_DATA * GTAU, rel=1e-6)
    assert controller.kv == KP_DATA and controller.torque_limit == pytest.approx(10.0 * GTAU, rel=1e-6)
    assert plant.motor_inertia + plant.load_inertia == pytest.approx(REFERENCE_MODEL["mass"])
    # the shaft mode, 2000 rad/s, far above the rigid loop s^2 + (kp/M) s + kp kv / M (120 rad/s) and under the guard
    mode = math.sqrt(plant.stiffness * (1.0 / plant.motor_inertia + 1.0 / plant.load_inertia))
    loop = math.sqrt(controller.kp * controller.kv / REFERENCE_MODEL["mass"])
    assert mode == pytest.approx(2000.0, rel=1e-4) and loop == pytest.approx(120.0, rel=0.01)
    assert mode > 15.0 * loop and mode < MAX_SHAFT_MODE
    assert plant.half_gap == 2.5e-8  # a total play of one encoder count


#: ``vir`` (V) of a few rows, copied from DATA_EMPS.mat: the torque column must be gtau * vir.
VIR_ROWS = {0: 2.5386280888756465, 1000: 0.9988351630445041, 3117: -2.173295177413393, 6224: 1.616748094693429}


def test_motor_torque_is_gtau_times_the_controller_output():
    torque = _table("emps_record.csv")["motor_torque"]
    for row, vir in VIR_ROWS.items():
        assert torque[row] == pytest.approx(GTAU * vir, rel=1e-7)  # 8 significant digits written


@needs_mat
def test_motor_torque_is_gtau_times_vir_of_the_mat():
    import scipy.io

    mat = scipy.io.loadmat(MAT, squeeze_me=True)
    torque = _table("emps_record.csv")["motor_torque"]
    assert float(mat["gtau"]) == GTAU
    rows = np.arange(0, torque.size, 517)
    np.testing.assert_allclose(torque[rows], GTAU * mat["vir"][rows], rtol=1e-7, atol=1e-6)
    for row, vir in VIR_ROWS.items():
        assert mat["vir"][row] == vir


def test_speed_integrates_to_the_encoder_position_without_lag():
    record = _table("emps_record.csv")
    speed, angle = record["motor_speed"], record["motor_angle"]
    # the trapezoidal integral of the speed follows the encoder to 10 um over the 0.246 m stroke (the speed is
    # the derivative of the position low-passed at 100 Hz; the same filter run causally lags 4 ms and leaves 0.5 mm)
    integral = angle[0] + np.concatenate([[0.0], np.cumsum(0.5e-3 * (speed[1:] + speed[:-1]))])
    assert np.max(np.abs(integral - angle)) < 1e-5
    # zero phase: the speed best matches the raw central difference of the position at lag 0
    raw = np.gradient(angle, 1e-3)
    inner = slice(50, -50)
    lags = range(-5, 6)
    match = [np.dot(np.roll(speed, -lag)[inner], raw[inner]) for lag in lags]
    assert list(lags)[int(np.argmax(match))] == 0


def test_least_squares_inverse_model_gives_the_data_sets_reference_values():
    """IDIM-LS as the data set's script does it: motor_torque = M a + F_v v + F_c sign(v) + offset, by linear
    least squares, the acceleration the central difference of the speed, the first 50 samples (the filter's
    start) dropped.  The data set's values come from its whole 24.8 s record; on the bundled round trip
    every value agrees within 10 %."""
    record = _table("emps_record.csv")[50:]
    speed = record["motor_speed"]
    acceleration = np.gradient(speed, 1e-3)
    regressors = np.column_stack([acceleration, speed, np.sign(speed), np.ones_like(speed)])
    mass, viscous, coulomb, offset = np.linalg.lstsq(regressors, record["motor_torque"], rcond=None)[0]
    fitted = {"mass": mass, "viscous": viscous, "coulomb": coulomb, "offset": offset}
    for name, value in REFERENCE_MODEL.items():
        assert fitted[name] == pytest.approx(value, rel=0.10), name
