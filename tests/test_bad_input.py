"""A corpus of bad inputs and output paths for every command.

Each bad case must end with exit code 2 and ONE line on the terminal,
``backlash-df: error: ...``, naming the file, key or option and the problem; no
traceback, and no output file left behind.  Output paths are checked before any
computation (the heavy stages are replaced by a function that fails the test if
it is reached).  Accepted inputs exit 0, and the files written honour the umask
and symbolic links.  Most cases run in-process through click's ``CliRunner``; a
few run the installed console script.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

import backlash_df.analysis
import backlash_df.cli.diagnose
import backlash_df.cli.sweeps
import backlash_df.cli.tune
import backlash_df.reproduce
from backlash_df.cli import main
from backlash_df.cli.common import COMPILING_NOTICE
from backlash_df.cli.outputs import Outputs
from backlash_df.identify.measurements import OPTIONAL_COLUMNS, REQUIRED_COLUMNS
from conftest import DOCS, EXAMPLES, PLANT_TOML

RIG = PLANT_TOML + """
[controller]
feedback = "load"
kp = 30.0
ti = 0.5
speed_filter = 0.002
delay = 0.0
"""

CSV = "time,motor_torque,motor_speed\n" + "".join(f"{0.001 * i:.3f},{(-1) ** i},{0.1 * i}\n" for i in range(50))


def _never(*args, **kwargs):
    raise AssertionError("computation reached although the input is bad")


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A scratch directory holding rig.toml and data.csv, as the working directory."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rig.toml").write_text(RIG)
    (tmp_path / "data.csv").write_text(CSV)
    (tmp_path / "folder").mkdir()
    return tmp_path


@pytest.fixture
def no_computation(monkeypatch):
    """Fail the test if a command gets as far as its heavy stage."""
    monkeypatch.setattr(backlash_df.analysis, "predict_limit_cycles", _never)
    monkeypatch.setattr(backlash_df.cli.diagnose, "run_diagnosis", _never)
    monkeypatch.setattr(backlash_df.reproduce, "table1", _never)
    monkeypatch.setattr(backlash_df.reproduce, "compare_torques", _never)
    monkeypatch.setattr(backlash_df.reproduce, "figure2_maps", _never)
    monkeypatch.setattr(backlash_df.cli.sweeps, "design_map", _never)
    monkeypatch.setattr(backlash_df.cli.sweeps, "continue_limit_cycles", _never)
    monkeypatch.setattr(backlash_df.cli.tune, "tune", _never)


def rig_with(old, new):
    """The good rig with one line replaced."""
    assert old in RIG
    return RIG.replace(old, new)


def assert_refused(result, words, folder):
    """Exit 2, one ``backlash-df: error:`` line holding every word, no traceback, no new file."""
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    assert lines[0].startswith("backlash-df: error: "), lines[0]
    assert "Traceback" not in result.output
    for word in words:
        assert word in lines[0], (word, lines[0])
    left = sorted(path.name for path in folder.rglob("*")
                  if path.name not in {"rig.toml", "data.csv", "folder", "dangling.json"})
    assert left == [], left


# --------------------------------------------------------------------------- rig files

RIG_CASES = {
    "empty file": ("", ["rig.toml", "missing table [plant]"]),
    "malformed TOML": (RIG + "\n[plant\n", ["rig.toml", "malformed TOML"]),
    "duplicate key": (rig_with("kp = 30.0", "kp = 30.0\nkp = 31.0"), ["rig.toml", "malformed TOML"]),
    "unknown table": (RIG + "\n[extras]\nx = 1\n", ["rig.toml", "unknown table [extras]"]),
    "plant not a table": ("plant = 1\n", ["rig.toml", "[plant] must be a table"]),
    "unknown plant key": (rig_with("half_gap = 0.05", "half_gap = 0.05\nbacklash = 0.1"),
                          ["rig.toml", "unknown key [plant] backlash"]),
    "unknown controller key": (rig_with("kp = 30.0", "kp = 30.0\ngain = 2.0"), ["unknown key [controller] gain"]),
    "missing stiffness": (rig_with("stiffness = 5895.0", ""), ["missing key [plant] stiffness"]),
    "missing kp": (rig_with("kp = 30.0", ""), ["missing key [controller] kp"]),
    "negative inertia": (rig_with("motor_inertia = 0.4", "motor_inertia = -0.4"),
                         ["[plant] motor_inertia", "must be > 0"]),
    "zero stiffness": (rig_with("stiffness = 5895.0", "stiffness = 0.0"), ["[plant] stiffness", "must be > 0"]),
    "negative damping": (rig_with("damping = 3.0", "damping = -3.0"), ["[plant] damping", "must be >= 0"]),
    "nan damping": (rig_with("damping = 3.0", "damping = nan"), ["[plant] damping", "must be finite"]),
    "inf stiffness": (rig_with("stiffness = 5895.0", "stiffness = inf"), ["[plant] stiffness", "must be finite"]),
    "string kp": (rig_with("kp = 30.0", 'kp = "fast"'), ["[controller] kp", "must be a number"]),
    "boolean ti": (rig_with("ti = 0.5", "ti = true"), ["[controller] ti", "must be a number"]),
    "stiffness 1e300": (rig_with("stiffness = 5895.0", "stiffness = 1e300"),
                        ["[plant] stiffness = 1e+300", "outside the accepted range [1e-06, 1e+12]"]),
    "kp 1e300": (rig_with("kp = 30.0", "kp = 1e300"), ["[controller] kp = 1e+300", "outside the accepted range"]),
    "motor inertia 1e-300": (rig_with("motor_inertia = 0.4", "motor_inertia = 1e-300"),
                             ["[plant] motor_inertia = 1e-300", "[1e-10, 1e+10] kg m^2"]),
    "load inertia 1e30": (rig_with("load_inertia = 5.6", "load_inertia = 1e30"), ["[plant] load_inertia = 1e+30"]),
    "half gap 1e300": (rig_with("half_gap = 0.05", "half_gap = 1e300"), ["[plant] half_gap = 1e+300", "rad"]),
    "half gap 4 rad": (rig_with("half_gap = 0.05", "half_gap = 4.0"), ["[plant] half_gap = 4", "3.14159"]),
    "delay 1e300": (rig_with("delay = 0.0", "delay = 1e300"), ["[controller] delay = 1e+300", "[0, 10] s"]),
    "ti 1e-300": (rig_with("ti = 0.5", "ti = 1e-300"), ["[controller] ti = 1e-300"]),
    "speed filter 1e9": (rig_with("speed_filter = 0.002", "speed_filter = 1e9"), ["[controller] speed_filter"]),
    "gear ratio 1e9": (rig_with("half_gap = 0.05", "half_gap = 0.05\ngear_ratio = 1e9"), ["[plant] gear_ratio = 1e+09"]),
    "load torque 1e300": (RIG + "\n[load]\ntorque = -1e300\n", ["[load] torque = -1e+300"]),
    "load torque twisting a turn": (RIG + "\n[load]\ntorque = 1e6\n", ["[load] torque = 1e+06 N m", "more than a turn"]),
    "rubber wider than the gap": (rig_with("half_gap = 0.05", "half_gap = 0.05\nrubber_thickness = 0.5"),
                                  ["[plant] rubber_thickness must be <="]),
    "bad feedback": (rig_with('feedback = "load"', 'feedback = "both"'), ["[controller] feedback"]),
    "unknown model": (RIG + '\n[model]\nbacklash = "hysteresis"\n', ["[model] backlash", "'hysteresis'"]),
    "rubber model without beta": (RIG + '\n[model]\nbacklash = "rubber"\n',
                                  ["rig.toml", "'rubber' needs [plant] rubber_thickness > 0"]),
    "unknown model key": (RIG + '\n[model]\nlaw = "rubber"\n', ["unknown key [model] law"]),
    "no controller": (RIG.split("[controller]")[0], ["rig.toml", "no [controller] table"]),
}


@pytest.mark.parametrize("text, words", list(RIG_CASES.values()), ids=list(RIG_CASES))
def test_predict_refuses_bad_rig(work, no_computation, text, words):
    (work / "rig.toml").write_text(text)
    result = CliRunner().invoke(main, ["predict", "rig.toml", "--json", "out.json", "--report", "out.html"])
    assert_refused(result, words, work)


def test_rig_not_utf8_names_the_file(work, no_computation):
    (work / "rig.toml").write_bytes(RIG.replace("load_inertia", "# Tr\xe4gheit\nload_inertia").encode("latin-1"))
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10"])
    assert_refused(result, ["rig.toml", "not a UTF-8 text file", "0xe4"], work)


@pytest.mark.parametrize("args, words", [
    (["predict", "nope.toml"], ["nope.toml", "cannot read rig file"]),
    (["predict", "folder"], ["folder", "is a directory"]),
    (["predict", "rig.toml", "--model", "rubber"], ["rig.toml", "'rubber' needs [plant] rubber_thickness"]),
    (["predict", "rig.toml", "--model", "coulomb"], ["'--model'", "'coulomb' is not one of", "phase-plane"]),
    (["predict"], ["Missing argument 'RIG_FILE'"]),
    (["predict", "rig.toml", "--jsn", "x.json"], ["No such option", "--jsn"]),
], ids=["missing rig", "rig is a directory", "rubber without beta", "unknown model", "no rig", "misspelt option"])
def test_predict_refuses_bad_arguments(work, no_computation, args, words):
    assert_refused(CliRunner().invoke(main, args), words, work)


# --------------------------------------------------------------------------- output paths

OUTPUT_CASES = {
    "predict json in missing dir": (["predict", "rig.toml", "--json", "nodir/out.json"],
                                    ["--json nodir/out.json", "directory nodir does not exist"]),
    "predict json under /proc": (["predict", "rig.toml", "--json", "/proc/x/out.json"],
                                 ["--json /proc/x/out.json", "does not exist"]),
    "predict report in missing dir": (["predict", "rig.toml", "--report", "nodir/r.html"],
                                      ["--report nodir/r.html", "does not exist"]),
    "predict json fine, report not": (["predict", "rig.toml", "--json", "out.json", "--report", "nodir/out.html"],
                                      ["--report nodir/out.html"]),
    "predict json is a directory": (["predict", "rig.toml", "--json", "folder"], ["'--json'", "is a directory"]),
    "predict one file twice": (["predict", "rig.toml", "--json", "out.txt", "--report", "out.txt"],
                               ["--report out.txt", "same file as --json"]),
    "predict json below a file": (["predict", "rig.toml", "--json", "rig.toml/out.json"],
                                  ["--json rig.toml/out.json", "rig.toml is a file, not a directory"]),
    "predict json link into nowhere": (["predict", "rig.toml", "--json", "dangling.json"],
                                       ["--json dangling.json", "gone", "does not exist"]),
    "df json in missing dir": (["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json",
                                "nodir/df.json"], ["--json nodir/df.json", "does not exist"]),
    "df json to standard input": (["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json",
                                   "/dev/stdin"], ["--json /dev/stdin"]),
    "df json is a directory": (["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json",
                                "folder"], ["'--json'", "is a directory"]),
    "diagnose json in missing dir": (["diagnose", "data.csv", "--rig", "rig.toml", "--json", "nodir/d.json"],
                                     ["--json nodir/d.json", "does not exist"]),
    "diagnose report in missing dir": (["diagnose", "data.csv", "--rig", "rig.toml", "--json", "d.json",
                                        "--report", "nodir/d.html"], ["--report nodir/d.html"]),
    "reproduce table in missing dir": (["reproduce", "table1", "--out", "nodir/t.csv"],
                                       ["--out nodir/t.csv", "does not exist"]),
    "reproduce figure in missing dir": (["reproduce", "figure2", "--out", "nodir/f.png"], ["--out nodir/f.png"]),
    "reproduce table as text": (["reproduce", "table1", "--out", "t.txt"], ["--out t.txt", ".csv or .json"]),
    "reproduce figure as csv": (["reproduce", "figure3", "--out", "f.csv"], ["--out f.csv", ".png"]),
    "reproduce out is a directory": (["reproduce", "figure2", "--out", "folder"], ["'--out'", "is a directory"]),
    "reproduce figure of unknown format": (["reproduce", "figure2", "--out", "f.jpg"],
                                           ["--out f.jpg: figure2 is written as .png, .pdf or .svg"]),
    # issue 49: a suffix names the format; --json and --report refuse that of another kind of file
    "predict json as html": (["predict", "rig.toml", "--json", "p.html"],
                             ["--json p.html: --json writes JSON, not an HTML report (use .json)"]),
    "predict report as json": (["predict", "rig.toml", "--report", "r.json"],
                               ["--report r.json: --report writes an HTML report, not JSON (use .html or .htm)"]),
    "predict report as png, upper case": (["predict", "rig.toml", "--json", "p.json", "--report", "r.PNG"],
                                          ["--report r.PNG: --report writes an HTML report, not a figure"]),
    "df json as csv": (["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json", "df.csv"],
                       ["--json df.csv: --json writes JSON, not CSV (use .json)"]),
    "df json over a rig file": (["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json",
                                 "rig.toml"], ["--json rig.toml: --json writes JSON, not a rig file"]),
    "diagnose json as pdf": (["diagnose", "data.csv", "--rig", "rig.toml", "--json", "d.pdf"],
                             ["--json d.pdf: --json writes JSON, not a figure"]),
    "diagnose report as json": (["diagnose", "data.csv", "--rig", "rig.toml", "--report", "d.json"],
                                    ["--report d.json: --report writes an HTML report, not JSON"]),
    "tune report as svg": (["tune", "rig.toml", "--vary", "kp", "1,100", "--report", "t.svg"],
                           ["--report t.svg: --report writes an HTML report, not a figure"]),
    "tune json as htm": (["tune", "rig.toml", "--vary", "kp", "1,100", "--json", "t.htm"],
                         ["--json t.htm: --json writes JSON, not an HTML report"]),
}


@pytest.mark.parametrize("args, words", list(OUTPUT_CASES.values()), ids=list(OUTPUT_CASES))
def test_bad_output_path_is_refused_before_computing(work, no_computation, args, words):
    (work / "dangling.json").symlink_to(work / "gone" / "out.json")
    assert_refused(CliRunner().invoke(main, args), words, work)


@pytest.mark.parametrize("existed", [False, True])
def test_a_failed_write_leaves_the_files_as_they_were(tmp_path, existed):
    """All or none: the second file cannot be written (a directory appeared after the check), so the
    first is removed (new) or gets its old content and mode back (existing); no temporary file is left."""
    first, second = tmp_path / "a.json", tmp_path / "b.html"
    if existed:
        first.write_text("old")
        first.chmod(0o640)
    outputs = Outputs({"--json": first, "--report": second})
    second.mkdir()
    with pytest.raises(ValueError, match=r"--report .*b\.html: cannot write \(.*\); no output written"):
        outputs.write({"--json": "{}", "--report": "<html></html>"})
    assert sorted(path.name for path in tmp_path.iterdir()) == (["a.json", "b.html"] if existed else ["b.html"])
    if existed:
        assert first.read_text() == "old" and first.stat().st_mode & 0o777 == 0o640


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_unwritable_directory_is_refused(work, no_computation):
    locked = work / "folder"
    locked.chmod(0o500)
    try:
        result = CliRunner().invoke(main, ["predict", "rig.toml", "--json", "folder/out.json"])
    finally:
        locked.chmod(0o700)
    assert_refused(result, ["--json folder/out.json", "not writable"], work)


# --------------------------------------------------------------------------- df

DF_CASES = {
    "negative amplitude": (["--amplitude", "-0.1", "--omega", "10"], ["'--amplitude'", "must be > 0", "-0.1"]),
    "zero amplitude": (["--amplitude", "0", "--omega", "10"], ["'--amplitude'", "must be > 0"]),
    "amplitude not a number": (["--amplitude", "abc", "--omega", "10"], ["'--amplitude'", "not a number: 'abc'"]),
    "empty item in a list": (["--amplitude", "0.1,", "--omega", "10"], ["'--amplitude'", "not a number: ''"]),
    "nan amplitude": (["--amplitude", "nan", "--omega", "10"], ["'--amplitude'", "finite"]),
    "inf amplitude": (["--amplitude", "0.1,inf", "--omega", "10"], ["'--amplitude'", "finite"]),
    "negative omega": (["--amplitude", "0.1", "--omega", "-10"], ["'--omega'", "must be >= 0"]),
    "nan omega": (["--amplitude", "0.1", "--omega", "nan"], ["'--omega'", "finite"]),
    "nan bias": (["--amplitude", "0.1", "--omega", "10", "--bias", "nan"], ["'--bias'", "finite"]),
    "bias not a number": (["--amplitude", "0.1", "--omega", "10", "--bias", "x"], ["'--bias'"]),
    "unknown model": (["--model", "hysteresis", "--amplitude", "0.1", "--omega", "10"],
                      ["'--model'", "'hysteresis' is not one of"]),
    "bias drowning the amplitude": (["--amplitude", "0.1", "--omega", "10", "--bias", "1e300"],
                                    ["bias = 1e+300 rad", "times the amplitude 0.1 rad"]),
    "torque overflowing": (["--model", "exact", "--amplitude", "1e300", "--omega", "1e300"],
                           ["amplitude = 1e+300 rad at omega = 1e+300 rad/s", "overflows"]),
    "rubber without beta": (["--model", "rubber", "--amplitude", "0.1", "--omega", "10"],
                            ["rig.toml", "rubber_thickness > 0"]),
    "no amplitude": (["--omega", "10"], ["Missing option '--amplitude'"]),
    "misspelt option": (["--amplitude", "0.1", "--omeg", "10"], ["No such option '--omeg'"]),
}


@pytest.mark.parametrize("args, words", list(DF_CASES.values()), ids=list(DF_CASES))
def test_df_refuses_bad_arguments(work, args, words):
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", *args, "--json", "df.json"])
    assert_refused(result, words, work)


def test_df_without_rig_and_with_a_bad_rig(work):
    assert_refused(CliRunner().invoke(main, ["df", "--amplitude", "0.1", "--omega", "1"]),
                   ["Missing option '--rig'"], work)
    (work / "rig.toml").write_text(rig_with("stiffness = 5895.0", "stiffness = 1e300"))
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "1"])
    assert_refused(result, ["rig.toml", "[plant] stiffness"], work)


# --------------------------------------------------------------------------- reproduce

REPRODUCE_CASES = {
    "unknown figure": (["table2"], ["'table2' is not one of", "figure2"]),
    "unknown setup": (["figure3", "--setup", "foo"], ["'--setup'", "'foo' is not one of", "one-sided"]),
    "unknown driver": (["table1", "--driver", "rubber"], ["'--driver'", "'rubber' is not one of"]),
    "zero step": (["table1", "--dt", "0"], ["'--dt'", "0<x<0.001"]),
    "large step": (["table1", "--dt", "1"], ["'--dt'"]),
    "negative step": (["figure3", "--dt", "-1e-5"], ["'--dt'"]),
    "step not a number": (["figure3", "--dt", "fast"], ["'--dt'", "not a valid float"]),
}


@pytest.mark.parametrize("args, words", list(REPRODUCE_CASES.values()), ids=list(REPRODUCE_CASES))
def test_reproduce_refuses_bad_arguments(work, no_computation, args, words):
    assert_refused(CliRunner().invoke(main, ["reproduce", *args]), words, work)


def test_reproduce_step_that_does_not_divide_the_cycle(work):
    """3e-5 s does not divide the 0.05 s disturbance cycle: refused before the simulation."""
    result = CliRunner().invoke(main, ["reproduce", "figure3", "--dt", "3e-5", "--out", "f.png"])
    assert_refused(result, ["dt = 3e-05 s must divide the cycle"], work)


# --------------------------------------------------------------------------- diagnose

DIAGNOSE_CASES = {
    "missing csv": ("nope.csv", None, ["nope.csv", "cannot read measurement file"]),
    "missing column": ("time,motor_torque\n0,1\n0.001,2\n", None, ["data.csv", "motor_speed"]),
    "empty csv": ("", None, ["data.csv"]),
    "text in a number column": (CSV.replace("0.002,1,", "0.002,one,"), None, ["data.csv", "one"]),
    "missing rig": (CSV, "nope.toml", ["nope.toml", "cannot read rig file"]),
    "bad rig": (CSV, rig_with("damping = 3.0", "damping = -1.0"), ["rig.toml", "[plant] damping"]),
}


@pytest.mark.parametrize("csv_text, rig, words", list(DIAGNOSE_CASES.values()), ids=list(DIAGNOSE_CASES))
def test_diagnose_refuses_bad_input(work, no_computation, csv_text, rig, words):
    data = "data.csv"
    if csv_text == "nope.csv":
        data = csv_text
    else:
        (work / "data.csv").write_text(csv_text)
    rig_file = "rig.toml"
    if rig == "nope.toml":
        rig_file = rig
    elif rig is not None:
        (work / "rig.toml").write_text(rig)
    result = CliRunner().invoke(main, ["diagnose", data, "--rig", rig_file, "--json", "d.json", "--report", "d.html"])
    assert_refused(result, words, work)


def _misspelled_rubber_record(folder, old="load_torque", new="load_trq"):
    """examples/diagnose_rubber.csv with ``load_torque`` spelt ``load_trq`` (issue 23), as data.csv."""
    text = (EXAMPLES / "diagnose_rubber.csv").read_text()
    assert text.startswith("time,motor_torque,motor_speed,load_speed,load_torque\n")
    (folder / "data.csv").write_text(text.replace(old, new, 1))
    (folder / "rig.toml").write_text((EXAMPLES / "diagnose_rig.toml").read_text())


NOTICE = "data.csv: load_trq: not a known column; did you mean load_torque?"


@pytest.mark.parametrize("old, new", [("load_speed", "load_sped"), ("load_torque", "load_trq")])
def test_diagnose_refuses_a_misspelled_column_in_one_line(work, no_computation, old, new):
    """Issue 49: with load_speed spelt load_sped the diagnosis ran without the load speed (cause: none)."""
    _misspelled_rubber_record(work, old, new)
    result = CliRunner().invoke(main, ["diagnose", "data.csv", "--rig", "rig.toml", "--json", "d.json",
                                       "--report", "d.html"])
    assert_refused(result, [f"data.csv: column '{new}' looks like a misspelling of '{old}'",
                            "--allow-unknown-columns"], work)


def _diagnosis_reached(measurements, rig, **options):
    raise ValueError(f"diagnosis reached with {', '.join(measurements.columns())}")


def test_diagnose_only_notes_an_unrelated_unknown_column(work, monkeypatch):
    _misspelled_rubber_record(work, "load_torque", "temperature")
    monkeypatch.setattr(backlash_df.cli.diagnose, "run_diagnosis", _diagnosis_reached)
    result = CliRunner().invoke(main, ["diagnose", "data.csv", "--rig", "rig.toml"])
    assert result.stderr.splitlines() == [
        "note: data.csv: temperature: not a known column; known: time, motor_torque, motor_speed, load_speed, "
        "load_torque, motor_angle, load_angle",
        "backlash-df: error: diagnosis reached with time, motor_torque, motor_speed, load_speed"]


def test_diagnose_strict_refuses_a_misspelled_column_in_one_line(work, no_computation):
    _misspelled_rubber_record(work)
    result = CliRunner().invoke(main, ["diagnose", "data.csv", "--rig", "rig.toml", "--strict", "--json", "d.json"])
    assert_refused(result, [f"backlash-df: error: {NOTICE}"], work)


def test_diagnose_allowing_unknown_columns_names_a_misspelled_column_and_goes_on(work):
    _misspelled_rubber_record(work)
    result = CliRunner().invoke(main, ["diagnose", "data.csv", "--rig", "rig.toml", "--allow-unknown-columns",
                                       "--json", "d.json"])
    assert result.exit_code == 0, result.output
    assert f"note: {NOTICE}" in result.stderr.splitlines()
    assert result.stdout.startswith("cause: ")  # the diagnosis ran
    assert NOTICE in json.loads((work / "d.json").read_text())["warnings"]


def test_diagnose_help_has_the_contract_table_of_columns():
    """Each column of the contract page's CSV table in the help: its unit, side and whether it is required."""
    page = (DOCS / "contract.md").read_text().split("## The measurement CSV", 1)[1].split("\n\n**", 1)[0]
    contract = {}
    for line in (line for line in page.splitlines() if line.startswith("| `")):
        name, unit, side, required = [cell.strip().strip("`") for cell in line.strip("|").split("|")][:4]
        contract[name] = (unit, side, required)
    assert list(contract) == [*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS]
    result = CliRunner().invoke(main, ["diagnose", "--help"])
    assert result.exit_code == 0
    helped = {}
    for line in result.output.splitlines():  # "  name:  unit[, side side][, required]; holds"
        name, _, rest = line.strip().partition(": ")
        if name in contract:
            unit, *more = rest.split(";")[0].split(", ")
            side = next((item.removesuffix(" side") for item in more if item.endswith(" side")), "")
            helped[name] = (unit.strip(), side, "yes" if "required" in more else "no")
    assert helped == contract
    text = " ".join(result.output.split())
    for words in ("gear_ratio n (torque times n, speed and angle divided by n)", "positive motor_torque drives the "
                  "motor forward", "positive load_torque drives the load forward", "derivative of its angle",
                  "did you mean load_torque?", "--strict", "looks like a misspelling of an optional column",
                  "--allow-unknown-columns"):
        assert words in text, words


