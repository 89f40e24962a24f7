"""``diagnose --rig-out``: the diagnosed model as a rig file (:meth:`~backlash_df.identify.Diagnosis.rig_out`).

The bundled friction record is diagnosed once (about 9 s) and its rig read back against the
diagnosis' own JSON; the mapping of every catalogue effect to its rig key, the clipping of the
boxes and the dropped causes are checked on hand-made diagnoses whose expected rig is written
out here.
"""

import dataclasses
import json
import re
import tomllib
from types import SimpleNamespace

import pytest
from click.testing import CliRunner

import backlash_df.cli.diagnose
from backlash_df.cli import main
from backlash_df.config import Friction, load_rig, rig_from_dict
from backlash_df.identify import Cause, DiagnosedRig, Diagnosis, FitParameter
from backlash_df.identify.predictors import PLANT_PARAMETERS
from conftest import EXAMPLES

RIG = EXAMPLES / "diagnose_rig.toml"
RECORD = EXAMPLES / "diagnose_friction.csv"
INTERVAL = re.compile(r"^(\w+) = (\S+)  # 95 %: \[(\S+), (\S+)\]$")


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    """The CLI's ``--rig-out`` and ``--json`` of the bundled friction record: (rig path, JSON, stdout+stderr)."""
    folder = tmp_path_factory.mktemp("rig_out")
    out, data = folder / "diagnosed.toml", folder / "diagnosis.json"
    result = CliRunner().invoke(main, ["diagnose", str(RECORD), "--rig", str(RIG), "--json", str(data),
                                       "--rig-out", str(out)])
    assert result.exit_code == 0, result.output
    return out, json.loads(data.read_text()), result.output


def test_the_written_rig_loads_with_the_diagnosis_values(diagnosed):
    path, data, _ = diagnosed
    rig, given = load_rig(path), load_rig(RIG)
    (cause,) = data["causes"]
    assert (cause["effect"], cause["side"]) == ("coulomb_friction", "load")
    assert rig.friction == Friction(coulomb_load=cause["parameters"]["coulomb_friction"]["value"])
    whole = data["whole_record"]["parameters"]
    assert {name: getattr(rig.plant, name) for name in PLANT_PARAMETERS} == {
        name: whole[name]["value"] for name in PLANT_PARAMETERS}
    assert (rig.plant.rubber_thickness, rig.plant.gear_ratio) == (given.plant.rubber_thickness, 1.0)
    assert (rig.controller, rig.model, rig.load) == (given.controller, given.model, given.load)


def test_every_value_with_an_interval_has_its_box_and_its_comment(diagnosed):
    path, data, _ = diagnosed
    rig, whole = load_rig(path), data["whole_record"]["parameters"]
    intervals = {name: whole[name]["ci95"] for name in PLANT_PARAMETERS}
    intervals["coulomb_load"] = data["causes"][0]["parameters"]["coulomb_friction"]["ci95"]
    values = dataclasses.asdict(rig.plant) | dataclasses.asdict(rig.friction)
    assert set(rig.uncertainty) == set(intervals)
    for name, (low, high) in intervals.items():
        assert low <= values[name] <= high, name  # the intervals hold their values: no clipping here
        assert rig.uncertainty[name] == (low, high), name
    commented = {}
    for line in path.read_text().splitlines():
        match = INTERVAL.match(line)
        if match:
            commented[match[1]] = (float(match[3]), float(match[4]))
            assert float(match[2]) == values[match[1]]
    assert set(commented) == set(intervals)
    for name, (low, high) in intervals.items():
        assert commented[name] == (pytest.approx(low, rel=1e-5), pytest.approx(high, rel=1e-5)), name


def test_nothing_is_dropped_from_this_record(diagnosed):
    path, _, output = diagnosed
    assert "dropped:" not in output and "dropped:" not in path.read_text()
    assert path.read_text().splitlines()[0] == f"# The rig {RIG} diagnosed from {RECORD}."


