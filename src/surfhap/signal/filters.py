"""Zero-phase band split and DFT321 (pure functions)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import butter, sosfilt, sosfilt_zi, sosfiltfilt

__all__ = ["band_split", "dft321", "zero_phase_lowpass"]


def band_split(x: np.ndarray, sample_rate: float, cutoff: float, order: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Split x (n,) into (low, high) with a zero-phase Butterworth filter at ``cutoff`` Hz.

    ``low`` is the forward-backward low-pass (Otake et al.: 2.5 Hz in 2021, 3.5 Hz in 2022)
    and ``high = x - low``, so ``low + high == x`` exactly.
    """
    x = np.asarray(x, dtype=float)
    if not 0 < cutoff < sample_rate / 2:
        raise ValueError(f"cutoff must be within (0, {sample_rate / 2}) Hz, got {cutoff}")
    sos = butter(order, cutoff, btype="low", fs=sample_rate, output="sos")
    low = sosfiltfilt(sos, x)
    return low, x - low


def dft321(xyz: np.ndarray) -> np.ndarray:
    """Combine three acceleration axes (n, 3) into one signal (n,) with the same spectrum energy.

    DFT321 (Landin et al. 2010, used by HaTT): |A(f)| = sqrt(sum_i |A_i(f)|^2), with the phase
    of sum_i A_i(f). Parseval: the result has the summed energy of the three axes.
    """
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise ValueError("dft321 needs an (n, 3) array")
    spec = np.fft.rfft(xyz, axis=0)
    mag = np.sqrt(np.sum(np.abs(spec) ** 2, axis=1))
    phase = np.angle(np.sum(spec, axis=1))
    return np.fft.irfft(mag * np.exp(1j * phase), n=xyz.shape[0])


@lru_cache(maxsize=64)
def _butter_low(order: int, cutoff: float, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Second-order sections (k, 6) of the Butterworth low-pass and their unit-step initial
    state (k, 2) (what ``sosfiltfilt`` recomputes on every call)."""
    sos = butter(order, cutoff, btype="low", fs=sample_rate, output="sos")
    return sos, sosfilt_zi(sos)


def _filtfilt(sos: np.ndarray, zi: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Forward-backward ``sosfilt`` of x (..., n) along its last axis, each pass started in the
    steady state of its first sample: ``sosfiltfilt(sos, x, axis=-1, padtype=None)``."""
    state = zi.reshape(zi.shape[0], *([1] * (x.ndim - 1)), 2)  # (k, ..., 2), broadcast over the leading axes
    y, _ = sosfilt(sos, x, axis=-1, zi=state * x[..., :1][None])
    y, _ = sosfilt(sos, y[..., ::-1], axis=-1, zi=state * y[..., -1:][None])
    return y[..., ::-1]


def zero_phase_lowpass(x: np.ndarray, sample_rate: float, cutoff: float, order: int = 4, pad_periods: float = 2.0,
                       pivot_periods: float = 0.5) -> np.ndarray:
    """Zero-phase Butterworth low-pass of x (..., n) along its last axis, with edge extension
    that leaves no step at the ends.

    scipy's odd extension reflects the signal through its first (last) *sample*; when the
    signal is noisy (a textured CoF) that sample is off the local level by about one noise
    standard deviation, and the reflected padding carries a step of twice that size into the
    filter, whose slow response leaks into ``x - low`` as a low-frequency transient lasting
    about a cut-off period (a false rise of the high band's spectrum below ~20 Hz).  Here
    the extension is the odd reflection through the least-squares *line* fitted to the first
    (last) ``pivot_periods`` cut-off periods, over ``pad_periods`` cut-off periods: level and
    slope continue, the noise is mirrored, and there is no step.  Signals shorter than the
    pad use their own length.  Returns an array of x's shape.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[-1]
    if not 0 < cutoff < sample_rate / 2:
        raise ValueError(f"cutoff must be within (0, {sample_rate / 2}) Hz, got {cutoff}")
    sos, zi = _butter_low(int(order), float(cutoff), float(sample_rate))
    if n < 3:
        return sosfiltfilt(sos, x, axis=-1, padtype="odd", padlen=max(n - 1, 0))
    pad = int(min(n - 1, max(1, round(pad_periods * sample_rate / cutoff))))
    m = int(min(n, max(2, round(pivot_periods * sample_rate / cutoff))))
    t = np.arange(m) - (m - 1) / 2.0
    tt = float(t @ t)

    def line_end(seg, at):  # value of the LS line through seg (..., m) at index ``at`` (0-based in seg)
        mean = seg.mean(axis=-1)
        slope = (seg - mean[..., None]) @ t / tt
        return mean + slope * (at - (m - 1) / 2.0)

    l0 = line_end(x[..., :m], 0)
    l1 = line_end(x[..., n - m:], m - 1)
    head = 2.0 * l0[..., None] - x[..., np.arange(pad, 0, -1)]
    tail = 2.0 * l1[..., None] - x[..., np.arange(n - 2, n - pad - 2, -1)]
    ext = np.concatenate((head, x, tail), axis=-1)
    return _filtfilt(sos, zi, ext)[..., pad:pad + n]
