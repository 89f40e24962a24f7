"""backlash-df: describing functions and limit cycles of drives with backlash.

Torque laws of Nordin, Galic and Gutman (1997) (:mod:`backlash_df.models`), the
rig file (:mod:`backlash_df.config`), the loop cut at the backlash
(:mod:`backlash_df.system`), and the stages built on them, one module each; every
import points down that list.  The names below are the public API; the
documentation's contract page states the rig-file keys, the JSON and CSV formats and
the sign conventions they follow.

The names load on first use (``lazy_loader``, as scipy and scikit-image load theirs): a
command or script imports only the stages it calls, so a ``predict`` does not import
the diagnosis or the tuning.
"""

import pkgutil as _pkgutil

import lazy_loader as _lazy

from ._version import __version__

#: The public names, by the module that holds them.
_EXPORTS = {
    "config": ["Controller", "Friction", "Load", "Plant", "Rig", "RigError", "load_rig", "rig_from_dict",
               "write_rig"],
    "models": ["MODEL_NAMES", "ExactModel", "StaticModel", "make_model", "theta_star"],
    "describing": ["DescribingFunctionResult", "ValidityMap", "describing_function", "describing_function_grid",
                   "dual_input_describing_function", "phase_plane_validity"],
    "plotting": ["ResultPlot"],
    "system": ["LinearPart"],
    "loops": ["DriveLoop", "drive_loop"],
    "simulation": ["MeasuredCycle", "SimulationResult", "measure_limit_cycle", "simulated_limit_cycle"],
    "simulation.record": ["SimulatedRecord"],
    "limit_cycles": ["LimitCyclePrediction", "limit_cycle_plot", "predict_limit_cycles", "verify_limit_cycles"],
    "orbits": ["OrbitNotFound", "PeriodicOrbit", "exact_orbits", "periodic_orbit"],
    "verdict": ["VERDICTS", "LoopVerdict", "judge_loop"],
    "analysis": ["LoopAnalysis", "analyse_loop"],
    "tuning": ["Tuning", "tune"],
    "sweeps": ["DesignMap", "design_map"],
    "continuation": ["Branch", "continue_limit_cycles"],
    "reproduce": ["TableOne", "TorqueComparison", "compare_torques", "integrated_torque", "table1"],
    "identify": ["Diagnosis", "Measurements", "diagnose", "load_measurements"],
    "elements": ["DeadZone", "Play", "Relay", "Saturation", "ShaftLaw"],
    "lure": ["LureLoop", "LureOrbit", "LureSimulation", "lure_loop"],
    "lure_verdict": ["LureVerdict", "judge_lure_loop"],
    "lure_continuation": ["LureBranch", "continue_lure_orbit"],
    "lure_map": ["LureDesignMap", "lure_design_map"],
}
_lazy_getattr, __dir__, _ = _lazy.attach(
    __name__, submod_attrs=_EXPORTS,
    submodules=[name for _, name, _ in _pkgutil.iter_modules(__path__) if not name.startswith("_")])


def __getattr__(name):
    """A public name, its module imported on first use and the name kept here (later uses cost a dict
    lookup); ``simulate`` is :func:`backlash_df.simulation.record.simulate`:
    :func:`~backlash_df.simulation.simulate_rig` unless given recorded inputs or a record to compare with."""
    if name == "simulate":
        from .simulation.record import simulate as value
    else:
        value = _lazy_getattr(name)
    globals()[name] = value
    return value


__all__ = [
    "__version__",
    "MODEL_NAMES",
    "make_model",
    "theta_star",
    "describing_function",
    "dual_input_describing_function",
    "describing_function_grid",
    "DescribingFunctionResult",
    "phase_plane_validity",
    "ValidityMap",
    "StaticModel",
    "ExactModel",
    "load_rig",
    "rig_from_dict",
    "Rig",
    "RigError",
    "Plant",
    "Controller",
    "Load",
    "Friction",
    "write_rig",
    "LinearPart",
    "DriveLoop",
    "drive_loop",
    "predict_limit_cycles",
    "verify_limit_cycles",
    "limit_cycle_plot",
    "LimitCyclePrediction",
    "simulate",
    "SimulationResult",
    "SimulatedRecord",
    "simulated_limit_cycle",
    "measure_limit_cycle",
    "MeasuredCycle",
    "periodic_orbit",
    "exact_orbits",
    "PeriodicOrbit",
    "OrbitNotFound",
    "VERDICTS",
    "judge_loop",
    "LoopVerdict",
    "analyse_loop",
    "LoopAnalysis",
    "tune",
    "Tuning",
    "design_map",
    "DesignMap",
    "continue_limit_cycles",
    "Branch",
    "compare_torques",
    "integrated_torque",
    "table1",
    "TableOne",
    "TorqueComparison",
    "load_measurements",
    "Measurements",
    "diagnose",
    "Diagnosis",
    "ResultPlot",
    "lure_loop",
    "LureLoop",
    "LureOrbit",
    "LureSimulation",
    "judge_lure_loop",
    "LureVerdict",
    "continue_lure_orbit",
    "LureBranch",
    "lure_design_map",
    "LureDesignMap",
    "Saturation",
    "DeadZone",
    "Relay",
    "Play",
    "ShaftLaw",
]
