"""Hold the latest finger sample at the drive rate (one helper for every chain).

The texture chain (:mod:`surfhap.render.chain`), the offline shape render and the live shape
renderer (:mod:`surfhap.render.shape_renderer`) all turn finger samples that arrive at a slow
rate (touch or model rate) into drive-rate inputs of the safety stage: for each drive sample,
the load and the age of the freshest finger sample in force at its time. :func:`hold_latest`
is that zero-order hold.

Time base: drive sample ``J`` is emitted at ``t_J = J / drive_rate`` s on the chain's clock
(0 at reset); source sample ``k`` is in force from ``src_time[k]`` s on (times
non-decreasing). A source sample counts from ``src_time[k] <= t_J + tol``: ``tol`` absorbs
the rounding of the two time bases.
"""

from __future__ import annotations

import numba

__all__ = ["hold_latest", "model_times"]


@numba.njit(cache=True, nogil=True)
def hold_latest(n_drive0, drive_rate, src_time, tol, load, stamp, last_load, last_stamp, out_load, out_age, out_index):
    """Zero-order hold of source samples onto the drive samples ``J = n_drive0 .. n_drive0 + m - 1``.

    n_drive0 : int, index of the first drive sample; drive_rate: Hz.
    src_time : (n,) float s, when each source sample comes into force (non-decreasing).
    tol      : s, rounding tolerance of the comparison.
    load     : (n,) float N; stamp: (n,) float s, time stamp of the touch data behind each
               source sample.
    last_load, last_stamp : N and s, what holds before the first source sample (the previous
               block's last sample; 0 N and -inf s at the start).
    out_load, out_age : (m,) float, filled with the held load (N) and the touch age
               ``t_J - stamp`` (s; inf with no touch yet); out_index (m,) int64: the source
               sample held (-1 before the first).
    """
    n = src_time.shape[0]
    k = -1
    for j in range(out_load.shape[0]):
        t = (n_drive0 + j) / drive_rate
        while k + 1 < n and src_time[k + 1] <= t + tol:
            k += 1
        if k < 0:
            out_load[j] = last_load
            out_age[j] = t - last_stamp
        else:
            out_load[j] = load[k]
            out_age[j] = t - stamp[k]
        out_index[j] = k


@numba.njit(cache=True, nogil=True)
def model_times(n_model0, model_rate, out):
    """Start times (s) of the model samples ``n_model0 .. n_model0 + n - 1`` at ``model_rate``
    Hz into ``out`` (n,) float: the ``src_time`` of :func:`hold_latest` for a chain that runs
    at a fixed model rate."""
    for k in range(out.shape[0]):
        out[k] = (n_model0 + k) / model_rate
