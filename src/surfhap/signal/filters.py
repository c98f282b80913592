"""DFT321: three acceleration axes into one signal (a pure function). The band split is
:class:`surfhap.signal.bands.BandSplit`."""

from __future__ import annotations

import numpy as np

__all__ = ["dft321"]


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
