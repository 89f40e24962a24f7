"""The rig file's ``[friction]`` table, ``[load] torque_offset``, ``[uncertainty]`` boxes and the rig writer.

The simulation models all friction and every analysis the viscous part; what the loop's
analyses do not model yet is refused in one place (:meth:`~backlash_df.config.Rig.require_modelled`,
called by ``drive_loop``): dry friction by the analyses that do not model it yet, a torque offset
by all, so a command given such a rig exits with code 2 and writes nothing.
"""

import dataclasses
import math
import pickle
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import backlash_df as bd
from backlash_df.checkpoint import describe
from backlash_df.cli import main
from backlash_df.config import RANGES, Friction, Load, RigError, load_rig, rig_from_dict, rig_to_toml, write_rig
from conftest import EXAMPLES, PLANT_TOML

PLANT = {"motor_inertia": 0.4, "load_inertia": 5.6, "stiffness": 5895.0, "damping": 3.0, "half_gap": 0.05}
CONTROLLER = {"feedback": "load", "kp": 30.0, "ti": 0.5, "speed_filter": 0.002}
FRICTION = {"coulomb_motor": 1.5, "coulomb_load": 20.0, "viscous_motor": 0.25, "viscous_load": 2.0,
            "breakaway_motor": 0.5, "breakaway_load": 8.0, "stribeck_speed": 0.05}
#: A rig with every key the round trips must keep: a cascade with a P speed controller (ti = inf), a load torque
#: and an offset of either sign, every friction, and boxes in three tables.
EVERY_KEY = {
    "plant": dict(PLANT, rubber_thickness=0.01, gear_ratio=12.5),
    "controller": dict(CONTROLLER, ti=math.inf, structure="cascade", kv=20.0, position_feedback="motor",
                       torque_limit=300.0, torque_lag=0.001, delay=0.0005),
    "load": {"torque": -40.0, "torque_offset": 3.25},
    "friction": FRICTION,
    "model": {"backlash": "rubber"},
    "uncertainty": {"load_inertia": [4.0, 8.0], "coulomb_load": [10, 30], "torque_offset": [-1.0, 5.0],
                    "stribeck_speed": [0.05, 0.05]},
}
EXAMPLE_RIGS = sorted(EXAMPLES.glob("*.toml")) + [EXAMPLES / "kuka" / "kuka_rig.toml"]


def _rig(**tables):
    return rig_from_dict({"plant": dict(PLANT), "controller": dict(CONTROLLER), **tables}, source="rig.toml")


# --------------------------------------------------------------------------- parsing and ranges

def test_friction_is_parsed_on_its_keys_and_defaults_to_none():
    rig = _rig(friction=FRICTION)
    assert dataclasses.asdict(rig.friction) == FRICTION
    assert rig.friction.any
    assert _rig().friction == Friction() and not _rig().friction.any
    assert [f.name for f in dataclasses.fields(Friction)] == list(FRICTION)  # the other engineer's interface
    assert all(f.default == 0.0 for f in dataclasses.fields(Friction))


@pytest.mark.parametrize("key", [key for key in FRICTION if key != "stribeck_speed"])
def test_any_friction_counts_but_a_stribeck_speed_alone_does_not(key):
    assert Friction(**{key: 1e-9}).any
    assert not Friction(stribeck_speed=0.3).any


def test_torque_offset_is_a_signed_load_key():
    assert _rig(load={"torque_offset": -12.5}).load.torque_offset == -12.5
    assert Load().torque_offset == 0.0


@pytest.mark.parametrize("key", list(FRICTION) + ["torque_offset"])
def test_each_new_key_has_a_range_and_its_ends_load(key):
    low, high, _ = RANGES[key]
    table = "load" if key == "torque_offset" else "friction"
    for value in (low, high):
        extra = {"stribeck_speed": 1.0} if key.startswith("breakaway") else {}
        rig = _rig(**{table: {key: value, **extra}})
        assert getattr(rig.load if table == "load" else rig.friction, key) == value
    with pytest.raises(RigError, match=rf"\[{table}\] {key} = .* is outside the accepted range"):
        _rig(**{table: {key: high * 10.0}})


