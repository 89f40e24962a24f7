"""The ``backlash-df`` command line.

Every command turns a ``ValueError`` from the library (bad rig file, bad CSV,
bad argument) and every click usage error into one line on stderr,
``backlash-df: error: ...``, and exit code 2.  Output paths are checked before
anything is computed, and a command writes all its outputs or none
(:class:`~backlash_df.cli.outputs.Outputs`).  Each command lives in a module of
its own and only parses, calls the library and prints; the group below lists them.
"""

import click

from .. import __version__
from .common import Group
from .describing import df_command
from .diagnose import diagnose_command
from .predict import predict_command
from .reproduce import reproduce_command
from .sweeps import continue_command, map_command
from .tune import tune_command

__all__ = ["main"]


@click.group(name="backlash-df", cls=Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="backlash-df")
def main():
    """Describing functions and limit cycles of drives with backlash.

    Torque laws of Nordin, Galic and Gutman (1997), their describing functions
    N(A, w), limit-cycle prediction on PI-controlled two-mass loops verified by
    time simulation, and diagnosis of measured data.
    """


main.add_command(predict_command)
main.add_command(df_command)
main.add_command(continue_command)
main.add_command(map_command)
main.add_command(tune_command)
main.add_command(diagnose_command)
main.add_command(reproduce_command)
