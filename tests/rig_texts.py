"""Rig-file text the CLI and parser tests write and mutate (``text.replace(old, new)``).

The plant is the paper's laboratory drive (Section 4) with a half gap of 0.05 rad,
the values of ``examples/paper_rig.toml``.
"""

PLANT_TOML = """
[plant]
motor_inertia = 0.4
load_inertia = 5.6
stiffness = 5895.0
damping = 3.0
half_gap = 0.05
"""