@pytest.mark.parametrize("tables, words", [
    ({"friction": {"coulomb_load": -1.0}}, "[friction] coulomb_load must be >= 0, got -1.0"),
    ({"friction": {"viscous_motor": -0.1}}, "[friction] viscous_motor must be >= 0"),
    ({"friction": {"stribeck_speed": -0.1}}, "[friction] stribeck_speed must be >= 0"),
    ({"friction": {"coulomb_load": math.nan}}, "[friction] coulomb_load must be finite"),
    ({"friction": {"coulomb_load": "20"}}, "[friction] coulomb_load must be a number"),
    ({"friction": {"breakaway_load": 8.0}}, "[friction] breakaway_load = 8 N m needs stribeck_speed > 0"),
    ({"friction": {"breakaway_motor": 1.0, "stribeck_speed": 0.0}}, "[friction] breakaway_motor = 1 N m needs"),
    ({"friction": {"coulomb": 20.0}}, "unknown key [friction] coulomb; allowed: coulomb_motor, coulomb_load"),
    ({"friction": 3.0}, "[friction] must be a table"),
    ({"load": {"coulomb": 0.0}}, "[load] coulomb is now [friction] coulomb_load"),
    ({"load": {"coulomb": 25.0}}, "[load] coulomb is now [friction] coulomb_load"),
    ({"load": {"torque_offset": math.inf}}, "[load] torque_offset must be finite"),
    ({"uncertainty": {"kp": [10.0, 40.0]}}, "[uncertainty] kp: not a numeric [plant], [friction] or [load] key"),
    ({"uncertainty": {"backlash": [1.0, 2.0]}}, "[uncertainty] backlash: not a numeric"),
    ({"uncertainty": {"load_inertia": "5 to 6"}}, "[uncertainty] load_inertia must be [low, high], two numbers"),
    ({"uncertainty": {"load_inertia": [5.0]}}, "[uncertainty] load_inertia must be [low, high]"),
    ({"uncertainty": {"load_inertia": [5.0, True]}}, "[uncertainty] load_inertia must be [low, high]"),
    ({"uncertainty": {"load_inertia": [5.0, math.inf]}}, "[uncertainty] load_inertia must be finite"),
    ({"uncertainty": {"load_inertia": [8.0, 4.0]}}, "[uncertainty] load_inertia = [8, 4]: low is above high"),
    ({"uncertainty": {"load_inertia": [6.0, 8.0]}},
     "[uncertainty] load_inertia = [6, 8] kg m^2 excludes the rig's value [plant] load_inertia = 5.6 kg m^2"),
    ({"uncertainty": {"coulomb_load": [1.0, 2.0]}}, "excludes the rig's value [friction] coulomb_load = 0 N m"),
    ({"uncertainty": {"coulomb_load": [-1.0, 2.0]}},
     "[uncertainty] coulomb_load = [-1, 2] N m reaches outside the accepted range [0, 1e+09] N m"),
    ({"uncertainty": [1.0, 2.0]}, "[uncertainty] must be a table"),
], ids=lambda item: item if isinstance(item, str) else None)
def test_each_refusal_is_one_line_naming_the_file_and_key(tables, words):
    with pytest.raises(RigError) as info:
        _rig(**tables)
    message = str(info.value)
    assert words in message and message.startswith("rig.toml: ") and "\n" not in message


def test_uncertainty_is_a_hashable_mapping_of_absolute_boxes():
    rig = rig_from_dict(EVERY_KEY)
    assert dict(rig.uncertainty) == {"load_inertia": (4.0, 8.0), "coulomb_load": (10.0, 30.0),
                                     "torque_offset": (-1.0, 5.0), "stribeck_speed": (0.05, 0.05)}
    assert list(rig.uncertainty) == list(EVERY_KEY["uncertainty"])  # the file's order
    assert hash(rig) == hash(rig_from_dict(EVERY_KEY)) and rig == rig_from_dict(EVERY_KEY)
    assert rig != rig_from_dict(dict(EVERY_KEY, uncertainty={"load_inertia": [4.0, 9.0]}))
    assert not _rig().uncertainty and dict(_rig().uncertainty) == {}
    with pytest.raises(TypeError):
        rig.uncertainty["load_inertia"] = (1.0, 2.0)
    sent = pickle.loads(pickle.dumps(rig))  # as an executor sends a rig to its workers
    assert sent == rig and hash(sent) == hash(rig) and dict(sent.uncertainty) == dict(rig.uncertainty)


def test_a_checkpoint_describes_the_new_values_by_name():
    described = describe(rig_from_dict(EVERY_KEY), omit=("source",))
    assert described["friction"] == FRICTION
    assert described["uncertainty"]["coulomb_load"] == [10.0, 30.0]
    assert described["load"] == {"torque": -40.0, "torque_offset": 3.25}


# --------------------------------------------------------------------------- to_dict, with_values, repr

def test_to_dict_round_trip_keeps_every_new_value():
    rig = rig_from_dict(EVERY_KEY)
    data = rig.to_dict()
    assert data["friction"] == FRICTION and data["load"] == EVERY_KEY["load"]
    assert data["uncertainty"]["coulomb_load"] == [10.0, 30.0]
    assert rig_from_dict(data) == rig


@pytest.mark.parametrize("name, table", [(key, "friction") for key in FRICTION if key != "stribeck_speed"]
                         + [("torque_offset", "load")])
