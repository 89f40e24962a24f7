"""Record the harmonic balance's results on the bundled rigs: the reference of tests/test_hb_speed.py.

Run from the repository root with the code to be taken as the reference (it was run on
commit 7e14c31's ``limit_cycles.py``, before the balance was batched, issue 21)::

    PYTHONPATH=$PWD python tests/record_hb_reference.py

It writes ``tests/data/hb_reference.json``: for every case of :data:`CASES` (rig file,
torque law, scan grid, rig values changed), every cycle's amplitude, omega, Loeb value,
residual, bias and command amplitude and every near miss, with ``repr`` of the floats
(all 17 digits).
"""

import json
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import backlash_df as bd  # noqa: E402

#: (rig file, model or None, grid, {rig value: value}); grid (24, 32) is the tuning screen's,
#: (30, 40) the design map's, (60, 80) the default.
CASES = [
    ("examples/load_feedback.toml", None, (60, 80), {}),
    ("examples/load_feedback.toml", "damped-dead-zone", (60, 80), {}),
    ("examples/load_feedback.toml", "exact", (60, 80), {}),
    ("examples/load_feedback.toml", None, (24, 32), {"kp": 45.0}),
    ("examples/motor_lag_feedback.toml", None, (60, 80), {}),
    ("examples/motor_lag_feedback.toml", "damped-dead-zone", (30, 40), {}),
    ("examples/motor_feedback.toml", None, (60, 80), {}),
    ("examples/loaded_feedback.toml", None, (60, 80), {}),
    ("examples/loaded_feedback.toml", "damped-dead-zone", (30, 40), {}),
    ("examples/loaded_suppressed.toml", None, (60, 80), {}),
    ("examples/load_feedback.toml", None, (60, 80), {"torque_limit": 20.0}),
]


def case_values(path, model, grid, changes):
    """The prediction's numbers of one case, JSON-ready."""
    rig = bd.load_rig(ROOT / path).with_values(**changes)
    prediction = bd.predict_limit_cycles(rig, model, grid=grid)
    return {
        "cycles": [{"amplitude": c.amplitude, "omega": c.omega, "loeb": c.loeb, "residual": c.residual,
                    "bias": c.bias, "command_amplitude": c.command_amplitude, "stable": c.stable}
                   for c in prediction.cycles],
        "near_misses": [{"amplitude": m.amplitude, "omega": m.omega, "distance": m.distance}
                        for m in prediction.near_misses],
    }


def main():
    cases = [{"rig": path, "model": model, "grid": list(grid), "changes": changes,
              **case_values(path, model, grid, changes)} for path, model, grid, changes in CASES]
    out = ROOT / "tests" / "data" / "hb_reference.json"
    out.write_text(json.dumps(cases, indent=1) + "\n")
    print(f"{len(cases)} cases -> {out}")


if __name__ == "__main__":
    main()
