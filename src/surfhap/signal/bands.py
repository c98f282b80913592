"""Fractional-octave band averaging of spectra, and the band-split filter's response.

Welch estimates scatter by about +-0.5 dB per bin even on long signals; comparing a rendered
spectrum to a model is meaningful after averaging within fractional-octave bands.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfreqz

__all__ = ["band_average", "band_split_high_gain", "highpass_gain", "spectral_deviation_db"]


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


def band_split_high_gain(freqs: np.ndarray, sample_rate: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Power gain (m,) of the high band of :func:`surfhap.signal.filters.band_split` at freqs Hz.

    The zero-phase low-pass has power gain |H|^4; the high band is x - low, gain (1 - |H|^2)^2.
    """
    sos = butter(order, cutoff, btype="low", fs=sample_rate, output="sos")
    _, h = sosfreqz(sos, worN=np.asarray(freqs, dtype=float), fs=sample_rate)
    return (1.0 - np.abs(h) ** 2) ** 2


def highpass_gain(freqs: np.ndarray, sample_rate: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Power gain (m,) at freqs Hz of a Butterworth high-pass applied forward and backward
    (``sosfiltfilt``): |H|^4."""
    sos = butter(order, cutoff, btype="high", fs=sample_rate, output="sos")
    _, h = sosfreqz(sos, worN=np.asarray(freqs, dtype=float), fs=sample_rate)
    return np.abs(h) ** 4


def spectral_deviation_db(freqs, measured, expected, fmin, fmax, fraction: int = 3):
    """Band centres and 10 log10(measured / expected) per 1/fraction-octave band."""
    c, m = band_average(freqs, measured, fmin, fmax, fraction)
    _, e = band_average(freqs, expected, fmin, fmax, fraction)
    return c, 10.0 * np.log10(m / e)
