"""Tribometer signal measures and the quadratic device-curve fit (Kim et al. 2017, Sec. 2.2).

Pure functions over arrays, shared by the grain renderer (:mod:`surfhap.render.grains`) and
the display calibration (:mod:`surfhap.lab.calibration`).

* :func:`tribometer_amplitude`: band-pass (10-500 Hz Butterworth, zero phase), peak-to-peak
  amplitudes between consecutive extrema, mean of the 50 largest (Sec. 2.2).
* :func:`fit_quadratic`: least-squares ``y = c0 + c1 x + c2 x^2`` with residuals (Fig. 2c, 3c).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from surfhap.errors import ConfigError

__all__ = ["TRIBOMETER_BAND", "TRIBOMETER_LARGEST", "tribometer_amplitude", "QuadraticFit", "fit_quadratic"]

TRIBOMETER_BAND = (10.0, 500.0)  # Hz, Butterworth band-pass of Kim et al. Sec. 2.2
TRIBOMETER_LARGEST = 50  # number of largest peak-to-peak amplitudes averaged (Sec. 2.2)


def tribometer_amplitude(force: np.ndarray, fs: float, n_largest: int = TRIBOMETER_LARGEST,
                         band: tuple[float, float] = TRIBOMETER_BAND, order: int = 2,
                         mask: np.ndarray | None = None) -> float:
    """Characteristic force amplitude (N) of one tribometer recording (Kim et al. Sec. 2.2).

    force (n,) float N tangential force at ``fs`` Hz. Band-pass (Butterworth, zero phase,
    ``order`` per pass: the paper gives the band, not the order), then the peak-to-peak
    amplitudes between consecutive extrema; returns the mean of the ``n_largest``.
    ``mask`` (n,) bool, optional: only swings whose two extrema both lie where ``mask`` is true
    count (e.g. the samples with the drive on, away from the switching transients).
    """
    from scipy.signal import butter, sosfiltfilt

    x = np.asarray(force, dtype=float)
    if x.ndim != 1 or x.size < 64 or not np.all(np.isfinite(x)):
        raise ConfigError("need a finite 1-D recording of at least 64 samples", field="force")
    lo, hi = band
    if not (0 < lo < hi < fs / 2):
        raise ConfigError(f"band {band} Hz must lie below half the sample rate {fs / 2:g} Hz", field="band")
    y = sosfiltfilt(butter(order, [lo, hi], btype="bandpass", fs=fs, output="sos"), x)
    d = np.diff(y)
    ext = np.nonzero(np.sign(d[1:]) != np.sign(d[:-1]))[0] + 1  # local extrema
    if ext.size < 2:
        return 0.0
    pp = np.abs(np.diff(y[ext]))
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != x.shape:
            raise ConfigError("mask must have the shape of the recording", field="mask")
        pp = pp[m[ext[:-1]] & m[ext[1:]]]
        if pp.size == 0:
            return 0.0
    k = min(int(n_largest), pp.size)
    return float(np.mean(np.sort(pp)[-k:]))


@dataclass(frozen=True)
class QuadraticFit:
    """``y = c0 + c1 x + c2 x^2`` fitted by least squares.

    coefficients : (3,) [c0, c1, c2], ascending powers.
    x, y         : (n,) the fitted points.
    residuals    : (n,) y - fit(x).
    rmse         : root mean square residual (units of y).
    r2           : coefficient of determination (nan when y is constant).
    """

    coefficients: tuple[float, float, float]
    x: np.ndarray
    y: np.ndarray
    residuals: np.ndarray
    rmse: float
    r2: float

    def __call__(self, x: np.ndarray) -> np.ndarray:
        c0, c1, c2 = self.coefficients
        x = np.asarray(x, dtype=float)
        return (c2 * x + c1) * x + c0


def fit_quadratic(x: np.ndarray, y: np.ndarray) -> QuadraticFit:
    """Least-squares quadratic through (x (n,), y (n,)) pairs, n >= 3 distinct x."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or np.unique(x).size < 3:
        raise ConfigError("need at least three points at distinct inputs", field="device")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ConfigError("inputs and forces must be finite", field="device")
    c2, c1, c0 = np.polyfit(x, y, 2)
    fit = (c2 * x + c1) * x + c0
    res = y - fit
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum(res ** 2)) / ss_tot if ss_tot > 0 else float("nan")
    return QuadraticFit((float(c0), float(c1), float(c2)), x.copy(), y.copy(), res,
                        float(np.sqrt(np.mean(res ** 2))), r2)
