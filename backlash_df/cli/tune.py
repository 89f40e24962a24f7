"""``backlash-df tune``: the fastest tuning certified not to hunt."""

import contextlib
import json

import click

from ..config import load_rig
from ..tuning import TUNABLE, tune
from .common import MODEL, echo_table, read_text, stage_bars
from .executors import checkpoint_for, checkpoint_options, executor_for, executor_options, stopped_note
from .outputs import Outputs

__all__ = ["tune_command"]


def _ranges(ctx, param, values):
    """``--vary NAME LOW,HIGH`` (repeatable) as ``{name: (low, high)}``."""
    vary = {}
    for name, text in values:
        try:
            low, high = (float(item) for item in text.split(","))
        except ValueError:
            raise click.BadParameter(f"{name} {text!r}: give LOW,HIGH (two numbers)") from None
        if name in vary:
            raise click.BadParameter(f"{name} given twice")
        vary[name] = (low, high)
    return vary


def _boxes(ctx, param, values):
    """``--uncertain NAME LOW,HIGH`` (repeatable) as ``{name: (low, high)}``, or None where not given."""
    return _ranges(ctx, param, values) if values else None


@click.command("tune")
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--vary", "vary", nargs=2, multiple=True, required=True, metavar="NAME LOW,HIGH", callback=_ranges,
              help=f"A rig value and its range, searched on a log scale (one or two of: {', '.join(TUNABLE)}).")
@click.option("--tolerance", type=click.FloatRange(min=0.0), default=0.0, show_default=True,
              help="Accepted hunting: largest first-harmonic amplitude of theta_d, rad.")
@click.option("--gain-margin", "gain_margin", type=float, default=1.25, show_default=True,
              help="Every varied value may be off by this factor (up or down) with the loop still certified; "
                   "1: none.")
@click.option("--uncertain", "uncertain", nargs=2, multiple=True, metavar="NAME LOW,HIGH", callback=_boxes,
              help="A rig value ([plant], [friction] or [load]) and the absolute range the drive's may lie in: "
                   "certified at every vertex of the box (repeatable; replaces the rig's [uncertainty] table).")
@click.option("--nominal", is_flag=True, help="Ignore the rig's [uncertainty] table: certify the nominal rig only.")
@click.option("--model", "model_name", default=None, type=MODEL,
              help="Torque law certified (default: the rig's [model] backlash).")
@executor_options
@checkpoint_options
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the tuning as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
def tune_command(rig_file, vary, tolerance, gain_margin, uncertain, nominal, model_name, workers, dask, scheduler, checkpoint_path, resume,
                 json_out, report_out):
    """The tuning of RIG_FILE with the largest bandwidth whose loop is certified not to hunt.

    The bandwidth is that of the loop with the gear in contact (speed reference to
    load speed; a cascade: position reference to load angle, -3 dB).  The certificate:
    the describing function's loci do not meet, shooting finds no periodic orbit,
    and every standard disturbance settles.  Every screened cell, bisection and
    certificate is kept in a checkpoint; after Ctrl-C, the same command with
    --resume computes only the others and finds the same tuning.

    With an [uncertainty] table in RIG_FILE (or --uncertain), the tuning is certified
    at every vertex of that box of rig values too.

    Example: backlash-df tune RIG --vary kp 1,1000 --vary ti 0.01,2
    """
    if nominal and uncertain is not None:
        raise click.UsageError("--nominal ignores the box that --uncertain gives: give one of them")
    outputs = Outputs({"--json": json_out, "--report": report_out})
    rig = load_rig(rig_file)
    checkpoint = checkpoint_for(outputs, "tune", checkpoint_path, resume)
    with contextlib.ExitStack() as stack:
        progress = stage_bars(stack, unit="tuning")
        with stopped_note(checkpoint, "cells"), executor_for(workers, dask, scheduler) as executor:
            tuning = tune(rig, vary, tolerance=tolerance, gain_margin=gain_margin,
                          uncertainty={} if nominal else uncertain, model=model_name,
                          executor=executor, progress=progress, checkpoint=checkpoint)
    for line in tuning.sentences():
        click.echo(line)
    click.echo("")
    for title, header, rows in tuning.tables():
        click.echo(title)
        echo_table(header, rows)
    texts = {}
    if "--json" in outputs:
        texts["--json"] = json.dumps(tuning.to_dict(), indent=2) + "\n"
    if "--report" in outputs:
        texts["--report"] = tuning.report_html(f"Tuning: {rig_file}", read_text(rig_file))
    outputs.write(texts)
    if checkpoint is not None:
        checkpoint.remove()
