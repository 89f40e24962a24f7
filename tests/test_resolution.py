"""Numbers at their resolution (issue 49): a value below the resolution of the computation that made it prints as 0.

The text a person reads prints a simulated cycle's bias as 0 below the resolution of its
measurement, a percentage that rounds to zero without a sign, and a value said to be
below a bound with the digits that show it; the JSON keeps every number as computed.
"""

import dataclasses
import math
import re

import pytest

import backlash_df as bd
from backlash_df.render.html import below_text, resolved, signed_percent
from backlash_df.simulation.cycles import BIAS_RESOLUTION, MeasuredCycle

#: A bias printed in scientific notation: the round-off the text must not show.
TINY_BIAS = re.compile(r"bias[ =]-?[0-9.]+e-")


@pytest.fixture(scope="module")
def unloaded(load_feedback_rig):
    """``predict examples/load_feedback.toml``: the analysis of a loop without load torque."""
    return bd.analyse_loop(load_feedback_rig, ["phase-plane"])


def test_the_simulated_bias_of_a_loop_without_load_prints_as_zero(unloaded):
    """The cycle reached from a twist is 2e-6 A off symmetric (3.25e-07 rad): below the measurement's resolution."""
    measured = unloaded.predictions[0].simulation
    assert measured.periodic and 0.0 < abs(measured.bias) < BIAS_RESOLUTION * measured.amplitude
    assert "bias 0 rad" in str(measured) and "bias=0 rad" in repr(measured)
    assert measured.to_dict()["bias"] == measured.bias  # the JSON keeps the value measured
    report = unloaded.report_html("Limit cycles", "")
    assert "bias 0 rad" in report and not TINY_BIAS.search(report), TINY_BIAS.search(report)


@pytest.mark.parametrize("verdict, periods", [("limit cycle", 6), ("sustained oscillation", 40)])
def test_a_bias_above_the_resolution_is_printed(verdict, periods):
    amplitude = 0.15
    above = MeasuredCycle(True, amplitude, 0.155, 95.0, -1.5 * BIAS_RESOLUTION * amplitude, True, verdict, periods)
    below = dataclasses.replace(above, bias=0.9 * BIAS_RESOLUTION * amplitude)
    assert "bias -0.000225 rad" in str(above) and "bias=-0.000225 rad" in repr(above)
    assert "bias 0 rad" in str(below) and "bias=0 rad" in repr(below)


@pytest.mark.parametrize("value, text", [
    (-4e-6, "0.00 %"), (4e-6, "0.00 %"), (-0.0, "0.00 %"), (0.0, "0.00 %"),
    (-6e-5, "-0.01 %"), (6e-5, "+0.01 %"), (0.1016, "+10.16 %"), (math.nan, ""), (math.inf, ""),
])
def test_a_percentage_that_rounds_to_zero_has_no_sign(value, text):
    assert signed_percent(value) == text


def test_resolved_keeps_what_the_computation_resolves():
    assert resolved(-1.31e-15, 1e-12) == 0.0 and resolved(1e-12, 1e-12) == 0.0
    assert resolved(-0.0208, 1.5e-4) == -0.0208 and math.isnan(resolved(math.nan, 1.0))


@pytest.mark.parametrize("value, text", [
    (1.96, "1.96"), (1.99996, "1.99996"), (1.5, "1.5"), (-0.3, "-0.3"), (2.0, "2.0"), (2.04, "2.0"),
    (math.nan, "nan"),
])
def test_a_value_below_a_bound_reads_below_it(value, text):
    """Issue 49: diagnose's ``screening: t 2.0 (ahead) below 2`` for t = 1.96 (the t of the significance rule,
    :data:`~backlash_df.identify.diagnose.MIN_T` = 2, is printed with :func:`below_text`)."""
    assert below_text(value, 2.0) == text
    if value < 2.0:
        assert float(text) < 2.0

