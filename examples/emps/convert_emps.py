"""Convert the EMPS record (``DATA_EMPS.mat``) to a measurement CSV and a reference CSV.

The record (Janot, Gautier and Brunot 2019; ``README.md`` here says where it comes from
and how to cite it) holds, at 1 kHz, the motor encoder position ``qm`` (m), the position
reference ``qg`` (m) and the controller's output ``vir`` (V), with the drive gain ``gtau``
(N/V).  The axis is linear: metres and newtons, read by the toolbox's rotational columns
as rad and N m.  The measurement CSV (``backlash_df.identify.measurements``) has the
motor columns only, on the motor side (the encoder already counts carriage metres, gear
ratio 1):

==============  =====================================================  ======
column          from                                                   unit
==============  =====================================================  ======
time            ``t`` rounded to 1 us (its stamps scatter by 3e-8 s)   s
motor_torque    ``gtau * vir``: the force the drive applies            N
motor_speed     d ``qm`` / dt, zero-phase (:func:`encoder_speed`)      m/s
motor_angle     ``qm``                                                 m
==============  =====================================================  ======

The reference CSV has the columns ``time`` (the same) and ``reference`` (``qg``, m): the
position the cascade follows, the input a simulation of the loop needs.

The speed is the data set's own: the position through a 4th-order Butterworth low-pass
at 100 Hz (five times the loop's 20 Hz bandwidth) run forward and backward
(``filtfilt``, zero phase), then central differences.  Zero phase matters here: a causal
filter would delay the speed against the force, which a diagnosis reads as an actuator
delay; and the same speed as the data set's inverse-model script keeps its published
friction values comparable.  The filter runs over the whole record before the cut, so
the cut's end has no filter transient.

Only the first round trip (0 to 6.224 s, where the reference first returns to 0: 6225
samples, both directions of travel at several speeds) is bundled, to keep the files near
the size of the other real record; ``--stop 18.704`` gives three round trips.  A record
of more than 20 000 samples (the whole 24.84 s) is decimated by block means to 2 ms as
every long record is (``measurements_from_arrays``).  ``DATA_EMPS_PULSES.mat`` converts
the same way: its force pulses (``pulses_N``, 5 V steps) are already in ``vir``.
Usage::

    python examples/emps/convert_emps.py DATA_EMPS.mat [emps_record.csv] [emps_reference.csv] [--stop 6.224]
"""

import argparse
from pathlib import Path

import numpy as np
import scipy.io
import scipy.signal

from backlash_df.identify import measurements_from_arrays, write_measurements

HERE = Path(__file__).resolve().parent
#: End (s) of the bundled part: the reference's first return to 0, one round trip.
STOP = 6.224
#: Order and cut-off (Hz) of the zero-phase Butterworth low-pass before differentiation (the data set's).
FILTER_ORDER, FILTER_CUTOFF = 4, 100.0
#: Significant digits written: the encoder's step, 5e-8 m, at 0.25 m needs 8.
PRECISION = 8


def load_record(mat_path):
    """The record's arrays and gains by name (``t``, ``qm``, ``qg``, ``vir``, ``gtau``, ``kp``, ``kv``)."""
    record = scipy.io.loadmat(mat_path, squeeze_me=True)
    return {name: np.asarray(record[name], dtype=float) for name in ("t", "qm", "qg", "vir", "gtau", "kp", "kv")}


def encoder_speed(position, dt):
    """Speed from an encoder position, zero phase: Butterworth low-pass forward and backward, central differences.

    Parameters
    ----------
    position : ndarray
        Encoder position (m or rad), uniformly sampled.
    dt : float
        Sampling interval, s.

    Returns
    -------
    ndarray
        Speed (m/s or rad/s), same length: :data:`FILTER_ORDER`-th order Butterworth at
        :data:`FILTER_CUTOFF` Hz through ``scipy.signal.filtfilt``, then ``numpy.gradient``
        (central differences inside, one-sided at the two ends, as the data set's ``diffcent``).
    """
    b, a = scipy.signal.butter(FILTER_ORDER, FILTER_CUTOFF, fs=1.0 / dt)
    return np.gradient(scipy.signal.filtfilt(b, a, position), dt)


def _part(record, stop):
    """The samples up to ``stop`` s (the record's last instant included within half a step)."""
    time = record["t"]
    dt = float(np.median(np.diff(time)))
    if not 0.0 < stop <= time[-1] + 0.5 * dt:
        raise ValueError(f"--stop {stop:g} s is outside the record (0, {time[-1]:g}] s")
    return time <= stop + 0.5 * dt, dt


def emps_measurements(mat_path, stop=STOP):
    """The record up to ``stop`` as checked :class:`~backlash_df.identify.Measurements` (gear ratio 1).

    Parameters
    ----------
    mat_path : str or Path
        ``DATA_EMPS.mat`` (or ``DATA_EMPS_PULSES.mat``).
    stop : float
        End of the part kept, s (:data:`STOP`: the first round trip).

    Returns
    -------
    Measurements
        ``motor_torque`` = ``gtau * vir`` (N), ``motor_speed`` from :func:`encoder_speed`
        over the whole record (m/s), ``motor_angle`` = ``qm`` (m); time rounded to 1 us.
    """
    record = load_record(mat_path)
    keep, dt = _part(record, stop)
    return measurements_from_arrays(
        time=np.round(record["t"][keep], 6),
        motor_torque=(record["gtau"] * record["vir"])[keep],
        motor_speed=encoder_speed(record["qm"], dt)[keep],
        motor_angle=record["qm"][keep],
        source=f"{Path(mat_path).name} to {stop:g} s",
    )


def emps_reference(mat_path, stop=STOP):
    """The position reference up to ``stop``: ``(time, reference)`` in s and m, at :func:`emps_measurements`' instants."""
    record = load_record(mat_path)
    keep, _ = _part(record, stop)
    return np.round(record["t"][keep], 6), record["qg"][keep]


def write_reference(path, time, reference):
    """Write the reference CSV: a header ``time,reference`` and :data:`PRECISION` significant digits."""
    lines = ["time,reference"] + [f"{t:.{PRECISION}g},{r:.{PRECISION}g}" for t, r in zip(time, reference)]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def main(argv=None):
    """Command line: write the measurement CSV and the reference CSV of the part up to ``--stop``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mat", type=Path, help="DATA_EMPS.mat")
    parser.add_argument("csv", nargs="?", default=HERE / "emps_record.csv", type=Path)
    parser.add_argument("reference", nargs="?", default=HERE / "emps_reference.csv", type=Path)
    parser.add_argument("--stop", type=float, default=STOP, help=f"end of the part kept, s (default {STOP:g})")
    args = parser.parse_args(argv)
    try:
        measurements = emps_measurements(args.mat, args.stop)
    except ValueError as error:
        parser.error(str(error))
    write_measurements(args.csv, measurements, precision=PRECISION)
    write_reference(args.reference, *emps_reference(args.mat, args.stop))
    print(f"{args.csv}, {args.reference}: {measurements.n_samples} samples at {measurements.dt:g} s")


if __name__ == "__main__":
    main()
