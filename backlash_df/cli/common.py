"""What every command shares: one-line errors with exit code 2, option types, plain-text tables, progress bars."""

import importlib
import math
import sys
import threading
import time
from pathlib import Path

import click

from .._jit import on_first_compile
from ..models import MODEL_NAMES

__all__ = ["Group", "fail", "FINITE", "MODEL", "COMPILING_NOTICE", "stderr_is_terminal", "progress_bar", "StageLine", "stage_bars",
           "numbers", "echo_table", "read_text"]


def fail(message, code=2):
    """Print ``message`` as one ``backlash-df: error:`` line and exit with ``code``."""
    click.echo(f"backlash-df: error: {' '.join(str(message).split())}", err=True)
    sys.exit(code)


_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())  # click >= 8.2


class Group(click.Group):
    """A click group whose errors are one line (``ValueError`` and usage errors, exit code 2) and whose
    commands are imported when they run.

    Parameters
    ----------
    commands : dict of str to str
        Each command's name and ``"module:function"`` in this package (click's
        lazy-loading group pattern): a command's module, and the library stages it
        imports, load only when that command runs or the help lists it.
    """

    def __init__(self, *args, commands=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._lazy = dict(commands or {})

    def list_commands(self, ctx):
        return list(self._lazy) + [name for name in super().list_commands(ctx) if name not in self._lazy]

    def get_command(self, ctx, name):
        if name not in self._lazy:
            return super().get_command(ctx, name)
        module, function = self._lazy[name].split(":")
        return getattr(importlib.import_module(f"{__package__}.{module}"), function)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            value = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except _NO_ARGS_IS_HELP as error:  # the bare group: its help, as click prints it
            error.show()
            sys.exit(error.exit_code)
        except click.ClickException as error:
            command = error.ctx.command_path if getattr(error, "ctx", None) else "backlash-df"
            hint = f" (see '{command} --help')" if isinstance(error, click.UsageError) else ""
            fail(f"{error.format_message()}{hint}", error.exit_code)
        except click.Abort:
            fail("aborted", 1)
        sys.exit(value if isinstance(value, int) else 0)

    def invoke(self, ctx):
        from threadpoolctl import threadpool_limits

        try:
            # one BLAS thread: the kernels' small matrices run 1.3-1.4x slower on two
            # (benchmarks/bench_startup.py)
            with threadpool_limits(1, user_api="blas"), on_first_compile(_compiling_notice):
                return super().invoke(ctx)
        except ValueError as error:
            fail(error)


#: The stderr line a command prints once when numba compiles (a cold cache: the first run).
COMPILING_NOTICE = "backlash-df: compiling kernels (first run only; later runs load them from a cache)"


def _compiling_notice():
    """One stderr line while numba compiles the kernels a command needs, for a person waiting at a terminal
    (not in a pipe, a log or a test runner's captured output)."""
    if stderr_is_terminal():
        click.echo(COMPILING_NOTICE, err=True)


def stderr_is_terminal():
    """True where standard error is a terminal."""
    return sys.stderr.isatty()


def progress_bar(desc, total=None, unit="it"):
    """The progress of one stage of a command: a bar on a terminal, one line in a log.

    Parameters
    ----------
    desc : str
        The stage's name, shown before the count (``"diagnose: fits"``).
    total : int, optional
        The count at which the stage is complete (None: unknown).
    unit : str
        What is counted, singular (``"fit"``).

    Returns
    -------
    tqdm or StageLine
        Where standard error is a terminal, a tqdm bar on it that leaves nothing behind
        when closed; elsewhere (a file, a pipe, CI, a notebook) a :class:`StageLine`,
        which draws no frames.  Both count with ``update(n)`` and hold ``n`` and a
        settable ``total``, take ``set_postfix_str``, ``close()`` and ``with``.
    """
    if stderr_is_terminal():
        from tqdm import tqdm  # only a terminal draws bars: a log or a pipe does not pay tqdm's import

        return tqdm(desc=desc, total=total, unit=unit, file=sys.stderr, leave=False)
    return StageLine(desc, total, unit)


def stage_bars(stack, unit="run", prefix=""):
    """The library's ``progress(stage, done, total)`` drawn as one :func:`progress_bar` per stage.

    A stage's bar opens at its first call (bad input, refused before any work, draws
    none) and is closed with ``stack`` (a :class:`contextlib.ExitStack`), or earlier by
    reaching its total.

    Parameters
    ----------
    stack : contextlib.ExitStack
    unit : str
        What the stages count, singular.
    prefix : str
        Put before each stage's name (``"diagnose: "``).

    Returns
    -------
    callable
        ``progress(stage, done, total)``.
    """
    bars = {}

    def progress(stage, done, total):
        if stage not in bars:
            bars[stage] = stack.enter_context(progress_bar(prefix + stage, total=total, unit=unit))
        bar = bars[stage]
        bar.total = total
        bar.update(done - bar.n)

    return progress


class StageLine:
    """A progress bar's stand-in off a terminal: one stderr line when its stage ends, nothing before.

    The stage ends when its count reaches ``total`` or, at the latest, when it is
    closed; the line then says ``DESC: N UNITs, S s`` (``diagnose: fits: 57 fits,
    3.2 s``).  A stage ended by an exception says nothing: the error line does.
    ``update`` may be called from several threads.

    Parameters
    ----------
    desc : str
        The stage's name.
    total : int, optional
        The count at which the stage is complete (None: unknown); may be set later.
    unit : str
        What is counted, singular.

    Attributes
    ----------
    n : int
        The count so far.
    """

    def __init__(self, desc, total=None, unit="it"):
        self.desc, self.total, self.unit = desc, total, unit
        self.n = 0
        self._start = time.perf_counter()
        self._lock = threading.Lock()
        self._ended = False

    def update(self, n=1):
        """Count ``n`` more; the stage ends when the count reaches ``total``."""
        with self._lock:
            self.n += n
            complete = self.total is not None and self.n >= self.total
        if complete:
            self.close()

    def set_postfix_str(self, s="", refresh=True):
        """Ignored: a log gets no running detail (the signature is tqdm's)."""

    def close(self):
        """End the stage with its one line (once; later calls do nothing)."""
        if self._end():
            plural = "" if self.n == 1 else "s"
            click.echo(f"{self.desc}: {self.n} {self.unit}{plural}, {time.perf_counter() - self._start:.1f} s",
                       err=True)

    def _end(self):
        """Mark the stage ended; True the first time only."""
        with self._lock:
            first, self._ended = not self._ended, True
        return first

    def __enter__(self):
        return self

    def __exit__(self, kind, value, traceback):
        if kind is None:
            self.close()
        else:
            self._end()


#: A torque-law name (``--model``).
MODEL = click.Choice(MODEL_NAMES)


class _FiniteFloat(click.ParamType):
    """A finite float (click's FLOAT accepts nan and inf)."""

    name = "float"

    def convert(self, value, param, ctx):
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"must be finite, got {value}", param, ctx)
        return number


#: A finite float option type.
FINITE = _FiniteFloat()


def numbers(positive):
    """A click callback: finite numbers from repeated options, each possibly comma-separated.

    ``positive``: each must be > 0 (else >= 0).  A bad item is a usage error naming the option.
    """
    def parse(ctx, param, values):
        found = []
        for item in (item.strip() for value in values for item in str(value).split(",")):
            try:
                number = float(item)
            except ValueError:
                raise click.BadParameter(f"not a number: {item!r}") from None
            if not math.isfinite(number) or number < 0.0 or (positive and number == 0.0):
                raise click.BadParameter(f"must be {'> 0' if positive else '>= 0'} and finite, got {item}")
            found.append(number)
        return found
    return parse


def echo_table(header, rows):
    """A plain-text table, columns padded to their widest cell, a blank line after it."""
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]
    for row in [header] + rows:
        click.echo("  ".join(str(cell).ljust(width) for cell, width in zip(row, widths)).rstrip())
    click.echo("")


def read_text(path):
    """The text of a file the command already read successfully (the rig file, for a report)."""
    return Path(path).read_text(encoding="utf-8")
