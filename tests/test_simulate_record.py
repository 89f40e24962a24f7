"""``backlash-df simulate`` and ``bd.simulate(rig, inputs=..., compare=...)``: a run on recorded inputs, compared.

Each check is against something the package did not compute: a record written here by
scipy's ``solve_ivp`` of the two-mass PI loop with the dead-zone law (24); python-control's
``forced_response`` of the loop with the gear in contact, which holds the inputs linear
between samples as the inputs file does; a cascade's load angle at rest against its
position reference.  Bad inputs are each one line, exit code 2, nothing written.
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

import backlash_df as bd
import backlash_df.cli.common
import backlash_df.cli.simulate
from backlash_df.cli import main
from backlash_df.simulation.record import TIME_TOLERANCE, read_inputs
from conftest import EXAMPLES, PLANT_TOML

# The paper's drive (Section 4) with a 0.02 rad half gap behind a 3:1 gear, a PI speed loop on the motor.
JM, JL, K, ALPHA, KP, TI, RATIO = 0.4, 5.6, 5895.0, 0.02, 20.0, 0.3, 3.0
RIG = {"plant": {"motor_inertia": JM, "load_inertia": JL, "stiffness": K, "damping": 3.0, "half_gap": ALPHA,
                 "gear_ratio": RATIO},
       "controller": {"kp": KP, "ti": TI, "feedback": "motor"}, "model": {"backlash": "dead-zone"}}
RIG_TOML = PLANT_TOML.replace("half_gap = 0.05", f"half_gap = {ALPHA}\ngear_ratio = {RATIO}") + f"""
[controller]
feedback = "motor"
kp = {KP}
ti = {TI}