@pytest.mark.parametrize("name", ["diagnosed.txt", "diagnosed.json", "diagnosed", "diagnosed.TOM"])
def test_a_rig_out_without_the_toml_suffix_writes_nothing(tmp_path, monkeypatch, name):
    def never(*args, **kwargs):
        raise AssertionError("the diagnosis ran although an output path is bad")

    monkeypatch.setattr(backlash_df.cli.diagnose, "run_diagnosis", never)
    result = CliRunner().invoke(main, ["diagnose", str(RECORD), "--rig", str(RIG), "--json",
                                       str(tmp_path / "d.json"), "--rig-out", str(tmp_path / name)])
    assert result.exit_code == 2
    assert result.output.strip() == (f"backlash-df: error: --rig-out {tmp_path / name}: --rig-out writes a rig "
                                     f"file, which needs the suffix .toml")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- the mapping, on hand-made diagnoses

def _parameter(name, value, low, high, unit="", bounds=(-1e6, 1e6)):
    return FitParameter(name, value, 0.0, 0.0, *bounds, unit=unit, interval=(low, high))


def _cause(effect, side, value, low, high, unit="N m", structure="two_mass", **fields):
    return Cause(effect, side, {effect: _parameter(effect, value, low, high, unit)}, 0.5, structure, **fields)


def _diagnosis(rig, causes, structure="two_mass", plant=None, inertia=None):
    plant = plant or {name: _parameter(name, 1.02 * getattr(rig.plant, name), getattr(rig.plant, name),
                                       1.04 * getattr(rig.plant, name)) for name in PLANT_PARAMETERS}
    rigid = SimpleNamespace(whole_record=SimpleNamespace(parameters={"inertia": inertia}))
    return SimpleNamespace(rig=rig, whole_record=SimpleNamespace(parameters=plant), structure=structure,
                           causes=causes, measurements=SimpleNamespace(source="record.csv"), rigid_body=rigid)


def test_each_effect_goes_to_its_rig_key():
    rig = dataclasses.replace(load_rig(RIG), source="rig.toml")
    causes = [_cause("breakaway_friction", "motor", 2.0, 1.5, 2.5, stribeck_speed=0.3),
              _cause("viscous_friction", "load", 0.2, -0.1, 0.5, unit="N m s/rad"),
              _cause("coulomb_friction", "motor", 3.0, 2.0, 4.0),
              _cause("torque_offset", None, -4.0, -5.0, -3.0),
              _cause("rubber", None, 0.01, 0.008, 0.05, unit="rad")]
    out = Diagnosis.rig_out(_diagnosis(rig, causes))
    expected = Friction(coulomb_motor=3.0, viscous_load=0.2, breakaway_motor=2.0, stribeck_speed=0.3)
    assert out.rig.friction == expected
    assert out.rig.load.torque_offset == -4.0
    assert (out.rig.plant.rubber_thickness, out.rig.model) == (0.01, "rubber")
    assert out.rig.plant.stiffness == 1.02 * rig.plant.stiffness
    assert out.rig.source == "rig.toml diagnosed from record.csv"
    box = out.rig.uncertainty
    assert box["viscous_load"] == (0.0, 0.5)  # clipped at the key's range, not below 0
    assert box["rubber_thickness"] == (0.008, 2.0 * out.rig.plant.half_gap)  # inside the gap (rubber <= 2 alpha)
    assert box["torque_offset"] == (-5.0, -3.0) and box["breakaway_motor"] == (1.5, 2.5)
    assert box["stiffness"] == (rig.plant.stiffness, 1.04 * rig.plant.stiffness)
    assert "stribeck_speed" not in box  # chosen on a grid: no interval
    assert out.intervals["viscous_load"] == (-0.1, 0.5)  # the comment keeps the interval as the diagnosis gives it
    assert out.dropped == []
    assert any('[model] backlash is "rubber"' in note for note in out.notes)
    assert rig_from_dict(tomllib.loads(out.to_toml()), source=out.rig.source) == out.rig


def test_an_interval_that_leaves_its_value_is_widened_to_hold_it():
    rig = load_rig(RIG)
    out = Diagnosis.rig_out(_diagnosis(rig, [_cause("coulomb_friction", "load", 4.0, 4.5, 5.0)]))
    assert out.rig.uncertainty["coulomb_load"] == (4.0, 5.0)


