"""DFT321: three acceleration axes into one signal (a pure function), and the compiled
forward-backward second-order-section filter of :class:`surfhap.signal.bands.BandSplit`."""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["dft321", "sos_filtfilt"]


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


@numba.njit(cache=True, nogil=True)
def _sos_pass(sos, z, x, y, backward):
    """One pass of scipy's ``sosfilt`` recursion (transposed direct form II, the same
    operations in the same order) over the rows of x (m, n) into y, forward or backward;
    z (m, k, 2) is the state, updated in place. The rows advance together, so their
    independent recursions overlap in the CPU."""
    m, n = x.shape
    for j in range(n):
        t = n - 1 - j if backward else j
        for i in range(m):
            cur = x[i, t]
            for s in range(sos.shape[0]):
                new = sos[s, 0] * cur + z[i, s, 0]
                z[i, s, 0] = sos[s, 1] * cur - sos[s, 4] * new + z[i, s, 1]
                z[i, s, 1] = sos[s, 2] * cur - sos[s, 5] * new
                cur = new
            y[i, t] = cur


@numba.njit(cache=True, nogil=True)
def sos_filtfilt(sos, zi, x):
    """Forward-backward filter of every row of x (m, n) by the sections sos (k, 6), each pass
    started in the steady state ``zi`` (k, 2) of its first sample: equals
    ``scipy.signal.sosfiltfilt(sos, x, axis=-1, padtype=None)`` sample for sample.
    Returns a new (m, n) array."""
    m, n = x.shape
    y = np.empty_like(x)
    z = np.empty((m, zi.shape[0], 2))
    for i in range(m):
        z[i] = zi * x[i, 0]
    _sos_pass(sos, z, x, y, False)
    for i in range(m):
        z[i] = zi * y[i, n - 1]
    _sos_pass(sos, z, y, y, True)
    return y
