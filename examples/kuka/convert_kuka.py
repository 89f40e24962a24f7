"""Convert one axis of the KUKA KR300 record (``record_A.mat``) to a measurement CSV.

The record (MIT licence, see ``LICENSE`` and ``README.md`` here) holds, per axis, the
motor torque on the motor side and two encoders in link degrees: the motor encoder
already divided by the gear ratio, and the secondary (link-side) encoder.  The CSV
keeps the toolbox's convention (``backlash_df.identify.measurements``): the motor
columns on the **motor side**, the load columns on the load (link) side, SI units:

==============  =====================================================  ======
column          from                                                   side
==============  =====================================================  ======
time            ``time_cont``                                          s
motor_torque    ``act_torque_abs_nm``                                  motor
motor_speed     ``act_vel_mot_deg_per_s`` x n x pi/180                 motor
load_speed      ``act_vel_se_deg_per_s`` x pi/180                      load
motor_angle     ``act_pos_mot_deg`` x n x pi/180                       motor
load_angle      ``act_pos_se_deg`` x pi/180                            load
==============  =====================================================  ======

Load it with the rig's gear ratio, ``load_measurements(csv, gear_ratio=n)``, and
every value is reflected to the link side.  Usage::

    python examples/kuka/convert_kuka.py [record_A.mat] [kuka_axis1.csv] [--axis 1]
"""

import argparse
import math
from pathlib import Path

import numpy as np
import scipy.io

from backlash_df.identify import measurements_from_arrays, write_measurements

HERE = Path(__file__).resolve().parent
#: Gear ratios (motor turns per link turn) of axes 1-3, from the robot model of the source repository.
GEAR_RATIOS = {1: 1798.0 / 7.0, 2: 267.43, 3: 252.33}


def load_record(mat_path):
    """The ``rec`` struct of the .mat file (fields as attributes, arrays of 6 axes x N)."""
    return scipy.io.loadmat(mat_path, squeeze_me=True, struct_as_record=False)["rec"]


def kuka_measurements(mat_path=HERE / "record_A.mat", axis=1):
    """One axis of the record as checked :class:`~backlash_df.identify.Measurements` (link side).

    Parameters
    ----------
    mat_path : str or Path
        The record, ``record_A.mat``.
    axis : int
        Robot axis 1, 2 or 3 (the axes with a secondary encoder).

    Returns
    -------
    Measurements
        Reflected through :data:`GEAR_RATIOS` ``[axis]``: every array on the link side.
    """
    if axis not in GEAR_RATIOS:
        raise ValueError(f"--axis must be one of {sorted(GEAR_RATIOS)} (axes with a link encoder), got {axis}")
    rec, row, n = load_record(mat_path), axis - 1, GEAR_RATIOS[axis]
    rad = math.pi / 180.0
    return measurements_from_arrays(
        time=np.asarray(rec.time_cont, dtype=float),
        motor_torque=rec.act_torque_abs_nm[row],
        motor_speed=rec.act_vel_mot_deg_per_s[row] * n * rad,
        load_speed=rec.act_vel_se_deg_per_s[row] * rad,
        motor_angle=rec.act_pos_mot_deg[row] * n * rad,
        load_angle=rec.act_pos_se_deg[row] * rad,
        source=f"{Path(mat_path).name} axis {axis}",
        gear_ratio=n,
    )


def main(argv=None):
    """Command line: write the CSV of one axis (motor columns on the motor side)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mat", nargs="?", default=HERE / "record_A.mat", type=Path)
    parser.add_argument("csv", nargs="?", default=HERE / "kuka_axis1.csv", type=Path)
    parser.add_argument("--axis", type=int, default=1, choices=sorted(GEAR_RATIOS), help="robot axis (default 1)")
    args = parser.parse_args(argv)
    measurements = kuka_measurements(args.mat, args.axis)
    write_measurements(args.csv, measurements, precision=12)
    print(f"{args.csv}: {measurements.n_samples} samples at {measurements.dt:g} s, "
          f"gear ratio {measurements.gear_ratio:.9g} (motor columns on the motor side)")


if __name__ == "__main__":
    main()
