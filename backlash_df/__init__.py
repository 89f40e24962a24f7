"""backlash-df: describing functions and limit cycles of drives with backlash.

Torque laws of Nordin, Galic and Gutman (1997) (:mod:`backlash_df.models`), the
rig file (:mod:`backlash_df.config`), the loop cut at the backlash
(:mod:`backlash_df.system`), and the stages built on them, one module each; every
import points down that list.  The names below are the public API; the
documentation's contract page states the rig-file keys, the JSON and CSV formats and
the sign conventions they follow.
"""

from ._version import __version__

from .config import Controller, Load, Plant, Rig, RigError, load_rig, rig_from_dict
from .models import MODEL_NAMES, ExactModel, StaticModel, make_model, theta_star
from .describing import (DescribingFunctionResult, ValidityMap, describing_function, describing_function_grid,
                         dual_input_describing_function, phase_plane_validity)
from .plotting import ResultPlot
from .system import LinearPart
from .loops import DriveLoop, drive_loop
from .simulation import MeasuredCycle, SimulationResult, measure_limit_cycle, simulated_limit_cycle
from .simulation import simulate_rig as simulate
from .limit_cycles import LimitCyclePrediction, limit_cycle_plot, predict_limit_cycles, verify_limit_cycles
from .orbits import OrbitNotFound, PeriodicOrbit, exact_orbits, periodic_orbit
from .verdict import VERDICTS, LoopVerdict, judge_loop
from .analysis import LoopAnalysis, analyse_loop
from .tuning import Tuning, tune
from .sweeps import DesignMap, design_map
from .continuation import Branch, continue_limit_cycles
from .reproduce import TableOne, TorqueComparison, compare_torques, integrated_torque, table1
from .identify import Diagnosis, Measurements, diagnose, load_measurements

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
    "LinearPart",
    "DriveLoop",
    "drive_loop",
    "predict_limit_cycles",
    "verify_limit_cycles",
    "limit_cycle_plot",
    "LimitCyclePrediction",
    "simulate",
    "SimulationResult",
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
]
