"""Compiled helpers of the live engine's per-chunk bookkeeping: the drive FIFO (a power-of-two
ring of float64 volts), a chunk's trace row and latencies, and a block mean. Each replaces a few numpy calls whose
fixed cost (1-2 us each) outweighs the arithmetic on a chunk of 5-100 samples."""

from __future__ import annotations

import numba

__all__ = ["fifo_write_peak", "fifo_read", "mean_or_nan", "record_chunk"]


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
def record_chunk(fifo, mask, w, drive, trace, index, t, inputs, target, friction, lat, n_lat, applied, n_applied,
                 now, offset, drive_rate):
    """The engine's bookkeeping of one chunk in one call: drive (m,) into the FIFO at ``w``
    (:func:`fifo_write_peak`); trace row ``index`` (mod the trace's power-of-two length) in the
    order of ``TRACE_FIELDS`` from ``inputs[:, 0]`` (speed, load, touch time, x, y), the peak,
    ``target[0]`` and the mean of ``friction`` (the display's samples; NaN for none or an empty
    chunk); and for each of the ``n_applied`` touches put in force
    (``applied``: (2, k) arrival stamp, model-sample position in the chunk of n) its latency
    into the ring ``lat`` from write count ``n_lat``: its emission ``now + (offset + pos m / n)
    / drive_rate`` (the chunk starts ``offset`` samples into the block emitted at ``now``)
    minus its arrival."""
    peak = fifo_write_peak(fifo, mask, w, drive)
    row = trace[index & (trace.shape[0] - 1)]
    row[0], row[1], row[2], row[3], row[4] = t, inputs[3, 0], inputs[4, 0], inputs[0, 0], inputs[1, 0]
    m, n = drive.shape[0], inputs.shape[1]
    row[5], row[6], row[7] = peak, target[0], mean_or_nan(friction) if m else float("nan")
    for j in range(n_applied):
        lat[(n_lat + j) & (lat.shape[0] - 1)] = now + (offset + applied[1, j] * m / n) / drive_rate - applied[0, j]
