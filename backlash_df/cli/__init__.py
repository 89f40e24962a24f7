"""The ``backlash-df`` command line.

Every command turns a ``ValueError`` from the library (bad rig file, bad CSV,
bad argument) and every click usage error into one line on stderr,
``backlash-df: error: ...``, and exit code 2.  Output paths are checked before
anything is computed, and a command writes all its outputs or none
(:class:`~backlash_df.cli.outputs.Outputs`).  Each command lives in a module of
its own and only parses, calls the library and prints; the group below lists them.
"""

import click

from .._version import __version__
from .common import Group

__all__ = ["main"]

#: Each command's module and function: a command imports its module, and so the library's stages it needs,
#: only when it runs (``backlash-df predict`` imports neither the diagnosis nor the tuning).
COMMANDS = {
    "predict": "predict:predict_command",
    "df": "describing:df_command",
    "continue": "sweeps:continue_command",
    "map": "sweeps:map_command",
    "tune": "tune:tune_command",
    "diagnose": "diagnose:diagnose_command",
    "simulate": "simulate:simulate_command",
    "reproduce": "reproduce:reproduce_command",
}


@click.group(name="backlash-df", cls=Group, commands=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="backlash-df")
def main():
    """Describing functions and limit cycles of drives with backlash.

    Torque laws of Nordin, Galic and Gutman (1997), their describing functions
    N(A, w), limit-cycle prediction on PI-controlled two-mass loops verified by
    time simulation, and diagnosis of measured data.
    """