[model]
backlash = "dead-zone"
"""
STEP = 1e-3  # s, the rows of the inputs and of the record
DURATION = 3.0


def reference(t):
    """A speed reference that reverses (both flanks of the gap are crossed), rad/s, load side."""
    return 2.0 * np.sin(2 * np.pi * 0.5 * t) + 0.5 * np.sin(2 * np.pi * 2.3 * t)


def load_torque(t):
    """A known load torque, N m."""
    return 15.0 * np.sin(2 * np.pi * 1.3 * t)


def reference_record(tmp_path):
    """Inputs and a measurement record of the rig, by ``solve_ivp`` of the loop written out here.

    States theta_d, w_m, w_l (rad, rad/s, load side), the speed error's integral I and the two
    angles; the inputs linear between the rows, as the inputs file says.  The dead-zone law
    T = k (theta_d - alpha sign theta_d) outside the gap, 0 inside, is continuous: the
    integrator needs no events at the contacts, and rtol 1e-10 leaves errors far below 1 %.
    """
    time = np.arange(int(round(DURATION / STEP)) + 1) * STEP
    r_rows, tl_rows = reference(time), load_torque(time)

    def rates(t, z):
        theta_d, w_m, w_l, integral, _, _ = z
        r, tl = np.interp(t, time, r_rows), np.interp(t, time, tl_rows)
        shaft = K * (theta_d - ALPHA * np.sign(theta_d)) if abs(theta_d) > ALPHA else 0.0
        u = KP * (r - w_m) + KP / TI * integral
        return [w_m - w_l, (u - shaft) / JM, (shaft + tl) / JL, r - w_m, w_m, w_l]

    solution = solve_ivp(rates, (0.0, time[-1]), np.zeros(6), method="DOP853", t_eval=time, rtol=1e-10,
                         atol=1e-12, max_step=STEP)
    theta_d, w_m, w_l, integral, theta_m, theta_l = solution.y
    u = KP * (r_rows - w_m) + KP / TI * integral
    inputs, record = tmp_path / "inputs.csv", tmp_path / "record.csv"
    np.savetxt(inputs, np.column_stack([time, r_rows, tl_rows]), delimiter=",", header="time,reference,load_torque",
               comments="", fmt="%.12g")
    # the record's motor columns on the motor side: torque / n, speed and angle * n
    np.savetxt(record, np.column_stack([time, u / RATIO, RATIO * w_m, w_l, tl_rows, RATIO * theta_m, theta_l]),
               delimiter=",", header="time,motor_torque,motor_speed,load_speed,load_torque,motor_angle,load_angle",
               comments="", fmt="%.12g")
    return inputs, record


def cli(*args):
    return CliRunner().invoke(main, ["simulate", *map(str, args)])


@pytest.fixture(scope="module")
def record_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("record")
    rig = folder / "rig.toml"
    rig.write_text(RIG_TOML)
    return (rig, *reference_record(folder))


def test_the_run_fits_an_independent_record(record_files, tmp_path):
    rig, inputs, record = record_files
    out = tmp_path / "out.json"
    result = cli(rig, "--inputs", inputs, "--compare", record, "--json", out)
    assert result.exit_code == 0, result.output
    fits = json.loads(out.read_text())["fit_percent"]
    assert set(fits) == {"motor_torque", "motor_speed", "load_speed", "motor_angle", "load_angle"}
    assert min(fits.values()) >= 99.0, fits
    for name, value in fits.items():  # the text says the same, one line a column
        assert any(line.split()[:2] == [name, f"{value:.1f}"] for line in result.output.splitlines())


@pytest.mark.parametrize("change", [{"stiffness": 1.3 * K}, {"load_inertia": 1.3 * JL}, {"motor_inertia": 1.3 * JM}])
def test_a_wrong_rig_fits_clearly_worse(record_files, change):
    _, inputs, record = record_files
    right = bd.simulate(bd.rig_from_dict(RIG), inputs=inputs, compare=record)
    wrong = bd.simulate(bd.rig_from_dict(RIG).with_values(**change), inputs=inputs, compare=record)
    assert min(right.fit_percent.values()) >= 99.0
    # below the 99 % bar, the residual of the worst column a thousand times the right rig's
    assert min(wrong.fit_percent.values()) < 99.0, wrong.fit_percent
    assert 100.0 - min(wrong.fit_percent.values()) > 1e3 * (100.0 - min(right.fit_percent.values()))


def test_the_csv_is_a_measurement_record_on_the_file_side(record_files, tmp_path):
    rig, inputs, record = record_files
    out = tmp_path / "out.csv"
    assert cli(rig, "--inputs", inputs, "--csv", out).exit_code == 0
    written = bd.load_measurements(out, gear_ratio=RATIO)
    measured = bd.load_measurements(record, gear_ratio=RATIO)
    np.testing.assert_allclose(written.time, measured.time, atol=1e-12)
    for name in ("motor_speed", "load_speed", "motor_torque"):
        spread = np.ptp(getattr(measured, name))
        np.testing.assert_allclose(getattr(written, name), getattr(measured, name), atol=0.02 * spread)
    raw = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_allclose(raw["motor_speed"], RATIO * written.motor_speed, rtol=1e-8, atol=1e-12)


def test_the_run_fits_the_project_generators_record():
    """The record generator (identify.synthesize: its own loop, a 5 times finer step, the exact model (1), (14))
    with no test signal, noise or data-sheet error: the sine speed reference (rebuilt here; the record does not
    hold it) and the smoothed square load torque (the record's, linear between its samples) are its only inputs.
    The rig's own law, exact, fits every column to 99.99 %; the load torque held linear between the record's
    1 ms samples, where the generator's is smooth, is what is left."""
    from backlash_df.identify import Experiment, synthesize

    rig = bd.load_rig(EXAMPLES / "diagnose_rig.toml")
    experiment = Experiment(test_amplitude=0.0, noise=0.0, warmup=0.0)
    record = synthesize(rig, "none", seed=3, duration=2.0, experiment=experiment, datasheet_error=0.0,
                        encoder_counts=2 ** 24).measurements
    reference = experiment.speed_amplitude * np.sin(2 * np.pi * experiment.speed_frequency * record.time)
    inputs = {"time": record.time, "reference": reference, "load_torque": record.load_torque}
    run = bd.simulate(rig, "exact", inputs=inputs, compare=record)
    assert set(run.fit_percent) == {"motor_torque", "motor_speed", "load_speed", "motor_angle", "load_angle"}
    assert min(run.fit_percent.values()) >= 99.99, run.fit_percent
    heavy = bd.simulate(rig.with_values(load_inertia=1.3 * rig.plant.load_inertia), "exact", inputs=inputs,
                        compare=record)
    assert min(heavy.fit_percent.values()) < 99.0, heavy.fit_percent


def linear_loop(c):
    """The loop with the gear in contact, T = k theta_d + c dtheta_d, as python-control's state space.

    States theta_d, w_m, w_l, I; inputs r, T_l; outputs w_m, w_l, u = kp (r - w_m) + (kp / ti) I.
    """
    import control as ct

    ki = KP / TI
    a = [[0.0, 1.0, -1.0, 0.0],
         [-K / JM, -(KP + c) / JM, c / JM, ki / JM],
         [K / JL, c / JL, -c / JL, 0.0],
         [0.0, -1.0, 0.0, 0.0]]
    b = [[0.0, 0.0], [KP / JM, 0.0], [0.0, 1.0 / JL], [1.0, 0.0]]
    c_out = [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -KP, 0.0, ki]]
    d_out = [[0.0, 0.0], [0.0, 0.0], [KP, 0.0]]
    return ct.ss(a, b, c_out, d_out)