MAP_CASES = {
    "json in missing dir": (["--json", "nodir/m.json"], ["--json nodir/m.json", "does not exist"]),
    "plot is a directory": (["--plot", "folder"], ["'--plot'", "is a directory"]),
    "plot of unknown format": (["--plot", "m.xyz"],
                               ["--plot m.xyz: unknown plot format '.xyz' (use .png, .pdf or .svg)"]),
    "plot as json": (["--json", "m.json", "--plot", "m2.json"], ["--plot m2.json: unknown plot format '.json'"]),
    "report as png": (["--report", "m.png"], ["--report m.png: --report writes an HTML report, not a figure"]),
    "json as svg": (["--json", "m.svg"], ["--json m.svg: --json writes JSON, not a figure (use .json)"]),
    "unknown model": (["--model", "coulomb"], ["'--model'", "'coulomb' is not one of"]),
    "rubber without beta": (["--model", "rubber"], ["rig.toml", "rubber_thickness > 0"]),
    "bad grid": (["--x", "kp", "5:60"], ["--x '5:60'", "START:STOP:N"]),
    "unknown rig value": (["--x", "gain", "1,2"], ["gain"]),
    "no workers": (["--workers", "0"], ["--workers must be >= 1"]),
}


@pytest.mark.parametrize("args, words", list(MAP_CASES.values()), ids=list(MAP_CASES))
def test_map_refuses_bad_input_before_computing(work, no_computation, args, words):
    assert_refused(CliRunner().invoke(main, ["map", "rig.toml", *args]), words, work)


