"""The batched harmonic balance (issue 21) against the unbatched one's results, recorded on bundled rigs.

``tests/data/hb_reference.json`` was written by ``tests/record_hb_reference.py`` from the
code before the balance was batched (each residual, Jacobian, Newton step and least-squares
evaluation its own call); every cycle's amplitude, omega, Loeb value and residual and every
near miss's amplitude, omega and distance must agree to 1e-10 relative.
"""

import json
import math
import pathlib
import sys

import pytest

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from record_hb_reference import case_values  # noqa: E402

REFERENCE = json.loads((HERE / "data" / "hb_reference.json").read_text())
RTOL = 1e-10


def _close(new, old, scale=None):
    if math.isnan(old):
        return math.isnan(new)
    return abs(new - old) <= RTOL * abs(scale if scale is not None else old)


@pytest.mark.parametrize("case", REFERENCE, ids=lambda c: f"{pathlib.Path(c['rig']).stem}-{c['model']}-{c['grid']}"
                         f"-{'-'.join(f'{k}={v}' for k, v in c['changes'].items())}")
def test_batched_balance_matches_the_unbatched_one(case):
    values = case_values(case["rig"], case["model"], tuple(case["grid"]), case["changes"])
    assert len(values["cycles"]) == len(case["cycles"])
    assert len(values["near_misses"]) == len(case["near_misses"])
    for new, old in zip(values["cycles"], case["cycles"]):
        assert new["stable"] == old["stable"]
        for key in ("amplitude", "omega", "loeb", "command_amplitude"):
            assert _close(new[key], old[key]), (key, new[key], old[key])
        # the bias is measured against the amplitude (zero without load); the residual is round-off
        assert _close(new["bias"], old["bias"], scale=old["amplitude"]), ("bias", new["bias"], old["bias"])
        assert new["residual"] < 1e-8 and old["residual"] < 1e-8
    for new, old in zip(values["near_misses"], case["near_misses"]):
        for key in ("amplitude", "omega", "distance"):
            assert _close(new[key], old[key]), (key, new[key], old[key])
