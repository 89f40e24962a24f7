"""Residual analysis: what the simulation gets wrong, in the manner of ``resid``.

For a residual ``e(t)`` (measured minus simulated speed) and the input ``u(t)``
(commanded motor torque):

* autocorrelation ``r_ee(k) / r_ee(0)`` for lags 0..25 (whiteness);
* cross-correlation ``r_eu(k) / sqrt(r_ee(0) r_uu(0))`` for lags -25..25
  (independence: a peak at lag k says the model misses the effect of u(t - k));
* both against the 99 % band ``+-2.58 / sqrt(N)`` of a white residual;
* the residual's power spectral density (Welch);
* the residual against the state: binned over theta_d, over the sign of the
  load speed and over the shaft torque (where in the phase plane it goes wrong).

Each catalogue effect leaves its own fingerprint: Coulomb friction a jump of the
mean residual slope with the speed sign, viscous friction a trend with the
speed, an actuator delay a cross-correlation peak at positive lags, rubber a
residual concentrated near ``|theta_d| = alpha``.
"""

import dataclasses

import numpy as np

from .._json import json_ready
from ..plotting import ResultPlot, legend_beside

__all__ = ["ResidualAnalysis", "residual_analysis", "correlation", "BAND_99"]

#: Normal quantile of the 99 % two-sided band drawn around correlations.
BAND_99 = 2.58
MAX_LAG = 25


def correlation(a, b, max_lag=MAX_LAG):
    """Normalised cross-correlation ``r_ab(k)`` for lags ``-max_lag..max_lag``.

    ``r_ab(k) = sum_t a(t) b(t - k) / sqrt(sum a^2 sum b^2)`` after removing the
    means, the convention of MATLAB's ``resid`` (positive k: ``b`` leads).

    Returns
    -------
    lags, values : ndarray

    Examples
    --------
    >>> a = np.sin(np.arange(200) * 0.3)
    >>> lags, r = correlation(a, a, 2)
    >>> lags.tolist(), round(float(r[2]), 6)
    ([-2, -1, 0, 1, 2], 1.0)
    """
    a = np.asarray(a, dtype=float) - np.mean(a)
    b = np.asarray(b, dtype=float) - np.mean(b)
    n = a.size
    scale = np.sqrt(np.sum(a * a) * np.sum(b * b))
    lags = np.arange(-max_lag, max_lag + 1)
    values = np.empty(lags.size)
    for i, k in enumerate(lags):
        values[i] = np.sum(a[k:] * b[: n - k]) if k >= 0 else np.sum(a[: n + k] * b[-k:])
    return lags, values / scale if scale > 0.0 else values


@dataclasses.dataclass(frozen=True, repr=False)
class ResidualAnalysis:
    """Residuals of one simulation and their statistics (see module docs).

    Attributes
    ----------
    time : ndarray
        Sample instants, s.
    residual : ndarray
        Measured minus simulated speeds, shape (N, m), rad/s.
    names : tuple of str
        Names of the residual columns (measured speeds).
    lags : ndarray
        Lags -25..25 in samples.
    autocorrelation, cross_correlation : ndarray
        Shape (m, len(lags)): of each residual with itself and with the input.
    band : float
        Half width of the 99 % band, ``2.58 / sqrt(N)``.
    frequency, spectrum : ndarray
        Welch PSD of each residual, Hz and (rad/s)^2/Hz, spectrum shape (m, F).
    state_bins : dict
        ``theta_d``, ``shaft_torque``, ``load_speed_sign``: (bin centres, mean
        residual per bin, shape (m, bins)).
    """

    time: np.ndarray
    residual: np.ndarray
    names: tuple
    lags: np.ndarray
    autocorrelation: np.ndarray
    cross_correlation: np.ndarray
    band: float
    frequency: np.ndarray
    spectrum: np.ndarray
    state_bins: dict

    @property
    def rms(self):
        """RMS of each residual, rad/s, as a dict."""
        return {name: float(np.sqrt(np.mean(self.residual[:, j] ** 2))) for j, name in enumerate(self.names)}

    def outside_band(self):
        """Fractions of lags whose auto- (lag > 0) and cross-correlation leave the 99 % band, per signal."""
        positive = self.lags > 0
        return {
            name: {
                "autocorrelation": float(np.mean(np.abs(self.autocorrelation[j, positive]) > self.band)),
                "cross_correlation": float(np.mean(np.abs(self.cross_correlation[j]) > self.band)),
            }
            for j, name in enumerate(self.names)
        }

    def __repr__(self):
        rms = ", ".join(f"{name} {value:.3g}" for name, value in self.rms.items())
        return f"<ResidualAnalysis N={self.time.size}, RMS (rad/s): {rms}, 99 % band +-{self.band:.3g}>"

    def to_dict(self):
        """JSON-ready: RMS per signal, the 99 % band, lags, auto- and cross-correlations, share outside the band."""
        return json_ready({"names": list(self.names), "n_samples": self.time.size, "rms": self.rms,
                           "band": self.band, "lags": self.lags, "autocorrelation": self.autocorrelation,
                           "cross_correlation": self.cross_correlation, "outside_band": self.outside_band()})

    def plot(self, ax=None, title=""):
        """Residuals over time, against theta_d and shaft torque, spectrum, auto- and cross-correlation.

        Parameters
        ----------
        ax : Figure or sequence of 6 Axes, optional
            A figure to fill with the six panels, or the panels; a new figure by default.
        title : str
            The figure's title (which model's residuals, say).

        Returns
        -------
        ResultPlot
            Axes of shape (3, 2), each titled with what it shows; one legend (the
            signals and the 99 % band) beside the top right panel.
        """
        import matplotlib.pyplot as plt
        from matplotlib.figure import Figure

        if ax is None or isinstance(ax, Figure):
            fig = ax or plt.figure(figsize=(11, 7.5), layout="constrained")
            axes = fig.subplots(3, 2)
        else:
            axes = np.asarray(ax, dtype=object).reshape(3, 2)
            fig = axes[0, 0].figure
        ax_time, ax_state, ax_psd, ax_torque, ax_auto, ax_cross = axes.ravel()
        for j, name in enumerate(self.names):
            ax_time.plot(self.time, self.residual[:, j], lw=0.8, label=name)
            centres, means = self.state_bins["theta_d"]
            ax_state.plot(centres, means[j], marker=".", label=name)
            centres, means = self.state_bins["shaft_torque"]
            ax_torque.plot(centres, means[j], marker=".", label=name)
            ax_psd.semilogy(self.frequency, self.spectrum[j], lw=0.8, label=name)
            positive = self.lags >= 0
            ax_auto.stem(self.lags[positive] + 0.2 * j, self.autocorrelation[j, positive], markerfmt=" ", basefmt=" ",
                         linefmt=f"C{j}-", label=name)
            ax_cross.stem(self.lags + 0.2 * j, self.cross_correlation[j], markerfmt=" ", basefmt=" ",
                          linefmt=f"C{j}-", label=name)
        for ax in (ax_auto, ax_cross):
            band = ax.axhspan(-self.band, self.band, color="0.85", zorder=0, label="99 % band")
            ax.set(xlabel="lag (samples)", ylabel="correlation")
        ax_time.set(xlabel="time (s)", ylabel="residual (rad/s)", title="measured - simulated speed")
        ax_state.set(xlabel="theta_d (rad, simulated)", ylabel="mean residual (rad/s)",
                     title="mean residual against theta_d")
        ax_torque.set(xlabel="shaft torque (N m, simulated)", ylabel="mean residual (rad/s)",
                      title="mean residual against shaft torque")
        ax_psd.set(xlabel="frequency (Hz)", ylabel="PSD ((rad/s)^2/Hz)", title="spectrum of the residual (Welch)")
        ax_auto.set_title("autocorrelation (whiteness)")
        ax_cross.set_title("cross-correlation with the motor torque")
        for panel in axes.flat:
            panel.title.set_fontsize("medium")
        legend_beside(ax_state, handles=[*ax_time.get_lines(), band])
        if title:
            fig.suptitle(title)
        return ResultPlot(fig, axes)


