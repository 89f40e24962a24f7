"""The ``backlash-df`` command line.

Every command turns a ``ValueError`` from the library (bad rig file, bad CSV,
bad argument) and every click usage error into one line on stderr,
``backlash-df: error: ...``, and exit code 2.  Output paths are checked before
anything is computed, and a command writes all its outputs or none
(:class:`~backlash_df.report.Outputs`).
"""

import math
import os
import sys
from pathlib import Path

import click

from . import __version__
from .models import MODEL_NAMES
from .report import Outputs
from .reproduce import LAW_NAMES, SETUPS


def _fail(message, code=2):
    """Print ``message`` as one ``backlash-df: error:`` line and exit with ``code``."""
    click.echo(f"backlash-df: error: {' '.join(str(message).split())}", err=True)
    sys.exit(code)


_NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())  # click >= 8.2


class _Group(click.Group):
    """A click group whose errors are one line: ``ValueError`` and usage errors, exit code 2."""

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
            _fail(f"{error.format_message()}{hint}", error.exit_code)
        except click.Abort:
            _fail("aborted", 1)
        sys.exit(value if isinstance(value, int) else 0)

    def invoke(self, ctx):
        from threadpoolctl import threadpool_limits

        try:
            # one BLAS thread: the kernels' small matrices run 1.3-1.4x slower on two
            # (benchmarks/bench_startup.py)
            with threadpool_limits(1, user_api="blas"):
                return super().invoke(ctx)
        except ValueError as error:
            _fail(error)


_MODEL = click.Choice(MODEL_NAMES)


class _FiniteFloat(click.ParamType):
    """A finite float (click's FLOAT accepts nan and inf)."""

    name = "float"

    def convert(self, value, param, ctx):
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"must be finite, got {value}", param, ctx)
        return number


_FINITE = _FiniteFloat()


@click.group(name="backlash-df", cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="backlash-df")
def main():
    """Describing functions and limit cycles of drives with backlash.

    Torque laws of Nordin, Galic and Gutman (1997), their describing functions
    N(A, w), limit-cycle prediction on PI-controlled two-mass loops verified by
    time simulation, and diagnosis of measured data.
    """


def _echo_table(header, rows):
    """A plain-text table, columns padded to their widest cell, a blank line after it."""
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]
    for row in [header] + rows:
        click.echo("  ".join(str(cell).ljust(width) for cell, width in zip(row, widths)).rstrip())
    click.echo("")


