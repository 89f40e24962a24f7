"""backlash-df: describing functions and limit cycles of drives with backlash.

Torque laws of Nordin, Galic and Gutman (1997) (:mod:`backlash_df.models`),
the rig file (:mod:`backlash_df.config`), and the stages built on them.
"""

__version__ = "0.1.0"

from .config import Controller, Load, Plant, Rig, RigError, load_rig, rig_from_dict
from .models import MODEL_NAMES, ExactModel, StaticModel, make_model, theta_star
from .describing import DescribingFunctionResult, ValidityMap, describing_function, describing_function_grid, phase_plane_validity
from .loops import DriveLoop, drive_loop
from .limit_cycles import LimitCyclePrediction, limit_cycle_plot, predict_limit_cycles, verify_limit_cycles

# The closed-loop simulation is public as ``backlash_df.simulate(rig, ...)``
# (DESIGN.md); the module keeps its name: ``from backlash_df.simulate import ...``.
from .simulate import MeasuredCycle, measure_limit_cycle, simulated_limit_cycle
from .simulate import simulate_rig as simulate
from .orbits import OrbitNotFound, PeriodicOrbit, exact_orbits, periodic_orbit
from .verdict import VERDICTS, LoopVerdict, judge_loop
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
    "DriveLoop",
    "drive_loop",
    "predict_limit_cycles",
    "verify_limit_cycles",
    "limit_cycle_plot",
    "LimitCyclePrediction",
    "simulate",
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
]
