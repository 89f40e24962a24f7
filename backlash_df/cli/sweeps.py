"""``backlash-df map`` and ``backlash-df continue``: verdicts over two rig values, branches over one."""

import contextlib
import json

import click
import numpy as np

from ..config import load_rig
from ..continuation import continue_limit_cycles
from ..render.html import figure_bytes
from ..sweeps import design_map
from .common import FINITE, MODEL, echo_table, read_text, stage_bars
from .executors import checkpoint_for, checkpoint_options, executor_for, executor_options, stopped_note
from .outputs import Outputs, plot_format

__all__ = ["map_command", "continue_command", "parse_values"]


def parse_values(option, text):
    """Grid values from ``START:STOP:N`` (linear), ``START:STOP:N:log`` (geometric) or ``V1,V2,...``.

    Raises
    ------
    ValueError
        One line naming ``option``.
    """
    parts = text.split(":")
    try:
        if len(parts) == 1:
            return np.array([float(item) for item in text.split(",")])
        if len(parts) in (3, 4) and (len(parts) == 3 or parts[3] == "log"):
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1 or (len(parts) == 4 and not (start > 0 and stop > 0)):
                raise ValueError
            return (np.geomspace if len(parts) == 4 else np.linspace)(start, stop, count)
    except ValueError:
        pass
    raise ValueError(f"{option} {text!r}: give START:STOP:N, START:STOP:N:log (positive ends) or V1,V2,...")


def _write_results(outputs, rig_file, result, title):
    """Write the requested ``--json``, ``--report`` and ``--plot`` (in the format its suffix names) of a map or a
    branch, all or none."""
    texts = {}
    if "--json" in outputs:
        texts["--json"] = json.dumps({"rig": str(rig_file), **result.to_dict()}, indent=2) + "\n"
    if "--report" in outputs:
        texts["--report"] = result.report_html(title=title, rig_text=read_text(rig_file))
    if "--plot" in outputs:
        texts["--plot"] = figure_bytes(result.plot().figure, plot_format(outputs.paths["--plot"]), dpi=110)
    outputs.write(texts)


@click.command("map")
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--x", "x_spec", nargs=2, default=("kp", "5:60:12"), show_default=True, metavar="NAME VALUES",
              help="First rig value and its grid: START:STOP:N, START:STOP:N:log or V1,V2,...")
@click.option("--y", "y_spec", nargs=2, default=("ti", "0.1:2:10:log"), show_default=True, metavar="NAME VALUES",
              help="Second rig value and its grid.")
@click.option("--model", "models", multiple=True, type=MODEL,
              help="Torque law (repeatable; default: the rig's [model] backlash).")
@click.option("--no-simulate", is_flag=True, help="DF verdicts only (no time simulation).")
@executor_options
@checkpoint_options
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the map as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
@click.option("--plot", "plot_out", type=click.Path(dir_okay=False),
              help="Save the figure: .png, .pdf or .svg, the format the suffix names.")
