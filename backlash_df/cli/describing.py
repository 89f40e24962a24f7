"""``backlash-df df``: a table of describing-function values."""

import json
import math

import click

from ..config import load_rig
from ..describing import describing_function_grid
from ..render.html import roundoff_zero
from .common import FINITE, MODEL, numbers
from .outputs import Outputs

__all__ = ["df_command"]


@click.command("df")
@click.option("--rig", "rig_file", required=True, type=click.Path(dir_okay=False), help="Rig file (TOML).")
@click.option("--model", "model_name", default=None, type=MODEL,
              help="Torque law (default: the rig's [model] backlash).")
@click.option("--amplitude", "amplitudes", multiple=True, required=True, metavar="A", callback=numbers(True),
              help="Amplitude of theta_d, rad, > 0; repeat or comma-separate for several.")
@click.option("--omega", "omegas", multiple=True, required=True, metavar="W", callback=numbers(False),
              help="Angular frequency, rad/s, >= 0; repeat or comma-separate for several.")
@click.option("--bias", type=FINITE, default=0.0, show_default=True, help="Mean of theta_d, rad.")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Write the table as JSON.")
def df_command(rig_file, model_name, amplitudes, omegas, bias, json_out):
    """Describing function N(A, w, bias) of a torque law: gain and phase.

    Every combination of the given amplitudes and frequencies is evaluated
    (x = bias + A sin(w t), N = (b1 + j a1) / A).
    """
    outputs = Outputs({"--json": json_out})
    rig = load_rig(rig_file)
    model = rig.make_model(model_name)
    points = describing_function_grid(model, amplitudes, omegas, bias=bias).to_dict()["points"]
    beta = f", beta = {model.rubber_thickness:g} rad" if model.name == "rubber" else ""
    click.echo(f"describing function of {model.name} (k = {model.stiffness:g} N m/rad, c = {model.damping:g} "
               f"N m s/rad, alpha = {model.half_gap:g} rad{beta}, bias = {bias:g} rad)")
    click.echo(f"{'A (rad)':>12} {'w (rad/s)':>12} {'A/alpha':>9} {'c w/k':>9} {'gain (N m/rad)':>15} "
               f"{'phase (deg)':>12} {'mean T (N m)':>13}")
    for row in points:
        rate = model.damping * row["omega"] / model.stiffness
        phase = roundoff_zero(row["phase_deg"], math.degrees(1.0))  # below 1e-12 rad: a static law's round-off
        mean = roundoff_zero(row["mean_torque"], row["gain"] * row["amplitude"])
        click.echo(f"{row['amplitude']:12.6g} {row['omega']:12.6g} {row['amplitude'] / model.half_gap:9.4g} "
                   f"{rate:9.3g} {row['gain']:15.6g} {phase:12.4f} {mean:13.4g}")
    payload = {"model": model.name, "rig": str(rig_file), "bias": bias, "points": points}
    outputs.write({"--json": json.dumps(payload, indent=2) + "\n"})
