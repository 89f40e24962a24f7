"""Every solution of the torque-limited harmonic balance, saturated ones included (issue 48).

A near-rigid shaft (k = 1e4 N m/rad, alpha = 1e-4 rad) on a torque limit of 1 N m under the speed controller
8 s / (s^3 + 2 s^2 + 2 s + 1) is python-control's saturation example with a stiff shaft in it: its cycle holds the
command on its limit 81 % of the time.  The slaved saturation gain has three roots there (N_s = 1 and two saturated
ones either side of the peak of U), and the cycle lives on a sliver of the (A, w) plane that the box's scan misses.
"""

import functools
import math

import control as ct
import numpy as np
import pytest

import backlash_df as bd
from backlash_df.describing import saturation_describing_function
from backlash_df.slaving import CommandSlaving

LIMIT = 1.0


@pytest.fixture(scope="module")
def stiff_rig():
    s = ct.tf("s")
    return bd.rig_from_dict({"plant": {"motor_inertia": 0.5, "load_inertia": 0.5, "stiffness": 1e4, "damping": 20.0,
                                       "half_gap": 1e-4},
                             "controller": {"kp": 1.0, "ti": 1.0, "feedback": "motor", "torque_limit": LIMIT},
                             "model": {"backlash": "phase-plane"}}).with_controller(
        speed=8 * s / (s**3 + 2 * s**2 + 2 * s + 1))


@pytest.fixture(scope="module")
def prediction(stiff_rig):
    return bd.predict_limit_cycles(stiff_rig)


def lure_df_cycle():
    """The Lur'e loop's own DF cycle, solved here: H(jw) real and negative at w = sqrt(2) (the denominator
    1 - 2 w^2 + j w (2 - w^2)), H = -8/3, so N_sat(U) = 3/8, solved for U by bisection on the closed form."""
    omega = math.sqrt(2.0)
    h = 8.0 / ((1j * omega) ** 3 + 2 * (1j * omega) ** 2 + 2 * (1j * omega) + 1)
    assert abs(h.imag) < 1e-12
    target = -1.0 / h.real
    lo, hi = 1.0, 1e3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        r = 1.0 / mid
        n = 2.0 / math.pi * (math.asin(r) + r * math.sqrt(1.0 - r * r))
        lo, hi = (mid, hi) if n > target else (lo, mid)
    return 0.5 * (lo + hi), omega


def test_the_df_predicts_the_saturated_cycle_of_the_stiff_rig(stiff_rig, prediction):
    saturated = [c for c in prediction.cycles if c.saturated]
    assert len(saturated) == 1
    cycle = saturated[0]
    assert cycle.stable and cycle.command_amplitude > LIMIT
    u_lure, w_lure = lure_df_cycle()
    assert u_lure == pytest.approx(3.344, abs=1e-3)  # python-control's saturation example
    # the near-rigid shaft is the Lur'e loop up to its compliance and gap: 1e-4 in w, 1e-3 in U
    assert cycle.omega == pytest.approx(w_lure, rel=1e-4)
    assert cycle.command_amplitude == pytest.approx(u_lure, rel=1e-3)
    # the harmonic balance substituted back with the slaved gain, computed here from the channels
    slaving = prediction.linear
    roots = slaving.roots(cycle.amplitude, cycle.omega)
    g = [slaving(cycle.omega, cycle.amplitude, branch=k) for k in range(roots.shape[-1])]
    n = complex(bd.describing_function(stiff_rig.make_model(None), cycle.amplitude, cycle.omega))
    assert min(abs(1.0 + complex(value) * n) for value in g) < 1e-8
    # the simulated cycle: within a few % of the DF's frequency
    measured, _ = bd.simulated_limit_cycle(stiff_rig, t_end=40.0, max_t_end=160.0, kick=3.0)
    assert measured.periodic and measured.saturation > 0.5
    assert cycle.omega == pytest.approx(measured.omega, rel=0.02)
    assert cycle.amplitude == pytest.approx(measured.amplitude, rel=0.1)


