"""Design maps: cells independent of the executor, verdicts checked by substitution and simulation."""

import json
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import backlash_df as bd
from backlash_df.loops import drive_loop
from backlash_df.sweeps import VERDICTS, design_map, rig_with
from conftest import EXAMPLES

RIG = bd.load_rig(EXAMPLES / "load_feedback.toml")
KP, TI = [10.0, 30.0], [0.1, 0.5]
SMALL = dict(models=("phase-plane",), grid=(20, 30), t_end=3.0, max_t_end=6.0)


@pytest.fixture(scope="module")
def serial_map():
    return design_map(RIG, KP, TI, **SMALL)


def _same(first, second):
    for name in first.models:
        for field in ("df_verdict", "sim_verdict"):
            assert np.array_equal(getattr(first, field)[name], getattr(second, field)[name])
        for field in ("df_amplitude", "df_bias", "sim_amplitude", "sim_bias"):
            assert np.array_equal(getattr(first, field)[name], getattr(second, field)[name], equal_nan=True)


def test_process_pool_gives_the_serial_map(serial_map):
    with ProcessPoolExecutor(2) as pool:
        _same(serial_map, design_map(RIG, KP, TI, executor=pool, **SMALL))


def test_dask_local_cluster_gives_the_serial_map(serial_map):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            _same(serial_map, design_map(RIG, KP, TI, executor=client.get_executor(), **SMALL))


def test_predicted_amplitudes_solve_the_harmonic_balance(serial_map):
    model = RIG.make_model("phase-plane")
    amplitude = serial_map.df_amplitude["phase-plane"]
    assert np.isfinite(amplitude).any()
    for i, kp in enumerate(KP):
        for j, ti in enumerate(TI):
            if not np.isfinite(amplitude[i, j]):
                continue
            loop = drive_loop(rig_with(rig_with(RIG, "kp", kp), "ti", ti))
            # the cycle's frequency is where -1/N(A, w) meets G: |1 + G N| = 0 at some w near the shaft mode
            omega = np.geomspace(20.0, 400.0, 20001)
            distance = np.abs(1 + loop.frequency_response(omega) * bd.describing_function(model, amplitude[i, j], omega))
            assert distance.min() < 1e-3


def test_verdicts_match_simulation_on_the_documented_tuning(serial_map):
    # kp = 30, ti = 0.5 is examples/load_feedback.toml: both the DF and simulation show the cycle
    assert serial_map.df_verdict["phase-plane"][1, 1] == "limit cycle"
    assert serial_map.sim_verdict["phase-plane"][1, 1] == "limit cycle"
    assert abs(serial_map.sim_amplitude["phase-plane"][1, 1] / 0.1505 - 1) < 0.01
    assert set(np.unique(serial_map.df_verdict["phase-plane"])) <= set(VERDICTS)


def test_unstable_contact_loop_grows_in_simulation():
    # ti far too short: the loop with the shaft in contact is unstable, the DF caps nothing
    rig = rig_with(RIG, "ti", 0.002)
    assert np.any(drive_loop(rig).linear_poles(5895.0, 3.0).real > 0)
    dmap = design_map(rig, [300.0], [0.002], models=("damped-dead-zone",), grid=(20, 30), t_end=1.0, max_t_end=2.0)
    assert dmap.df_verdict["damped-dead-zone"][0, 0] == "unstable"
    result = bd.simulate(rig, "damped-dead-zone", t_end=1.0, kick=1.0)
    assert np.abs(result.theta_d[-100:]).max() > 10 * np.abs(result.theta_d[:100]).max()


def test_json_and_plot(serial_map):
    data = json.loads(json.dumps(serial_map.to_dict()))
    assert data["x"] == {"parameter": "kp", "values": KP}
    assert data["models"][0]["df"]["verdict"][1][1] == "limit cycle"
    drawn = serial_map.plot()
    assert drawn.axes.shape == (1, 2)
    import matplotlib.pyplot as plt

    plt.close(drawn.figure)


def test_rig_with_names_the_bad_parameter():
    assert rig_with(RIG, "load.torque", 50.0).load.torque == 50.0
    assert rig_with(RIG, "stiffness", 1000.0).plant.stiffness == 1000.0
    with pytest.raises(ValueError, match="parameter 'gain': not a numeric value.*controller.kp"):
        rig_with(RIG, "gain", 1.0)
    with pytest.raises(ValueError, match=r"\[controller\] kp must be > 0"):
        rig_with(RIG, "kp", -1.0)
    with pytest.raises(ValueError, match="parameter 'feedback'"):
        rig_with(RIG, "feedback", 1.0)
