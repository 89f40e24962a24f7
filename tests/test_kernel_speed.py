"""The command line's 'compiling (first run only)' notice (issue 21): once when numba compiles, never when it does not."""

import numba
from click.testing import CliRunner

import backlash_df.cli.common

from backlash_df._jit import on_first_compile
from backlash_df.cli import main
from backlash_df.cli.common import COMPILING_NOTICE


def _fresh_function():
    """A function numba has never compiled (no disk cache): calling it compiles."""
    return numba.njit(lambda x: 2.0 * x + 1.0)


def test_announced_once_however_many_functions_compile():
    calls = []
    first, second = _fresh_function(), _fresh_function()
    with on_first_compile(lambda: calls.append(1)):
        assert first(1.0) == 3.0
        assert second(2.0) == 5.0
        assert first(3.0) == 7.0
    assert calls == [1]


def test_not_announced_when_nothing_compiles():
    calls = []
    compiled = _fresh_function()
    compiled(1.0)  # compiled before the block: a warm run
    with on_first_compile(lambda: calls.append(1)):
        assert compiled(4.0) == 9.0
    assert calls == []
    after = _fresh_function()
    after(1.0)  # compiled after the block: the listener is gone
    assert calls == []


def test_command_line_says_so_on_stderr_only_when_compiling(tmp_path, monkeypatch):
    rig = tmp_path / "rig.toml"
    rig.write_text('[plant]\nmotor_inertia = 0.4\nload_inertia = 5.6\nstiffness = 5895.0\ndamping = 3.0\n'
                   'half_gap = 0.05\n\n[controller]\nkp = 30.0\nti = 0.5\nfeedback = "load"\n')
    runner = CliRunner()
    warm = runner.invoke(main, ["predict", str(rig)])  # whatever this process has not compiled yet, now compiled
    assert warm.exit_code == 0, warm.output
    again = runner.invoke(main, ["predict", str(rig)])
    assert again.exit_code == 0
    assert "compiling" not in again.stderr and "compiling" not in again.stdout
    # a command that must compile (a kernel numba has not seen) says so once, on stderr
    import backlash_df.cli.predict as predict_module

    fresh = _fresh_function()
    original = predict_module.analyse_loop

    def analyse_compiling(*args, **kwargs):
        fresh(1.0)  # the function of the moment: compiled by the first call
        return original(*args, **kwargs)

    monkeypatch.setattr(predict_module, "analyse_loop", analyse_compiling)
    piped = runner.invoke(main, ["predict", str(rig)])  # stderr not a terminal: a log, a pipe, a test runner
    assert piped.exit_code == 0 and "compiling" not in piped.output
    fresh = _fresh_function()
    monkeypatch.setattr(backlash_df.cli.common, "stderr_is_terminal", lambda: True)  # a person at a terminal
    cold = runner.invoke(main, ["predict", str(rig)])
    assert cold.exit_code == 0
    assert cold.stderr.count(COMPILING_NOTICE) == 1
    assert "compiling" not in cold.stdout
