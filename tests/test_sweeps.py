"""Design maps: cells independent of the executor, verdicts checked by substitution and simulation, no cell lost."""

import concurrent.futures
import contextlib
import functools
import json
import math
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
import backlash_df.cli.sweeps
import backlash_df.sweeps
from backlash_df.checkpoint import Checkpoint
from backlash_df.cli import main
from backlash_df.loops import drive_loop
from backlash_df.render.sweeps import VERDICT_CODES
from backlash_df.sweeps import design_map
from backlash_df.verdict import VERDICTS
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


def test_predicted_amplitudes_solve_the_harmonic_balance(serial_map):
    model = RIG.make_model("phase-plane")
    amplitude = serial_map.df_amplitude["phase-plane"]
    assert np.isfinite(amplitude).any()
    for i, kp in enumerate(KP):
        for j, ti in enumerate(TI):
            if not np.isfinite(amplitude[i, j]):
                continue
            loop = drive_loop(RIG.with_values(kp=kp, ti=ti))
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
    rig = RIG.with_values(ti=0.002)
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


def test_with_values_names_the_bad_parameter():
    assert RIG.with_values(**{"load.torque": 50.0}).load.torque == 50.0
    assert RIG.with_values(stiffness=1000.0).plant.stiffness == 1000.0
    both = RIG.with_values(kp=45.0, **{"controller.ti": 0.3, "load.torque": -20.0})
    assert (both.controller.kp, both.controller.ti, both.load.torque) == (45.0, 0.3, -20.0)
    assert both.with_values(kp=RIG.controller.kp, ti=RIG.controller.ti, torque=RIG.load.torque).to_dict() == RIG.to_dict()
    assert RIG.with_values() is RIG
    with pytest.raises(ValueError, match="parameter 'gain': not a numeric value.*controller.kp"):
        RIG.with_values(gain=1.0)
    with pytest.raises(ValueError, match=r"\[controller\] kp must be > 0"):
        RIG.with_values(ti=0.3, kp=-1.0)
    with pytest.raises(ValueError, match="parameter 'feedback'"):
        RIG.with_values(feedback=1.0)
    with pytest.raises(ValueError, match="'kp' and 'controller.kp' name the same value, controller.kp"):
        RIG.with_values(kp=40.0, **{"controller.kp": 50.0})


def test_with_values_keeps_a_users_controller():
    ct = pytest.importorskip("control")
    user = RIG.with_controller(speed=ct.tf([30.0], [1.0]))
    assert user.with_values(stiffness=6000.0).controller.speed_controller is user.controller.speed_controller


# --------------------------------------------------------------------------- checkpoints: no finished cell lost

DF_ONLY = dict(models=("phase-plane",), grid=(20, 30), simulate=False)
KP3, TI2 = [10.0, 30.0, 45.0], [0.1, 0.5]


def _json(result):
    return json.dumps(result.to_dict())


@pytest.fixture(scope="module")
def df_map():
    return design_map(RIG, KP3, TI2, **DF_ONLY)


class _Interrupt:
    """A stand-in for ``sweeps.predict_limit_cycles`` that counts its calls and raises Ctrl-C at call ``at``."""

    def __init__(self, at=None):
        self.calls, self.at = 0, at

    def __call__(self, *args, **kwargs):
        self.calls += 1
        if self.calls == self.at:
            raise KeyboardInterrupt
        return bd.predict_limit_cycles(*args, **kwargs)


def test_interrupted_map_resumes_to_the_same_map_and_recomputes_no_finished_cell(df_map, tmp_path, monkeypatch):
    path = tmp_path / "map.checkpoint"
    interrupt = _Interrupt(at=4)  # one law, so one prediction per cell: Ctrl-C in the fourth cell
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", interrupt)
    with pytest.raises(KeyboardInterrupt):
        design_map(RIG, KP3, TI2, checkpoint=path, **DF_ONLY)
    assert len(path.read_text().splitlines()) == 1 + 3  # the header and the three cells done
    counting = _Interrupt()
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", counting)
    resumed = design_map(RIG, KP3, TI2, checkpoint=Checkpoint(path, resume=True), **DF_ONLY)
    assert counting.calls == len(KP3) * len(TI2) - 3
    assert _json(resumed) == _json(df_map)
    assert len(path.read_text().splitlines()) == 1 + 6


