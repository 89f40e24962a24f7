"""The closed-loop benchmark's own numerics (benchmarks/bench_simulation.py, compiled_rk.py).

The benchmark's verdicts rest on its compiled competitors being right and on its exact
reference being exact; both are checked here against closed forms (no timing).
"""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import bench_simulation  # noqa: E402
import compiled_rk  # noqa: E402
from backlash_df._laws import DAMPED_DEAD_ZONE  # noqa: E402

#: On one worker: the benchmark's compiled pairs and floor loops compile once, not on each.
pytestmark = pytest.mark.xdist_group("benchmark-numerics")

# a damped oscillator with a constant force, the same in every mode: dz/dt = A z + f
A = np.array([[0.0, 1.0], [-400.0, -2.0]])
F = np.array([0.0, 4.0])
Z0 = np.array([0.1, 3.0])


def oscillator(method, rtol, t_eval, half_gap=1e3, mode=0):
    """theta_d = z[0] by a compiled pair from ``mode``; with a huge gap the dead-zone law stays free."""
    out = np.full(t_eval.size, np.nan)
    params = np.array([1.0, 0.0, half_gap, 0.0])
    nfev, switches = compiled_rk.integrate(method, *compiled_rk.tableau(method), np.stack([A] * 3), np.stack([F] * 3),
                                           DAMPED_DEAD_ZONE, params, np.array([1.0, 0.0]), np.array([0.0, 1.0]), mode,
                                           Z0, t_eval[-1], rtol, t_eval, out)
    return out, switches


def exact_oscillator(t_eval):
    """z(t) = exp(M t) (z0, 1) with the force as an augmented state."""
    m_aug = np.zeros((3, 3))
    m_aug[:2, :2], m_aug[:2, 2] = A, F
    return np.array([(expm(m_aug * t) @ np.append(Z0, 1.0))[0] for t in t_eval])


@pytest.mark.parametrize("method", [compiled_rk.DP5, compiled_rk.DP8])
def test_compiled_pairs_converge_to_the_exact_flow(method):
    """Dense output on a grid: the error falls with rtol, to below 1e-9 of the amplitude at rtol 1e-12."""
    t_eval = np.linspace(0.0, 0.5, 251)
    exact = exact_oscillator(t_eval)
    errors = [np.abs(oscillator(method, rtol, t_eval)[0] - exact).max() / np.ptp(exact) for rtol in (1e-6, 1e-12)]
    assert errors[1] < 1e-9
    assert errors[0] > 1e3 * errors[1]


def test_compiled_pair_restarts_at_every_switch_without_losing_accuracy():
    """With alpha inside the motion the dead-zone law switches at every |x| = alpha crossing.

    The modes share one flow here, so the exact solution ignores the switches: the pair
    must count every crossing (from the exact flow on a 1e-5 s grid) and stay on the flow.
    """
    t_eval = np.linspace(0.0, 0.4, 401)
    out, switches = oscillator(compiled_rk.DP8, 1e-11, t_eval, half_gap=0.05, mode=2)  # x(0) > alpha
    exact = exact_oscillator(t_eval)
    m_aug = np.zeros((3, 3))
    m_aug[:2, :2], m_aug[:2, 2] = A, F
    step, q, outside = expm(m_aug * 1e-5), np.append(Z0, 1.0), []
    for _ in range(40_000):
        outside.append(abs(q[0]) > 0.05)
        q = step @ q
    assert switches == np.count_nonzero(np.diff(outside)) >= 4
    assert np.abs(out - exact).max() < 1e-8 * np.ptp(exact)


def test_expm_taylor_matches_scipy_on_the_loop_matrices():
    """The reference's long-double exponential against scipy's in double, on every mode of a bundled loop."""
    loop = bench_simulation.ClosedLoop(*bench_simulation.CASES[0])
    n = loop.z0.size
    for a_m, f_m in loop.affine.values():
        m_aug = np.zeros((n + 1, n + 1))
        m_aug[:n, :n], m_aug[:n, n] = a_m, f_m
        for h in (1e-6, 1e-3):
            ours = bench_simulation.expm_taylor(m_aug * h).astype(float)
            assert np.abs(ours - expm(m_aug * h)).max() <= 1e-14 * np.abs(ours).max()


@pytest.mark.slow
def test_exact_reference_agrees_with_the_kernel_and_refinement():
    """Two independent exact computations of the loop (the package's kernel, the benchmark's reference) agree."""
    loop = bench_simulation.ClosedLoop(*bench_simulation.CASES[0])
    reference, switches = bench_simulation.exact_reference(loop)
    refined, _ = bench_simulation.exact_reference(loop, scan=bench_simulation.SCAN / 4)
    kernel, _ = bench_simulation.kernel_run(loop, 10)
    scale = np.ptp(reference)
    assert switches > 50
    assert np.abs(refined - reference).max() < 1e-15 * scale
    assert np.abs(kernel - reference).max() < 1e-10 * scale


def test_rk4_floor_is_a_fourth_order_rk4_step():
    """The RK4 floor's four stages are a classical RK4 step: off contact (a huge gap, no torque) its theta_d
    after 0.5 s approaches the exact flow exp(A t) z0, the error falling about 16-fold per halving of dt."""
    params = np.array([1.0, 0.0, 1e3, 0.0])
    exact = (expm(A * 0.5) @ Z0)[0]
    errors = []
    for n_steps in (250, 500):
        outputs = (np.empty((n_steps + 1, 2)), np.empty(n_steps + 1), np.empty(n_steps + 1),
                   np.empty(n_steps + 1, dtype=np.int64), np.zeros(n_steps + 1, dtype=np.int64))
        bench_simulation.floor_rk4_loop(A, np.array([0.0, 1.0]), Z0, DAMPED_DEAD_ZONE, params, np.array([1.0, 0.0]),
                                        np.array([0.0, 1.0]), 0.5 / n_steps, n_steps, *outputs)
        assert np.all(outputs[1] == 0.0) and np.all(outputs[3] == 0)  # free all along: no torque
        errors.append(abs(outputs[0][-1, 0] - exact))
    assert errors[1] < 1e-7 * abs(Z0).max()
    assert 12.0 < errors[0] / errors[1] < 20.0


def test_friction_case_sticks_and_slips_and_its_accuracy_converges():
    """The friction row's premise and its accuracy column: the stick-slip cascade sticks and slips through the
    run, and its error against the half-step run falls about 16-fold a halving (RK4) to below 1e-8 of the range."""
    loop = bench_simulation.friction_loop()
    coarse, transitions, stuck = bench_simulation.friction_accuracy(loop, 2e-4)
    fine, transitions_fine, _ = bench_simulation.friction_accuracy(loop, 1e-4)
    assert transitions == transitions_fine >= 10 and 0.2 < stuck < 0.9
    assert fine < 1e-8
    assert 8.0 < coarse / fine < 32.0
