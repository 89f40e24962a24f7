"""One result protocol over every public result class (issue 18).

Each class: ``to_dict()`` is JSON-ready (``json.dumps(..., allow_nan=False)``
accepts it and gives the same data back), the repr is one short line, ``plot(ax=None)``
returns a :class:`~backlash_df.ResultPlot` whose ``figure`` holds its ``axes`` (and
draws into axes it is given), and ``report_html(title="", rig_text="")`` where a
report exists shows the title and the rig text, escaped.  The instances are the
``results`` fixture of ``conftest.py`` (tests/test_plot_layout.py walks the same
ones); the list of classes is checked against the package: a new public class with
a ``to_dict`` must be added there.
"""

import importlib
import inspect
import json
import pkgutil

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402

import backlash_df as bd  # noqa: E402
from conftest import PLOTS, REPORTS  # noqa: E402

RIG_TEXT = "[plant]\n# a <b>rig</b> & its text\n"


def _public_result_classes():
    """Every class in a public module's ``__all__`` that has a ``to_dict`` method (the rig file's are inputs)."""
    names = set()
    for info in pkgutil.walk_packages(bd.__path__, "backlash_df."):
        if any(part.startswith("_") for part in info.name.split(".")) or info.name.startswith(
                ("backlash_df.cli", "backlash_df.config")):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            item = getattr(module, name)
            if inspect.isclass(item) and callable(getattr(item, "to_dict", None)):
                names.add(name)
    return names


def test_every_public_result_class_is_covered(results):
    covered = {type(result).__name__ for result in results.values()}
    assert _public_result_classes() <= covered


@pytest.mark.parametrize("name", sorted(["LimitCyclePrediction", "LimitCycle", "NearMiss", "LoopVerdict", "Probe",
                                         "LinearStability", "LoopAnalysis", "PeriodicOrbit", "Branch", "BranchPoint",
                                         "SpecialPoint", "DesignMap", "SimulationResult", "MeasuredCycle",
                                         "DescribingFunctionResult", "ValidityMap", "TorqueComparison", "TableOne",
                                         "Measurements", "SimulatedRecord", "Diagnosis", "Cause", "Stage", "ShaftResolution",
                                         "CandidateResult", "Calibration", "FitParameter", "Replay", "FreeRunReplay",
                                         "ResidualAnalysis", "LoadLimit", "Tuning", "Certificate", "Candidate",
                                         "Disturbance", "Rest", "Reason", "Finding", "RecordNote", "WeakBaseline",
                                         "Unexplained", "FewSegments", "UnphysicalInterval", "OnBound", "InitialSpeed",
                                         "Absorbed", "SideUndetermined", "Disagreement", "LureOrbit",
                                         "LureSimulation", "LureVerdict", "LureProbe",
                                         "LureBranch", "LureDesignMap"]))
def test_to_dict_is_json_and_the_repr_one_line(results, name):
    result = results[name]
    data = result.to_dict()
    assert isinstance(data, dict) and data
    assert json.loads(json.dumps(data, allow_nan=False)) == json.loads(json.dumps(data, allow_nan=False))
    text = repr(result)
    assert "\n" not in text and len(text) < 400, text
    assert "array(" not in text  # no numpy arrays dumped into the repr


@pytest.mark.parametrize("name", PLOTS)
def test_plot_returns_a_result_plot(results, name):
    result = results[name]
    try:
        drawn = result.plot()
        assert isinstance(drawn, bd.ResultPlot)
        assert drawn.axes.size >= 1 and all(isinstance(ax, Axes) for ax in drawn.axes.flat)
        assert all(ax.figure is drawn.figure for ax in drawn.axes.flat)
        assert any(ax.has_data() for ax in drawn.axes.flat)
        # drawn again into the same axes: the result draws where it is told
        again = result.plot(ax=drawn.axes.reshape(-1) if drawn.axes.size > 1 else drawn.axes.flat[0])
        assert again.figure is drawn.figure
        assert [id(ax) for ax in again.axes.flat] == [id(ax) for ax in drawn.axes.flat]
    finally:
        plt.close("all")


@pytest.mark.parametrize("name", REPORTS)
def test_report_html_shows_title_and_rig_text(results, name):
    page = results[name].report_html(title="A title <here>", rig_text=RIG_TEXT)
    assert page.startswith("<!DOCTYPE html>")
    assert "<title>A title &lt;here&gt;</title>" in page
    assert "a &lt;b&gt;rig&lt;/b&gt; &amp; its text" in page  # escaped, once
    assert page.count("its text") == 1
    default = results[name].report_html()
    assert "<title></title>" not in default
    plt.close("all")


def test_the_removed_shims_are_gone(results):
    """0.2 removed the old returns and aliases (changelog): each fails as any missing name does."""
    with pytest.raises(TypeError):
        results["SimulationResult"].plot()[0]
    with pytest.raises(AttributeError):
        results["LimitCyclePrediction"].plot().get_xlabel
    for result, name in ((results["LimitCyclePrediction"], "to_dicts"), (results["Diagnosis"], "to_json"),
                         (results["TableOne"], "to_json")):
        assert not hasattr(result, name)
    with pytest.raises(TypeError):
        results["Diagnosis"].causes[0]["effect"]
    with pytest.raises(ModuleNotFoundError):
        import backlash_df.simulate  # noqa: F401
    assert not hasattr(bd.verdict, "judge")
    plt.close("all")


def test_the_readme_names_exactly_the_results_that_plot():
    """README.md lists the result classes with ``.plot()``: the list is the package's, no more, no less."""
    from conftest import ROOT

    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    listed = text.split("have a `.plot()` that returns a `ResultPlot` (`.figure`, `.axes`):")[1].split(";")[0]
    named = {word.strip("`, .") for word in listed.split() if word.startswith("`")} - {"and"}
    plotting = set()
    for info in pkgutil.walk_packages(bd.__path__, "backlash_df."):
        if info.name.startswith("backlash_df.cli") or any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        plotting |= {name for name in getattr(module, "__all__", ())
                     if inspect.isclass(item := getattr(module, name)) and callable(getattr(item, "to_dict", None))
                     and callable(getattr(item, "plot", None))}
    assert named == plotting