CONTINUE_CASES = {
    "json in missing dir": (["--from", "1", "--to", "5", "--json", "nodir/c.json"], ["--json nodir/c.json"]),
    "nan start": (["--from", "nan", "--to", "5"], ["'--from'", "must be finite"]),
    "unknown model": (["--from", "1", "--to", "5", "--model", "foo"], ["'--model'", "'foo' is not one of"]),
    "too few DF values": (["--from", "1", "--to", "5", "--df-values", "1"], ["'--df-values'", "x>=2"]),
    "no end": (["--from", "1"], ["Missing option '--to'"]),
    "plot of unknown format": (["--from", "1", "--to", "5", "--plot", "c.jpeg"],
                               ["--plot c.jpeg: unknown plot format '.jpeg' (use .png, .pdf or .svg)"]),
    "report as csv": (["--from", "1", "--to", "5", "--report", "c.csv"],
                      ["--report c.csv: --report writes an HTML report, not CSV"]),
}


@pytest.mark.parametrize("args, words", list(CONTINUE_CASES.values()), ids=list(CONTINUE_CASES))
def test_continue_refuses_bad_input_before_computing(work, no_computation, args, words):
    assert_refused(CliRunner().invoke(main, ["continue", "rig.toml", "--parameter", "kp", *args]), words, work)


