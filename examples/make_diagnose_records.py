"""Write the bundled diagnosis records, ``diagnose_rubber.csv`` and ``diagnose_friction.csv``.

Each is a record of ``diagnose_rig.toml``'s drive made by
:func:`backlash_df.identify.synthesize`: a rig that is not the fitted model (its
own PI loop, a 5 times finer step, noise, data-sheet errors of up to 4 %), 4 s at
1 kHz (two periods of the speed reference), so that the estimation part holds the 20
independent segments the cluster-robust intervals ask for.  The hidden effects:

* ``diagnose_rubber.csv``: rubber in the coupling, beta = 0.0132 rad (seed 12);
* ``diagnose_friction.csv``: Coulomb friction on the load side, 4.18 N m (seed 1).

(Seed 10, the 2 s rubber record of earlier versions, gives at 4 s a rubber fit whose
block t statistic is 1.96 against the rule's 2: not named.  Seeds 11-13
are named; ``benchmarks/bench_diagnose.py`` measures the rate over many seeds.)

Run: ``python examples/make_diagnose_records.py`` (from the repository root).
"""

from pathlib import Path

from backlash_df import load_rig
from backlash_df.identify import synthesize, write_measurements

HERE = Path(__file__).resolve().parent
#: file name -> (hidden effect, seed); every record 4 s at 1 kHz.
RECORDS = {"diagnose_rubber.csv": ("rubber", 12), "diagnose_friction.csv": ("coulomb_friction@load", 1)}
DURATION = 4.0


def write(name, folder=HERE):
    """Write bundled record ``name`` into ``folder`` (8 significant digits)."""
    effect, seed = RECORDS[name]
    record = synthesize(load_rig(HERE / "diagnose_rig.toml"), effect, seed=seed, duration=DURATION)
    write_measurements(Path(folder) / name, record.measurements, precision=8)


if __name__ == "__main__":
    for name in RECORDS:
        write(name)
        print(f"wrote examples/{name}")
