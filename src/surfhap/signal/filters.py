"""Zero-phase band split and DFT321 (pure functions)."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt

__all__ = ["band_split", "dft321"]


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
