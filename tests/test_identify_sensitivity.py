"""Forward sensitivities of the diagnosis' prediction: each partial derivative against central differences
of the function it differentiates, the Jacobian of a k-step fit against differences of simulations."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from backlash_df import load_rig, rig_from_dict
from backlash_df.identify import load_measurements, synthesize
from backlash_df.friction import friction, friction_kernel, friction_partials
from backlash_df.identify._kernels import torque_partials
from backlash_df.identify.calibrate import Shooting, sensitivity_jacobian
from backlash_df.identify.predictors import TwoMassModel, nominal_values, segment_bounds
from backlash_df._laws import LAW_CODES, mode_torque, static_mode, theta_star_kernel, theta_star_partials

PLANT = {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 3.0, "half_gap": 0.02}
CONTROLLER = {"kp": 20.0, "ti": 0.3, "feedback": "motor", "speed_filter": 0.002}
KUKA = Path(__file__).resolve().parents[1] / "examples" / "kuka"
STATIC_LAWS = [name for name in LAW_CODES if name != "exact"]


def _central(f, q, j, rel=1e-6, floor=1e-3):
    """Central difference of ``f(*q)`` by its argument ``j``, step ``rel max(|q_j|, floor)``."""
    step = rel * max(abs(q[j]), floor)
    up, down = list(q), list(q)
    up[j] += step
    down[j] -= step
    return (f(*up) - f(*down)) / (2.0 * step)


@pytest.mark.parametrize("law", STATIC_LAWS)
def test_torque_partials_are_the_derivatives_of_the_held_mode_torque(law):
    """At 2,000 seeded points of each law's contact modes (rubber: its band too, beta = 0.4 alpha), the
    closed forms equal central differences of ``_laws.mode_torque`` with the mode held."""
    code = LAW_CODES[law]
    rng = np.random.default_rng(7)
    k, c, alpha, beta = 5895.0, 3.0, 0.02, 0.008
    modes = set()
    for _ in range(2000):
        x, v = rng.uniform(-0.06, 0.06), rng.uniform(-30.0, 30.0)
        m = static_mode(code, x, v, k, c, alpha, beta)
        if m == 0:
            continue
        modes.add(abs(m))
        q = [x, v, k, c, alpha, beta]
        exact = torque_partials(code, m, *q)
        for j in range(6):
            numeric = _central(lambda *a: mode_torque(code, m, *a), q, j)
            scale = abs(mode_torque(code, m, *q)) / max(abs(q[j]), 1e-3) + abs(numeric)
            assert abs(exact[j] - numeric) <= 1e-6 * scale + 1e-9, (law, m, q, j)
    assert modes == ({1, 2} if law == "rubber" else {2})


def test_theta_star_partials_are_its_derivatives():
    """theta*(v) of (19) and its derivatives by v, k, c and alpha against central differences of
    ``_laws.theta_star_kernel``, over K = 2 alpha k / (c v) from 0.05 to 40 (both branches of its root)."""
    k, c, alpha = 5895.0, 3.0, 0.02
    for big_k in np.geomspace(0.05, 39.0, 40):
        v = 2.0 * alpha * k / (c * big_k)
        q = [v, k, c, alpha]
        value, *exact = theta_star_partials(*q)
        assert value == theta_star_kernel(*q)
        for j in range(4):
            numeric = _central(theta_star_kernel, q, j, rel=1e-7)
            assert exact[j] == pytest.approx(numeric, rel=1e-6, abs=1e-9 * alpha / max(abs(q[j]), 1e-3))


def test_friction_partials_are_its_derivatives():
    """F(w) = d w + (F_c + F_b exp(-(w/w_s)^2)) tanh(w/eps) and its derivatives by w, F_c and F_b."""
    eps, w_s = 0.05, 0.4
    for w in np.linspace(-2.0, 2.0, 41):
        for viscous, coulomb, breakaway in ((0.7, 0.0, 0.0), (0.7, 3.0, 0.0), (0.0, 3.0, 5.0)):
            value, by_w, by_coulomb, by_breakaway = friction_partials(w, viscous, coulomb, breakaway, eps, w_s)
            law = lambda w_, c_, b_: viscous * w_ + (c_ + b_ * np.exp(-(w_ / w_s) ** 2)) * np.tanh(w_ / eps)
            q = [w, coulomb, breakaway]
            assert value == pytest.approx(law(*q), rel=1e-15, abs=1e-15)
            for j, exact in enumerate((by_w, by_coulomb, by_breakaway)):
                assert exact == pytest.approx(_central(law, q, j, floor=1.0), rel=1e-6, abs=1e-9)
            # the prediction kernel's shortcuts: no tanh without Coulomb nor breakaway friction, no exp without
            # breakaway friction (zero partials where they would be)
            short = friction_partials(w, viscous, coulomb, breakaway, eps, w_s, coulomb != 0.0 or breakaway != 0.0,
                                      breakaway != 0.0)
            assert short[:2] == (value, by_w)


def test_the_friction_law_compiled_and_on_arrays_is_one_law():
    """The kernels' law (``friction_kernel``, with its shortcuts) is ``friction_partials``' value to the bit, and
    numpy's evaluation of the same text on an array (``friction``) agrees to rounding: numpy's tanh and exp are
    not the C library's, which numba calls."""
    eps, w_s = 0.05, 0.4
    w = np.linspace(-2.0, 2.0, 41)
    for viscous, coulomb, breakaway in ((0.0, 0.0, 0.0), (0.7, 0.0, 0.0), (0.7, 3.0, 0.0), (0.0, 3.0, 5.0)):
        compiled = np.array([friction_kernel(x, viscous, coulomb, breakaway, eps, w_s) for x in w])
        with_partials = [friction_partials(x, viscous, coulomb, breakaway, eps, w_s, coulomb != 0.0 or breakaway != 0.0,
                                           breakaway != 0.0)[0] for x in w]
        assert np.array_equal(compiled, with_partials)
        np.testing.assert_allclose(friction(w, viscous, coulomb, breakaway, eps, w_s), compiled, rtol=1e-15,
                                   atol=1e-15)