def test_a_line_cut_by_a_killed_run_is_dropped_and_its_cell_computed_again(df_map, tmp_path, monkeypatch):
    path = tmp_path / "map.checkpoint"
    design_map(RIG, KP3[:2], TI2, checkpoint=path, **DF_ONLY)  # the first four cells of the map, in order
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:-1]) + lines[-1][: len(lines[-1]) // 2])  # killed while writing cell 4
    counting = _Interrupt()
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", counting)
    resumed = design_map(RIG, KP3, TI2, checkpoint=Checkpoint(path, resume=True), **DF_ONLY)
    assert counting.calls == 6 - 3
    assert _json(resumed) == _json(df_map)
    assert all(json.loads(line) for line in path.read_text().splitlines())


def test_a_checkpoint_of_another_run_is_refused_in_one_line(tmp_path):
    path = tmp_path / "map.checkpoint"
    design_map(RIG, KP3[:1], TI2, checkpoint=path, **DF_ONLY)
    other = RIG.with_values(stiffness=6000.0)
    with pytest.raises(ValueError, match=r"belongs to another run \(it differs in rig\.plant\.stiffness\)"):
        design_map(other, KP3[:1], TI2, checkpoint=Checkpoint(path, resume=True), **DF_ONLY)
    with pytest.raises(ValueError, match=r"differs in grid, t_end"):
        design_map(RIG, KP3[:1], TI2, checkpoint=Checkpoint(path, resume=True), models=("phase-plane",),
                   grid=(20, 31), t_end=3.0, simulate=False)
    with pytest.raises(ValueError, match="exists .*resume from it"):
        design_map(RIG, KP3[:1], TI2, checkpoint=path, **DF_ONLY)
    with pytest.raises(ValueError, match="no such file to resume from"):
        Checkpoint(tmp_path / "none.checkpoint", resume=True)
    (tmp_path / "notes.txt").write_text("kp = 30\n")
    with pytest.raises(ValueError, match="not a backlash-df checkpoint"):
        design_map(RIG, KP3[:1], TI2, checkpoint=Checkpoint(tmp_path / "notes.txt", resume=True), **DF_ONLY)


def test_a_deferred_checkpoint_is_written_only_when_the_run_stops(tmp_path, monkeypatch):
    quiet = tmp_path / "quiet.checkpoint"
    design_map(RIG, KP3[:1], TI2, checkpoint=Checkpoint(quiet, after=math.inf), **DF_ONLY)
    assert not quiet.exists()  # a run that ends before `after` seconds leaves no file
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", _Interrupt(at=3))
    with pytest.raises(KeyboardInterrupt):
        design_map(RIG, KP3, TI2, checkpoint=Checkpoint(quiet, after=math.inf), **DF_ONLY)
    assert len(quiet.read_text().splitlines()) == 1 + 2  # Ctrl-C writes the cells done


def _die_once(marker, function, item):
    """``function(item)``, except that the first call of all (the one that creates ``marker``) kills its process."""
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return function(item)
    os.kill(os.getpid(), signal.SIGKILL)


class _KillingExecutor(concurrent.futures.Executor):
    """An executor whose first cell kills the worker process running it, mid-cell."""

    def __init__(self, inner, marker):
        self.inner, self.marker = inner, str(marker)

    def submit(self, function, *args, **kwargs):
        return self.inner.submit(functools.partial(_die_once, self.marker, function), *args, **kwargs)


def test_dask_local_cluster_with_a_worker_killed_mid_run_gives_the_serial_map(serial_map, tmp_path):
    distributed = pytest.importorskip("distributed")
    marker = tmp_path / "killed"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            before = set(client.run(os.getpid).values())
            dmap = design_map(RIG, KP, TI, executor=_KillingExecutor(client.get_executor(), marker),
                              checkpoint=tmp_path / "map.checkpoint", **SMALL)
            client.wait_for_workers(2)
            after = set(client.run(os.getpid).values())
    assert marker.exists() and before - after  # a worker process died in a cell (its nanny started another)
    assert _json(dmap) == _json(serial_map)
    kept = [json.loads(line)["key"] for line in (tmp_path / "map.checkpoint").read_text().splitlines()[1:]]
    assert sorted(kept) == sorted([kp, ti] for kp in KP for ti in TI)  # every cell kept once


def test_process_pool_map_with_a_checkpoint_is_the_serial_map(serial_map, tmp_path):
    with ProcessPoolExecutor(2) as pool:
        dmap = design_map(RIG, KP, TI, executor=pool, checkpoint=tmp_path / "map.checkpoint", **SMALL)
    assert _json(dmap) == _json(serial_map)
    with ProcessPoolExecutor(2) as pool:  # everything kept: nothing is submitted
        again = design_map(RIG, KP, TI, executor=_KillingExecutor(pool, tmp_path / "unused"),
                           checkpoint=Checkpoint(tmp_path / "map.checkpoint", resume=True), **SMALL)
    assert not (tmp_path / "unused").exists()
    assert _json(again) == _json(serial_map)


# --------------------------------------------------------------------------- the command line

CLI_GRID = ["--x", "kp", "5:60:4", "--y", "ti", "0.1:2:4:log", "--model", "phase-plane", "--no-simulate"]


def _cells(path):
    """Finished cells in a checkpoint file (complete lines after the header)."""
    return max(path.read_text().count("\n") - 1, 0) if path.exists() else 0


def _run_until(args, path, cells, work, stop):
    """Run ``backlash-df ARGS`` in ``work``; send ``stop`` once ``path`` holds ``cells`` cells; (exit code, stderr)."""
    process = subprocess.Popen([sys.executable, "-c", "from backlash_df.cli import main; main()", *args], cwd=work,
                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "MPLBACKEND": "Agg"})
    while _cells(path) < cells and process.poll() is None:
        time.sleep(0.02)
    assert process.poll() is None, "the map ended before it could be stopped"
    process.send_signal(stop)
    _, err = process.communicate(timeout=120)
    return process.returncode, err


