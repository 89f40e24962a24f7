"""``backlash-df predict``: bad input is one line naming key and file, exit code 2; verdicts in every output."""

import json
import math
import re

import pytest
from click.testing import CliRunner

from backlash_df.cli import main
from conftest import EXAMPLES, PLANT_TOML

GOOD = PLANT_TOML + """
[controller]
feedback = "load"
kp = 30.0
ti = 0.5
"""


def run(tmp_path, text, *args):
    path = tmp_path / "rig.toml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["predict", str(path), *args])
    return path, result


@pytest.mark.parametrize(
    "text, args, words",
    [
        (GOOD.replace("kp = 30.0", "kp = 30.0\ngain = 2.0"), (), ["unknown key", "[controller] gain"]),
        (GOOD.replace("ti = 0.5", "ti = -0.5"), (), ["[controller] ti", "> 0"]),
        (GOOD.replace('feedback = "load"', 'feedback = "both"'), (), ["[controller] feedback"]),
        (GOOD.replace("half_gap = 0.05", "half_gap = 0.05\n[[oops"), (), ["malformed TOML"]),
        (GOOD.split("[controller]")[0], (), ["no [controller] table"]),
        (GOOD, ("--model", "coulomb"), ["'--model'", "'coulomb' is not one of", "phase-plane"]),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, text, args, words):
    path, result = run(tmp_path, text, *args)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("backlash-df: error:")
    assert str(path) in lines[0] or args  # a bad option is named instead of the file
    for word in words:
        assert word in lines[0]


def test_missing_file_names_it(tmp_path):
    result = CliRunner().invoke(main, ["predict", str(tmp_path / "nope.toml")])
    assert result.exit_code == 2
    assert "nope.toml" in result.output and "cannot read rig file" in result.output


def test_unstable_loop_gets_its_verdict_everywhere(tmp_path):
    # kp = 3000 on the load speed: the loop in contact is unstable (tests/test_verdict.py checks its poles)
    json_path, report_path = tmp_path / "out.json", tmp_path / "out.html"
    path, result = run(tmp_path, GOOD.replace("kp = 30.0", "kp = 3000.0"), "--json", str(json_path),
                       "--report", str(report_path))
    assert result.exit_code == 0, result.output
    assert "RuntimeWarning" not in result.output
    data = json.loads(json_path.read_text())
    entry = data["models"][0]
    assert entry["model"] == "phase-plane" and entry["verdict"] == "unstable"
    assert entry["contact_loop"]["stable"] is False and entry["contact_loop"]["max_real"] > 0.0
    assert entry["contact_loop"]["poles"][0][0] == entry["contact_loop"]["max_real"]
    assert entry["open_loop"]["status"] in ("stable", "marginal", "unstable")
    assert {probe["outcome"] for probe in entry["probes"]} == {"diverged"}
    assert "limit_cycles" in data and all(cycle["simulated"] is None for cycle in data["limit_cycles"])
    verdict_lines = [line for line in result.output.splitlines() if line.startswith("phase-plane  unstable")]
    pole = entry["contact_loop"]["poles"][0]
    assert len(verdict_lines) == 1
    assert f"unstable (rightmost pole {pole[0]:.4g} +- {abs(pole[1]):.4g}j 1/s)" in verdict_lines[0]
    page = report_path.read_text()
    assert "Verdict and linear stability" in page and "verdict: unstable" in page


def test_exact_adds_the_orbits_next_to_the_df(tmp_path):
    # examples/load_feedback.toml: one stable cycle; the exact orbit must sit on the simulated one
    json_path = tmp_path / "out.json"
    path, result = run(tmp_path, GOOD.replace("ti = 0.5", "ti = 0.5\nspeed_filter = 0.002"), "--exact",
                       "--json", str(json_path))
    assert result.exit_code == 0, result.output
    entry = json.loads(json_path.read_text())["models"][0]
    assert entry["verdict"] == "limit cycle" and entry["df_agrees"] is True
    (orbit,) = entry["exact_orbits"]
    simulated = entry["simulated_cycle"]
    assert orbit["stable"] and abs(orbit["multipliers"][0][0] - 1.0) < 1e-6  # the trivial multiplier
    assert abs(orbit["amplitude"] / simulated["amplitude"] - 1.0) < 1e-3
    assert abs(orbit["omega"] / simulated["omega"] - 1.0) < 1e-3
    assert abs(orbit["period"] * orbit["omega"] - 2.0 * math.pi) < 1e-9
    header = [line for line in result.output.splitlines() if line.startswith("model") and "A exact (rad)" in line]
    assert len(header) == 1


# ---- the text a person reads, on the bundled examples (issue 23): columns line up, none is empty in every
# ---- row, round-off prints as 0; the JSON of the same run is the reference


@pytest.fixture(scope="module")
def predicted(tmp_path_factory):
    """``predict EXAMPLE --exact --json``: the standard output and the JSON, one run per example."""
    runs = {}

    def run_example(name):
        if name not in runs:
            out = tmp_path_factory.mktemp(name) / "out.json"
            result = CliRunner().invoke(main, ["predict", str(EXAMPLES / f"{name}.toml"), "--exact", "--json",
                                               str(out)])
            assert result.exit_code == 0, result.output
            runs[name] = result.stdout, json.loads(out.read_text())
        return runs[name]
    return run_example


def text_tables(text):
    """The tables of the text as ``{first header cell after model: (header, rows as dicts)}``.

    A table is a block starting ``model  ``; a column starts where its header cell
    starts, and every cell must start there too, two blanks after the cell before it.
    """
    tables = {}
    for block in text.split("\n\n"):
        lines = block.splitlines()
        if not lines or not lines[0].startswith("model  "):
            continue
        found = list(re.finditer(r"\S+(?: \S+)*", lines[0]))
        header, starts = [match.group() for match in found], [match.start() for match in found]
        rows = []
        for line in lines[1:]:
            for start in starts[1:]:
                assert len(line) <= start - 2 or line[start - 2:start] == "  ", (start, line)
            cells = [line[start:end].rstrip() for start, end in zip(starts, [*starts[1:], None])]
            assert not any(cell.startswith(" ") for cell in cells), line
            rows.append(dict(zip(header, cells)))
        tables[header[1]] = header, rows
    return tables


def assert_no_empty_column(tables):
    for header, rows in tables.values():
        for name in header:
            assert any(row[name] for row in rows), (name, header)


def test_text_of_a_cycle_without_near_miss_or_hunting_disturbance(predicted):
    text, data = predicted("load_feedback")
    tables = text_tables(text)
    assert_no_empty_column(tables)
    (entry,) = data["models"]
    assert entry["near_misses"] == [] and entry["disturbance_to_start"] is None
    header, rows = tables["A pred (rad)"]
    assert header == ["model", "A pred (rad)", "w pred (rad/s)", "Loeb", "A sim (rad)", "w sim (rad/s)", "A error",
                      "w error"]  # no near miss, no load: no closest miss, no bias
    (cycle,) = data["limit_cycles"]
    assert rows == [{"model": "phase-plane", "A pred (rad)": f"{cycle['amplitude']:.5g}",
                     "w pred (rad/s)": f"{cycle['omega']:.5g}", "Loeb": "stable",
                     "A sim (rad)": f"{cycle['simulated']['amplitude']:.5g}",
                     "w sim (rad/s)": f"{cycle['simulated']['omega']:.5g}",
                     "A error": f"{100 * (cycle['amplitude'] / cycle['simulated']['amplitude'] - 1):+.2f} %",
                     "w error": f"{100 * (cycle['omega'] / cycle['simulated']['omega'] - 1):+.2f} %"}]
    assert tables["verdict"][0] == ["model", "verdict", "contact loop (k + c s)", "open loop (T = 0)"]
    header, (row,) = tables["A exact (rad)"]
    (orbit,) = entry["exact_orbits"]
    # without load the orbit is symmetric: its computed mean is round-off, printed 0, kept in the JSON
    assert abs(orbit["bias"]) <= 1e-12 * orbit["amplitude"] and row["bias (rad)"] == "0"
    assert row["A exact (rad)"] == f"{orbit['amplitude']:.6g}"


def test_text_without_a_cycle_lines_up(predicted):
    text, data = predicted("motor_feedback")
    tables = text_tables(text)
    assert_no_empty_column(tables)
    (entry,) = data["models"]
    assert data["limit_cycles"] == [] and entry["exact_orbits"] == [] and entry["verdict"] == "no oscillation"
    assert tables["A pred (rad)"] == (["model", "A pred (rad)", "A sim (rad)"],
                                      [{"model": "phase-plane", "A pred (rad)": "none",
                                        "A sim (rad)": "no limit cycle"}])
    assert "A exact (rad)" not in tables  # no orbit: no table, the sentence says why
    assert "(exact orbits: shooting found no periodic orbit" in text


def test_text_under_load_shows_the_bias_of_the_df_and_of_the_orbits(predicted):
    text, data = predicted("loaded_feedback")
    tables = text_tables(text)
    assert_no_empty_column(tables)
    header, rows = tables["A pred (rad)"]
    assert header[:4] == ["model", "A pred (rad)", "w pred (rad/s)", "bias pred (rad)"]
    cycles = data["limit_cycles"]
    assert [row["bias pred (rad)"] for row in rows] == [f"{cycle['bias']:.4g}" for cycle in cycles]
    assert [row["A sim (rad)"] for row in rows] == [
        "" if cycle["simulated"] is None else f"{cycle['simulated']['amplitude']:.5g}" for cycle in cycles]
    assert all(cycle["bias"] < -0.01 for cycle in cycles)  # the load of 100 N m pushes theta_d to the left flank
    header, rows = tables["A exact (rad)"]
    orbits = data["models"][0]["exact_orbits"]
    assert [row["bias (rad)"] for row in rows] == [f"{orbit['bias']:.4g}" for orbit in orbits]
    assert all(orbit["bias"] < -0.01 for orbit in orbits)


def test_a_df_error_that_rounds_to_zero_prints_without_a_sign(predicted):
    """Issue 49: the unstable orbit of motor_lag_feedback and its DF cycle differ in w by -0.004 %, printed
    ``-0.00 %``; a percentage that rounds to zero prints ``0.00 %``."""
    text, data = predicted("motor_lag_feedback")
    header, rows = text_tables(text)["A exact (rad)"]
    orbits = data["models"][0]["exact_orbits"]
    assert "-0.00 %" not in text and "+0.00 %" not in text
    for orbit, row in zip(orbits, rows, strict=True):
        same = [cycle for cycle in data["limit_cycles"] if cycle["stable"] == orbit["stable"]]
        df = min(same, key=lambda cycle: abs(math.log(cycle["amplitude"] / orbit["amplitude"])))
        error = 100.0 * (df["omega"] / orbit["omega"] - 1.0)
        assert row["w DF error"] == ("0.00 %" if abs(error) < 0.005 else f"{error:+.2f} %")
    assert any(-0.005 < 100.0 * (c["omega"] / o["omega"] - 1.0) < 0.0  # the case of the issue is still here
               for o in orbits for c in data["limit_cycles"] if c["stable"] == o["stable"])
