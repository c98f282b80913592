"""Spectra of spliced signals, spectra averaged across participants, and the similarity index.

Averaging across participants (Otake et al. 2022, Sec. III-B): each participant's power
spectrum is computed, the spectra are averaged, and the AR model is estimated from the
averaged spectrum. Here a participant's spectrum is the periodogram of their spliced
spans, ``P_g(f) = sum_spans |FFT(span)|^2 / n_g`` (n_g = samples of that participant),
evaluated on a grid fine enough (nfft >= 2 L - 1 for the longest span L) that its inverse
FFT is exactly the biased autocovariance. The mean over participants of these periodograms
therefore has as inverse FFT the mean of their autocovariances, which is what
Levinson–Durbin (Yule–Walker) needs: "average the power spectra, then estimate from the
averaged spectrum", without resynthesising a time series and without joints between spans.

Similarity index between a measured and a modelled one-sided PSD on a common uniform
frequency grid, over a band [f_lo, f_hi]::

    SI = 1 - sum_f |S_meas(f) - S_model(f)| / sum_f (S_meas(f) + S_model(f))

SI is 1 for identical spectra and 0 for spectra with disjoint support; it is symmetric,
scale-aware (a model 2x too strong gives SI = 2/3) and dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import get_window

__all__ = [
    "AveragedSpectrum",
    "average_spectra",
    "welch_spans",
    "similarity_index",
    "log_spectral_distance",
]


@dataclass(frozen=True)
class AveragedSpectrum:
    """Spectrum averaged across groups (participants).

    freqs          : (m,) Hz, rfft grid of ``nfft``.
    psd            : (m,) one-sided PSD (units^2/Hz) of the average periodogram.
    autocovariance : (max_lag + 1,) the inverse FFT of the average periodogram.
    n_samples      : total samples over all groups (the n of AIC).
    n_groups       : number of groups that contributed.
    nfft           : FFT length.
    """

    freqs: np.ndarray
    psd: np.ndarray
    autocovariance: np.ndarray
    n_samples: int
    n_groups: int
    nfft: int


def _next_pow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(max(2, n))))


def average_spectra(
    groups: Sequence[Sequence[np.ndarray]],
    sample_rate: float,
    max_lag: int,
    demean: bool = True,
    min_samples: int = 1,
) -> AveragedSpectrum:
    """Average the periodograms of several groups of spans (see the module docstring).

    groups : one sequence of 1-D spans per participant. Groups with fewer than
    ``min_samples`` samples are skipped. Each span is demeaned on its own when ``demean``.
    """
    spans_by_group = []
    for g in groups:
        spans = [np.asarray(s, dtype=float).reshape(-1) for s in g]
        spans = [s for s in spans if s.size > 1]
        n = sum(s.size for s in spans)
        if n >= max(min_samples, 1):
            spans_by_group.append(spans)
    if not spans_by_group:
        raise ValueError("no group has enough samples to estimate a spectrum")
    longest = max(s.size for g in spans_by_group for s in g)
    nfft = _next_pow2(max(2 * longest - 1, 2 * (max_lag + 1)))
    acc = np.zeros(nfft // 2 + 1)
    n_total = 0
    for spans in spans_by_group:
        per = np.zeros(nfft // 2 + 1)
        n_g = 0
        for s in spans:
            if demean:
                s = s - s.mean()
            X = np.fft.rfft(s, nfft)
            per += X.real**2 + X.imag**2
            n_g += s.size
        acc += per / n_g
        n_total += n_g
    mean_per = acc / len(spans_by_group)
    acov = np.fft.irfft(mean_per, nfft)[: max_lag + 1]
    psd = 2.0 * mean_per / sample_rate
    psd[0] /= 2.0
    if nfft % 2 == 0:
        psd[-1] /= 2.0
    freqs = np.fft.rfftfreq(nfft, 1.0 / sample_rate)
    return AveragedSpectrum(freqs, psd, acov, int(n_total), len(spans_by_group), int(nfft))


def welch_spans(spans: Sequence[np.ndarray], sample_rate: float, nperseg: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD over several spans: Hann windows of ``nperseg`` with 50 % overlap inside
    each span; a span shorter than ``nperseg`` (but >= 16 samples) gives one Hann window of
    its own length, zero-padded. All windows are averaged with equal weight.

    Returns freqs (nperseg // 2 + 1,) Hz and the one-sided PSD (units^2/Hz).
    """
    nper = int(nperseg)
    acc = np.zeros(nper // 2 + 1)
    count = 0
    full_win = get_window("hann", nper)
    step = nper // 2
    for s in spans:
        s = np.asarray(s, dtype=float).reshape(-1)
        if s.size < 16:
            continue
        if s.size >= nper:
            k = 1 + (s.size - nper) // step
            idx = np.arange(k)[:, None] * step + np.arange(nper)[None, :]
            seg = s[idx]
            seg = seg - seg.mean(axis=1, keepdims=True)
            X = np.fft.rfft(seg * full_win, nper, axis=1)
            acc += np.sum(X.real**2 + X.imag**2, axis=0) / np.sum(full_win**2)
            count += k
        else:
            win = get_window("hann", s.size)
            X = np.fft.rfft((s - s.mean()) * win, nper)
            acc += (X.real**2 + X.imag**2) / np.sum(win**2)
            count += 1
    if count == 0:
        raise ValueError("no span long enough for a spectrum (need >= 16 samples)")
    psd = 2.0 * acc / count / sample_rate
    psd[0] /= 2.0
    if nper % 2 == 0:
        psd[-1] /= 2.0
    return np.fft.rfftfreq(nper, 1.0 / sample_rate), psd


def _band(freqs, f_lo, f_hi):
    f = np.asarray(freqs, dtype=float)
    hi = np.inf if f_hi is None else f_hi
    sel = (f >= f_lo) & (f <= hi)
    if not np.any(sel):
        raise ValueError(f"no frequency bin within [{f_lo}, {f_hi}] Hz")
    return sel


def similarity_index(freqs: np.ndarray, measured: np.ndarray, modelled: np.ndarray, f_lo: float = 0.0, f_hi: float | None = None) -> float:
    """SI = 1 - sum|S_meas - S_model| / sum(S_meas + S_model) over [f_lo, f_hi] (module
    docstring). freqs, measured, modelled : (m,) on one uniform grid. Returns a float in [0, 1]."""
    sel = _band(freqs, f_lo, f_hi)
    a = np.asarray(measured, dtype=float)[sel]
    b = np.asarray(modelled, dtype=float)[sel]
    den = float(np.sum(a + b))
    if not den > 0:
        raise ValueError("both spectra are zero in the band")
    return float(1.0 - np.sum(np.abs(a - b)) / den)


def log_spectral_distance(freqs: np.ndarray, measured: np.ndarray, modelled: np.ndarray, f_lo: float = 0.0, f_hi: float | None = None) -> float:
    """Mean absolute difference in dB between two PSDs over [f_lo, f_hi] (m,) -> float."""
    sel = _band(freqs, f_lo, f_hi)
    tiny = np.finfo(float).tiny
    a = 10 * np.log10(np.maximum(np.asarray(measured, dtype=float)[sel], tiny))
    b = 10 * np.log10(np.maximum(np.asarray(modelled, dtype=float)[sel], tiny))
    return float(np.mean(np.abs(a - b)))
