"""The ``backlash-df`` command line.

Every command turns a ``ValueError`` from the library (bad rig file, bad CSV,
bad argument) into one line on stderr and exit code 2, like click's own usage
errors; nothing half-written is left behind (outputs are written last, through
:func:`write_output`).
"""

import os
import sys
import tempfile
from pathlib import Path

import click

from . import __version__


class _Group(click.Group):
    """A click group whose commands report ``ValueError`` as one line, exit code 2."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except ValueError as error:
            message = " ".join(str(error).split())
            click.echo(f"backlash-df: error: {message}", err=True)
            sys.exit(2)


def write_output(path, text):
    """Write ``text`` to ``path`` atomically: a reader never sees half a file."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="backlash-df")
def main():
    """Describing functions and limit cycles of drives with backlash.

    Torque laws of Nordin, Galic and Gutman (1997), their describing functions
    N(A, w), limit-cycle prediction on PI-controlled two-mass loops verified by
    time simulation, and diagnosis of measured data.
    """


@main.command()
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--model", "models", multiple=True, metavar="NAME",
              help="Torque law to analyse (repeatable; default: the rig's [model] backlash).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the results as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
def predict(rig_file, models, json_out, report_out):
    """Predict limit cycles of RIG_FILE's PI loop for each model, verified by time simulation."""
    import html
    import json

    from tqdm import tqdm

    from .config import load_rig
    from .limit_cycles import predict_limit_cycles, prediction_json, prediction_report, prediction_rows
    from .limit_cycles import verify_limit_cycles
    from .models import MODEL_NAMES

    rig = load_rig(rig_file)
    rig.require_controller()
    models = list(dict.fromkeys(models or [rig.model]))
    for name in models:
        if name not in MODEL_NAMES:
            raise ValueError(f"--model: unknown model {name!r} (rig {rig_file}); choose one of: {', '.join(MODEL_NAMES)}")
    predictions = [predict_limit_cycles(rig, name) for name in models]
    total = sum(max(1, len(p.stable_cycles)) for p in predictions)
    with tqdm(total=total, desc="simulating", unit="run", file=sys.stderr, leave=False) as bar:
        predictions = [verify_limit_cycles(rig, p, progress=bar.update) for p in predictions]
    header, rows = prediction_rows(predictions)
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]
    for row in [header] + rows:
        click.echo("  ".join(str(cell).ljust(width) for cell, width in zip(row, widths)).rstrip())
    if json_out:
        write_output(json_out, json.dumps(prediction_json(predictions, source=str(rig_file)), indent=2) + "\n")
    if report_out:
        rig_text = html.escape(Path(rig_file).read_text(encoding="utf-8"))
        write_output(report_out, prediction_report(predictions, title=f"Limit cycles: {rig_file}", rig_text=rig_text))


@main.command()
@click.argument("what", type=click.Choice(["figure2", "figure3", "table1"]))
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Write the result: PNG for figure2/figure3, .csv or .json for table1.")
@click.option("--setup", default="one-sided", show_default=True, help="figure3: the Table I setup to plot.")
@click.option("--driver", default="phase-plane", show_default=True,
              help="figure3/table1: the law that drives the simulation (the others are evaluated along it).")
@click.option("--dt", type=float, default=2e-5, show_default=True, help="figure3/table1: simulation step, s.")
def reproduce(what, out, setup, driver, dt):
    """Recompute the paper's Figure 2, Figure 3 or Table I and print it as text."""
    from . import reproduce as paper

    suffixes = {"figure2": (".png",), "figure3": (".png",), "table1": (".csv", ".json")}[what]
    if out is not None and Path(out).suffix.lower() not in suffixes:
        raise ValueError(f"--out {out}: {what} is written as {' or '.join(suffixes)}")
    if not (dt > 0.0 and dt < 1e-3):
        raise ValueError(f"--dt must lie in (0, 1e-3) s, got {dt!r}")
    if what == "figure2":
        maps = paper.figure2_maps()
        click.echo(paper.figure2_summary(maps))
        if out:
            paper.save_figure(paper.figure2(maps=maps)[0], out)
    elif what == "figure3":
        comparison, ax = paper.figure3(setup=setup, driver=driver, dt=dt)
        click.echo(paper.TableOne((comparison,)).to_text())
        if out:
            paper.save_figure(ax.figure, out)
        else:
            import matplotlib.pyplot as plt

            plt.close(ax.figure)
    else:
        table = paper.table1(driver=driver, dt=dt)
        click.echo(table.to_text())
        if out:
            write_output(out, table.to_json() if Path(out).suffix.lower() == ".json" else table.to_csv())


