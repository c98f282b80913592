"""The band split (low band / texture band) and fractional-octave band averaging of spectra.

:class:`BandSplit` is the one definition of the split of Otake et al. (2.5 Hz in 2021, 3.5 Hz
in 2022): a zero-phase (forward-backward) Butterworth low-pass gives the low band, and the
texture band is ``x - low``. Fitting, texture calibration, the fidelity metrics and the
spectrum figures all use it.

Welch estimates scatter by about +-0.5 dB per bin even on long signals; comparing a rendered
spectrum to a model is meaningful after averaging within fractional-octave bands.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from pydantic import Field
from pydantic.dataclasses import dataclass
from scipy.signal import butter, sosfilt, sosfilt_zi, sosfiltfilt, sosfreqz

__all__ = ["BandSplit", "band_average", "spectral_deviation_db"]


@lru_cache(maxsize=64)
def _butter_low(order: int, cutoff: float, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Second-order sections (k, 6) of the Butterworth low-pass and their unit-step initial state (k, 2)."""
    sos = butter(order, cutoff, btype="low", fs=sample_rate, output="sos")
    return sos, sosfilt_zi(sos)


def _filtfilt(sos: np.ndarray, zi: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Forward-backward ``sosfilt`` of x (..., n) along its last axis, each pass started in the
    steady state of its first sample: ``sosfiltfilt(sos, x, axis=-1, padtype=None)``, compiled
    (:func:`surfhap.signal.filters.sos_filtfilt`; numba is imported on the first split)."""
    from surfhap.signal.filters import sos_filtfilt

    rows = np.ascontiguousarray(x.reshape(-1, x.shape[-1]))
    return sos_filtfilt(sos, zi, rows).reshape(x.shape)


@dataclass(frozen=True)
class BandSplit:
    """Zero-phase Butterworth split at ``cutoff`` Hz: ``low`` (forward-backward low-pass of
    ``order``) and ``high = x - low``, so ``low + high == x`` (to rounding).

    Edges: scipy's odd extension reflects the signal through its first (last) *sample*; on a
    noisy signal (a textured CoF, an acceleration) that sample is off the local level by about
    one noise standard deviation, the padding carries a step of twice that into the filter, and
    its slow response leaks into ``high`` as a transient lasting about a cut-off period (a false
    rise of the texture band's spectrum at low frequencies). Here the extension is the odd
    reflection through the least-squares *line* fitted to the first (last) ``pivot_periods``
    cut-off periods, over ``pad_periods`` cut-off periods: level and slope continue, the noise
    is mirrored, and there is no step. Signals shorter than the pad use their own length.
    """

    cutoff: float = 3.5  # Hz, within (0, fs / 2): checked against the sample rate of each call
    order: int = Field(4, ge=1, le=12)
    pad_periods: float = Field(2.0, gt=0, allow_inf_nan=False)
    pivot_periods: float = Field(0.5, gt=0, allow_inf_nan=False)

    def _sos(self, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
        if not 0 < self.cutoff < sample_rate / 2:
            raise ValueError(f"cutoff must be within (0, {sample_rate / 2}) Hz, got {self.cutoff}")
        return _butter_low(self.order, float(self.cutoff), float(sample_rate))

    def low(self, x: np.ndarray, sample_rate: float) -> np.ndarray:
        """The low band of x (..., n) along its last axis (an array of x's shape)."""
        x = np.asarray(x, dtype=float)
        n = x.shape[-1]
        sos, zi = self._sos(sample_rate)
        if n < 3:
            return sosfiltfilt(sos, x, axis=-1, padtype="odd", padlen=max(n - 1, 0))
        pad = int(min(n - 1, max(1, round(self.pad_periods * sample_rate / self.cutoff))))
        m = int(min(n, max(2, round(self.pivot_periods * sample_rate / self.cutoff))))
        t = np.arange(m) - (m - 1) / 2.0
        tt = float(t @ t)

        def line_end(seg, at):  # value of the LS line through seg (..., m) at index ``at`` (0-based in seg)
            mean = seg.mean(axis=-1)
            return mean + ((seg - mean[..., None]) @ t / tt) * (at - (m - 1) / 2.0)

        head = 2.0 * line_end(x[..., :m], 0)[..., None] - x[..., pad:0:-1]
        tail = 2.0 * line_end(x[..., n - m:], m - 1)[..., None] - x[..., n - pad - 1:n - 1][..., ::-1]
        return _filtfilt(sos, zi, np.concatenate((head, x, tail), axis=-1))[..., pad:pad + n]

    def split(self, x: np.ndarray, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of x (..., n); ``high = x - low``."""
        x = np.asarray(x, dtype=float)
        low = self.low(x, sample_rate)
        return low, x - low

    def high(self, x: np.ndarray, sample_rate: float) -> np.ndarray:
        """The texture band ``x - low`` of x (..., n)."""
        return self.split(x, sample_rate)[1]

    def high_gain(self, freqs: np.ndarray, sample_rate: float) -> np.ndarray:
        """Power gain (m,) of the texture band at freqs Hz, away from the edges: the low band's
        amplitude gain is |H|^2 (forward and backward), the texture band's ``1 - |H|^2``."""
        sos, _ = self._sos(sample_rate)
        _, h = sosfreqz(sos, worN=np.asarray(freqs, dtype=float), fs=sample_rate)
        return (1.0 - np.abs(h) ** 2) ** 2


def band_average(freqs: np.ndarray, psd: np.ndarray, fmin: float, fmax: float, fraction: int = 3):
    """Mean PSD in 1/fraction-octave bands between fmin and fmax.

    freqs (m,) Hz, psd (m,) or (k, m). Returns centres (b,) Hz and averages (b,) or (k, b);
    bands holding no frequency bin are dropped.
    """
    freqs = np.asarray(freqs, dtype=float)
    psd = np.asarray(psd, dtype=float)
    n_bands = int(np.ceil(fraction * np.log2(fmax / fmin)))
    edges = fmin * 2.0 ** (np.arange(n_bands + 1) / fraction)
    edges[-1] = fmax
    centres, means = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (freqs >= lo) & (freqs < hi) if hi < fmax else (freqs >= lo) & (freqs <= hi)
        if np.any(sel):
            centres.append(np.sqrt(lo * hi))
            means.append(psd[..., sel].mean(axis=-1))
    return np.array(centres), np.stack(means, axis=-1) if means else np.zeros(psd.shape[:-1] + (0,))


def spectral_deviation_db(freqs, measured, expected, fmin, fmax, fraction: int = 3):
    """Band centres and 10 log10(measured / expected) per 1/fraction-octave band."""
    c, m = band_average(freqs, measured, fmin, fmax, fraction)
    _, e = band_average(freqs, expected, fmin, fmax, fraction)
    return c, 10.0 * np.log10(m / e)