def test_diagnose_without_rig(work, no_computation):
    assert_refused(CliRunner().invoke(main, ["diagnose", "data.csv"]), ["Missing option '--rig'"], work)


def test_bare_command_prints_its_help(work):
    result = CliRunner().invoke(main, [])
    assert result.exit_code == 2
    assert "Usage: backlash-df" in result.output and "error:" not in result.output
    for command in ("predict", "df", "diagnose", "reproduce"):
        assert command in result.output


def test_unknown_command_and_option(work):
    assert_refused(CliRunner().invoke(main, ["identify", "rig.toml"]), ["No such command 'identify'"], work)
    assert_refused(CliRunner().invoke(main, ["--verbose"]), ["No such option", "--verbose"], work)


# --------------------------------------------------------------------------- accepted inputs


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_accepted_df_run_writes_json_with_the_umask(work, umask, mode):
    """Exit 0, no warning (numba's FutureWarning on broadcast views is gone), the mode the umask gives."""
    old = os.umask(umask)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.06,0.1", "--omega",
                                               "10", "--json", "df.json"])
    finally:
        os.umask(old)
    assert result.exit_code == 0, result.output
    assert len(json.loads((work / "df.json").read_text())["points"]) == 2
    assert (work / "df.json").stat().st_mode & 0o777 == mode


