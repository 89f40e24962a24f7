"""``backlash-df simulate``: the rig's closed loop driven by recorded inputs, compared with a measured record."""

import contextlib
import json

import click

from ..config import load_rig
from ..render.html import figure_bytes
from ..render.simulation import simulated_record_lines
from ..simulation.record import simulate_record
from .common import stage_bars, stderr_is_terminal
from .outputs import Outputs, plot_format

__all__ = ["simulate_command"]


@click.command("simulate")
@click.argument("rig_file", metavar="RIG", type=click.Path(dir_okay=False))
@click.option("--inputs", "inputs", type=click.Path(dir_okay=False), default=None,
              help="CSV of time (s), reference (rad/s; rad in a cascade) and optional load_torque (N m), load side. "
                   "Without: the reference 0 and the rig's load torque.")
@click.option("--t-end", "t_end", type=click.FloatRange(0.0, min_open=True), default=None,
              help="Length of the run, s (default: the inputs' span, else the record's; needed without either).")
@click.option("--compare", "compare", type=click.Path(dir_okay=False), default=None,
              help="A measurement CSV: the fit of each response column it holds.")
@click.option("--csv", "csv_out", type=click.Path(dir_okay=False), default=None,
              help="Write the responses as a measurement CSV (motor columns on the motor side).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None,
              help="Write the run (and the fits) as JSON.")
@click.option("--plot", "plot_out", type=click.Path(dir_okay=False), default=None,
              help="Write a figure of the responses (measured beside them with --compare): .png, .pdf or .svg.")
def simulate_command(rig_file, inputs, t_end, compare, csv_out, json_out, plot_out):
    """Run the closed loop of the rig file RIG on recorded inputs and print its length, steps and, with
    --compare, the fit of each column.

    The inputs CSV has a header row and the columns time (s, increasing, uniform
    to 0.1 % of its step), reference (the speed reference in rad/s, or in a
    cascade the position reference in rad) and optionally load_torque (N m),
    linear between rows.  The run starts at the first row and spans the file
    unless --t-end is given; the output samples are the inputs' instants.  The
    measurement CSV written by --csv and read by --compare has the columns of
    'backlash-df diagnose' (motor columns on the motor side through the rig's
    gear_ratio).
    """
    outputs = Outputs({"--csv": csv_out, "--json": json_out, "--plot": plot_out})
    if inputs is None and compare is None and t_end is None:
        raise ValueError("--t-end: give the run's length (s), or --inputs or --compare for it to span")
    rig = load_rig(rig_file)
    with contextlib.ExitStack() as stack:
        progress = stage_bars(stack, unit="step") if stderr_is_terminal() else None
        run = simulate_record(rig, inputs=inputs, t_end=t_end, compare=compare, progress=progress)
    for line in simulated_record_lines(run):
        click.echo(line)
    texts = {}
    if "--csv" in outputs:
        texts["--csv"] = run.to_csv()
    if "--json" in outputs:
        texts["--json"] = json.dumps(run.to_dict(), indent=2) + "\n"
    if "--plot" in outputs:
        texts["--plot"] = figure_bytes(run.plot().figure, plot_format(outputs.paths["--plot"]), dpi=110)
    outputs.write(texts)