def test_the_orbit_from_the_saturated_df_cycle_converges(stiff_rig, prediction):
    cycle = next(c for c in prediction.cycles if c.saturated)
    orbit = bd.periodic_orbit(stiff_rig, "phase-plane", seed=(cycle.amplitude, cycle.omega))
    lure = bd.lure_loop(ct.tf(8, [1, 2, 2, 1]), bd.Saturation(LIMIT)).periodic_orbit((3.344, 1.4142))
    assert orbit.residual < 1e-10 and orbit.stable
    assert orbit.omega == pytest.approx(lure.omega, rel=1e-4)
    assert orbit.omega == pytest.approx(cycle.omega, rel=0.01)


def test_the_branch_roots_are_fixed_points_of_the_slaving(prediction):
    slaving = prediction.linear
    amplitudes = np.array([1.1e-4, 1.5e-4, 1.834e-4, 1e-3, 1e-2])[:, None]
    omegas = np.array([1.0, 1.41421356, 1.4142135623730951, 1.5, 10.0])[None, :]
    roots = slaving.roots(amplitudes, omegas)
    assert roots.shape[-1] >= 3  # the unsaturated root and two saturated ones near w = sqrt(2)
    checked = 0
    for k in range(roots.shape[-1]):
        gain = roots[..., k]
        u = slaving.command_amplitude(amplitudes, omegas, branch=k)
        there = np.isfinite(gain)
        assert np.all(np.abs(saturation_describing_function(u[there], LIMIT) - gain[there]) < 1e-9)
        checked += there.sum()
        if k:
            assert np.all(gain[there] < roots[..., k - 1][there])  # numbered from the top
    assert checked > amplitudes.size * omegas.size  # saturated roots among them
    # the roots are every sign change of N_s - N_sat(U(N_s)), as a fine brute-force grid sees them
    a, w = 1.834e-4, 1.41421356
    grid = np.linspace(1e-6, 1.0, 2_000_001)[:-1]  # N_s < 1: the saturated roots
    excess = grid - saturation_describing_function(a * np.abs(_command_per_theta(slaving, w, grid)), LIMIT)
    changes = grid[1:][np.sign(excess[1:]) != np.sign(excess[:-1])]
    found = slaving.roots(a, w)
    saturated = found[np.isfinite(found) & (found < 1.0)]
    assert len(saturated) == len(changes) == 2
    assert saturated == pytest.approx(np.sort(changes)[::-1], abs=1e-6)


def _command_per_theta(slaving, omega, gains):
    """u / theta_d of the loop with the command through ``gains`` (the channels' linear-fractional form)."""
    from backlash_df.system import command_channels
    a, b, c, d = (complex(x) for x in command_channels(slaving.part, np.array(omega)))
    return c / (a * (1.0 - d * gains) + b * c * gains)


def test_a_rig_whose_only_solution_is_unsaturated_is_predicted_as_before(stiff_rig):
    """Without the torque limit's dips in the box (a stiffer limit: the saturated branch needs A > L mu(w), beyond
    the box), the branches add nothing: the same cycles, digit for digit, as the balance on N_s = 1."""
    rig = stiff_rig.with_values(torque_limit=1e6)
    limited = bd.predict_limit_cycles(rig)
    assert not any(c.saturated for c in limited.cycles)
    part = bd.drive_loop(rig.with_law(rig.make_model(None)), dry_friction=True).linear_part()
    slaving = CommandSlaving(part)
    model = rig.make_model(None)
    cycles, near = bd.limit_cycles.solve_harmonic_balance(
        lambda omega, amplitude: slaving(omega), functools.partial(bd.describing_function, model, bias=0.0),
        model.half_gap, limited.amplitude_range, limited.omega_range, amplitude_dependent=True)
    assert [(c.amplitude, c.omega, c.stable) for c in limited.cycles] == [(c.amplitude, c.omega, c.stable)
                                                                          for c in cycles]
    assert [(m.amplitude, m.omega) for m in limited.near_misses] == [(m.amplitude, m.omega) for m in near]
