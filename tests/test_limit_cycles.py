"""Harmonic balance G(jw) N(A, w) = -1: roots, Loeb stability, near misses, simulation."""

import math

import numpy as np
import pytest
from conftest import EXAMPLES
from scipy import optimize

from backlash_df import load_rig, predict_limit_cycles, simulated_limit_cycle
from backlash_df.limit_cycles import solve_harmonic_balance
from backlash_df.loops import drive_loop


def dead_zone_df(k, alpha):
    """Classical dead zone: N = k (1 - (2/pi)(asin(a/A) + (a/A) sqrt(1 - (a/A)^2))), A > a."""

    def n_of(amplitude, omega):
        r = np.minimum(alpha / np.asarray(amplitude, dtype=float), 1.0)
        return k * (1 - 2 / np.pi * (np.arcsin(r) + r * np.sqrt(1 - r * r))) + 0j * np.asarray(omega)

    return n_of


def saturation_df(k, alpha):
    """Saturation at |x| = alpha: N = k - N_dead_zone (closed form)."""
    dz = dead_zone_df(k, alpha)
    return lambda amplitude, omega: k - dz(amplitude, omega)


def third_order(gain):
    """G = gain / (s (s + 1)^2): crosses the negative real axis at w = 1, G = -gain / 2."""
    return lambda omega: gain / (1j * omega * (1j * omega + 1) ** 2)


@pytest.mark.parametrize("gain", [3.0, 8.0, 40.0])
def test_dead_zone_root_is_the_classical_one(gain):
    k, alpha = 1.0, 0.2
    n_of = dead_zone_df(k, alpha)
    cycles, _ = solve_harmonic_balance(third_order(gain), n_of, alpha, (alpha * 1.0001, 100.0), (0.05, 20.0))
    assert len(cycles) == 1
    cycle = cycles[0]
    assert cycle.omega == pytest.approx(1.0, rel=1e-9)  # phase -180 deg at w = 1
    # N(A) = 2 / gain at the root; substitute back
    assert abs(1 + third_order(gain)(cycle.omega) * n_of(cycle.amplitude, cycle.omega)) < 1e-9
    assert n_of(cycle.amplitude, 1.0).real == pytest.approx(2.0 / gain, rel=1e-8)
    # dead zone: -1/N runs from -inf towards -1/k into the encircled region: unstable
    assert not cycle.stable


def test_saturation_cycle_is_stable():
    n_of = saturation_df(1.0, 0.2)
    cycles, _ = solve_harmonic_balance(third_order(8.0), n_of, 0.2, (0.2001, 100.0), (0.05, 20.0))
    assert len(cycles) == 1 and cycles[0].stable
    assert cycles[0].omega == pytest.approx(1.0, rel=1e-9)


def test_two_crossings_give_two_roots():
    # conditionally stable loop: G = 100 (s + 1)^2 / (s^3 (s/20 + 1)^2) has phase -180 deg where
    # 2 atan(w) - 2 atan(w/20) = 90 deg (w = 1.118 and 17.88), with |G| = 160 and 3.1 > 1/k there,
    # so the dead zone locus (-inf, -1/k) meets it at both crossings.
    def g(omega):
        s = 1j * omega
        return 100.0 * (s + 1) ** 2 / (s**3 * (s / 20 + 1) ** 2)

    n_of = dead_zone_df(1.0, 0.1)
    cycles, _ = solve_harmonic_balance(g, n_of, 0.1, (0.10001, 1000.0), (0.01, 100.0), grid=(60, 100))
    assert len(cycles) == 2
    assert sorted(c.omega for c in cycles) == pytest.approx([1.1184726928798947, 17.881527307120102], rel=1e-8)
    for cycle in cycles:
        assert abs(1 + g(cycle.omega) * n_of(cycle.amplitude, cycle.omega)) < 1e-9
        assert abs(np.angle(g(cycle.omega))) == pytest.approx(math.pi, abs=1e-7)
    assert {c.stable for c in cycles} == {True, False}


