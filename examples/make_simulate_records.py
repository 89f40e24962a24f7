"""Write the bundled inputs and record of ``backlash-df simulate``: ``simulate_inputs.csv``, ``simulate_record.csv``.

The record is one of ``diagnose_rig.toml``'s drive made by
:func:`backlash_df.identify.synthesize` with no test signal injected, so that the
speed reference and the load torque are its only inputs: 2 s at 1 kHz from rest,
data-sheet errors of up to 4 % (seed 3), speed noise of 0.02 rad/s and encoder angles
of 2^16 counts a turn.  The inputs file holds what drove it: the generator's sine
speed reference (3 rad/s at 0.5 Hz) and the load torque the record holds, at the
record's instants.

Run: ``python examples/make_simulate_records.py`` (from the repository root).
"""

from pathlib import Path

import numpy as np

from backlash_df import load_rig
from backlash_df.identify import Experiment, synthesize, write_measurements

HERE = Path(__file__).resolve().parent
EXPERIMENT = Experiment(test_amplitude=0.0, warmup=0.0)
SEED, DURATION, COUNTS = 3, 2.0, 2 ** 16


def write(folder=HERE):
    """Write both files into ``folder`` (8 significant digits)."""
    record = synthesize(load_rig(HERE / "diagnose_rig.toml"), "none", seed=SEED, duration=DURATION,
                        experiment=EXPERIMENT, encoder_counts=COUNTS).measurements
    write_measurements(Path(folder) / "simulate_record.csv", record, precision=8)
    reference = EXPERIMENT.speed_amplitude * np.sin(2 * np.pi * EXPERIMENT.speed_frequency * record.time)
    rows = [",".join(f"{value:.8g}" for value in row) for row in zip(record.time, reference, record.load_torque)]
    (Path(folder) / "simulate_inputs.csv").write_text("\n".join(["time,reference,load_torque", *rows]) + "\n",
                                                      encoding="utf-8")


if __name__ == "__main__":
    write()
    print("wrote examples/simulate_inputs.csv and examples/simulate_record.csv")
