"""``backlash-df diagnose``: what the rig's model gets wrong in a measurement record, and why."""

import contextlib
import json
import os
from concurrent.futures import ThreadPoolExecutor

import click

from ..config import load_rig
from ..identify import diagnose as run_diagnosis
from ..identify import load_measurements
from .common import stage_bars
from .outputs import Outputs

__all__ = ["diagnose_command"]


@click.command("diagnose")
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--rig", "rig_file", required=True, type=click.Path(dir_okay=False), help="Rig file (TOML).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Write the diagnosis as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), default=None,
              help="Write a self-contained HTML report.")
@click.option("--rig-out", "rig_out", type=click.Path(dir_okay=False), default=None,
              help="Write the diagnosed model as a rig file (.toml): the calibrated plant, the named friction, "
                   "torque offset and rubber, each value with its 95 % interval as a comment and in [uncertainty]; "
                   "causes it cannot hold are listed as dropped.")
@click.option("--strict", is_flag=True, help="Refuse a CSV whose header names a column not listed above.")
@click.option("--allow-unknown-columns", is_flag=True,
              help="Read a column that looks like a misspelt one of the list above (load_sped) as an unknown "
                   "column: not read, with a note.")
def diagnose_command(data, rig_file, json_out, report_out, rig_out, strict, allow_unknown_columns):
    """Name the physical cause of what the rig's model gets wrong in the measurement CSV DATA.

    DATA: UTF-8, comma-separated with a decimal point, one header row naming the
    columns in any order, SI units, uniformly sampled, at least 200 rows:

    \b
    time:          s, required; sample instants, increasing, uniform
    motor_torque:  N m, motor side, required; torque commanded to the motor
    motor_speed:   rad/s, motor side, required; measured motor speed
    load_speed:    rad/s, load side; measured load speed
    load_torque:   N m, load side; known torque on the load (else 0)
    motor_angle:   rad, motor side; motor encoder angle
    load_angle:    rad, load side; load (secondary) encoder angle

    Sides: the motor columns are reflected to the load side through the rig's
    [plant] gear_ratio n (torque times n, speed and angle divided by n).  Signs:
    a positive motor_torque drives the motor forward, a positive load_torque
    drives the load forward, each speed is the derivative of its angle, and the
    twist is theta_d = motor_angle / n - load_angle.  A header name not in this
    list is not read: a note names it with the closest known column
    (load_trq: not a known column; did you mean load_torque?); --strict refuses
    the file instead.  A name that looks like a misspelling of an optional
    column the header lacks (load_sped, load_trq, Load_Speed) refuses the file
    unless --allow-unknown-columns is given.
    """
    outputs = Outputs({"--json": json_out, "--report": report_out, "--rig-out": rig_out})
    rig = load_rig(rig_file)
    measurements = load_measurements(data, gear_ratio=rig.plant.gear_ratio, strict=strict,
                                     allow_unknown_columns=allow_unknown_columns)
    for note in measurements.notes:
        click.echo(f"note: {note}", err=True)
    with contextlib.ExitStack() as stack, ThreadPoolExecutor(min(2, os.cpu_count() or 1)) as pool:
        result = run_diagnosis(measurements, rig, executor=pool,
                               progress=stage_bars(stack, unit="fit", prefix="diagnose: "))
    for line in result.sentences():
        click.echo(line)
    texts = {}
    if "--json" in outputs:
        texts["--json"] = json.dumps(result.to_dict(), indent=2) + "\n"
    if "--report" in outputs:
        texts["--report"] = result.report_html()
    if "--rig-out" in outputs:
        diagnosed = result.rig_out()
        for note in diagnosed.dropped:
            click.echo(f"dropped: {note}", err=True)
        for note in diagnosed.notes:
            click.echo(f"note: {note}", err=True)
        texts["--rig-out"] = diagnosed.to_toml()
    outputs.write(texts)
