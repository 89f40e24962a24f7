"""Exact periodic orbits with Coulomb friction: stick phases as segments on the zero-speed surface.

The rig is ``examples/motor_lag_feedback.toml`` (phase plane law, PI on the filtered
motor speed, a torque lag) with Coulomb friction on the load.  Its backlash cycle (A about
0.15 rad, 255 rad/s) makes the load reverse without stopping at 300 N m; from about 400 N m
on the load sticks twice a period (37 % of it at 500 N m) while the motor swings in the gap.

What is checked, each against something the orbit is not built from:

* the orbit against the package's time simulation (RK4 with its own stick logic, whose
  stick and slip ``tests/test_friction_loop.py`` checks against a DOP853 reference),
  started on the orbit's section state and run for 30 periods at three steps: the run
  stays on the orbit (amplitude and frequency to 1e-6, the share of the period stuck to
  the sampling's resolution), and more closely as the step is halved;
* the monodromy matrix, saltation matrices of the sticks included, against central
  differences of the period map;
* a stick phase absorbs every deviation of the load's speed: a Floquet multiplier at 0.
"""

import math

import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
from backlash_df.cli import main
from backlash_df.orbits import orbit_residual
from backlash_df.simulation import measure_limit_cycle
from conftest import EXAMPLES

EXAMPLE = EXAMPLES / "motor_lag_feedback.toml"


def _rig(**friction):
    return bd.load_rig(EXAMPLE).with_values(**friction)


@pytest.fixture(scope="module")
def orbits():
    """The stable orbit at Coulomb friction 300, 400 and 500 N m on the load, each seeding the next."""
    seed = bd.predict_limit_cycles(_rig(coulomb_load=300.0)).stable_cycles[0]
    found = {}
    for level in (300.0, 400.0, 500.0):
        found[level] = seed = bd.periodic_orbit(_rig(coulomb_load=level), seed=seed)
    return found


def test_the_load_sticks_twice_a_period_once_the_friction_holds_it_at_its_reversals(orbits):
    assert orbits[300.0].stuck_time == (0.0,)
    assert [event[2:] for event in orbits[300.0].friction_events] == [(1, -1), (-1, 1)]  # reversals only
    for level in (400.0, 500.0):
        orbit = orbits[level]
        assert orbit.stable and orbit.rubbing == ("load",) and orbit.stuck_time[0] > 0.15 * orbit.period
        assert [event[2:] for event in orbit.friction_events] == [(1, 0), (0, -1), (-1, 0), (0, 1)]
    assert orbits[500.0].stuck_time[0] > orbits[400.0].stuck_time[0]
    friction = orbits[500.0].to_dict()["friction"]
    assert friction["sides"] == ["load"] and friction["events"] == 4
    assert friction["stuck_fraction"][0] == pytest.approx(orbits[500.0].stuck_time[0] / orbits[500.0].period)
    assert "load stuck 37 % of T" in repr(orbits[500.0])


@pytest.mark.parametrize("level", [300.0, 500.0])
def test_a_simulation_started_on_the_orbit_stays_on_it_as_its_step_is_refined(orbits, level):
    orbit, rig = orbits[level], _rig(coulomb_load=level)
    initial = dict(zip(orbit.state_names, orbit.state))
    errors = []
    for dt in (4e-5, 2e-5, 1e-5):
        run = bd.simulate(rig, t_end=30 * orbit.period, dt=dt, initial=initial)
        measured = measure_limit_cycle(run)
        assert measured.found
        errors.append(max(abs(measured.amplitude / orbit.amplitude - 1.0), abs(measured.omega / orbit.omega - 1.0)))
        last = int(round(orbit.period / dt))
        stuck = np.mean(run.friction_mode[-last:, 0] == 0)
        assert stuck == pytest.approx(orbit.stuck_time[0] / orbit.period, abs=2.0 / last)
    assert max(errors) < 1e-6


def test_the_monodromy_with_stick_phases_is_the_period_map_s_finite_differences(orbits):
    orbit, rig = orbits[500.0], _rig(coulomb_load=500.0)
    unknowns = np.append(orbit.state, orbit.period)
    _, jacobian = orbit_residual(rig, None, unknowns)
    n = orbit.state.size
    monodromy = jacobian[:n, :n] + np.eye(n)
    differences = np.zeros((n, n))
    for j in range(n):
        step = 1e-6 * max(abs(orbit.state[j]), 1e-6)
        up, down = unknowns.copy(), unknowns.copy()
        up[j] += step
        down[j] -= step
        differences[:, j] = (orbit_residual(rig, None, up)[0][:n] - orbit_residual(rig, None, down)[0][:n]) / (2 * step)
    differences += np.eye(n)
    assert np.abs(differences - monodromy).max() < 1e-5 * np.abs(monodromy).max()
    np.testing.assert_allclose(np.sort(np.abs(np.linalg.eigvals(monodromy))), np.sort(np.abs(orbit.multipliers)),
                               atol=1e-9)
    assert np.abs(orbit.multipliers[1:]).min() < 1e-9  # the stick absorbs the load speed's deviation
    assert abs(orbit.multipliers[0] - 1.0) < 1e-8


def test_the_verdict_confirms_a_stick_phase_cycle_by_its_exact_orbit(orbits):
    rig = _rig(coulomb_load=500.0)
    verdict = bd.judge_loop(rig, bd.verify_limit_cycles(rig, bd.predict_limit_cycles(rig)), exact=True)
    assert verdict.verdict in ("limit cycle", "bistable")
    confirming = verdict.evidence.exact_orbit  # the stable exact orbit on the simulated cycle
    assert confirming is not None and confirming.stuck_time[0] > 0.0
    assert confirming.amplitude == pytest.approx(orbits[500.0].amplitude, rel=1e-8)


def test_a_branch_over_the_coulomb_friction_follows_the_orbits_into_their_stick_phases(orbits, tmp_path):
    branch = bd.continue_limit_cycles(_rig(coulomb_load=300.0), "coulomb_load", (300.0, 500.0), seed=orbits[300.0],
                                      df_values=2)
    assert branch.points[0].parameter == pytest.approx(300.0) and branch.points[-1].parameter == pytest.approx(500.0)
    assert branch.points[0].orbit.stuck_time == (0.0,) and branch.points[-1].orbit.stuck_time[0] > 0.0
    assert branch.points[-1].orbit.amplitude == pytest.approx(orbits[500.0].amplitude, rel=1e-8)
    rig_file = tmp_path / "rubbing.toml"
    rig_file.write_text(_rig(coulomb_load=300.0).to_toml())
    result = CliRunner().invoke(main, ["continue", str(rig_file), "--parameter", "coulomb_load", "--from", "300",
                                       "--to", "400", "--df-values", "2"])
    assert result.exit_code == 0, result.output


def test_a_breakaway_friction_is_refused_by_the_orbits_in_one_line():
    rig = _rig(coulomb_load=300.0, breakaway_load=50.0, stribeck_speed=0.1)
    with pytest.raises(ValueError, match=r"breakaway_load = 50: a breakaway friction's Stribeck decay is not affine"):
        bd.periodic_orbit(rig, seed=(0.15, 255.0))
    with pytest.raises(ValueError, match="Stribeck decay is not affine"):
        bd.continue_limit_cycles(rig, "kp", (200.0, 220.0))
    assert math.isfinite(bd.predict_limit_cycles(rig).stable_cycles[0].amplitude)  # the DF takes it all the same
