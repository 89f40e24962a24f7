"""What the tests share: the repository's paths, the bundled rigs, the paper plant's rig-file text.

Test modules import the constants (``from conftest import EXAMPLES``: pytest puts
this folder on ``sys.path``) and take the rigs as fixtures.  Every path is
absolute, so the tests pass from any working directory.
"""

import os
import subprocess
import sys
from pathlib import Path

# One BLAS thread per process, set before numpy loads here and inherited by pytest-xdist's
# workers, the notebooks' kernels and the commands the tests run: two workers on two cores,
# each with OpenBLAS's two threads spinning between the loops' small matrix products, spent
# a third more CPU for no gain in time (a tune of motor_lag_feedback: 10.8 s of CPU on two
# threads, 7.2 s on one, 7.3 s and 7.2 s of wall time).  The command line pins one thread
# for the same reason (backlash_df/cli/common.py).
for _variable in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import pytest  # noqa: E402
import control as ct  # noqa: E402

import backlash_df as bd
from backlash_df.disturbances import standard_disturbances
from backlash_df.continuation import continue_limit_cycles
from backlash_df.identify import predict, replay
from backlash_df.loaded import load_limit
from backlash_df.reproduce import TableOne, compare_torques
from backlash_df.simulation import simulate_two_mass

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
KUKA = EXAMPLES / "kuka"
EMPS = EXAMPLES / "emps"
DOCS = ROOT / "docs"
NOTEBOOKS = ROOT / "notebooks"

#: Rig-file text the CLI and parser tests write and mutate (``text.replace(old, new)``): the
#: paper's laboratory drive (Section 4) with a half gap of 0.05 rad, as ``examples/paper_rig.toml``.
PLANT_TOML = """
[plant]
motor_inertia = 0.4
load_inertia = 5.6
stiffness = 5895.0
damping = 3.0
half_gap = 0.05
"""


def example_rig(name):
    """A bundled rig by its file stem (``"load_feedback"``)."""
    return bd.load_rig(EXAMPLES / f"{name}.toml")


@pytest.fixture(scope="session")
def load_feedback_rig():
    """``examples/load_feedback.toml``: PI on the load speed, a stable cycle of A = 0.15 rad."""
    return example_rig("load_feedback")


@pytest.fixture(scope="session")
def motor_feedback_rig():
    """``examples/motor_feedback.toml``: PI on the motor speed, no cycle."""
    return example_rig("motor_feedback")


@pytest.fixture(scope="session")
def motor_lag_rig():
    """``examples/motor_lag_feedback.toml``: motor feedback with filter and torque lag, bistable."""
    return example_rig("motor_lag_feedback")


@pytest.fixture(scope="session")
def loaded_rig():
    """``examples/loaded_feedback.toml``: load feedback under a load torque of 100 N m."""
    return example_rig("loaded_feedback")


@pytest.fixture(scope="session")
def results():
    """One instance of every public result class, from the bundled examples (small grids, short runs).

    tests/test_result_protocol.py checks that the classes cover the package's public ones.
    """
    rig = example_rig("load_feedback")
    lag = example_rig("motor_lag_feedback")
    analysis = bd.analyse_loop(lag, ["phase-plane"], exact=True)
    verdict = analysis.verdicts[0]
    prediction = verdict.prediction
    orbit = verdict.orbits[0]
    branch = continue_limit_cycles(rig, "kp", (29.0, 31.0), "phase-plane", df_values=2, df_grid=(12, 16))
    dmap = bd.design_map(rig, [20.0, 30.0], [0.3, 0.5], models=("phase-plane",), grid=(12, 16), simulate=True,
                         t_end=2.0, max_t_end=4.0)
    data = bd.load_measurements(EXAMPLES / "diagnose_rubber.csv")
    diagnosis_rig = example_rig("diagnose_rig")
    diagnosis = bd.diagnose(data, diagnosis_rig, candidates=["rubber"])
    comparison = compare_torques("one-sided", dt=1e-4, warmup_cycles=2)
    measured, _ = bd.simulated_limit_cycle(rig, "phase-plane", t_end=2.0, max_t_end=2.0, kick=5.0)
    model = rig.make_model("phase-plane")
    tuning = bd.tune(example_rig("load_feedback"), {"kp": (20.0, 40.0)})  # hunts at every gain: the least hunting
    lure = bd.lure_loop(ct.tf(8, [1, 2, 2, 1]), bd.Saturation(1.0))  # python-control's saturation example
    return {
        "LimitCyclePrediction": prediction,
        "LimitCycle": prediction.cycles[0],
        "NearMiss": bd.predict_limit_cycles(example_rig("loaded_feedback"), grid=(24, 32)).near_misses[0],
        "LoopVerdict": verdict,
        "Probe": verdict.probes[0],
        "LinearStability": verdict.contact_loop,
        "LoopAnalysis": analysis,
        "PeriodicOrbit": orbit,
        "Branch": branch,
        "BranchPoint": branch.points[0],
        "SpecialPoint": bd.continuation.SpecialPoint("fold", 30.0, 0.1, "a turning point"),
        "DesignMap": dmap,
        "SimulationResult": simulate_two_mass(bd.reproduce.PAPER_PLANT, "phase-plane", 0.05, 1e-4, motor_torque=1.0),
        "MeasuredCycle": measured,
        "DescribingFunctionResult": bd.describing_function_grid(model, [0.06, 0.1], [10.0, 100.0]),
        "ValidityMap": bd.phase_plane_validity(5895.0, 3.0, 0.05, [0.5, 2.0], [0.01, 0.1]),
        "TorqueComparison": comparison,
        "TableOne": TableOne((comparison,)),
        "Measurements": data,
        "SimulatedRecord": bd.simulate(diagnosis_rig, inputs=EXAMPLES / "simulate_inputs.csv",
                                       compare=EXAMPLES / "simulate_record.csv"),
        "Diagnosis": diagnosis,
        "Cause": diagnosis.causes[0],
        "Stage": diagnosis.rigid_body,
        "ShaftResolution": diagnosis.shaft,
        "CandidateResult": diagnosis.extended,
        "Calibration": diagnosis.extended.calibration,
        "FitParameter": next(iter(diagnosis.extended.calibration.parameters.values())),
        "Replay": predict(data, diagnosis_rig),
        "FreeRunReplay": replay(data, diagnosis_rig),
        "ResidualAnalysis": diagnosis.residuals_extended,
        "LoadLimit": load_limit(rig, "phase-plane", rtol=0.2, grid=(12, 16)),
        "Tuning": tuning,
        "Certificate": tuning.best,
        "Candidate": tuning.screen[0],
        "Disturbance": standard_disturbances(rig)[0],
        "Rest": verdict.rests[0],
        "Reason": diagnosis.candidates[1].reason_record,
        "Finding": diagnosis.candidates[1].reason_record.findings[0],
        "LureOrbit": lure.periodic_orbit((3.344, 1.4142)),
        "LureSimulation": lure.simulate(10.0),
        "LureVerdict": (lure_verdict := bd.judge_lure_loop(bd.lure_loop(ct.tf(1, [1, 3, 2, 0]), bd.Relay(1.0, 0.2)))),
        "LureProbe": lure_verdict.probes[0],
        "LureBranch": bd.continue_lure_orbit(lure, "limit", [1.0, 1.2], (3.344, 1.4142)),
        "LureDesignMap": bd.lure_design_map(lure, ("gain", [0.3, 1.0]), ("limit", [1.0])),
        **_caveats(),
    }


