"""Continuation: every point an orbit, the branch against simulation, folds and births where they are, no step lost."""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
import backlash_df.continuation
from backlash_df.checkpoint import Checkpoint
from backlash_df.cli import main
from backlash_df.continuation import continue_limit_cycles
from backlash_df.loops import drive_loop
from backlash_df.orbits import orbit_residual
from conftest import EXAMPLES

RIG = bd.load_rig(EXAMPLES / "load_feedback.toml")


def _simulated(rig, orbit, t_end=10.0):
    """The simulated cycle started on the orbit's amplitude (dt fine enough for 1e-4)."""
    measured, _ = bd.simulated_limit_cycle(rig, "phase-plane", t_end=t_end, max_t_end=4 * t_end, dt=2e-5,
                                           initial={"theta_d": orbit.bias}, kick=orbit.amplitude * orbit.omega)
    return measured


@pytest.fixture(scope="module")
def short_branch():
    return continue_limit_cycles(RIG, "kp", (25.0, 35.0), "phase-plane", df_values=3)


def test_every_point_is_an_orbit_to_the_shooting_tolerance(short_branch):
    assert len(short_branch.points) >= 4
    assert short_branch.values[0] == 25.0 and short_branch.values[-1] == 35.0
    for point in short_branch.points:
        unknowns = np.append(point.orbit.state, point.orbit.period)
        residual, _ = orbit_residual(RIG.with_values(kp=point.parameter), "phase-plane", unknowns)
        assert point.orbit.residual < 1e-10
        assert np.abs(residual[:-1]).max() < 1e-9 * max(np.abs(unknowns[:-1]).max(), 1.0)
        assert abs(residual[-1]) < 1e-9 * np.abs(point.orbit.dtheta_d).max()
        assert point.orbit.stable and abs(point.orbit.multipliers[0] - 1) < 1e-8
    assert np.all(np.diff(short_branch.amplitude) > 0)  # the cycle grows with the gain
    assert short_branch.special == ()


def test_branch_agrees_with_simulation_at_one_gain(short_branch):
    orbit = short_branch.orbit_at(30.0)
    measured = _simulated(RIG.with_values(kp=30.0), orbit)
    assert measured.found
    assert orbit.amplitude == pytest.approx(measured.amplitude, rel=1e-4)
    assert orbit.omega == pytest.approx(measured.omega, rel=1e-4)


def test_json_and_plot(short_branch):
    data = json.loads(json.dumps(short_branch.to_dict()))
    assert data["parameter"] == "kp" and len(data["points"]) == len(short_branch.points)
    assert data["df"][0]["cycles"][0]["stable"] is True
    drawn = short_branch.plot()
    assert drawn.axes[1].get_xlabel() == "kp (N m s/rad)"  # the rig value with its unit
    import matplotlib.pyplot as plt

    plt.close(drawn.figure)


def test_bad_range_and_parameter():
    with pytest.raises(ValueError, match="two different finite values"):
        continue_limit_cycles(RIG, "kp", (5.0, 5.0))
    with pytest.raises(ValueError, match="parameter 'gain'"):
        continue_limit_cycles(RIG, "gain", (5.0, 6.0))


@pytest.mark.slow
def test_gain_branch_against_simulation_and_the_contact_loop_limit():
    branch = continue_limit_cycles(RIG, "kp", (5.0, 60.0), "phase-plane", df_values=5)
    for kp in (8.0, 15.0, 25.0, 35.0, 45.0):
        orbit = branch.orbit_at(kp)
        measured = _simulated(RIG.with_values(kp=kp), orbit, t_end=20.0)
        assert measured.found, kp
        assert orbit.amplitude == pytest.approx(measured.amplitude, rel=1e-4), kp
    (end,) = [s for s in branch.special if s.kind == "end"]
    kp_limit = float(end.detail.rsplit("=", 1)[1])
    poles = [drive_loop(RIG.with_values(kp=kp)).linear_poles(5895.0, 3.0).real.max() for kp in
             (0.99 * kp_limit, 1.01 * kp_limit)]
    assert poles[0] < 0 < poles[1]
    assert end.parameter < kp_limit


