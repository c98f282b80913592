"""Compiled helpers of the live engine's per-chunk bookkeeping: the drive FIFO (a power-of-two
ring of float64 volts), the trace row and a block mean. Each replaces a few numpy calls whose
fixed cost (1-2 us each) outweighs the arithmetic on a chunk of 5-100 samples."""

from __future__ import annotations

import numba

__all__ = ["fifo_write_peak", "fifo_read", "mean_or_nan", "write_trace_row"]


@numba.njit(cache=True, nogil=True)
def fifo_write_peak(fifo, mask, w, drive):
    """Write drive (m,) at ring positions w, w+1, ... (mod ``mask + 1``); return max |drive|
    (V; 0 for an empty chunk, NaN if any sample is NaN)."""
    peak = 0.0
    bad = False
    for i in range(drive.shape[0]):
        v = drive[i]
        fifo[(w + i) & mask] = v
        a = abs(v)
        if a > peak:
            peak = a
        elif a != a:
            bad = True
    return float("nan") if bad else peak


@numba.njit(cache=True, nogil=True)
def fifo_read(fifo, mask, r, out):
    """Copy out.shape[0] samples from ring positions r, r+1, ... into ``out``."""
    for i in range(out.shape[0]):
        out[i] = fifo[(r + i) & mask]


@numba.njit(cache=True, nogil=True)
def mean_or_nan(x):
    """Mean of (n,) float, NaN when n == 0."""
    n = x.shape[0]
    if n == 0:
        return float("nan")
    s = 0.0
    for i in range(n):
        s += x[i]
    return s / n


@numba.njit(cache=True, nogil=True)
def write_trace_row(trace, index, t, x, y, speed, load, v_peak, target, friction):
    """Write one row of the engine trace ((capacity, 8) float, capacity a power of two) at
    ``index`` mod capacity, in the order of ``TRACE_FIELDS``."""
    row = trace[index & (trace.shape[0] - 1)]
    row[0] = t
    row[1] = x
    row[2] = y
    row[3] = speed
    row[4] = load
    row[5] = v_peak
    row[6] = target
    row[7] = friction
