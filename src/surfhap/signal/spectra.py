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
Optionally each span is tapered (Tukey; the normalisation becomes sum w^2 and the
equivalent sample count sum (sum w^2)^2 / sum w^4), a known pre-filter's gain is divided
out and the bins below a frequency are continued flat (the high-pass notch an all-pole
model cannot represent); see :func:`average_spectra` and docs/fitting.md.

Similarity index between a measured and a modelled one-sided PSD on a common uniform
frequency grid, over a band [f_lo, f_hi]::

    SI = 1 - sum_f |S_meas(f) - S_model(f)| / sum_f (S_meas(f) + S_model(f))

SI is 1 for identical spectra and 0 for spectra with disjoint support; it is symmetric,
scale-aware (a model 2x too strong gives SI = 2/3) and dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.signal import get_window
from scipy.signal.windows import tukey

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
    n_samples      : total samples over all groups.
    n_groups       : number of groups that contributed.
    nfft           : FFT length.
    n_effective    : equivalent number of independent samples, the n of AIC / BIC:
                     sum over spans of (sum w^2)^2 / sum w^4 for the taper w (= n_samples
                     without a taper).
    taper          : Tukey taper fraction used on every span (0 = rectangular).
    fill_below     : Hz; bins below it were replaced (see :func:`average_spectra`), or None.
    """

    freqs: np.ndarray
    psd: np.ndarray
    autocovariance: np.ndarray
    n_samples: int
    n_groups: int
    nfft: int
    n_effective: float = 0.0
    taper: float = 0.0
    fill_below: float | None = None


def _next_pow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(max(2, n))))


def _chunks(items: Sequence, sizes: Sequence[int], budget: int = 1 << 22):
    """items in consecutive chunks (lists) whose sizes sum to at most ``budget`` (or of one item)."""
    chunk, total = [], 0
    for item, size in zip(items, sizes):
        if chunk and total + size > budget:
            yield chunk
            chunk, total = [], 0
        chunk.append(item)
        total += size
    if chunk:
        yield chunk


@lru_cache(maxsize=256)
def _tukey(n: int, taper: float) -> tuple[np.ndarray, float, float]:
    """Tukey window (n,) and its sums of squares and fourth powers."""
    w = tukey(n, taper)
    return w, float(w @ w), float(np.sum(w**4))


@lru_cache(maxsize=256)
def _hann(n: int) -> tuple[np.ndarray, float]:
    """Periodic Hann window (n,) (``get_window("hann", n)``) and its sum of squares."""
    w = get_window("hann", n)
    return w, float(np.sum(w**2))


def average_spectra(
    groups: Sequence[Sequence[np.ndarray]],
    sample_rate: float,
    max_lag: int,
    demean: bool = True,
    min_samples: int = 1,
    taper: float = 0.0,
    fill_below: float | None = None,
    gain=None,
) -> AveragedSpectrum:
    """Average the periodograms of several groups of spans (see the module docstring).

    groups : one sequence of 1-D spans per participant. Groups with fewer than
    ``min_samples`` samples are skipped. Each span is demeaned on its own when ``demean``.

    taper : Tukey fraction (0..1) applied to every span before its FFT; the participant's
    periodogram is then ``sum |FFT(w span)|^2 / sum w^2``. Yule–Walker from a rectangular
    window suffers end effects of order (spectral dynamic range) / (span length), which on
    peaky spectra is enough for AIC to add spurious poles; a taper removes them (Percival &
    Walden 1993, Sec. 9.4). ``n_effective`` then counts the equivalent samples.

    fill_below : Hz or None. The periodogram bins below it are replaced by the mean of the
    bins in [fill_below, 1.5 fill_below] (a flat continuation) before the autocovariance is
    taken. Use it when the spans were high-passed (the band split): the high band has a
    notch of depth ~ (f / f_c)^16 at DC that an all-pole model cannot represent and chases
    with ever more poles; the notch says nothing about the texture, whose own spectrum there
    is unknown (the low band owns those frequencies).

    gain : None or a function freqs (m,) Hz -> (m,) power gain of a known zero-phase
    pre-filter (a high-pass); at and above ``fill_below`` the periodogram is divided by it,
    so the model describes the signal before that filter (choose ``fill_below`` where the
    gain is still >= ~0.5).
    """
    if not 0.0 <= taper <= 1.0:
        raise ValueError(f"taper must be within [0, 1], got {taper}")
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
    nfft = _next_pow2(max(2 * longest - 1, 2 * (max_lag + 1), int(np.ceil(4 * sample_rate / fill_below)) if fill_below else 0))
    acc = np.zeros(nfft // 2 + 1)
    n_total = 0
    n_eff = 0.0
    for spans in spans_by_group:
        per = np.zeros(nfft // 2 + 1)
        w2 = 0.0
        for chunk in _chunks(spans, [nfft] * len(spans)):  # one FFT call per chunk of spans, zero-padded to nfft
            rows = np.zeros((len(chunk), nfft))
            for row, s in zip(rows, chunk):
                if demean:
                    s = s - s.mean()
                if taper > 0:
                    w, sw2, sw4 = _tukey(s.size, taper)
                    s = s * w
                else:
                    sw2 = sw4 = float(s.size)
                row[: s.size] = s
                w2 += sw2
                n_eff += sw2 * sw2 / sw4
            X = np.fft.rfft(rows, axis=1)
            for p in X.real**2 + X.imag**2:
                per += p
        acc += per / w2
        n_total += sum(s.size for s in spans)
    mean_per = acc / len(spans_by_group)
    freqs = np.fft.rfftfreq(nfft, 1.0 / sample_rate)
    if gain is not None:
        if not fill_below:
            raise ValueError("gain compensation needs fill_below (where the gain is too small to divide by)")
        above = freqs >= fill_below
        mean_per = mean_per.copy()
        mean_per[above] /= np.maximum(np.asarray(gain(freqs[above]), dtype=float), 1e-12)
    if fill_below:
        ref = (freqs >= fill_below) & (freqs <= 1.5 * fill_below)
        if not np.any(ref):
            raise ValueError(f"no frequency bin within [{fill_below}, {1.5 * fill_below}] Hz to continue below {fill_below} Hz")
        mean_per = np.where(freqs < fill_below, np.mean(mean_per[ref]), mean_per)
    acov = np.fft.irfft(mean_per, nfft)[: max_lag + 1]
    psd = 2.0 * mean_per / sample_rate
    psd[0] /= 2.0
    if nfft % 2 == 0:
        psd[-1] /= 2.0
    return AveragedSpectrum(freqs, psd, acov, int(n_total), len(spans_by_group), int(nfft), float(n_eff), float(taper),
                            float(fill_below) if fill_below else None)


def welch_spans(spans: Sequence[np.ndarray], sample_rate: float, nperseg: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD over several spans: Hann windows of ``nperseg`` with 50 % overlap inside
    each span; a span shorter than ``nperseg`` (but >= 16 samples) gives one Hann window of
    its own length, zero-padded. All windows are averaged with equal weight.

    Returns freqs (nperseg // 2 + 1,) Hz and the one-sided PSD (units^2/Hz).
    """
    nper = int(nperseg)
    step = nper // 2
    full_win, full_w2 = _hann(nper)
    spans = [s for s in (np.asarray(s, dtype=float).reshape(-1) for s in spans) if s.size >= 16]
    ks = [1 + (s.size - nper) // step if s.size >= nper else 0 for s in spans]  # full windows per span
    summed = {}  # span index -> the summed power of its full windows
    long_ = [i for i, k in enumerate(ks) if k]
    for chunk in _chunks(long_, [ks[i] * nper for i in long_]):  # the windows of several spans in one FFT call
        seg = np.concatenate([spans[i][np.arange(ks[i])[:, None] * step + np.arange(nper)[None, :]] for i in chunk])
        seg = seg - seg.mean(axis=1, keepdims=True)
        X = np.fft.rfft(seg * full_win, nper, axis=1)
        power = X.real**2 + X.imag**2
        for i, a in zip(chunk, np.cumsum([0] + [ks[i] for i in chunk])):
            summed[i] = np.sum(power[a:a + ks[i]], axis=0) / full_w2
    acc = np.zeros(nper // 2 + 1)
    for i, s in enumerate(spans):
        if ks[i]:
            acc += summed[i]
        else:
            win, w2 = _hann(s.size)
            X = np.fft.rfft((s - s.mean()) * win, nper)
            acc += (X.real**2 + X.imag**2) / w2
    count = sum(ks) + ks.count(0)
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
