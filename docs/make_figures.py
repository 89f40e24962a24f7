"""Draw the pictures the README and the docs show, from the bundled examples.

Run from the repository root after a change to the models or the example rigs::

    python docs/make_figures.py

It writes ``docs/_static/nyquist_overlay.png``: the Nyquist overlay of
``examples/motor_lag_feedback.toml`` (PI on the motor speed with a speed filter
and a torque-loop lag), G(jw) with the -1/N(A, w) loci of the phase plane law
(23) and the damped dead-zone (26): the phase plane law's predicted limit cycles
marked with A and w, the dead-zone's closest miss with its distance.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import backlash_df as bd  # noqa: E402
from backlash_df.limit_cycles import limit_cycle_plot  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STATIC = ROOT / "docs" / "_static"
RIG = ROOT / "examples" / "motor_lag_feedback.toml"
MODELS = ("phase-plane", "damped-dead-zone")


def nyquist_overlay(path=STATIC / "nyquist_overlay.png"):
    """Save the Nyquist overlay of the motor-lag example; returns the predictions."""
    rig = bd.load_rig(RIG)
    predictions = [bd.predict_limit_cycles(rig, model) for model in MODELS]
    drawn = limit_cycle_plot(predictions)
    drawn.ax.set_title(f"{RIG.name}: G(jw) and -1/N(A, w); thin loci labelled with w (rad/s)", fontsize="medium")
    drawn.figure.savefig(path, dpi=110)
    return predictions


if __name__ == "__main__":
    STATIC.mkdir(parents=True, exist_ok=True)
    for prediction in nyquist_overlay():
        print(prediction.model, prediction.cycles or prediction.near_misses[:1])