def _synthetic(effects, encoder_counts=2**20, law="phase-plane", seed=7):
    rig = rig_from_dict({"plant": PLANT, "controller": CONTROLLER, "model": {"backlash": law}})
    record = synthesize(rig, effects, seed=seed, duration=0.8, encoder_counts=encoder_counts)
    return rig, record.measurements


def _kuka_speeds_only():
    rig = load_rig(KUKA / "kuka_rig.toml")
    record = load_measurements(KUKA / "kuka_axis1.csv", gear_ratio=rig.plant.gear_ratio)
    return rig, dataclasses.replace(record, motor_angle=None, load_angle=None)


CASES = {
    # the twist measured: offset, encoder skew, friction, delay and torque offset, speeds corrected
    "angles": (lambda: _synthetic({"coulomb_friction@load": 3.0, "actuator_delay": 0.003}),
               {"coulomb_friction_load": 2.5, "viscous_friction_load": 0.4, "actuator_delay": 0.0025,
                "torque_offset": 0.5, "encoder_skew": 1e-4}, True),
    # speeds only: the twist integrated, its drift corrected too; breakaway friction
    "speeds only": (lambda: _synthetic({"coulomb_friction@load": 3.0}, encoder_counts=None),
                    {"coulomb_friction_load": 2.5, "breakaway_friction_motor": 1.0}, True),
    # the rubber band (36)
    "rubber": (lambda: _synthetic({"rubber": 0.01}), {"rubber_thickness": 0.009}, False),
    # the dead-zone law
    "dead zone": (lambda: _synthetic({"viscous_friction@motor": 0.5}, law="dead-zone"),
                  {"viscous_friction_motor": 0.4}, False),
    # quasi-static starts: every value moves the segments' initial states (KUKA, no angle columns; a gap of
    # 1e-3 rad: the rig's 1e-5 rad moves the speeds by less than their last digit in a difference's step)
    "quasi-static": (_kuka_speeds_only, {"half_gap": 1e-3, "coulomb_friction_load": 450.0,
                                         "viscous_friction_load": 1700.0, "actuator_delay": 0.002}, False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_sensitivity_jacobian_agrees_with_differences_of_simulations(case):
    """The Jacobian of a k-step fit's residual (data rows, and with multiple shooting the corrections and
    the prior's rows) from one run of the sensitivities equals central differences of the residual, each
    column from two simulations, to 1e-6 relative (column norms; the differences' step 3e-6 of the scaled
    value: round-off and a mode switch crossed within a step both stay below that)."""
    make, effect_values, shoot = CASES[case]
    rig, measurements = make()
    model = TwoMassModel(measurements, rig)
    n = measurements.n_samples
    start, stop = int(0.05 * n), n
    starts, stops = segment_bounds(start, stop, max(int(round(0.1 / measurements.dt)), 5))
    measured = measurements.speeds[start:stop]
    weights = 1.0 / measured.std(axis=0)
    values = nominal_values(rig) | effect_values | {"theta_d0": 0.001}
    names = list(dict.fromkeys(list(PLANT) + ([] if model.quasi_static else ["theta_d0"]) + list(effect_values)))
    scales = np.array([abs(values[name]) for name in names])
    shooting = Shooting(measurements, starts, stops, 0.3, model.drifting) if shoot else None
    g = len(names)

    def values_of(x):
        return values | dict(zip(names, x[:g] * scales))

    def residual(x):  # the fit's residual, written out
        corrections = shooting.corrections(x[g:]) if shooting else None
        states, _ = model.run(values_of(x), starts, stops, corrections)
        data = ((measured - states[start:stop, 1:1 + measured.shape[1]]) * weights).ravel(order="F")
        return np.concatenate([data, shooting.penalty(x[g:])]) if shooting else data

    x = np.ones(g)
    if shooting:
        x = np.concatenate([x, np.random.default_rng(1).normal(size=shooting.size)])
    jacobian = sensitivity_jacobian(model, names, values_of, scales, (start, stop), starts, stops, weights,
                                    shooting)(x)
    jacobian = jacobian.toarray() if shooting else jacobian
    columns = list(range(g)) + ([g + b * shooting.n_segments + 2 for b in range(len(shooting.states))]
                                if shooting else [])
    for j in columns:
        step = 3e-6 * max(1.0, abs(x[j]))
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        numeric = (residual(up) - residual(down)) / (2.0 * step)
        label = names[j] if j < g else f"correction {j - g}"
        assert np.linalg.norm(jacobian[:, j] - numeric) <= 1e-6 * max(np.linalg.norm(numeric), 1e-9), label
    if shooting:
        assert np.allclose(jacobian[measured.size:, g:], 0.3 * shooting.prior_matrix.toarray())