@pytest.fixture(scope="module")
def cli_map_json(tmp_path_factory):
    work = tmp_path_factory.mktemp("reference")
    result = CliRunner().invoke(main, ["map", str(EXAMPLES / "load_feedback.toml"), *CLI_GRID, "--json",
                                       str(work / "m.json")])
    assert result.exit_code == 0, result.output
    return (work / "m.json").read_text()


def test_map_killed_then_interrupted_then_resumed_writes_the_uninterrupted_map(cli_map_json, tmp_path):
    args = ["map", str(EXAMPLES / "load_feedback.toml"), *CLI_GRID, "--json", "m.json", "--checkpoint", "m.ckpt"]
    code, _ = _run_until(args, tmp_path / "m.ckpt", 3, tmp_path, signal.SIGKILL)
    assert code == -signal.SIGKILL and not (tmp_path / "m.json").exists()
    killed = _cells(tmp_path / "m.ckpt")
    code, err = _run_until([*args, "--resume", "--workers", "2"], tmp_path / "m.ckpt", killed + 3, tmp_path,
                           signal.SIGINT)
    kept = _cells(tmp_path / "m.ckpt")
    assert code == 1 and err.strip().splitlines()[-1] == (
        f"backlash-df: error: interrupted; {kept} of 16 cells kept in m.ckpt: run the same command with --resume "
        "to continue")
    with contextlib.chdir(tmp_path):
        result = CliRunner().invoke(main, [*args, "--resume"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "m.json").read_text() == cli_map_json
    assert not (tmp_path / "m.ckpt").exists()  # the outputs are written: nothing left to resume


def test_map_prints_the_verdict_grid_labelled_with_the_values(tmp_path):
    # (kp, ti) = (30, 0.5) is examples/load_feedback.toml's cycle, (300, 0.002) an unstable contact loop
    # (test_verdicts_match_simulation_on_the_documented_tuning, test_unstable_contact_loop_grows_in_simulation)
    result = CliRunner().invoke(main, ["map", str(EXAMPLES / "load_feedback.toml"), "--x", "kp", "30,300", "--y",
                                       "ti", "0.002,0.5", "--model", "damped-dead-zone", "--no-simulate", "--json",
                                       str(tmp_path / "m.json")])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    start = lines.index("damped-dead-zone, DF verdicts:")
    header, *rows = [line.split() for line in lines[start + 1:start + 4]]
    assert header == ["kp", "\\", "ti", "0.002", "0.5"]
    grid = {row[0]: dict(zip(header[3:], row[1:])) for row in rows}
    assert grid["30"]["0.5"] == "C" and grid["300"]["0.002"] == "U"
    verdicts = json.loads((tmp_path / "m.json").read_text())["models"][0]["df"]["verdict"]
    assert [[grid[kp][ti] for ti in ("0.002", "0.5")] for kp in ("30", "300")] == [
        [VERDICT_CODES[v] for v in row] for row in verdicts]
    assert ". no oscillation  C limit cycle  B bistable  U unstable  ? undetermined" in lines


def _never(*args, **kwargs):
    raise AssertionError("computation reached although the input is bad")


@pytest.mark.parametrize("args, words", [
    (["--resume"], "checkpoint backlash-df-map.checkpoint: no such file to resume from"),
    (["--checkpoint", "nodir/m.ckpt"], "--checkpoint nodir/m.ckpt: directory nodir does not exist"),
    (["--checkpoint", "old.ckpt"], "checkpoint old.ckpt exists (kept by an interrupted run): resume from it"),
    (["--json", "m.json"], "checkpoint m.json.checkpoint exists (kept by an interrupted run)"),
])
def test_map_refuses_a_checkpoint_it_cannot_use_before_computing(tmp_path, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(backlash_df.cli.sweeps, "design_map", _never)
    (tmp_path / "old.ckpt").write_text("")
    (tmp_path / "m.json.checkpoint").write_text("")
    result = CliRunner().invoke(main, ["map", str(EXAMPLES / "load_feedback.toml"), *args])
    assert result.exit_code == 2
    (line,) = result.output.strip().splitlines()
    assert line.startswith(f"backlash-df: error: {words}")


def test_ctrl_c_keeps_the_cells_done_beside_the_output_and_resume_finishes_the_map(tmp_path, monkeypatch):
    reference = design_map(RIG, KP3, TI2, models=("phase-plane",), simulate=False)  # the command's DF grid
    monkeypatch.chdir(tmp_path)
    args = ["map", str(EXAMPLES / "load_feedback.toml"), "--x", "kp", "10,30,45", "--y", "ti", "0.1,0.5", "--model",
            "phase-plane", "--no-simulate", "--json", "m.json"]
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", _Interrupt(at=3))
    result = CliRunner().invoke(main, args)
    # a run shorter than a minute holds its cells in memory; Ctrl-C writes them beside the first output
    assert result.exit_code == 1 and result.output.strip().splitlines() == [
        "backlash-df: error: interrupted; 2 of 6 cells kept in m.json.checkpoint: run the same command with "
        "--resume to continue"]
    assert _cells(tmp_path / "m.json.checkpoint") == 2 and not (tmp_path / "m.json").exists()
    counting = _Interrupt()
    monkeypatch.setattr(backlash_df.sweeps, "predict_limit_cycles", counting)
    result = CliRunner().invoke(main, [*args, "--resume"])
    assert result.exit_code == 0, result.output
    assert counting.calls == 4
    assert json.loads((tmp_path / "m.json").read_text())["models"] == json.loads(_json(reference))["models"]
    assert not (tmp_path / "m.json.checkpoint").exists()


def test_a_map_explores_a_boxed_value_beyond_its_box_and_names_its_cells_plainly(tmp_path):
    """The ``[uncertainty]`` box of a swept value does not bound the grid (the map explores it); a box of another value
    is kept; a cell's rig names the values as numbers (``0.5``, not numpy's repr)."""
    rig = bd.load_rig(EXAMPLES / "load_feedback.toml")
    boxed = bd.rig_from_dict({**rig.to_dict(), "uncertainty": {"stiffness": [5800.0, 6000.0], "load_inertia": [5.0, 6.0]}})
    plain = design_map(rig, [3000.0, 5895.0], [30.0], x="stiffness", y="kp", simulate=False)
    swept = design_map(boxed, [3000.0, 5895.0], [30.0], x="stiffness", y="kp", simulate=False)
    assert swept.to_dict() == plain.to_dict()
    assert dict(boxed.without_uncertainty("plant.stiffness").uncertainty) == {"load_inertia": (5.0, 6.0)}
    assert boxed.without_uncertainty("ti") is boxed
    with pytest.raises(ValueError, match="parameter 'stifness': not a numeric value"):
        boxed.without_uncertainty("stifness")
    assert "controller.kp = 0.5" in rig.with_values(kp=np.float64(0.5)).source
    rig_file = tmp_path / "boxed.toml"
    rig_file.write_text(boxed.to_toml())
    result = CliRunner().invoke(main, ["map", str(rig_file), "--x", "stiffness", "3000,5895", "--y", "kp", "30",
                                       "--no-simulate"])
    assert result.exit_code == 0, result.output
