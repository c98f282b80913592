"""Kinematics stage: finger speed from touch samples at the sensor rate.

Speed is the distance between consecutive touch samples over their time difference,
smoothed by a one-pole low-pass (``cutoff`` Hz; hand motion lies below a few Hz, Otake et al.
2021 Sec. III-B). Samples arrive with their own time stamps, so jittery sensors are handled.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["Kinematics"]


@numba.njit(cache=True, nogil=True)
def _smooth_speed(t, x, y, pt, px, py, s, tau, out):
    for i in range(t.shape[0]):
        dt = t[i] - pt
        if dt > 0.0:
            raw = np.hypot(x[i] - px, y[i] - py) / dt
            if np.isfinite(raw):
                s += dt / (tau + dt) * (raw - s)
        out[i] = s
        pt, px, py = t[i], x[i], y[i]
    return s


class Kinematics:
    """``process(t, x, y) -> speed``: all (n,) float, t in s, x/y in m, speed in m/s."""

    def __init__(self, cutoff: float = 20.0):
        if not (np.isfinite(cutoff) and cutoff > 0):
            raise ValueError("cutoff must be > 0 Hz")
        self.cutoff = float(cutoff)
        self.reset()

    def reset(self) -> None:
        self._last = None  # (t, x, y)
        self._speed = 0.0

    def process(self, t: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        n = t.shape[0]
        out = np.empty(n)
        if n == 0:
            return out
        pt, px, py = (t[0], x[0], y[0]) if self._last is None else self._last
        tau = 1.0 / (2.0 * np.pi * self.cutoff)
        self._speed = _smooth_speed(t, x, y, pt, px, py, self._speed, tau, out)
        self._last = (t[-1], x[-1], y[-1])
        return out
