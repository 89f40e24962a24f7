"""``backlash-df predict``: the limit-cycle report of a rig's loop."""

import contextlib
import json

import click

from ..analysis import analyse_loop, loop_models
from ..config import load_rig
from .common import MODEL, echo_table, read_text, stage_bars
from .outputs import Outputs
from .warmup import warm_kernels

__all__ = ["predict_command"]


@click.command("predict")
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--model", "models", multiple=True, type=MODEL,
              help="Torque law to analyse (repeatable; default: the rig's [model] backlash).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the results as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
@click.option("--exact", is_flag=True,
              help="Also find the exact periodic orbits by shooting (amplitude, period, Floquet multipliers).")
def predict_command(rig_file, models, json_out, report_out, exact):
    """Predict limit cycles of RIG_FILE's PI loop for each model, verified by time simulation.

    Each model gets a verdict: no oscillation, limit cycle, bistable, unstable or
    undetermined, with the stability of the linear loop in contact and open.
    """
    outputs = Outputs({"--json": json_out, "--report": report_out})
    rig = load_rig(rig_file)
    models = loop_models(rig, models)
    warm_kernels(rig, rig_file, models)
    with contextlib.ExitStack() as stack:
        analysis = analyse_loop(rig, models, exact=exact, progress=stage_bars(stack))
    for header, rows in analysis.tables():
        if rows:  # no exact orbit: the sentences say why
            echo_table(header, rows)
    for line in analysis.sentences():
        click.echo(line)
    texts = {}
    if "--json" in outputs:
        texts["--json"] = json.dumps(analysis.to_dict(), indent=2) + "\n"
    if "--report" in outputs:
        texts["--report"] = analysis.report_html(f"Limit cycles: {rig_file}", read_text(rig_file))
    outputs.write(texts)