def test_with_values_varies_the_friction_and_the_offset(name, table):
    rig = _rig(friction={"stribeck_speed": 0.1})
    changed = rig.with_values(**{name: 7.5})
    assert getattr(getattr(changed, table), name) == 7.5
    assert rig.with_values(**{f"{table}.{name}": 7.5}) == changed
    assert dataclasses.replace(changed, **{table: getattr(rig, table)}, source=rig.source) == rig


def test_with_values_checks_friction_as_the_file_does_and_keeps_the_boxes():
    rig = rig_from_dict(EVERY_KEY)
    assert rig.with_values(coulomb_load=25.0).uncertainty == rig.uncertainty
    with pytest.raises(RigError, match=r"\[friction\] coulomb_load must be >= 0"):
        rig.with_values(coulomb_load=-1.0)
    with pytest.raises(RigError, match=r"\[uncertainty\] coulomb_load = \[10, 30\] N m excludes"):
        rig.with_values(coulomb_load=40.0)
    with pytest.raises(RigError, match=r"breakaway_load = 8 N m needs stribeck_speed > 0"):
        _rig(friction={"breakaway_load": 8.0, "stribeck_speed": 1.0}).with_values(stribeck_speed=0.0)


def test_repr_shows_friction_and_uncertainty_only_where_the_rig_has_them():
    plain = repr(_rig())
    assert "friction" not in plain and "uncertainty" not in plain
    assert plain.startswith("Rig(plant=Plant(") and plain.endswith("source='rig.toml')")
    full = repr(rig_from_dict(EVERY_KEY))
    assert "friction=Friction(coulomb_motor=1.5" in full and "uncertainty=Uncertainty({'load_inertia'" in full


# --------------------------------------------------------------------------- the writer

@pytest.mark.parametrize("path", EXAMPLE_RIGS, ids=lambda path: path.name)
def test_every_bundled_rig_is_written_and_read_back_equal(tmp_path, path):
    rig = load_rig(path)
    write_rig(rig, tmp_path / "rig.toml")
    back = load_rig(tmp_path / "rig.toml")
    assert dataclasses.replace(back, source=rig.source) == rig
    text = (tmp_path / "rig.toml").read_text()
    assert "[friction]" not in text and "[uncertainty]" not in text  # tables a rig without them does not need


def test_a_rig_with_every_key_is_written_with_comments_and_read_back_equal(tmp_path):
    rig = rig_from_dict(EVERY_KEY)
    path = tmp_path / "every.toml"
    write_rig(rig, path, comments={"coulomb_load": "95 %: [18, 22]", "uncertainty.load_inertia": "data sheet"},
              header="first line\nsecond line")
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    assert lines[:2] == ["# first line", "# second line"]
    assert "coulomb_load = 20.0  # 95 %: [18, 22]" in lines
    assert "load_inertia = [4.0, 8.0]  # data sheet" in lines and "load_inertia = 5.6" in lines
    assert "ti = inf" in lines and 'backlash = "rubber"' in lines and "torque_offset = 3.25" in lines
    assert dataclasses.replace(load_rig(path), source=rig.source) == rig
    assert rig.to_toml() == rig_to_toml(rig)
    assert tomllib.loads(rig.to_toml())["friction"] == FRICTION


def test_written_floats_read_back_to_the_same_doubles():
    values = {"motor_inertia": 0.1 + 0.2, "load_inertia": 10.0 / 3.0, "stiffness": 2.0 ** 14 / 3.0,
              "half_gap": math.pi / 7.0}
    rig = rig_from_dict({"plant": values, "friction": {"coulomb_load": 1.0 / 3.0, "viscous_load": 5e-300}})
    back = rig_from_dict(tomllib.loads(rig_to_toml(rig)))
    assert back == rig
    assert back.friction.coulomb_load.hex() == (1.0 / 3.0).hex()


# --------------------------------------------------------------------------- what the analyses do not model yet

DRY = [key for key in FRICTION if key.startswith(("coulomb", "breakaway"))]


@pytest.mark.parametrize("key", DRY)
def test_the_df_analyses_refuse_dry_friction_the_simulation_takes_it(key):
    rig = _rig(friction={key: 2.0, "stribeck_speed": 0.1})
    with pytest.raises(RigError, match=rf"^rig.toml: \[friction\] {key} = 2: this loop leaves dry friction out"):
        bd.drive_loop(rig)
    side = key.split("_")[1]
    assert bd.drive_loop(rig, dry_friction=True).linear_part().sticking.names == (side,)


def test_every_loop_refuses_a_torque_offset_in_one_line():
    rig = _rig(load={"torque_offset": -2.0})
    for dry_friction in (False, True):
        with pytest.raises(RigError, match=r"^rig.toml: \[load\] torque_offset = -2: no analysis of the loop models"):
            bd.drive_loop(rig, dry_friction=dry_friction)


