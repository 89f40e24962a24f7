"""One keyword, one meaning across the public API (as python-control's ``kwargs_test.py`` checks its own).

The test walks every public function of the package and holds it to the rules:

* the data come first and may be positional; every option after them is keyword-only
  (the table ``DATA`` names each function's data: a new public function must be added);
* parallel work is ``executor=`` (a :class:`concurrent.futures.Executor`), never ``workers=``
  (a count is the command line's ``--workers``);
* long work reports through ``progress=``, keyword-only, with one protocol:
  ``progress(stage, done, total)`` (its docstring says so);
* where the torque law may be left out it is the rig's: ``model=None`` / ``models=None``.
"""

import importlib
import inspect
import pkgutil

import pytest

import backlash_df as bd

#: Each public function's data: the leading parameters that may be passed by position.
DATA = {
    "make_model": ("name",),
    "theta_star": ("dtheta_d", "stiffness", "damping", "half_gap"),
    "describing_function": ("model", "amplitude", "omega"),
    "dual_input_describing_function": ("model", "amplitude", "omega"),
    "describing_function_grid": ("model", "amplitude", "omega"),
    "phase_plane_validity": ("stiffness", "damping", "half_gap", "amplitude_ratio", "rate"),
    "load_rig": ("path",),
    "rig_from_dict": ("data", "source"),
    "write_rig": ("rig", "path"),
    "drive_loop": ("rig",),
    "predict_limit_cycles": ("rig", "model"),
    "verify_limit_cycles": ("rig", "prediction"),
    "limit_cycle_plot": ("predictions", "ax"),
    "simulate": ("rig", "model"),
    "simulated_limit_cycle": ("rig", "model"),
    "measure_limit_cycle": ("result",),
    "periodic_orbit": ("rig", "model", "seed"),
    "exact_orbits": ("rig", "prediction"),
    "judge_loop": ("rig", "prediction"),
    "analyse_loop": ("rig", "models"),
    "tune": ("rig", "vary"),
    "design_map": ("rig", "x_values", "y_values"),
    "continue_limit_cycles": ("rig", "parameter", "values_or_range", "model"),
    "compare_torques": ("setup",),
    "integrated_torque": ("model", "time", "theta_d", "dtheta_d"),
    "table1": ("setups",),
    "load_measurements": ("path",),
    "diagnose": ("measurements", "rig"),
    "lure_loop": ("system", "nonlinearity"),
    "judge_lure_loop": ("loop", "prediction"),
    "continue_lure_orbit": ("loop", "parameter", "values", "seed"),
    "lure_design_map": ("loop", "x", "y"),
}


def public_functions():
    """``(name, function)`` of every function the package's top level exports."""
    return [(name, getattr(bd, name)) for name in bd.__all__ if inspect.isfunction(getattr(bd, name))]


def module_functions():
    """``(qualified name, function)`` of every function in a public module's ``__all__``."""
    found = []
    for info in pkgutil.walk_packages(bd.__path__, "backlash_df."):
        if any(part.startswith("_") for part in info.name.split(".")) or info.name.startswith("backlash_df.cli"):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            item = getattr(module, name)
            if inspect.isfunction(item) and item.__module__ == module.__name__:
                found.append((f"{info.name}.{name}", item))
    return found


def test_every_public_function_names_its_data():
    assert {name for name, _ in public_functions()} == set(DATA)


@pytest.mark.parametrize("name, function", public_functions(), ids=[name for name, _ in public_functions()])
def test_options_after_the_data_are_keyword_only(name, function):
    parameters = [p for p in inspect.signature(function).parameters.values() if p.kind is not p.VAR_KEYWORD]
    positional = tuple(p.name for p in parameters if p.kind is not p.KEYWORD_ONLY)
    assert positional == DATA[name], f"{name}: positional {positional}, data {DATA[name]}"


@pytest.mark.parametrize("name, function", module_functions(), ids=[name for name, _ in module_functions()])
def test_one_keyword_one_meaning(name, function):
    parameters = inspect.signature(function).parameters
    assert "workers" not in parameters, f"{name}: parallel work is executor=, not workers="
    for keyword in ("progress", "executor"):
        if keyword in parameters:
            assert parameters[keyword].kind is inspect.Parameter.KEYWORD_ONLY, f"{name}: {keyword} keyword-only"
            assert parameters[keyword].default is None, f"{name}: {keyword}=None by default"
    if "progress" in parameters:
        assert "progress(stage, done, total)" in " ".join(function.__doc__.split()), f"{name}: the protocol"
    for keyword in ("model", "models"):  # where a rig's law may be left out, it is the rig's
        if "rig" in parameters and keyword in parameters and parameters[keyword].default is not inspect.Parameter.empty:
            assert parameters[keyword].default is None, f"{name}: {keyword} defaults to the rig's law"


def test_progress_is_called_with_stage_done_total():
    """One protocol, seen from a caller: stages named, counts rising to the total."""
    calls = []
    rig = bd.load_rig(bd.__path__[0] + "/../examples/load_feedback.toml")
    bd.analyse_loop(rig, ["phase-plane"], progress=lambda *args: calls.append(args))
    assert calls and all(len(call) == 3 and isinstance(call[0], str) for call in calls)
    stages = {stage for stage, _, _ in calls}
    for stage in stages:
        counts = [(done, total) for s, done, total in calls if s == stage]
        assert [done for done, _ in counts] == sorted(done for done, _ in counts)
        assert counts[-1][0] == counts[-1][1]  # the stage ends complete
