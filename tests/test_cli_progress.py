"""Progress bars only on a terminal (issue 49).

With standard error a terminal, a command draws tqdm bars; redirected (a log file,
CI, a notebook), it writes one plain line per stage when the stage ends and no
carriage-return frames.  The helper is checked both ways on fake streams, then
three commands that draw bars run with standard error captured: ``predict`` as a
process writing to a file, ``tune`` and ``diagnose`` in-process.
"""

import functools
import io
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner
from tqdm import tqdm

import backlash_df.cli.diagnose
from backlash_df.cli import main
from backlash_df.cli.common import progress_bar
from conftest import EXAMPLES

#: The line a stage leaves in a log: ``DESC: N UNITs, S s``.
STAGE_LINE = r"{}: {} {}, \d+\.\d s"


class _Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self):
        return True


def test_on_a_terminal_the_bar_is_tqdm_drawing_frames(monkeypatch):
    monkeypatch.setattr(sys, "stderr", _Terminal())
    with progress_bar("diagnose: fits", unit="fit") as bar:
        assert isinstance(bar, tqdm)
        bar.update()
        bar.set_postfix_str("rubber")
    assert "\r" in sys.stderr.getvalue() and "diagnose: fits" in sys.stderr.getvalue()


def test_off_a_terminal_one_line_when_the_stage_is_closed(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    with progress_bar("diagnose: fits", unit="fit") as bar:
        threads = [threading.Thread(target=lambda: [bar.update() for _ in range(500)]) for _ in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        bar.set_postfix_str("refine rubber")
        assert sys.stderr.getvalue() == ""  # nothing while the stage runs
    assert re.fullmatch(STAGE_LINE.format("diagnose: fits", 1000, "fits") + "\n", sys.stderr.getvalue())
    bar.close()  # once only
    assert sys.stderr.getvalue().count("\n") == 1


def test_off_a_terminal_a_stage_ends_at_its_total_and_says_nothing_on_an_error(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    bar = progress_bar("simulating", total=2, unit="run")
    bar.update()
    assert sys.stderr.getvalue() == ""
    bar.total = 1  # tune sets the total as it learns it
    bar.update(0)
    assert re.fullmatch(STAGE_LINE.format("simulating", 1, "run") + "\n", sys.stderr.getvalue())
    with pytest.raises(KeyboardInterrupt), progress_bar("screening", unit="tuning") as stopped:
        stopped.update()
        raise KeyboardInterrupt
    assert sys.stderr.getvalue().count("\n") == 1  # the error line says what happened


def test_no_command_draws_a_tqdm_bar_of_its_own():
    """Every bar of the command line comes from the helper."""
    folder = Path(backlash_df.cli.__file__).parent
    drawing = [path.name for path in folder.glob("*.py") if path.name != "common.py" and "tqdm" in path.read_text()]
    assert drawing == []


def test_predict_with_stderr_to_a_file_writes_one_line(tmp_path):
    """The issue's case, ``backlash-df predict RIG 2>log``: the console script as a process."""
    log = tmp_path / "log"
    script = shutil.which("backlash-df", path=str(Path(sys.executable).parent)) or shutil.which("backlash-df")
    with log.open("w") as stderr:
        result = subprocess.run([script, "predict", str(EXAMPLES / "load_feedback.toml")], cwd=tmp_path,
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=stderr, text=True,
                                timeout=120, env={**os.environ, "MPLBACKEND": "Agg"})
    assert result.returncode == 0
    text = log.read_text()
    assert "\r" not in text
    assert re.fullmatch(STAGE_LINE.format("simulating", r"\d+", "runs") + "\n", text), text


def test_tune_off_a_terminal_writes_one_line_per_stage_in_order(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["tune", str(EXAMPLES / "load_feedback.toml"), "--vary", "kp", "10,40"])
    assert result.exit_code == 0, result.output
    assert "\r" not in result.stderr
    stages = [line.split(":")[0] for line in result.stderr.splitlines()]
    expected = ["screening", "refinement", "certification", "least hunting", "front", "front orbits"]  # none certified
    assert stages == expected, result.stderr  # one line a stage


def test_diagnose_off_a_terminal_writes_one_line(tmp_path, monkeypatch):
    """The issue's ``diagnose`` (hundreds of frames before), its fits cut to the rubber candidate for speed."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(backlash_df.cli.diagnose, "run_diagnosis",
                        functools.partial(backlash_df.cli.diagnose.run_diagnosis, candidates=["rubber"]))
    result = CliRunner().invoke(main, ["diagnose", str(EXAMPLES / "diagnose_rubber.csv"), "--rig",
                                       str(EXAMPLES / "diagnose_rig.toml"), "--json", "d.json"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("cause: rubber") and (tmp_path / "d.json").exists()
    assert re.fullmatch(STAGE_LINE.format("diagnose: fits", r"\d+", "fits") + "\n", result.stderr), result.stderr