def test_a_symlink_given_as_output_is_written_through(work):
    (work / "link.json").symlink_to(work / "folder" / "target.json")
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10",
                                       "--json", "link.json"])
    assert result.exit_code == 0, result.output
    assert (work / "link.json").is_symlink()
    assert json.loads((work / "folder" / "target.json").read_text())["model"] == "phase-plane"


def test_an_existing_file_keeps_its_mode(work):
    out = work / "df.json"
    out.write_text("old")
    out.chmod(0o640)
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10",
                                       "--json", "df.json"])
    assert result.exit_code == 0, result.output
    assert out.stat().st_mode & 0o777 == 0o640 and out.read_text().startswith("{")
    assert not list(work.glob(".*")), list(work.glob(".*"))  # no temporary or backup file left


def test_accepted_predict_run_writes_both_outputs_and_the_report_reads_as_text(work):
    """Exit 0, JSON and HTML written; the report shows no Python repr such as ``MeasuredCycle(amplitude=...)``."""
    result = CliRunner().invoke(main, ["predict", "rig.toml", "--model", "phase-plane", "--model", "damped-dead-zone",
                                       "--json", "out.json", "--report", "out.html"])
    assert result.exit_code == 0, result.output
    payload = json.loads((work / "out.json").read_text())
    assert [entry["model"] for entry in payload["models"]] == ["phase-plane", "damped-dead-zone"]  # none dropped
    report = (work / "out.html").read_text()
    assert "<b>damped-dead-zone</b>" in report
    assert "limit cycle: A = " in report
    assert not re.search(r"\b[A-Z][A-Za-z]+\([a-z_]+=", report), re.search(r"\b[A-Z][A-Za-z]+\([a-z_]+=.{0,40}", report)


