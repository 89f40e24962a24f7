"""What the tests share: the repository's paths, the bundled rigs, the paper plant's rig-file text.

Test modules import the constants (``from conftest import EXAMPLES``: pytest puts
this folder on ``sys.path``) and take the rigs as fixtures.  Every path is
absolute, so the tests pass from any working directory.
"""

from pathlib import Path

import pytest

import backlash_df as bd

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
KUKA = EXAMPLES / "kuka"
DOCS = ROOT / "docs"
NOTEBOOKS = ROOT / "notebooks"

#: Rig-file text the CLI and parser tests write and mutate (``text.replace(old, new)``): the
#: paper's laboratory drive (Section 4) with a half gap of 0.05 rad, as ``examples/paper_rig.toml``.
PLANT_TOML = """
[plant]
motor_inertia = 0.4
load_inertia = 5.6
stiffness = 5895.0
damping = 3.0
half_gap = 0.05
"""


def example_rig(name):
    """A bundled rig by its file stem (``"load_feedback"``)."""
    return bd.load_rig(EXAMPLES / f"{name}.toml")


@pytest.fixture(scope="session")
def load_feedback_rig():
    """``examples/load_feedback.toml``: PI on the load speed, a stable cycle of A = 0.15 rad."""
    return example_rig("load_feedback")


@pytest.fixture(scope="session")
def motor_feedback_rig():
    """``examples/motor_feedback.toml``: PI on the motor speed, no cycle."""
    return example_rig("motor_feedback")


@pytest.fixture(scope="session")
def motor_lag_rig():
    """``examples/motor_lag_feedback.toml``: motor feedback with filter and torque lag, bistable."""
    return example_rig("motor_lag_feedback")


@pytest.fixture(scope="session")
def loaded_rig():
    """``examples/loaded_feedback.toml``: load feedback under a load torque of 100 N m."""
    return example_rig("loaded_feedback")
