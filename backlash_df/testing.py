"""Assertions for users' own pytest suites: pin describing-function values.

>>> from backlash_df import make_model
>>> from backlash_df.testing import assert_describing_function
>>> model = make_model("dead-zone", stiffness=100.0, half_gap=0.1)
>>> assert_describing_function(model, 0.2, 10.0, gain=39.1002, phase_deg=0.0, rtol=1e-5)
"""

import numpy as np

from .describing import describing_function

__all__ = ["assert_describing_function"]


def assert_describing_function(model, amplitude, omega, gain=None, phase_deg=None, rtol=1e-7, atol_deg=1e-6,
                               bias=0.0):
    """Assert the gain and/or phase of a describing function.

    Parameters
    ----------
    model : BacklashModel
        The torque law.
    amplitude, omega : array_like
        A (rad) and w (rad/s), broadcast together.
    gain : array_like, optional
        Expected gain ``|N|`` (N m/rad), compared with relative tolerance ``rtol``.
    phase_deg : array_like, optional
        Expected phase of N (degrees), compared with absolute tolerance ``atol_deg``.
    rtol : float
        Relative tolerance on the gain.
    atol_deg : float
        Absolute tolerance on the phase, degrees.
    bias : float, optional
        Mean of theta_d, rad.

    Raises
    ------
    AssertionError
        With a table of expected and actual values side by side for every point
        that is off.
    ValueError
        Neither ``gain`` nor ``phase_deg`` given.
    """
    if gain is None and phase_deg is None:
        raise ValueError("give gain=..., phase_deg=... or both")
    n = describing_function(model, amplitude, omega, bias=bias)
    a, w, n = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(omega, dtype=float), n)
    actual_gain = np.abs(n)
    actual_phase = np.degrees(np.angle(n))
    bad = np.zeros(n.shape, dtype=bool)
    if gain is not None:
        expected_gain = np.broadcast_to(np.asarray(gain, dtype=float), n.shape)
        bad |= ~np.isclose(actual_gain, expected_gain, rtol=rtol, atol=0.0)
    if phase_deg is not None:
        expected_phase = np.broadcast_to(np.asarray(phase_deg, dtype=float), n.shape)
        bad |= ~(np.abs(actual_phase - expected_phase) <= atol_deg)
    if not bad.any():
        return
    lines = [
        f"describing function of {model.name!r} off at {int(bad.sum())} of {bad.size} point(s) "
        f"(rtol={rtol:g} on gain, atol={atol_deg:g} deg on phase):",
        f"{'A (rad)':>12} {'w (rad/s)':>12} {'gain expected':>15} {'gain actual':>15} "
        f"{'phase expected':>15} {'phase actual':>15}",
    ]
    for index in zip(*np.nonzero(bad)) if n.ndim else [()]:
        expect_g = f"{expected_gain[index]:.9g}" if gain is not None else "-"
        expect_p = f"{expected_phase[index]:.9g}" if phase_deg is not None else "-"
        lines.append(
            f"{a[index]:12.6g} {w[index]:12.6g} {expect_g:>15} {actual_gain[index]:15.9g} "
            f"{expect_p:>15} {actual_phase[index]:15.9g}"
        )
    raise AssertionError("\n".join(lines))