def map_command(rig_file, x_spec, y_spec, models, no_simulate, workers, dask, scheduler, checkpoint_path, resume,
                json_out, report_out, plot_out):
    """Design map of RIG_FILE over two rig values: DF verdicts and simulation side by side.

    Prints one grid of verdicts per law (rows: the first value, columns: the
    second; C limit cycle, B bistable, U unstable, . no oscillation,
    ? undetermined), the DF's and the simulation's.  Finished cells are kept in a
    checkpoint; after Ctrl-C, the same command with --resume computes only the
    others, and the map is the same as an uninterrupted one.

    Example: backlash-df map RIG --x kp 5:60:40 --y ti 0.1:2:40:log --workers 2
    """
    outputs = Outputs({"--json": json_out, "--report": report_out, "--plot": plot_out})
    rig = load_rig(rig_file)
    rig.require_controller()
    models = list(dict.fromkeys(models or [rig.model]))
    for name in models:
        rig.make_model(name)  # a law the rig cannot describe (rubber without beta) stops here
    x_values, y_values = parse_values("--x", x_spec[1]), parse_values("--y", y_spec[1])
    rig = rig.without_uncertainty(x_spec[0], y_spec[0])  # the grid explores its values, boxed or not
    rig.with_values(**{x_spec[0]: x_values[0], y_spec[0]: y_values[0]})  # names checked before any work
    checkpoint = checkpoint_for(outputs, "map", checkpoint_path, resume)
    with stopped_note(checkpoint, "cells", x_values.size * y_values.size), \
            executor_for(workers, dask, scheduler) as executor, contextlib.ExitStack() as stack:
        dmap = design_map(rig, x_values, y_values, x=x_spec[0], y=y_spec[0], models=models,
                          simulate=not no_simulate, executor=executor, progress=stage_bars(stack, unit="cell"),
                          checkpoint=checkpoint)
    click.echo(f"design map of {rig_file}: {x_spec[0]} ({x_values.size}) x {y_spec[0]} ({y_values.size})")
    for title, header, rows in dmap.tables():
        click.echo(title)
        echo_table(header, rows)
    for line in dmap.sentences():
        click.echo(line)
    _write_results(outputs, rig_file, dmap, f"Design map: {rig_file}")
    if checkpoint is not None:
        checkpoint.remove()


@click.command("continue")
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--parameter", required=True, metavar="NAME",
              help="Rig value to continue in: kp, ti, stiffness, load.torque, ... (any numeric key).")
@click.option("--from", "start", type=FINITE, required=True, help="First value of the parameter.")
@click.option("--to", "stop", type=FINITE, required=True, help="Last value of the parameter.")
@click.option("--model", "model_name", default=None, type=MODEL,
              help="Torque law (default: the rig's [model] backlash); piecewise-affine laws only.")
@click.option("--df-values", type=click.IntRange(min=2), default=25, show_default=True,
              help="Parameter values at which the describing function is evaluated beside the branch.")
@executor_options
@checkpoint_options
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the branch as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
@click.option("--plot", "plot_out", type=click.Path(dir_okay=False),
              help="Save the figure: .png, .pdf or .svg, the format the suffix names.")
def continue_command(rig_file, parameter, start, stop, model_name, df_values, workers, dask, scheduler,
                     checkpoint_path, resume, json_out, report_out, plot_out):
    """Branch of exact periodic orbits of RIG_FILE's loop over one rig value, the DF beside it.

    Pseudo-arclength continuation of the shooting orbits, through folds; marks
    folds, stability changes (Floquet), grazing and births.  Prints the orbits,
    the DF's cycles at the --df-values values and the special points.  The
    executor options run the DF predictions.  The first orbit, every step of the
    branch and every DF prediction are kept in a checkpoint; after Ctrl-C, the
    same command with --resume goes on from the last step kept.

    Example: backlash-df continue RIG --parameter kp --from 5 --to 60
    """
    outputs = Outputs({"--json": json_out, "--report": report_out, "--plot": plot_out})
    rig = load_rig(rig_file)
    rig.require_controller()
    checkpoint = checkpoint_for(outputs, "continue", checkpoint_path, resume)
    with stopped_note(checkpoint, "steps"), executor_for(workers, dask, scheduler) as executor, \
            contextlib.ExitStack() as stack:
        branch = continue_limit_cycles(rig, parameter, (start, stop), model_name, df_values=df_values,
                                       executor=executor, progress=stage_bars(stack, unit="step"),
                                       checkpoint=checkpoint)
    for title, header, rows in branch.tables():
        click.echo(title)
        echo_table(header, rows)
    for line in branch.sentences():
        click.echo(line)
    _write_results(outputs, rig_file, branch, f"Continuation in {parameter}: {rig_file}")
    if checkpoint is not None:
        checkpoint.remove()