@main.command()
@click.argument("rig_file", type=click.Path(dir_okay=False))
@click.option("--model", "models", multiple=True, type=_MODEL,
              help="Torque law to analyse (repeatable; default: the rig's [model] backlash).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), help="Write the results as JSON.")
@click.option("--report", "report_out", type=click.Path(dir_okay=False), help="Write a self-contained HTML report.")
@click.option("--exact", is_flag=True,
              help="Also find the exact periodic orbits by shooting (amplitude, period, Floquet multipliers).")
def predict(rig_file, models, json_out, report_out, exact):
    """Predict limit cycles of RIG_FILE's PI loop for each model, verified by time simulation.

    Each model gets a verdict: no oscillation, limit cycle, bistable, unstable or
    undetermined, with the stability of the linear loop in contact and open.
    """
    import html
    import json

    from tqdm import tqdm

    from .config import load_rig
    from .limit_cycles import predict_limit_cycles, prediction_json, prediction_report, prediction_rows
    from .limit_cycles import orbit_rows, verdict_rows, verify_limit_cycles
    from .verdict import judge

    outputs = Outputs({"--json": json_out, "--report": report_out})
    rig = load_rig(rig_file)
    rig.require_controller()
    models = list(dict.fromkeys(models or [rig.model]))
    for name in models:
        rig.make_model(name)  # a law the rig cannot describe (rubber without beta) stops here
    rig_text = html.escape(Path(rig_file).read_text(encoding="utf-8")) if "--report" in outputs else ""
    predictions = [predict_limit_cycles(rig, name) for name in models]
    total = sum(max(1, len(p.stable_cycles)) for p in predictions)
    with tqdm(total=total + len(predictions), desc="simulating", unit="run", file=sys.stderr, leave=False) as bar:
        predictions = [verify_limit_cycles(rig, p, progress=bar.update) for p in predictions]
        judged = []
        for prediction in predictions:  # (tqdm's update() returns True when it redraws: not a filter)
            judged.append(judge(rig, prediction, exact=exact))
            bar.update()
        predictions = judged
    for header, rows in (prediction_rows(predictions), verdict_rows(predictions)) + (
            (orbit_rows(predictions),) if exact else ()):
        _echo_table(header, rows)
    for prediction in predictions:
        note = f" (exact orbits: {prediction.verdict.orbit_note})" if prediction.verdict.orbit_note else ""
        click.echo(f"{prediction.model}: {prediction.verdict.verdict}: {prediction.verdict.reason}{note}")
    texts = {}
    if "--json" in outputs:
        texts["--json"] = json.dumps(prediction_json(predictions, source=str(rig_file)), indent=2) + "\n"
    if "--report" in outputs:
        texts["--report"] = prediction_report(predictions, title=f"Limit cycles: {rig_file}", rig_text=rig_text)
    outputs.write(texts)


@main.command()
@click.argument("what", type=click.Choice(["figure2", "figure3", "table1"]))
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Write the result: PNG for figure2/figure3, .csv or .json for table1.")
@click.option("--setup", default="one-sided", show_default=True, type=click.Choice(list(SETUPS)),
              help="figure3: the Table I setup to plot.")
@click.option("--driver", default="phase-plane", show_default=True, type=click.Choice(LAW_NAMES),
              help="figure3/table1: the law that drives the simulation (the others are evaluated along it).")
@click.option("--dt", type=click.FloatRange(0.0, 1e-3, min_open=True, max_open=True), default=2e-5,
              show_default=True, help="figure3/table1: simulation step, s, in (0, 1e-3).")
def reproduce(what, out, setup, driver, dt):
    """Recompute the paper's Figure 2, Figure 3 or Table I and print it as text.

    Table I: the integral of the shaft torque T over one disturbance cycle (N m s)
    for each law, evaluated along one simulated trajectory, against the exact
    model (1), (14), and the RMS of T - T_exact (N m).  --out table.csv names
    each column's unit (integral_N_m_s, error_percent, rms_error_N_m,
    rms_error_percent); --out table.json lists them under "units".
    """
    from . import reproduce as paper
    from .report import figure_png

    suffixes = {"figure2": (".png",), "figure3": (".png",), "table1": (".csv", ".json")}[what]
    if out is not None and Path(out).suffix.lower() not in suffixes:
        raise ValueError(f"--out {out}: {what} is written as {' or '.join(suffixes)}")
    outputs = Outputs({"--out": out})
    if what == "figure2":
        maps = paper.figure2_maps()
        click.echo(paper.figure2_summary(maps))
        text = figure_png(paper.figure2(maps=maps)[0], dpi=120) if out else None
    elif what == "figure3":
        comparison = paper.compare_torques(setup, driver=driver, dt=dt)
        click.echo(paper.TableOne((comparison,)).to_text())
        text = figure_png(comparison.plot().figure, dpi=120) if out else None
    else:
        table = paper.table1(driver=driver, dt=dt)
        click.echo(table.to_text())
        text = (table.to_json() if Path(out).suffix.lower() == ".json" else table.to_csv()) if out else None
    outputs.write({"--out": text})


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

    outputs = Outputs({"--json": json_out, "--report": report_out})
    rig = load_rig(rig_file)
    measurements = load_measurements(data, gear_ratio=rig.plant.gear_ratio)
    for note in measurements.notes:
        click.echo(f"note: {note}", err=True)
    from tqdm import tqdm

    with tqdm(desc="diagnose: fits", unit="fit", file=sys.stderr, leave=False) as bar:
        result = run_diagnosis(measurements, rig, workers=min(2, os.cpu_count() or 1),
                               progress=lambda label: (bar.set_postfix_str(label[:40]), bar.update()))
    shaft = result.shaft
    click.echo(f"cause: {result.cause} (from the {result.structure.replace('_', '-')} model; shaft mode "
               f"{shaft.mode_frequency:.3g} Hz, resolved band {shaft.resolved_frequency:.3g} Hz)")
    for cause in result.causes:
        for name, parameter in cause["parameters"].items():
            low, high = parameter["ci95"]
            side = f" ({cause['side']} side)" if cause["side"] and cause["structure"] == "two_mass" else ""
            value = f"{parameter['value']:.4g}" if cause["determined"] else "not determined"
            click.echo(f"  {cause['effect']}{side}: {name} = {value} "
                       f"{parameter['unit']} (95 % CI {low:.4g} .. {high:.4g}), gain {100 * cause['gain']:.1f} %")
    for label, causes in (("two-mass", result.two_mass_causes), ("rigid-body", result.rigid_body.causes)):
        named = "; ".join(f"{c['effect']}" + (f" ({c['side']} side)" if c["side"] and label == "two-mass" else "")
                          + f" {p['value']:.4g} {p['unit']} ({p['ci95'][0]:.4g} .. {p['ci95'][1]:.4g})"
                          for c in causes for p in c["parameters"].values())
        click.echo(f"  {label} model names: {named or 'none'}")
    click.echo(result.sentence)
    if result.encoder_skew is not None:
        click.echo(f"  {result.skew_sentence()}")
    for label, model in (("", result.baseline), ("", result.extended), ("rigid body: ", result.rigid_body.baseline),
                         ("rigid body: ", result.rigid_body.extended)):
        label += " + ".join(model.effects) or "none (baseline)"
        fits = ", ".join(f"{name} {model.fit_percent[name]:.1f} % k-step / {model.ahead_fit_percent[name]:.1f} % ahead "
                         f"/ {model.free_run_fit_percent[name]:.1f} % free run" for name in model.fit_percent)
        click.echo(f"  validation fit of {label}: {fits}")
    for warning in result.warnings:
        click.echo(f"warning: {warning}")
    texts = {}
    if "--json" in outputs:
        texts["--json"] = result.to_json() + "\n"
    if "--report" in outputs:
        texts["--report"] = result.report_html()
    outputs.write(texts)


def _numbers(positive):
    """A click callback: finite numbers from repeated options, each possibly comma-separated.

    ``positive``: each must be > 0 (else >= 0).  A bad item is a usage error naming the option.
    """
    def parse(ctx, param, values):
        numbers = []
        for item in (item.strip() for value in values for item in str(value).split(",")):
            try:
                number = float(item)
            except ValueError:
                raise click.BadParameter(f"not a number: {item!r}") from None
            if not math.isfinite(number) or number < 0.0 or (positive and number == 0.0):
                raise click.BadParameter(f"must be {'> 0' if positive else '>= 0'} and finite, got {item}")
            numbers.append(number)
        return numbers
    return parse


@main.command("df")
@click.option("--rig", "rig_file", required=True, type=click.Path(dir_okay=False), help="Rig file (TOML).")
@click.option("--model", "model_name", default=None, type=_MODEL,
              help="Torque law (default: the rig's [model] backlash).")
@click.option("--amplitude", "amplitudes", multiple=True, required=True, metavar="A", callback=_numbers(True),
              help="Amplitude of theta_d, rad, > 0; repeat or comma-separate for several.")
@click.option("--omega", "omegas", multiple=True, required=True, metavar="W", callback=_numbers(False),
              help="Angular frequency, rad/s, >= 0; repeat or comma-separate for several.")
@click.option("--bias", type=_FINITE, default=0.0, show_default=True, help="Mean of theta_d, rad.")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Write the table as JSON.")
def describing(rig_file, model_name, amplitudes, omegas, bias, json_out):
    """Describing function N(A, w, bias) of a torque law: gain and phase.

    Every combination of the given amplitudes and frequencies is evaluated
    (x = bias + A sin(w t), N = (b1 + j a1) / A).
    """
    import json

    from .config import load_rig
    from .describing import describing_function_grid

    outputs = Outputs({"--json": json_out})
    rig = load_rig(rig_file)
    model = rig.make_model(model_name)
    result = describing_function_grid(model, amplitudes, omegas, bias)
    rows = []
    for i, amplitude in enumerate(result.amplitude):
        for j, omega in enumerate(result.omega):
            rows.append({
                "amplitude": float(amplitude), "omega": float(omega),
                "gain": float(result.gain[i, j]), "phase_deg": float(result.phase_deg[i, j]),
                "real": float(result.N[i, j].real), "imag": float(result.N[i, j].imag),
                "mean_torque": float(result.mean_torque[i, j]),
            })
    click.echo(f"describing function of {model.name} (k = {model.stiffness:g} N m/rad, c = {model.damping:g} "
               f"N m s/rad, alpha = {model.half_gap:g} rad, bias = {bias:g} rad)")
    click.echo(f"{'A (rad)':>12} {'w (rad/s)':>12} {'A/alpha':>9} {'c w/k':>9} {'gain (N m/rad)':>15} "
               f"{'phase (deg)':>12} {'mean T (N m)':>13}")
    for row in rows:
        rate = model.damping * row["omega"] / model.stiffness
        click.echo(f"{row['amplitude']:12.6g} {row['omega']:12.6g} {row['amplitude'] / model.half_gap:9.4g} "
                   f"{rate:9.3g} {row['gain']:15.6g} {row['phase_deg']:12.4f} {row['mean_torque']:13.4g}")
    payload = {"model": model.name, "rig": str(rig_file), "bias": bias, "points": rows}
    outputs.write({"--json": json.dumps(payload, indent=2) + "\n"})


from . import cli_sweeps  # noqa: E402, F401  (registers ``map`` on the group; it imports ``main``)