@pytest.mark.parametrize("side", ["motor", "load"])
def test_viscous_friction_is_the_two_mass_drive_with_dampers(side):
    """G with viscous friction against its closed form: the plant blocks ``1 / (J s + d)`` (loops module docs)."""
    d = 7.0
    rig = _rig(friction={f"viscous_{side}": d})
    loop = bd.drive_loop(rig)
    omega = np.array([0.5, 20.0, 400.0])
    s = 1j * omega
    jm, jl = rig.plant.motor_inertia, rig.plant.load_inertia
    ctl = rig.controller
    c = ctl.kp * (1 + 1 / (ctl.ti * s)) / (ctl.speed_filter * s + 1) if ctl.speed_filter else \
        ctl.kp * (1 + 1 / (ctl.ti * s))
    p_m = 1 / (jm * s + (d if side == "motor" else 0.0))
    p_l = 1 / (jl * s + (d if side == "load" else 0.0))
    expected = (p_m / (1 + c * p_m) + p_l) / s if ctl.feedback == "motor" else (p_m * (1 + c * p_l) + p_l) / s
    np.testing.assert_allclose(loop.frequency_response(omega), expected, rtol=1e-12)
    np.testing.assert_allclose(loop.frd(omega).eval(omega), expected, rtol=1e-12)


def test_a_stribeck_speed_alone_and_the_boxes_change_no_number():
    plain = _rig()
    boxed = _rig(friction={"stribeck_speed": 0.2}, uncertainty={"load_inertia": [5.0, 6.0], "damping": [0, 5]})
    omega = [1.0, 30.0, 300.0]
    assert (bd.drive_loop(boxed).frequency_response(omega) == bd.drive_loop(plain).frequency_response(omega)).all()
    cycles = [(c.amplitude, c.omega) for c in bd.predict_limit_cycles(boxed).cycles]
    assert cycles and cycles == [(c.amplitude, c.omega) for c in bd.predict_limit_cycles(plain).cycles]


RIG_TOML = PLANT_TOML + """
[controller]
feedback = "load"
kp = 30.0
ti = 0.5
speed_filter = 0.002
"""


COMMANDS = {
    "predict": ["predict", "rig.toml", "--json", "out.json"],
    "tune": ["tune", "rig.toml", "--vary", "kp", "1,100", "--json", "out.json"],
    "map": ["map", "rig.toml", "--x", "kp", "10,20", "--y", "ti", "0.1,0.5", "--json", "out.json"],
    "continue": ["continue", "rig.toml", "--parameter", "kp", "--from", "10", "--to", "20", "--json", "out.json"],
}
DRY_FRICTION = ("friction", "breakaway_motor = 0.5\nstribeck_speed = 0.1", "Stribeck decay is not affine")
OFFSET = ("load", "torque_offset = -3.0", "models a torque offset")


@pytest.mark.parametrize("args, table, extra, words",
                         [(COMMANDS[name], *OFFSET) for name in COMMANDS]
                         + [(COMMANDS["continue"], *DRY_FRICTION)],  # predict, tune and map take it
                         ids=[f"{name}-offset" for name in COMMANDS] + ["continue-dry"])
def test_commands_refuse_friction_with_exit_code_2_and_write_nothing(tmp_path, monkeypatch, args, table, extra, words):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rig.toml").write_text(RIG_TOML + f"\n[{table}]\n{extra}\n")
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error: rig.toml"), result.output
    assert f"[{table}] {extra.split(' =')[0]}" in lines[0] and words in lines[0]
    assert sorted(path.name for path in tmp_path.iterdir()) == ["rig.toml"]


def test_load_coulomb_is_refused_by_a_command_with_a_pointer(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rig.toml").write_text(RIG_TOML + "\n[load]\ncoulomb = 0.0\n")
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10"])
    assert result.exit_code == 2
    assert result.output.strip() == ("backlash-df: error: rig.toml: [load] coulomb is now [friction] coulomb_load "
                                     "(N m, the load side's Coulomb friction); move the key there")


def test_every_command_accepts_the_boxes(tmp_path, monkeypatch):
    """The describing function of a rig with boxes is that of the rig without (no command reads them yet)."""
    monkeypatch.chdir(tmp_path)
    args = ["--amplitude", "0.1", "--omega", "10"]
    (tmp_path / "rig.toml").write_text(RIG_TOML)
    plain = CliRunner().invoke(main, ["df", "--rig", "rig.toml", *args])
    (tmp_path / "rig.toml").write_text(RIG_TOML + "\n[uncertainty]\nstiffness = [5000, 7000]\n")
    boxed = CliRunner().invoke(main, ["df", "--rig", "rig.toml", *args])
    assert boxed.exit_code == plain.exit_code == 0 and boxed.output == plain.output
