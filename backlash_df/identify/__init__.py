"""From measured data to named causes (the way the paper found the rubber, Section 3).

:func:`load_measurements` reads and checks a record, :func:`predict` and
:func:`replay` simulate the rig's model from the measured torques (k-step
prediction or free run), :func:`calibrate` fits the data-sheet values and
effect parameters with intervals that hold for correlated residuals,
:func:`residual_analysis` shows what the model gets wrong, :data:`EFFECTS` is
the catalogue of candidate causes and :func:`diagnose` selects a set of them
(forward selection, backward check) into a :class:`Diagnosis`.
:func:`synthesize` makes records with hidden effects from a rig that is not the
fitted model.

One module a stage, every import pointing down: :mod:`.measurements` (the record),
:mod:`.signals` (its conditioning), :mod:`.predictors` (the two-mass and rigid-body
models and their predictions, on compiled kernels private to the package),
:mod:`.calibrate` (the fit), :mod:`.effects` (the catalogue), :mod:`.residuals`,
:mod:`.reasons` (why the diagnosis decided as it did, as records), :mod:`.diagnose` and
:mod:`.synthetic`.
"""

from .calibrate import Calibration, FitParameter, calibrate, refine
from .diagnose import (BASELINE_MIN_FIT, MIN_GAIN, MIN_T, VALIDATION_HORIZON, CandidateResult, Cause, DiagnosedRig,
                       Diagnosis, Stage, check_excitation, check_speed_units, diagnose, stage_disagreements)
from .effects import EFFECT_NAMES, EFFECTS, Effect, get_effect
from .measurements import Measurements, load_measurements, measurements_from_arrays, write_measurements
from .predictors import Replay, fit_percent, predict, replay
from .residuals import ResidualAnalysis, correlation, residual_analysis
from .synthetic import Experiment, SyntheticRecord, synthesize

__all__ = [
    "Measurements", "load_measurements", "measurements_from_arrays", "write_measurements",
    "Effect", "EFFECTS", "EFFECT_NAMES", "get_effect",
    "Calibration", "FitParameter", "Replay", "calibrate", "refine", "predict", "replay", "fit_percent",
    "ResidualAnalysis", "residual_analysis", "correlation",
    "CandidateResult", "Cause", "Stage", "Diagnosis", "DiagnosedRig", "diagnose", "stage_disagreements", "check_speed_units",
    "check_excitation", "MIN_GAIN", "MIN_T",
    "BASELINE_MIN_FIT", "VALIDATION_HORIZON",
    "Experiment", "SyntheticRecord", "synthesize",
]
