"""Virtual finger trajectories at the touch-sensor rate (SI: s, m, N).

A :class:`Trajectory` is what a touch panel with force sensors reports: time stamps,
position and load. Build one with :func:`constant_scan` or :func:`strokes`, or read a
recorded one with :func:`surfhap.exchange.trajectory_csv.read_trajectory_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from surfhap.errors import ConfigError

__all__ = ["Trajectory", "constant_scan", "strokes", "DEFAULT_SENSOR_RATE"]

DEFAULT_SENSOR_RATE = 125.0  # Hz, the force-sensor rate of Otake et al. 2021 (Sec. II)


@dataclass(frozen=True)
class Trajectory:
    """Touch samples: t (n,) s strictly increasing, x and y (n,) m, load (n,) N (0 = lifted)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    load: np.ndarray
    name: str = "trajectory"

    def __post_init__(self):
        arrs = [np.asarray(a, dtype=float) for a in (self.t, self.x, self.y, self.load)]
        n = arrs[0].shape
        if any(a.ndim != 1 or a.shape != n for a in arrs):
            raise ValueError("t, x, y and load must be 1-D arrays of one length")
        if n[0] < 2:
            raise ValueError("a trajectory needs at least two samples")
        for label, a in zip(("t", "x", "y", "load"), arrs):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{label} contains NaN or inf")
        if not np.all(np.diff(arrs[0]) > 0):
            raise ValueError("t must be strictly increasing")
        if np.any(arrs[3] < 0):
            raise ValueError("load must be >= 0")
        for name, a in zip(("t", "x", "y", "load"), arrs):
            object.__setattr__(self, name, a)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def sensor_rate(self) -> float:
        """Median sample rate, Hz."""
        return float(1.0 / np.median(np.diff(self.t)))


def _check(speed: float, load: float, duration: float, sensor_rate: float):
    if not (np.isfinite(speed) and 0 < speed <= 2.0):
        raise ConfigError(f"must be in (0, 2] m/s, got {speed}", field="speed")
    if not (np.isfinite(load) and 0 < load <= 20.0):
        raise ConfigError(f"must be in (0, 20] N, got {load}", field="load")
    if not (np.isfinite(duration) and 0 < duration <= 3600):
        raise ConfigError(f"must be in (0, 3600] s, got {duration}", field="duration")
    if not (np.isfinite(sensor_rate) and 10 <= sensor_rate <= 10_000):
        raise ConfigError(f"must be in [10, 10000] Hz, got {sensor_rate}", field="sensor_rate")


def constant_scan(speed: float, load: float, duration: float, sensor_rate: float = DEFAULT_SENSOR_RATE,
                  direction: float = 0.0) -> Trajectory:
    """A straight scan at constant speed (m/s) and load (N), heading ``direction`` (rad)."""
    _check(speed, load, duration, sensor_rate)
    t = np.arange(0.0, duration + 0.5 / sensor_rate, 1.0 / sensor_rate)
    s = speed * t
    return Trajectory(t, s * np.cos(direction), s * np.sin(direction), np.full(t.size, float(load)),
                      name=f"scan {speed * 1e3:g} mm/s, {load:g} N")


def strokes(speed: float, load: float, duration: float, length: float = 0.08,
            sensor_rate: float = DEFAULT_SENSOR_RATE) -> Trajectory:
    """Back-and-forth strokes of ``length`` m at constant ``speed`` (m/s), reversing at the ends."""
    _check(speed, load, duration, sensor_rate)
    if not (np.isfinite(length) and 0 < length <= 1.0):
        raise ConfigError(f"must be in (0, 1] m, got {length}", field="length")
    t = np.arange(0.0, duration + 0.5 / sensor_rate, 1.0 / sensor_rate)
    phase = (speed * t / length) % 2.0
    x = length * np.where(phase < 1.0, phase, 2.0 - phase)
    return Trajectory(t, x, np.zeros_like(t), np.full(t.size, float(load)),
                      name=f"strokes {speed * 1e3:g} mm/s, {load:g} N, {length * 1e3:g} mm")