def test_inputs_are_linear_between_rows_as_the_linear_loop_says():
    """A coarse ramp-and-hold reference (10 ms rows) on a rig whose gap (1e-9 rad) leaves it linear: the run
    agrees with python-control's forced_response, which takes the inputs linear between samples, to 1e-6 of
    each signal's range (the gap's torque k alpha is 6e-6 N m); the inputs held between rows miss by 1e-2."""
    import control as ct

    rows = np.arange(0.0, 1.0 + 1e-9, 0.01)
    r_rows = np.interp(rows, [0.0, 0.1, 0.4, 0.6, 1.0], [0.0, 2.0, 2.0, -1.0, -1.0])
    tl_rows = np.where(rows < 0.5, 0.0, 8.0) + 5.0 * rows
    rig = bd.rig_from_dict(RIG | {"plant": RIG["plant"] | {"half_gap": 1e-9, "gear_ratio": 1.0},
                                  "model": {"backlash": "damped-dead-zone"}})
    run = bd.simulate(rig, inputs={"time": rows, "reference": r_rows, "load_torque": tl_rows})
    response = ct.forced_response(linear_loop(3.0), rows, np.vstack([r_rows, tl_rows]))
    expected = dict(zip(("motor_speed", "load_speed", "motor_torque"), response.outputs))
    np.testing.assert_allclose(run.simulated.time, rows, atol=1e-12)
    for name, values in expected.items():
        np.testing.assert_allclose(getattr(run.simulated, name), values, atol=1e-6 * np.ptp(values), err_msg=name)
    np.testing.assert_allclose(run.simulated.load_torque, tl_rows, atol=1e-12)
    # the test can fail: the inputs held between rows (the zero-order hold) give another response
    held = ct.forced_response(ct.c2d(linear_loop(3.0), 0.01, "zoh"), rows, np.vstack([r_rows, tl_rows]))
    assert np.max(np.abs(held.outputs[0] - expected["motor_speed"])) > 1e-2 * np.ptp(expected["motor_speed"])


def linear_cascade(c, kv):
    """The cascade with the gear in contact: P position loop (load angle) around the PI on the motor speed.

    States theta_d, w_m, w_l, theta_l, I; inputs r (rad), T_l; outputs theta_l, w_m, u; the speed reference
    kv (r - theta_l), u = kp (kv (r - theta_l) - w_m) + (kp / ti) I.
    """
    import control as ct

    ki = KP / TI
    a = [[0.0, 1.0, -1.0, 0.0, 0.0],
         [-K / JM, -(KP + c) / JM, c / JM, -KP * kv / JM, ki / JM],
         [K / JL, c / JL, -c / JL, 0.0, 0.0],
         [0.0, 0.0, 1.0, 0.0, 0.0],
         [0.0, -1.0, 0.0, -kv, 0.0]]
    b = [[0.0, 0.0], [KP * kv / JM, 0.0], [0.0, 1.0 / JL], [0.0, 0.0], [kv, 0.0]]
    c_out = [[0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0, 0.0], [0.0, -KP, 0.0, -KP * kv, ki]]
    d_out = [[0.0, 0.0], [0.0, 0.0], [KP * kv, 0.0]]
    return ct.ss(a, b, c_out, d_out)


