"""``backlash-df reproduce``: the paper's Figure 2, Figure 3 and Table I."""

import json
from pathlib import Path

import click

from .. import reproduce as paper
from ..render.html import FIGURE_FORMATS, figure_bytes
from ..render.reproduce import figure2_summary
from .outputs import Outputs, plot_format

__all__ = ["reproduce_command"]


@click.command("reproduce")
@click.argument("what", type=click.Choice(["figure2", "figure3", "table1"]))
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="Write the result: .png, .pdf or .svg for figure2/figure3 (the format the suffix names), "
                   ".csv or .json for table1.")
@click.option("--setup", default="one-sided", show_default=True, type=click.Choice(list(paper.SETUPS)),
              help="figure3: the Table I setup to plot.")
@click.option("--driver", default="phase-plane", show_default=True, type=click.Choice(paper.LAW_NAMES),
              help="figure3/table1: the law that drives the simulation (the others are evaluated along it).")
@click.option("--dt", type=click.FloatRange(0.0, 1e-3, min_open=True, max_open=True), default=2e-5,
              show_default=True, help="figure3/table1: simulation step, s, in (0, 1e-3).")
def reproduce_command(what, out, setup, driver, dt):
    """Recompute the paper's Figure 2, Figure 3 or Table I and print it as text.

    Table I: the integral of the shaft torque T over one disturbance cycle (N m s)
    for each law, evaluated along one simulated trajectory, against the exact
    model (1), (14), and the RMS of T - T_exact (N m).  --out table.csv names
    each column's unit (integral_N_m_s, error_percent, rms_error_N_m,
    rms_error_percent); --out table.json lists them under "units".
    """
    suffixes = {"figure2": tuple(FIGURE_FORMATS), "figure3": tuple(FIGURE_FORMATS), "table1": (".csv", ".json")}[what]
    if out is not None and Path(out).suffix.lower() not in suffixes:
        raise ValueError(f"--out {out}: {what} is written as {', '.join(suffixes[:-1])} or {suffixes[-1]}")
    outputs = Outputs({"--out": out})
    if what == "figure2":
        maps = paper.figure2_maps()
        click.echo(figure2_summary(maps))
        text = figure_bytes(paper.figure2(maps=maps)[0], plot_format(out), dpi=120) if out else None
    elif what == "figure3":
        comparison = paper.compare_torques(setup, driver=driver, dt=dt)
        click.echo(paper.TableOne((comparison,)).to_text())
        text = figure_bytes(comparison.plot().figure, plot_format(out), dpi=120) if out else None
    else:
        table = paper.table1(driver=driver, dt=dt)
        click.echo(table.to_text())
        as_json = out is not None and Path(out).suffix.lower() == ".json"
        text = (json.dumps(table.to_dict(), indent=2) + "\n" if as_json else table.to_csv()) if out else None
    outputs.write({"--out": text})