@pytest.mark.slow
def test_load_fold_is_where_simulation_loses_the_cycle():
    branch = continue_limit_cycles(RIG, "load.torque", (0.0, 300.0), "phase-plane", df_values=4)
    kinds = [s.kind for s in branch.special]
    assert "fold" in kinds and "birth" in kinds
    fold = next(s for s in branch.special if s.kind == "fold")
    stable = branch.points[int(np.argmax(branch.values))].orbit
    for torque, cycles in ((0.98 * fold.parameter, True), (1.02 * fold.parameter, False)):
        rig = RIG.with_values(**{"load.torque": torque})
        assert _simulated(rig, stable, t_end=20.0).found is cycles, torque


# --------------------------------------------------------------------------- checkpoints and the printed text


class _Counted:
    """Stand-ins for ``continuation.periodic_orbit`` and ``continuation.predict_limit_cycles``: count the calls,
    raise Ctrl-C at a given call of each."""

    def __init__(self, monkeypatch, orbit_at=None, prediction_at=None):
        self.orbits, self.predictions = 0, 0
        self.orbit_at, self.prediction_at = orbit_at, prediction_at
        monkeypatch.setattr(backlash_df.continuation, "periodic_orbit", self.orbit)
        monkeypatch.setattr(backlash_df.continuation, "predict_limit_cycles", self.prediction)

    def orbit(self, *args, **kwargs):
        self.orbits += 1
        if self.orbits == self.orbit_at:
            raise KeyboardInterrupt
        return bd.periodic_orbit(*args, **kwargs)

    def prediction(self, *args, **kwargs):
        self.predictions += 1
        if self.predictions == self.prediction_at:
            raise KeyboardInterrupt
        return bd.predict_limit_cycles(*args, **kwargs)


def test_interrupted_continuation_resumes_to_the_same_branch_and_recomputes_no_finished_step(short_branch, tmp_path,
                                                                                           monkeypatch):
    path = tmp_path / "branch.checkpoint"
    args = (RIG, "kp", (25.0, 35.0), "phase-plane")
    whole = _Counted(monkeypatch)
    assert json.dumps(continue_limit_cycles(*args, df_values=3, checkpoint=path).to_dict()) == json.dumps(
        short_branch.to_dict())
    path.unlink()
    # the first orbit takes one DF prediction, each branch point one polished orbit (the step past kp = 35
    # one more: it is polished where it lands, then on the end), then come three DF predictions
    assert whole.predictions == 1 + 3 and whole.orbits == len(short_branch.points) + 1
    _Counted(monkeypatch, orbit_at=5)  # Ctrl-C while polishing the fifth orbit
    with pytest.raises(KeyboardInterrupt):
        continue_limit_cycles(*args, df_values=3, checkpoint=path)
    second = _Counted(monkeypatch, prediction_at=2)  # resumed at the fifth orbit, Ctrl-C in the second DF cell
    with pytest.raises(KeyboardInterrupt):
        continue_limit_cycles(*args, df_values=3, checkpoint=Checkpoint(path, resume=True))
    assert (second.orbits, second.predictions) == (whole.orbits - 4, 2)  # the first orbit is not sought again
    third = _Counted(monkeypatch)
    resumed = continue_limit_cycles(*args, df_values=3, checkpoint=Checkpoint(path, resume=True))
    assert (third.orbits, third.predictions) == (0, 2)
    assert json.dumps(resumed.to_dict()) == json.dumps(short_branch.to_dict())
    with pytest.raises(ValueError, match=r"another run \(it differs in ds_max\)"):
        continue_limit_cycles(*args, df_values=3, ds_max=0.5, checkpoint=Checkpoint(path, resume=True))


