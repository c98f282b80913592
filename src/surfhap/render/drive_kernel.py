"""The compiled tail shared by every drive law (:class:`surfhap.render.drive.DriveLaw`), kept
apart so that listing materials and methods does not import numba."""

from __future__ import annotations

import math

import numba

__all__ = ["target_to_voltage"]


@numba.njit(cache=True, nogil=True)
def target_to_voltage(target, load, alpha, voltage):
    """The tail every law shares, in one pass: ``voltage = alpha sqrt(max(target, 0))`` (V; a
    NaN target stays NaN for the safety stage to catch). Returns (clipped, touching): samples
    in contact (load > 0) whose target is negative (not renderable), and samples in contact."""
    clipped = 0
    touching = 0
    for i in range(target.shape[0]):
        t = target[i]
        if load[i] > 0.0:
            touching += 1
            if t < 0.0:
                clipped += 1
        voltage[i] = 0.0 if t <= 0.0 else alpha * math.sqrt(t)
    return clipped, touching