def test_a_cascade_follows_its_position_reference():
    """A cascade's reference is a position (rad): a ramp to 0.3 rad and a hold.  With a gap of 1e-9 rad the loop
    is linear: the load angle, motor speed and torque agree with python-control's forced_response of the cascade
    written above to 1e-6 of their ranges, and the load angle ends within 1 % of the reference (the speed loop's
    integrator takes the position error away).  motor_angle - load_angle is theta_d.  (With the rig's gap of
    0.02 rad this loop hunts: an integrator in a position loop with backlash.)"""
    import control as ct

    kv = 5.0
    rig = bd.rig_from_dict({"plant": RIG["plant"] | {"gear_ratio": 1.0, "half_gap": 1e-9},
                            "controller": {"structure": "cascade", "kv": kv, "kp": KP, "ti": TI, "feedback": "motor",
                                           "position_feedback": "load"},
                            "model": {"backlash": "damped-dead-zone"}})
    rows = np.arange(0.0, 8.0 + 1e-9, 0.005)
    target = np.interp(rows, [0.0, 1.0, 8.0], [0.0, 0.3, 0.3])
    run = bd.simulate(rig, inputs={"time": rows, "reference": target})
    assert run.reference_kind == "position" and run.to_dict()["reference"] == "position"
    response = ct.forced_response(linear_cascade(3.0, kv), rows, np.vstack([target, np.zeros_like(rows)]))
    for name, values in zip(("load_angle", "motor_speed", "motor_torque"), response.outputs):
        np.testing.assert_allclose(getattr(run.simulated, name), values, atol=1e-6 * np.ptp(values), err_msg=name)
    assert abs(run.simulated.load_angle[-1] - 0.3) < 0.01 * 0.3  # 0.2 % left after 7 s of hold: a slow mode
    np.testing.assert_allclose(run.simulated.motor_angle - run.simulated.load_angle,
                               np.interp(rows, run.simulation.time, run.simulation.theta_d), atol=1e-12)


def test_without_inputs_the_run_is_simulate_rigs(record_files):
    """No inputs: the reference 0 and the rig's load torque; the columns are the run's states."""
    rig = bd.rig_from_dict(RIG | {"load": {"torque": 4.0}})
    run = bd.simulation.record.simulate_record(rig, t_end=0.5, initial={"motor_speed": 1.0})
    plain = bd.simulate(rig, t_end=0.5, initial={"motor_speed": 1.0})
    np.testing.assert_array_equal(run.simulation.states, plain.states)
    np.testing.assert_array_equal(run.simulated.motor_speed, plain.state("motor_speed"))
    assert np.all(run.simulated.load_torque == 4.0)


def test_progress_reports_steps_and_changes_nothing():
    rig = bd.rig_from_dict(RIG)
    inputs = {"time": [0.0, 0.5, 1.0], "reference": [0.0, 1.0, -1.0]}
    calls = []
    counted = bd.simulation.record.simulate_record(rig, inputs=inputs, progress=lambda *a: calls.append(a))
    plain = bd.simulate(rig, inputs=inputs)
    np.testing.assert_array_equal(counted.simulation.states, plain.simulation.states)
    assert {stage for stage, _, _ in calls} == {"simulate"}
    assert calls[-1][1] == calls[-1][2] == plain.steps
    assert [done for _, done, _ in calls] == sorted(done for _, done, _ in calls)


def inputs_text(rows):
    return "\n".join(rows) + "\n"


GOOD_ROWS = ["time,reference"] + [f"{0.01 * i:.2f},{0.1 * i:.2f}" for i in range(5)]


@pytest.mark.parametrize("rows, words", [
    (["time,speed"] + GOOD_ROWS[1:], ["missing column reference"]),
    (["t,reference"] + GOOD_ROWS[1:], ["missing column time"]),
    (["time,reference,load_trq"] + [row + ",0" for row in GOOD_ROWS[1:]], ["unknown column 'load_trq'"]),
    (GOOD_ROWS[:3] + ["0.02,nan"] + GOOD_ROWS[4:], ["reference is NaN or infinite at line 4"]),
    (GOOD_ROWS[:3] + ["0.02,inf"] + GOOD_ROWS[4:], ["reference is NaN or infinite at line 4"]),
    (GOOD_ROWS[:3] + ["0.02,x"] + GOOD_ROWS[4:], ["line 4, column reference: 'x' is not a number"]),
    (GOOD_ROWS[:3] + ["0.01,0.2"] + GOOD_ROWS[4:], ["time does not increase at line 4"]),
    (GOOD_ROWS[:3] + ["0.0201,0.2"] + GOOD_ROWS[4:], ["not uniformly sampled", "line 4", "0.1 %"]),
    (GOOD_ROWS[:2], ["1 row", "at least 2"]),
])
def test_bad_inputs_are_one_line_exit_2_and_nothing_written(record_files, tmp_path, rows, words):
    rig = record_files[0]
    inputs, out = tmp_path / "in.csv", tmp_path / "out.csv"
    inputs.write_text(inputs_text(rows))
    result = cli(rig, "--inputs", inputs, "--csv", out, "--json", tmp_path / "out.json")
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:") and str(inputs) in lines[0], lines
    for word in words:
        assert word in lines[0]
    assert list(tmp_path.iterdir()) == [inputs]