def test_near_miss_of_a_locus_that_turns_back():
    # N(A) = N_dz(A) exp(-(A/alpha - 1)/5) is real with a maximum N_max at A*: -1/N comes
    # closest to the origin at -1/N_max and turns back.  G = gain / (s (s+1)^2) crosses the
    # real axis at -gain/2 (w = 1); with gain N_max / 2 = 0.97 the loci miss by 3 %.
    alpha = 0.1
    dz = dead_zone_df(1.0, alpha)

    def n_of(amplitude, omega):
        return dz(amplitude, omega) * np.exp(-(np.asarray(amplitude) / alpha - 1) / 5)

    found = optimize.minimize_scalar(lambda a: -n_of(a, 1.0).real, bounds=(alpha, 20 * alpha), method="bounded",
                                     options={"xatol": 1e-12})
    a_star, n_max = found.x, -found.fun
    g = third_order(2 * 0.97 / n_max)
    box = ((1.0001 * alpha, 100 * alpha), (0.05, 20.0))
    cycles, near = solve_harmonic_balance(g, n_of, alpha, *box)
    assert cycles == []
    miss = near[0]
    value = abs(1 + g(miss.omega) * n_of(miss.amplitude, miss.omega))
    assert value == pytest.approx(miss.distance, rel=1e-9)  # substituted back
    # an independent dense scan finds nothing closer; on the real axis (w = 1, A*) it is 3 %
    a = alpha + np.geomspace(1e-3 * alpha, 10 * alpha, 600)[:, None]
    w = np.geomspace(0.3, 3.0, 600)[None, :]
    assert np.abs(1 + g(w) * n_of(a, w)).min() >= miss.distance - 1e-9
    assert miss.distance <= abs(1 + g(1.0) * n_of(a_star, 1.0)) == pytest.approx(0.03, rel=1e-6)
    # the complex gain change lambda = -1/(G N) at the miss makes the loci touch; 1 % more crosses twice
    lam = complex(-1 / (g(miss.omega) * n_of(miss.amplitude, miss.omega)))
    assert abs(lam - 1) == pytest.approx(miss.distance, rel=0.05)
    cycles, _ = solve_harmonic_balance(lambda om: 1.01 * lam * g(om), n_of, alpha, *box)
    assert len(cycles) == 2 and {c.stable for c in cycles} == {True, False}
    for cycle in cycles:
        assert abs(1 + 1.01 * lam * g(cycle.omega) * n_of(cycle.amplitude, cycle.omega)) < 1e-9


@pytest.fixture(scope="module")
def load_rig_example():
    return load_rig(EXAMPLES / "load_feedback.toml")


def test_simulation_is_converged_under_step_halving(load_rig_example):
    rig = load_rig_example
    from backlash_df.simulation import default_step

    model = rig.make_model("phase-plane")
    dt = default_step(drive_loop(rig).linear_part(), model)
    coarse, _ = simulated_limit_cycle(rig, model, t_end=10.0, dt=dt, kick=15.0)
    fine, _ = simulated_limit_cycle(rig, model, t_end=10.0, dt=dt / 2, kick=15.0)
    assert coarse.found and fine.found
    assert coarse.amplitude == pytest.approx(fine.amplitude, rel=1e-3)
    assert coarse.omega == pytest.approx(fine.omega, rel=1e-3)
    # the measured first harmonic is below the peak (the cycle is not a pure sine) and above alpha
    assert rig.plant.half_gap < fine.amplitude < fine.peak


def test_motor_feedback_settles_without_limit_cycle():
    rig = load_rig(EXAMPLES / "motor_feedback.toml")
    for name in ("phase-plane", "damped-dead-zone", "exact"):
        measured, result = simulated_limit_cycle(rig, name, t_end=10.0, kick=15.0)
        assert measured.verdict == "no limit cycle"
        tail = result.time > 0.75 * result.time[-1]
        speeds = result.state("motor_speed") - result.state("load_speed")
        assert np.abs(speeds[tail]).max() < 1e-3 * 15.0  # relative motion decayed 1000-fold from the kick
        assert np.all(result.torque[tail] == 0.0)  # no shaft contact at the end


def test_rest_against_a_side_of_the_gap_is_no_limit_cycle():
    """A loop that comes to rest in contact (theta_d = -alpha, no torque) has no cycle.

    Round-off leaves a periodic wobble of ~1e-15 rad there; the measurement must
    call it rest, not a limit cycle (a design-map sweep once did).
    """
    import dataclasses

    rig = load_rig(EXAMPLES / "motor_lag_feedback.toml")
    rig = dataclasses.replace(rig, controller=dataclasses.replace(rig.controller, kp=74.1, ti=0.652))
    measured, result = simulated_limit_cycle(rig, "phase-plane", t_end=40.0, max_t_end=40.0, kick=12.57)
    tail = result.time > 0.75 * result.time[-1]
    assert np.ptp(result.theta_d[tail]) < 1e-9  # at rest ...
    assert abs(abs(result.theta_d[-1]) - rig.plant.half_gap) < 1e-9  # ... against a side of the gap
    assert not measured.found
    assert measured.verdict == "no limit cycle"


def test_a_near_miss_on_a_flat_of_the_residual_is_reported_once_at_the_flats_top():
    """Under a load torque the gear stays in contact at small A: N(A, w) = k + j w c there, flat in A.

    The near miss at the contact loop's resonance is then a flat valley of |1 + G N|;
    it is reported once, at the largest amplitude of the flat (where the gap opens),
    the same on three grids, instead of wherever round-off stopped the minimiser.
    """
    rig = load_rig(EXAMPLES / "loaded_feedback.toml")
    misses = [predict_limit_cycles(rig, grid=grid).near_misses for grid in ((24, 32), (40, 50), (60, 80))]
    assert [len(m) for m in misses] == [1, 1, 1]
    for other in misses[1:]:
        assert other[0].amplitude == pytest.approx(misses[0][0].amplitude, rel=1e-6)
        assert other[0].omega == pytest.approx(misses[0][0].omega, rel=1e-6)
        assert other[0].distance == pytest.approx(misses[0][0].distance, rel=1e-9)
