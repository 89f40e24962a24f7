"""Residual statistics against closed forms."""

import numpy as np
import pytest

from backlash_df.identify import correlation, residual_analysis
from backlash_df.identify.residuals import BAND_99


def test_correlation_of_a_delayed_input_peaks_at_its_lag():
    """e(t) = u(t - 3): r_eu(3) = 1 exactly up to the ends, and r_eu(k) ~ 0 elsewhere for white u."""
    u = np.random.default_rng(0).normal(size=5000)
    e = np.concatenate([np.zeros(3), u[:-3]])
    lags, r = correlation(e, u)
    assert lags[np.argmax(r)] == 3
    assert r[lags == 3][0] == pytest.approx(1.0, abs=2e-3)
    assert np.max(np.abs(r[lags != 3])) < BAND_99 / np.sqrt(u.size)


def test_white_residual_stays_in_the_99_percent_band():
    """For white noise about 1 % of the 25 positive lags leave +-2.58/sqrt(N): allow 3 of 25."""
    rng = np.random.default_rng(1)
    n = 4000
    time = np.arange(n) * 1e-3
    residual = rng.normal(size=(n, 2))
    analysis = residual_analysis(time, residual, rng.normal(size=n), rng.normal(size=n), rng.normal(size=n),
                                 rng.normal(size=n), ("motor_speed", "load_speed"))
    assert analysis.band == pytest.approx(2.58 / np.sqrt(n))
    for fractions in analysis.outside_band().values():
        assert fractions["autocorrelation"] <= 3 / 25
        assert fractions["cross_correlation"] <= 4 / 51
    assert analysis.autocorrelation[0, analysis.lags == 0][0] == pytest.approx(1.0)


def test_state_bins_and_spectrum_find_a_planted_fingerprint():
    """A residual equal to 0.1 sign(w_l) (Coulomb-like) has bin means -0.1 / +0.1 by speed sign;
    a residual sin(2 pi 40 t) has its spectral peak at 40 Hz."""
    n = 4000
    time = np.arange(n) * 1e-3
    speed = np.sin(2 * np.pi * 0.5 * time)
    residual = np.column_stack([0.1 * np.sign(speed), np.sin(2 * np.pi * 40.0 * time)])
    analysis = residual_analysis(time, residual, speed, speed, speed, speed, ("a", "b"))
    centres, means = analysis.state_bins["load_speed_sign"]
    np.testing.assert_allclose(means[0], [-0.1, 0.1], atol=1e-3)  # sign(0) = 0 at the two zero crossings
    assert analysis.frequency[np.argmax(analysis.spectrum[1])] == pytest.approx(40.0, abs=4.0)