def test_causes_without_a_rig_key_or_a_value_are_dropped_not_lost():
    rig = load_rig(RIG)
    delay = _cause("actuator_delay", None, 0.003, 0.002, 0.004, unit="s")
    undetermined = _cause("coulomb_friction", "load", 4.0, 3.0, 5.0, determined=False)
    out = Diagnosis.rig_out(_diagnosis(rig, [delay, undetermined]))
    assert out.rig.friction == Friction() and out.rig.controller == rig.controller
    assert len(out.dropped) == 2
    assert out.dropped[0].startswith("actuator_delay = 0.003 s (95 %: [0.002, 0.004]): no rig key")
    assert "[controller] delay (dead time on every measured signal) is 0 s" in out.dropped[0]
    assert out.dropped[1] == "coulomb_friction@load: named, but the record does not determine its value"
    text = out.to_toml()
    assert f"# dropped: {out.dropped[0]}" in text.splitlines() and "actuator_delay" not in text.split("[plant]")[1]
    assert "DiagnosedRig" in repr(out) and "2 dropped" in repr(out)


def test_an_actuator_delay_the_rig_holds_is_not_dropped():
    rig = load_rig(RIG).with_values(delay=0.003)
    out = Diagnosis.rig_out(_diagnosis(rig, [_cause("actuator_delay", None, 0.0031, 0.0025, 0.0036, unit="s")]))
    assert out.dropped == [] and out.rig.controller.delay == 0.003
    assert out.notes == ["actuator_delay = 0.0031 s (95 %: [0.0025, 0.0036]) agrees with the rig's [controller] "
                         "delay = 0.003 s"]


def test_a_plant_value_on_its_bound_stays_the_rigs():
    rig = load_rig(RIG)
    plant = {name: _parameter(name, getattr(rig.plant, name), 0.9 * getattr(rig.plant, name),
                              1.1 * getattr(rig.plant, name)) for name in PLANT_PARAMETERS}
    plant["damping"] = _parameter("damping", 15.0, 14.0, 16.0, "N m s/rad", bounds=(0.0, 15.0))
    out = Diagnosis.rig_out(_diagnosis(rig, [], plant=plant))
    assert out.rig.plant.damping == rig.plant.damping and "damping" not in out.rig.uncertainty
    assert out.notes == ["[plant] damping stays the rig's 3: its fit ended on a bound of the range it was allowed "
                         "(15 N m s/rad)"]


def test_the_rigid_body_splits_its_inertia_in_the_rigs_ratio_and_puts_friction_on_the_load_side():
    rig = load_rig(RIG)  # J_m = 0.4, J_l = 5.6: shares 1/15 and 14/15
    inertia = _parameter("inertia", 7.5, 7.2, 7.8, "kg m^2")
    causes = [_cause("coulomb_friction", "load", 7.0, 5.0, 9.0, structure="rigid_body")]
    out = Diagnosis.rig_out(_diagnosis(rig, causes, structure="rigid_body", inertia=inertia))
    assert out.rig.plant.motor_inertia == pytest.approx(0.5, rel=1e-15)
    assert out.rig.plant.load_inertia == pytest.approx(7.0, rel=1e-15)
    assert out.rig.uncertainty["load_inertia"] == pytest.approx((7.2 * 14 / 15, 7.8 * 14 / 15), rel=1e-15)
    assert (out.rig.plant.stiffness, out.rig.plant.half_gap) == (rig.plant.stiffness, rig.plant.half_gap)
    assert out.rig.friction == Friction(coulomb_load=7.0)
    assert len(out.notes) == 2 and "written on the load side" in out.notes[1]


def test_diagnosed_rig_is_the_rig_of_rig_out():
    rig = load_rig(RIG)
    diagnosis = _diagnosis(rig, [_cause("coulomb_friction", "load", 4.0, 3.0, 5.0)])
    diagnosis.rig_out = lambda: Diagnosis.rig_out(diagnosis)
    assert Diagnosis.diagnosed_rig(diagnosis) == Diagnosis.rig_out(diagnosis).rig
    assert isinstance(Diagnosis.rig_out(diagnosis), DiagnosedRig)


def test_a_rigid_body_inertia_on_its_bound_leaves_the_plant_the_rigs():
    rig = load_rig(RIG)
    inertia = _parameter("inertia", 7.8, 7.5, 8.1, "kg m^2", bounds=(4.2, 7.8))
    out = Diagnosis.rig_out(_diagnosis(rig, [], structure="rigid_body", inertia=inertia))
    assert out.rig.plant == rig.plant and dict(out.rig.uncertainty) == {}
    assert out.notes == ["the record does not resolve the shaft's mode, and the rigid-body model's inertia ended on a "
                         "bound of the range it was allowed (7.8 kg m^2): every plant value stays the rig's"]