@pytest.mark.parametrize("args, words", [
    ((), ["--t-end", "--inputs or --compare"]),
    (("--t-end", "1", "--csv", "{tmp}/out.json"), ["--csv", "writes CSV, not JSON"]),
    (("--t-end", "1", "--compare", "{tmp}/nope.csv"), ["nope.csv"]),
    (("--t-end", "-1"), ["--t-end"]),
])
def test_bad_options_are_one_line_exit_2_and_nothing_written(record_files, tmp_path, args, words):
    rig = record_files[0]
    result = cli(rig, *(arg.format(tmp=tmp_path) for arg in args), "--json", tmp_path / "run.json")
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:"), lines
    for word in words:
        assert word in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_a_record_beyond_the_run_is_refused(record_files, tmp_path):
    rig, inputs, record = record_files
    result = cli(rig, "--inputs", inputs, "--t-end", "1", "--compare", record, "--json", tmp_path / "run.json")
    assert result.exit_code == 2 and "beyond the run's" in result.output and "--t-end" in result.output
    assert list(tmp_path.iterdir()) == []


def test_the_time_tolerance_is_the_stated_one():
    steps = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    inside = steps.copy()
    inside[2] += 0.9 * TIME_TOLERANCE  # one step 0.09 % long, the next as short
    read_inputs({"time": inside, "reference": np.zeros(5)})
    outside = steps.copy()
    outside[2] += 1.1 * TIME_TOLERANCE
    with pytest.raises(ValueError, match="not uniformly sampled"):
        read_inputs({"time": outside, "reference": np.zeros(5)})


def test_inputs_and_speed_reference_together_are_refused():
    with pytest.raises(ValueError, match="pass no speed_reference or load_torque"):
        bd.simulate(bd.rig_from_dict(RIG), inputs={"time": [0.0, 1.0], "reference": [0.0, 1.0]},
                    speed_reference=1.0)


def test_progress_only_on_a_terminal(record_files, monkeypatch):
    """Off a terminal stderr stays empty; on one (the check made to say so) a tqdm bar counts the steps."""
    rig, inputs, _ = record_files
    quiet = cli(rig, "--inputs", inputs, "--t-end", "0.2")
    assert quiet.exit_code == 0 and quiet.stderr == ""
    monkeypatch.setattr(backlash_df.cli.simulate, "stderr_is_terminal", lambda: True)
    monkeypatch.setattr(backlash_df.cli.common, "stderr_is_terminal", lambda: True)
    drawn = cli(rig, "--inputs", inputs, "--t-end", "0.2")
    assert drawn.exit_code == 0 and "\r" in drawn.stderr and "simulate" in drawn.stderr
    assert drawn.stdout == quiet.stdout


@pytest.mark.parametrize("option, path, words", [
    ("--csv", "nodir/out.csv", ["--csv nodir/out.csv", "does not exist"]),
    ("--json", "out.html", ["--json out.html", "not an HTML report"]),
    ("--plot", "out.jpg", ["--plot out.jpg", "unknown plot format"]),
])
def test_outputs_are_checked_before_the_run(record_files, tmp_path, monkeypatch, option, path, words):
    def never(*args, **kwargs):
        raise AssertionError("the run started before the outputs were checked")

    monkeypatch.setattr(backlash_df.cli.simulate, "simulate_record", never)
    monkeypatch.chdir(tmp_path)
    rig, inputs, _ = record_files
    other = [] if option == "--csv" else ["--csv", "good.csv"]  # a good output beside the bad one: none written
    result = cli(rig, "--inputs", inputs, *other, option, path)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1
    for word in words:
        assert word in result.output
    assert list(tmp_path.iterdir()) == []
