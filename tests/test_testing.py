"""The users' assertion: passes on the closed form, fails with a side-by-side table."""

import numpy as np
import pytest

from backlash_df import make_model
from backlash_df.testing import assert_describing_function

K, C, ALPHA = 5895.0, 3.0, 0.05


def damped_dead_zone_reference(ratio, omega):
    """(26): N = (k + j c w) F(alpha / A), F Tustin's dead-zone fraction."""
    r = 1.0 / ratio
    f = 1.0 - (2.0 / np.pi) * (np.arcsin(r) + r * np.sqrt(1.0 - r * r))
    return (K + 1j * C * omega) * f


def test_passes_on_the_closed_form():
    model = make_model("damped-dead-zone", stiffness=K, damping=C, half_gap=ALPHA)
    ratio, omega = np.array([1.5, 3.0]), np.array([10.0, 500.0])
    n = damped_dead_zone_reference(ratio, omega)
    assert_describing_function(model, ratio * ALPHA, omega, gain=np.abs(n), phase_deg=np.degrees(np.angle(n)))


def test_fails_with_expected_and_actual_side_by_side():
    model = make_model("damped-dead-zone", stiffness=K, damping=C, half_gap=ALPHA)
    n = damped_dead_zone_reference(2.0, 100.0)
    with pytest.raises(AssertionError) as info:
        assert_describing_function(model, 2.0 * ALPHA, 100.0, gain=1.01 * abs(n), rtol=1e-3)
    message = str(info.value)
    assert "gain expected" in message and "gain actual" in message
    assert f"{1.01 * abs(n):.9g}" in message and f"{abs(n):.9g}" in message


def test_phase_tolerance_is_absolute_in_degrees():
    model = make_model("damped-dead-zone", stiffness=K, damping=C, half_gap=ALPHA)
    phase = np.degrees(np.angle(damped_dead_zone_reference(2.0, 100.0)))
    assert_describing_function(model, 2.0 * ALPHA, 100.0, phase_deg=phase + 0.009, atol_deg=0.01)
    with pytest.raises(AssertionError, match="phase expected"):
        assert_describing_function(model, 2.0 * ALPHA, 100.0, phase_deg=phase + 0.011, atol_deg=0.01)


def test_needs_something_to_compare():
    model = make_model("phase-plane", stiffness=K, damping=C, half_gap=ALPHA)
    with pytest.raises(ValueError, match="gain"):
        assert_describing_function(model, 0.1, 10.0)