@pytest.mark.parametrize("name, magic", [("m.pdf", b"%PDF-"), ("m.svg", b"<?xml"), ("m.PNG", b"\x89PNG\r\n\x1a\n"),
                                         ("m", b"\x89PNG\r\n\x1a\n")])
def test_plot_is_written_in_the_format_its_suffix_names(work, name, magic):
    """Issue 49: ``--plot m.pdf`` wrote a PNG named m.pdf (the quickest command with --plot: a map, no simulation)."""
    result = CliRunner().invoke(main, ["map", "rig.toml", "--x", "kp", "20,30", "--y", "ti", "0.5", "--no-simulate",
                                       "--plot", name])
    assert result.exit_code == 0, result.output
    data = (work / name).read_bytes()
    assert data.startswith(magic), data[:16]
    assert name != "m.svg" or b"<svg" in data


def test_reproduce_figure2_writes_a_png(work):
    result = CliRunner().invoke(main, ["reproduce", "figure2", "--out", "f.png"])
    assert result.exit_code == 0, result.output
    assert (work / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- real processes


def _script():
    script = shutil.which("backlash-df", path=str(Path(sys.executable).parent)) or shutil.which("backlash-df")
    assert script, "the backlash-df console script is not installed (pip install -e .)"
    return script


def _run(work, *args):
    return subprocess.run([_script(), *args], cwd=work, capture_output=True, text=True, timeout=300,
                          stdin=subprocess.DEVNULL, env={**os.environ, "MPLBACKEND": "Agg"})


def test_json_to_dash_is_standard_output(work):
    result = CliRunner().invoke(main, ["df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10",
                                       "--json", "-"])
    assert result.exit_code == 0, result.output
    table, _, payload = result.output.partition("{")
    assert "gain (N m/rad)" in table and json.loads("{" + payload)["points"][0]["omega"] == 10.0
    assert not (work / "-").exists()


def test_process_json_to_dev_stdout_follows_the_table(work):
    result = _run(work, "df", "--rig", "rig.toml", "--amplitude", "0.1", "--omega", "10", "--json", "/dev/stdout")
    assert result.returncode == 0, result.stderr
    assert result.stderr.replace(COMPILING_NOTICE + "\n", "") == ""  # no warnings (a cold cache's notice aside)
    table, _, payload = result.stdout.partition("{")
    assert "gain (N m/rad)" in table
    assert json.loads("{" + payload)["points"][0]["amplitude"] == 0.1


@pytest.mark.parametrize("args, words", [
    (["predict", "rig.toml", "--json", "nodir/x.json"], ["--json nodir/x.json"]),
    (["df", "--rig", "rig.toml", "--amplitude", "-0.1", "--omega", "1"], ["'--amplitude'"]),
], ids=["predict output path", "df usage error"])
def test_process_error_is_one_line_on_stderr(work, args, words):
    result = _run(work, *args)
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error: "), result.stderr
    assert all(word in lines[0] for word in words)