def test_continue_prints_the_df_values_it_computed_and_round_off_bias_as_zero(tmp_path):
    result = CliRunner().invoke(main, ["continue", str(EXAMPLES / "load_feedback.toml"), "--parameter", "kp",
                                       "--from", "25", "--to", "35", "--df-values", "3", "--json",
                                       str(tmp_path / "b.json")])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    # issue 49: the output starts with the table (no repr line before it), every header with its unit
    assert lines[0] == "exact periodic orbits of the phase-plane law (shooting; stability by Floquet multipliers):"
    assert re.split(r"\s{2,}", lines[1]) == ["kp (N m s/rad)", "A (rad)", "w (rad/s)", "period (s)", "bias (rad)",
                                             "|mu| max", "Floquet"]
    df = lines.index("describing function at 3 values (stability by Loeb's criterion):")
    assert re.split(r"\s{2,}", lines[df + 1]) == ["kp (N m s/rad)", "A DF (rad)", "w DF (rad/s)", "bias (rad)", "Loeb"]
    model = RIG.make_model("phase-plane")
    rows = [line.split() for line in lines[df + 2:df + 5]]
    assert [float(row[0]) for row in rows] == [25.0, 30.0, 35.0]
    for kp, amplitude, omega, bias, loeb in rows:
        # each printed cycle solves the harmonic balance 1 + G(jw) N(A, w) = 0 to its printed digits
        g = drive_loop(RIG.with_values(kp=float(kp))).frequency_response(np.array([float(omega)]))
        n = bd.describing_function(model, float(amplitude), np.array([float(omega)]))
        assert abs(1 + g * n)[0] < 3e-4 and (bias, loeb) == ("0", "stable")
    data = json.loads((tmp_path / "b.json").read_text())
    printed_rows = [line.split() for line in lines[2:2 + len(data["points"])]]
    assert [float(row[3]) for row in printed_rows] == [float(f"{point['period']:.5g}") for point in data["points"]]
    printed = [row[4] for row in printed_rows]
    # the computed bias of these symmetric orbits is round-off (|bias| < 1e-12 A): the JSON keeps it, the text says 0
    assert any(point["bias"] != 0.0 for point in data["points"])
    assert all(abs(point["bias"]) < 1e-12 * point["amplitude"] for point in data["points"])
    assert printed == ["0"] * len(data["points"])


def test_a_branch_in_a_friction_from_zero_its_range_end():
    """Viscous friction of the load from 0 (the end of its range: a one-sided parameter derivative there), each
    point an orbit of its own rig, the cycle damped as the friction grows, and the simulation agreeing."""
    lag = bd.load_rig(EXAMPLES / "motor_lag_feedback.toml")
    branch = continue_limit_cycles(lag, "viscous_load", (0.0, 200.0), "phase-plane", df_values=2)
    assert branch.values[0] == 0.0 and branch.values[-1] == 200.0
    for point in branch.points:
        unknowns = np.append(point.orbit.state, point.orbit.period)
        residual, _ = orbit_residual(lag.with_values(viscous_load=point.parameter), "phase-plane", unknowns)
        assert np.abs(residual[:-1]).max() < 1e-9 * max(np.abs(unknowns[:-1]).max(), 1.0)
    assert np.all(np.diff(branch.amplitude) < 0)
    orbit = branch.orbit_at(200.0)
    rig = lag.with_values(viscous_load=200.0)  # the simulation started on the orbit's state stays on it
    names = drive_loop(rig).linear_part().state_names
    measured = bd.measure_limit_cycle(bd.simulate(rig, "phase-plane", t_end=1.0, dt=2e-6,
                                                  initial=dict(zip(names, orbit.state[:len(names)]))))
    assert orbit.amplitude == pytest.approx(measured.amplitude, rel=1e-4)
    assert orbit.omega == pytest.approx(measured.omega, rel=1e-5)
