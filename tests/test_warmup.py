"""A cold cache filled on two cores (issue 21): the second process starts only when numba compiles, and
never outlives the command."""

import contextlib
import subprocess
import sys
from pathlib import Path

import pytest

import backlash_df as bd
from backlash_df.cli import warmup

RIG = Path(__file__).resolve().parents[1] / "examples" / "load_feedback.toml"


class _Process:
    """Stands in for ``subprocess.Popen``: records the command and what was done to it."""

    started = []

    def __init__(self, argv, **kwargs):
        self.argv, self.kwargs, self.calls = argv, kwargs, []
        self.started.append(self)

    def wait(self):
        self.calls.append("wait")

    def kill(self):
        self.calls.append("kill")


@pytest.fixture
def processes(monkeypatch):
    monkeypatch.setattr(_Process, "started", [])
    monkeypatch.setattr(warmup.subprocess, "Popen", _Process)
    monkeypatch.setattr(warmup, "_cores", lambda: 2)
    return _Process.started


@contextlib.contextmanager
def _compiling(announce):
    """``on_first_compile`` where numba compiles at once (a cold cache)."""
    announce()
    yield


def test_a_warm_cache_starts_no_second_process(processes):
    rig = bd.load_rig(RIG)
    warmup.warm_kernels(rig, RIG, ["phase-plane"])  # whatever this worker had not compiled, now compiled
    processes.clear()
    warmup.warm_kernels(rig, RIG, ["phase-plane", "dead-zone"])
    assert processes == []


def test_a_compile_starts_one_second_process_and_waits_for_it(processes, monkeypatch):
    monkeypatch.setattr(warmup, "on_first_compile", _compiling)
    warmup.warm_kernels(bd.load_rig(RIG), RIG, ["phase-plane", "dead-zone"])
    assert [p.argv for p in processes] == [[sys.executable, "-c", warmup.SECOND_PROCESS, str(RIG),
                                            "phase-plane", "dead-zone"]]
    assert processes[0].calls[0] == "wait"
    assert processes[0].kwargs["stdout"] == processes[0].kwargs["stderr"] == subprocess.DEVNULL


def test_one_core_starts_no_second_process(processes, monkeypatch):
    monkeypatch.setattr(warmup, "on_first_compile", _compiling)
    monkeypatch.setattr(warmup, "_cores", lambda: 1)
    warmup.warm_kernels(bd.load_rig(RIG), RIG, ["phase-plane"])
    assert processes == []


def test_an_interrupted_command_kills_the_second_process(processes, monkeypatch):
    monkeypatch.setattr(warmup, "on_first_compile", _compiling)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(warmup, "simulate_rig", interrupted)
    with pytest.raises(KeyboardInterrupt):
        warmup.warm_kernels(bd.load_rig(RIG), RIG, ["phase-plane"])
    assert processes[0].calls == ["kill"]


def test_the_second_process_runs_and_prints_nothing():
    done = subprocess.run([sys.executable, "-c", warmup.SECOND_PROCESS, str(RIG), "phase-plane"],
                          capture_output=True, text=True, timeout=300)
    assert (done.returncode, done.stdout, done.stderr) == (0, "", "")


def test_a_slow_loop_warms_up_as_a_fast_one(processes, monkeypatch):
    """A hundred of the loop's own steps, whatever its time scale (here a step of seconds)."""
    monkeypatch.setattr(warmup, "on_first_compile", _compiling)
    slow = bd.rig_from_dict({"plant": {"motor_inertia": 1e4, "load_inertia": 1e4, "stiffness": 1.0, "damping": 0.1,
                                       "half_gap": 0.05},
                             "controller": {"kp": 0.01, "ti": 100.0, "feedback": "motor"}})
    warmup.warm_kernels(slow, RIG, ["phase-plane"])
    assert [p.calls for p in processes] == [["wait", "kill"]]