def _caveats():
    """One warning record of each concern (:mod:`backlash_df.identify.reasons`), by its class name."""
    from backlash_df.identify import reasons as r

    records = [r.RecordNote(text="a note"), r.WeakBaseline(speed="motor_speed", fit=12.5, minimum=30.0),
               r.Unexplained(speed="load_speed", fit=50.2, horizon=0.4, minimum=75.0),
               r.FewSegments(segments=6, samples=100, minimum=20),
               r.UnphysicalInterval(name="damping", value=1.5, ci95=(-0.5, 3.5), unit="N m s/rad"),
               r.OnBound(structure="rigid_body", values=(r.BoundValue("inertia", 1989.0, "kg m^2", 1071.0, 1989.0),),
                         plant=False),
               r.InitialSpeed(name="motor_speed0", fitted=2.5, measured=1.25),
               r.Absorbed(kept="coulomb_friction@load", dropped="viscous_friction@load", kept_value=465.0,
                          kept_ci95=(440.0, 490.0), kept_unit="N m", dropped_value=12.5, dropped_ci95=(10.0, 15.0),
                          dropped_unit="N m s/rad", kept_alone=869.0),
               r.SideUndetermined(effect="coulomb_friction", side="motor", other_side="load", gain=0.96,
                                  other_gain=0.961),
               r.Disagreement(effect="coulomb_friction", two_mass={"value": 2.0, "ci95": [1.5, 2.5], "unit": "N m"},
                              rigid_body={"value": 4.5, "ci95": [4.25, 4.75], "unit": "N m"})]
    return {type(record).__name__: record for record in records}


#: Keys of ``results`` whose class draws a picture (``plot(ax=None)``).
PLOTS = ["LimitCyclePrediction", "LoopVerdict", "LoopAnalysis", "PeriodicOrbit", "Branch", "DesignMap",
         "SimulationResult", "DescribingFunctionResult", "ValidityMap", "TorqueComparison", "TableOne", "Measurements",
         "SimulatedRecord", "Diagnosis", "Replay", "FreeRunReplay", "ResidualAnalysis", "Tuning", "LureOrbit",
         "LureSimulation", "LureVerdict", "LureBranch", "LureDesignMap"]

#: Keys of ``results`` whose class writes a report (``report_html(title="", rig_text="")``).
REPORTS = ["LimitCyclePrediction", "LoopAnalysis", "Branch", "DesignMap", "Diagnosis", "Tuning"]


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    """With pytest-xdist workers: the kernels compiled into numba's cache once, in two processes, before the
    workers start (tests/warm_kernels.py); on a warm cache this costs the workloads' runs, a few seconds."""
    config = session.config
    workers = config.getoption("numprocesses", None)  # pytest-xdist's -n, resolved to a count by now
    if hasattr(config, "workerinput") or not (isinstance(workers, int) and workers > 1):
        return
    warm = Path(__file__).with_name("warm_kernels.py")
    # the package the tests import (the checkout's, first on sys.path), not another installed one
    path = os.pathsep.join([str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
    halves = [subprocess.Popen([sys.executable, str(warm), str(half)], cwd=ROOT, env={**os.environ, "PYTHONPATH": path},
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for half in range(2)]
    for number, half in enumerate(halves):
        _, error = half.communicate()
        if half.returncode:  # the tests that call the same code fail with the message; the suite runs on, slower
            last = (error.strip().splitlines() or ["no message"])[-1]
            config.get_terminal_writer().line(f"tests/warm_kernels.py {number} failed ({last}): the kernels compile "
                                              "in each worker instead", yellow=True)


def pytest_collection_modifyitems(items):
    """The notebooks, then the tests that share a long computation on one worker (an xdist group: a tuning, the
    built documentation), then the rest: the longest work handed out first, so that both workers finish together
    (the groups of tests/test_tuning.py, collected late, ran last and alone)."""
    items.sort(key=lambda item: 0 if item.nodeid.startswith("notebooks/") else
               1 if item.get_closest_marker("xdist_group") else 2)
