"""From measured data to a named cause (the way the paper found the rubber, Section 3).

:func:`load_measurements` reads and checks a record, :func:`replay` simulates the
rig's model from the measured torques, :func:`calibrate` fits the data-sheet
values, :func:`residual_analysis` shows what the simulation gets wrong,
:data:`EFFECTS` is the catalogue of candidate causes and :func:`diagnose` ties
them together into a :class:`Diagnosis`.  :func:`synthesize` makes records with
a hidden effect from a rig that is not the fitted model.
"""

from .calibrate import Calibration, FitParameter, Replay, calibrate, fit_percent, replay, segment_replay
from .diagnose import BIC_MARGIN, RSS_RATIO, CandidateResult, Diagnosis, check_speed_units, diagnose
from .effects import EFFECT_NAMES, EFFECTS, Effect, get_effect
from .measurements import Measurements, load_measurements, measurements_from_arrays, write_measurements
from .residuals import ResidualAnalysis, correlation, residual_analysis
from .synthetic import Experiment, SyntheticRecord, synthesize

__all__ = [
    "Measurements", "load_measurements", "measurements_from_arrays", "write_measurements",
    "Effect", "EFFECTS", "EFFECT_NAMES", "get_effect",
    "Calibration", "FitParameter", "Replay", "calibrate", "replay", "segment_replay", "fit_percent",
    "ResidualAnalysis", "residual_analysis", "correlation",
    "CandidateResult", "Diagnosis", "diagnose", "check_speed_units", "BIC_MARGIN", "RSS_RATIO",
    "Experiment", "SyntheticRecord", "synthesize",
]
