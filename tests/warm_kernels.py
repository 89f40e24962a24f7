"""Fill numba's disk cache with the package's kernels, in two halves of about equal compile time.

``python tests/warm_kernels.py 0`` (or ``1``) runs one half's workloads.  The test session
(``conftest.pytest_sessionstart``) runs both halves side by side before pytest-xdist starts
its workers: on a cold cache every worker, notebook kernel and command of the suite
otherwise compiled the same kernels for itself, about 100 s of CPU in all against 36 s
for one compile of each.  A workload whose kernels are cached costs its run alone (a
fraction of a second); a kernel the workloads miss compiles where a test first calls it.
"""

import sys
from pathlib import Path

import numpy as np

import backlash_df as bd

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LAWS = ("dead-zone", "damped-dead-zone", "revised-dead-zone", "phase-plane", "rubber", "elasto-backlash", "exact")


def _rig():
    return bd.load_rig(EXAMPLES / "load_feedback.toml")


def _model(rig, law):
    return bd.make_model(law, **{**rig.plant.shaft, "rubber_thickness": 0.01})


def exact_kernel_and_verdict():
    """The exact-discretisation kernel, the phase plane law's describing function, a verdict (8 s of compiling)."""
    rig = _rig()
    bd.judge_loop(rig, bd.predict_limit_cycles(rig, "phase-plane"))


def rk4_kernel_and_laws():
    """The RK4 kernel and every law's torque and describing function (13 s)."""
    rig = _rig()
    bd.simulate(rig, _model(rig, "rubber"), t_end=0.05)
    for law in LAWS:
        model = _model(rig, law)
        if law != "exact":
            model.torque(np.array([0.04, 0.06]), np.array([0.0, 1.0]))
        bd.describing_function(model, [0.06, 0.1], 100.0)


def describing_function_variants():
    """The grid's threads and the reference quadrature of the describing functions, with and without bias (7 s)."""
    from backlash_df.describing import describing_function_grid
    from backlash_df.describing._evaluation import evaluate

    rig = _rig()
    amplitude, omega = 0.05 * np.geomspace(1.01, 50.0, 4), np.geomspace(1.0, 2e4, 3)
    for law in ("phase-plane", "rubber"):
        for bias in (0.0, 0.02):
            describing_function_grid(_model(rig, law), amplitude, omega, bias=bias)
    evaluate(_model(rig, "phase-plane"), amplitude[:, None], omega[None, :], 0.0, "harmonic-balance")


def diagnosis():
    """The diagnosis' prediction kernels, two-mass and rigid body (6 s)."""
    from backlash_df.identify.predictors import predict

    measurements = bd.load_measurements(EXAMPLES / "diagnose_friction.csv")
    rig = bd.load_rig(EXAMPLES / "diagnose_rig.toml")
    for structure in ("two_mass", "rigid_body"):
        predict(measurements, rig, structure=structure)


def coulomb_kernel():
    """The exact kernel with Coulomb friction's modes (7 s)."""
    bd.simulate(_rig().with_values(coulomb_load=200.0), t_end=0.05)


def breakaway_kernel():
    """The RK4 kernel with a breakaway friction's stick logic (10 s)."""
    bd.simulate(_rig().with_values(coulomb_load=200.0, breakaway_load=50.0, stribeck_speed=0.1), t_end=0.05)


HALVES = ((exact_kernel_and_verdict, diagnosis, describing_function_variants, coulomb_kernel),
          (rk4_kernel_and_laws, breakaway_kernel))


if __name__ == "__main__":
    for workload in HALVES[int(sys.argv[1])]:
        workload()