@main.command()
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--rig", "rig_file", required=True, type=click.Path(dir_okay=False), help="Rig file (TOML).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Write the diagnosis as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), default=None,
              help="Write a self-contained HTML report.")
def diagnose(data, rig_file, json_out, report_out):
    """Name the physical cause of what the rig's model gets wrong in a measurement CSV."""
    from .config import load_rig
    from .identify import diagnose as run_diagnosis
    from .identify import load_measurements

    rig = load_rig(rig_file)
    measurements = load_measurements(data)
    result = run_diagnosis(measurements, rig, workers=min(2, os.cpu_count() or 1))
    click.echo(f"cause: {result.cause}")
    click.echo(result.sentence)
    for candidate in result.candidates:
        click.echo(f"  {candidate.cause:17s} validation fit {candidate.mean_fit_percent:7.2f} %  "
                   f"{'accepted' if candidate.accepted else ''}")
    report = result.report_html() if report_out else None  # build everything before writing anything
    if json_out:
        write_output(json_out, result.to_json() + "\n")
    if report_out:
        write_output(report_out, report)


def _floats(name, values):
    """Numbers from repeated options, each possibly a comma-separated list."""
    numbers = []
    for value in values:
        for item in str(value).split(","):
            try:
                numbers.append(float(item))
            except ValueError:
                raise ValueError(f"--{name}: not a number: {item!r}") from None
    if not numbers:
        raise ValueError(f"--{name}: give at least one value")
    return numbers


@main.command("df")
@click.option("--rig", "rig_file", required=True, type=click.Path(dir_okay=False), help="Rig file (TOML).")
@click.option("--model", "model_name", default=None, metavar="NAME",
              help="Torque law (default: the rig's [model] backlash).")
@click.option("--amplitude", "amplitudes", multiple=True, required=True, metavar="A",
              help="Amplitude of theta_d, rad; repeat or comma-separate for several.")
@click.option("--omega", "omegas", multiple=True, required=True, metavar="W",
              help="Angular frequency, rad/s; repeat or comma-separate for several.")
@click.option("--bias", type=float, default=0.0, show_default=True, help="Mean of theta_d, rad.")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Write the table as JSON.")
def describing(rig_file, model_name, amplitudes, omegas, bias, json_out):
    """Describing function N(A, w, bias) of a torque law: gain and phase.

    Every combination of the given amplitudes and frequencies is evaluated
    (x = bias + A sin(w t), N = (b1 + j a1) / A).
    """
    import json

    import numpy as np

    from .config import load_rig
    from .describing import describing_function_grid

    rig = load_rig(rig_file)
    model = rig.make_model(model_name)
    result = describing_function_grid(model, _floats("amplitude", amplitudes), _floats("omega", omegas), bias)
    rows = []
    for i, amplitude in enumerate(result.amplitude):
        for j, omega in enumerate(result.omega):
            rows.append({
                "amplitude": float(amplitude), "omega": float(omega),
                "gain": float(result.gain[i, j]), "phase_deg": float(result.phase_deg[i, j]),
                "real": float(result.N[i, j].real), "imag": float(result.N[i, j].imag),
                # round-off of a symmetric law's zero mean is printed as 0
                "mean_torque": float(np.where(abs(result.mean_torque[i, j]) < 1e-12 * model.stiffness
                                              * model.half_gap, 0.0, result.mean_torque[i, j])),
            })
    click.echo(f"describing function of {model.name} (k = {model.stiffness:g} N m/rad, c = {model.damping:g} "
               f"N m s/rad, alpha = {model.half_gap:g} rad, bias = {bias:g} rad)")
    click.echo(f"{'A (rad)':>12} {'w (rad/s)':>12} {'A/alpha':>9} {'c w/k':>9} {'gain (N m/rad)':>15} "
               f"{'phase (deg)':>12} {'mean T (N m)':>13}")
    for row in rows:
        rate = model.damping * row["omega"] / model.stiffness
        click.echo(f"{row['amplitude']:12.6g} {row['omega']:12.6g} {row['amplitude'] / model.half_gap:9.4g} "
                   f"{rate:9.3g} {row['gain']:15.8g} {row['phase_deg']:12.6f} {row['mean_torque']:13.6g}")
    if json_out:
        payload = {"model": model.name, "rig": str(rig_file), "bias": bias, "points": rows}
        write_output(json_out, json.dumps(payload, indent=2) + "\n")