def _binned(x, residual, bins=15):
    edges = np.linspace(np.min(x), np.max(x), bins + 1)
    if edges[0] == edges[-1]:
        edges = np.array([edges[0] - 0.5, edges[0] + 0.5])
    index = np.clip(np.digitize(x, edges) - 1, 0, edges.size - 2)
    centres = 0.5 * (edges[1:] + edges[:-1])
    means = np.full((residual.shape[1], centres.size), np.nan)
    for b in range(centres.size):
        inside = index == b
        if inside.any():
            means[:, b] = residual[inside].mean(axis=0)
    return centres, means


def residual_analysis(time, residual, motor_torque, theta_d, shaft_torque, load_speed, names):
    """Residual statistics of one simulation against the data (see module docs).

    Parameters
    ----------
    time : ndarray
        Sample instants, s.
    residual : ndarray
        Measured minus simulated speeds, shape (N, m), rad/s.
    motor_torque : ndarray
        The input u(t), N m.
    theta_d, shaft_torque, load_speed : ndarray
        Simulated state along the record: rad, N m, rad/s.
    names : tuple of str
        Names of the residual columns.

    Returns
    -------
    ResidualAnalysis
    """
    residual = np.asarray(residual, dtype=float).reshape(len(time), -1)
    n = residual.shape[0]
    autocorrelation = np.array([correlation(residual[:, j], residual[:, j])[1] for j in range(residual.shape[1])])
    lags, _ = correlation(residual[:, 0], motor_torque)
    cross = np.array([correlation(residual[:, j], motor_torque)[1] for j in range(residual.shape[1])])
    fs = 1.0 / float(time[1] - time[0])
    from scipy.signal import welch  # lazy: scipy.signal takes a second to import

    frequency, spectrum = welch(residual, fs=fs, nperseg=min(256, n), axis=0)
    sign_centres = np.array([-1.0, 1.0])
    sign_means = np.array([[residual[load_speed < 0, j].mean() if np.any(load_speed < 0) else np.nan,
                            residual[load_speed >= 0, j].mean() if np.any(load_speed >= 0) else np.nan]
                           for j in range(residual.shape[1])])
    return ResidualAnalysis(
        time=np.asarray(time, dtype=float), residual=residual, names=tuple(names), lags=lags,
        autocorrelation=autocorrelation, cross_correlation=cross, band=BAND_99 / np.sqrt(n),
        frequency=frequency, spectrum=spectrum.T,
        state_bins={"theta_d": _binned(theta_d, residual), "shaft_torque": _binned(shaft_torque, residual),
                    "load_speed_sign": (sign_centres, sign_means)},
    )
