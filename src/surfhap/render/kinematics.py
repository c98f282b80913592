"""Kinematics stage: finger speed from touch samples at the sensor rate.

Speed is the distance between consecutive touch samples over their time difference,
smoothed by a one-pole low-pass (``cutoff`` Hz; hand motion lies below a few Hz, Otake et al.
2021 Sec. III-B). Samples arrive with their own time stamps, so jittery sensors are handled.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Kinematics"]


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
        if self._last is None:
            pt, px, py = t[0], x[0], y[0]
        else:
            pt, px, py = self._last
        tt = np.concatenate(([pt], t))
        dt = np.diff(tt)
        dist = np.hypot(np.diff(np.concatenate(([px], x))), np.diff(np.concatenate(([py], y))))
        with np.errstate(divide="ignore", invalid="ignore"):
            raw = np.where(dt > 0, dist / dt, np.nan)
        tau = 1.0 / (2.0 * np.pi * self.cutoff)
        s = self._speed
        for i in range(n):
            if np.isfinite(raw[i]):
                a = dt[i] / (tau + dt[i])
                s += a * (raw[i] - s)
            out[i] = s
        self._speed = s
        self._last = (t[-1], x[-1], y[-1])
        return out
