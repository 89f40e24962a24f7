"""Predict, verify, judge: the limit-cycle analysis of a rig's loop as one library call.

:func:`analyse_loop` runs, for each torque law, the describing-function prediction
(:func:`~backlash_df.limit_cycles.predict_limit_cycles`), its check by time
simulation (:func:`~backlash_df.limit_cycles.verify_limit_cycles`) and the verdict
(:func:`~backlash_df.verdict.judge_loop`), optionally with the exact periodic orbits.
The :class:`LoopAnalysis` it returns prints as the ``backlash-df predict`` text, writes
its JSON and its HTML report; the command line only parses, calls and prints.
"""

import dataclasses

from .limit_cycles import limit_cycle_plot, predict_limit_cycles, verify_limit_cycles
from .render.analysis import analysis_report, analysis_sentences, analysis_tables
from .verdict import judge_loop

__all__ = ["LoopAnalysis", "analyse_loop", "loop_models"]


@dataclasses.dataclass(frozen=True)
class LoopAnalysis:
    """Every torque law's prediction, its simulation and its verdict, for one loop.

    Attributes
    ----------
    verdicts : tuple of LoopVerdict
        One per law, in the order asked; each holds its verified
        :class:`~backlash_df.limit_cycles.LimitCyclePrediction` (``.prediction``).
    exact : bool
        Whether the exact periodic orbits were sought.
    source : str
        Where the rig came from (its file).
    """

    verdicts: tuple
    exact: bool = False
    source: str = ""

    @property
    def predictions(self):
        """The verified DF predictions, one per law."""
        return tuple(verdict.prediction for verdict in self.verdicts)

    def __repr__(self):
        words = ", ".join(f"{v.model}: {v.verdict}" for v in self.verdicts)
        return f"<LoopAnalysis of {self.source or 'a rig'}: {words}>"

    def tables(self):
        """The terminal's tables: ``[(header, rows), ...]`` (predicted cycles, verdicts, and orbits if sought;
        :func:`~backlash_df.render.analysis.analysis_tables`)."""
        return analysis_tables(self)

    def sentences(self):
        """One line per law: the verdict and why, and why there are no exact orbits, where so
        (:func:`~backlash_df.render.analysis.analysis_sentences`)."""
        return analysis_sentences(self)

    def to_dict(self):
        """The ``predict`` JSON (contract page): ``limit_cycles``, ``rig``, and per law its verdict and details."""
        return {
            "limit_cycles": [entry for prediction in self.predictions for entry in prediction.cycle_dicts()],
            "rig": self.source,
            "models": [
                {
                    "model": verdict.model,
                    **verdict.to_dict(),
                    "simulated": None if verdict.prediction.simulation is None
                    else verdict.prediction.simulation.cycle_dict(),
                    "near_misses": [miss.to_dict() for miss in verdict.prediction.near_misses],
                    "amplitude_range": list(verdict.prediction.amplitude_range),
                    "omega_range": list(verdict.prediction.omega_range),
                }
                for verdict in self.verdicts
            ],
        }

    def plot(self, ax=None, **kwargs):
        """Nyquist overlay of every law's loci with G(jw); see :func:`~backlash_df.limit_cycles.limit_cycle_plot`."""
        return limit_cycle_plot(self.predictions, ax=ax, **kwargs)

    def report_html(self, title="", rig_text=""):
        """A self-contained HTML page: summary with verdicts, Nyquist overlay, cycles, verdicts, orbits.

        Parameters
        ----------
        title : str
            Page title (default: "Limit cycles: " and the rig's source).
        rig_text : str
            The rig file's text, shown as it is.

        See Also
        --------
        backlash_df.render.analysis.analysis_report
        """
        return analysis_report(self, self.plot().figure, title, rig_text)


def loop_models(rig, models=None):
    """The torque laws :func:`analyse_loop` analyses: ``models`` without repeats (default: the rig's
    ``[model] backlash``), each checked against the rig.

    Raises
    ------
    ValueError
        No ``[controller]``, or a law the rig cannot describe (``rubber`` without
        ``rubber_thickness``).
    """
    rig.require_controller()
    models = list(dict.fromkeys(models or [rig.model]))
    for name in models:
        rig.make_model(name)  # a law the rig cannot describe stops here
    return models


def analyse_loop(rig, models=None, *, exact=False, progress=None):
    """Predict, verify and judge the limit cycles of a rig's loop for each torque law.

    Parameters
    ----------
    rig : Rig
        Plant and ``[controller]``.
    models : sequence of str, optional
        Torque laws (default: the rig's ``[model] backlash``); repeats are dropped.
    exact : bool
        Also find the exact periodic orbits by shooting (:mod:`backlash_df.orbits`).
    progress : callable, optional
        ``progress(stage, done, total)`` (the package's one protocol), stage
        ``"simulating"``, after each verifying simulation and each verdict.

    Returns
    -------
    LoopAnalysis

    Raises
    ------
    ValueError
        No ``[controller]``, or a law the rig cannot describe (``rubber`` without
        ``rubber_thickness``), before anything is computed.
    """
    models = loop_models(rig, models)
    predictions = [predict_limit_cycles(rig, name) for name in models]
    total = sum(max(1, len(p.stable_cycles)) for p in predictions) + len(predictions)
    done = 0

    def step(*_):
        nonlocal done
        done += 1
        if progress is not None:
            progress("simulating", done, total)

    verified = [verify_limit_cycles(rig, prediction, progress=step) for prediction in predictions]
    verdicts = []
    for prediction in verified:
        verdicts.append(judge_loop(rig, prediction, exact=exact))
        step()
    return LoopAnalysis(tuple(verdicts), exact=bool(exact), source=rig.source)
