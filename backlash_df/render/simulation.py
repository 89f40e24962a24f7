"""A run against a record in words: the lines ``backlash-df simulate`` prints.

Rendered from a :class:`~backlash_df.simulation.record.SimulatedRecord`'s attributes:
the run's length, steps and samples, its inputs and, with a record, the fit of each
compared column.
"""

__all__ = ["simulated_record_lines"]

#: What a fit percentage is, as the text states it.
FIT_DEFINITION = "fit = 100 (1 - |y - y_sim| / |y - mean y|) %, free run"


def simulated_record_lines(run):
    """The summary of a run against recorded inputs, and its fit per column, as lines of text.

    Parameters
    ----------
    run : SimulatedRecord

    Returns
    -------
    list of str
    """
    simulated, simulation = run.simulated, run.simulation
    lines = [f"simulated {simulated.duration:g} s of {run.rig.source} with the {simulation.model.name} law: "
             f"{run.steps} steps of {run.dt:.3g} s, {simulated.n_samples} samples every {simulated.dt:.3g} s, "
             f"{simulation.events} mode changes"]
    unit = "rad" if run.reference_kind == "position" else "rad/s"
    if run.inputs is None:
        lines.append(f"inputs: none ({run.reference_kind} reference 0 {unit}, the rig's load torque)")
    else:
        load = "load_torque" if run.inputs.load_torque is not None else "the rig's load torque"
        lines.append(f"inputs: {run.inputs.source} ({run.inputs.time.size} rows: {run.reference_kind} reference in "
                     f"{unit}, {load})")
    if run.record is not None:
        lines.append(f"compared with {run.record.source} ({run.record.n_samples} samples; {FIT_DEFINITION}):")
        width = max(len(name) for name in run.fit_percent)
        lines += [f"  {name:<{width}}  {value:6.1f} %" for name, value in run.fit_percent.items()]
    return lines
