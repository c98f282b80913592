"""Virtual finger trajectories at the touch-sensor rate (SI: s, m, N).

A :class:`Trajectory` is what a touch panel with force sensors reports: time stamps,
position and load. Build one with :func:`constant_scan` or :func:`strokes`, or read a
recorded one with :func:`surfhap.exchange.trajectory_csv.read_trajectory_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import field_validator, model_validator

from surfhap.checked import FiniteArray, checked_dataclass
from surfhap.errors import ConfigError
# the plausibility bounds of a finger (one definition, shared with the force-feedback engine)
from surfhap.models.finger import ACCELERATION_WINDOW, MAX_ACCELERATION, MAX_LOAD, MAX_SPEED

__all__ = ["Trajectory", "constant_scan", "strokes", "DEFAULT_SENSOR_RATE", "MAX_SPEED", "MAX_LOAD", "MAX_ACCELERATION",
           "ACCELERATION_WINDOW", "Implausible", "implausible", "check_scan"]

DEFAULT_SENSOR_RATE = 125.0  # Hz, the force-sensor rate of Otake et al. 2021 (Sec. II)

@checked_dataclass
class Trajectory:
    """Touch samples: t (n,) s strictly increasing, x and y (n,) m, load (n,) N (0 = lifted)."""

    t: FiniteArray
    x: FiniteArray
    y: FiniteArray
    load: FiniteArray
    name: str = "trajectory"

    @field_validator("t")
    @classmethod
    def _increasing(cls, t):
        if t.ndim == 1 and not (t.size >= 2 and np.all(np.diff(t) > 0)):
            raise ValueError("must be strictly increasing, with at least two samples")
        return t

    @field_validator("load")
    @classmethod
    def _pressing(cls, load):
        if np.any(load < 0):
            raise ValueError("must be >= 0")
        return load

    @model_validator(mode="after")
    def _one_length(self):
        if any(a.ndim != 1 or a.shape != self.t.shape for a in (self.t, self.x, self.y, self.load)):
            raise ValueError("t, x, y and load must be 1-D arrays of one length")
        return self

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def sensor_rate(self) -> float:
        """Median sample rate, Hz."""
        return float(1.0 / np.median(np.diff(self.t)))


@dataclass(frozen=True)
class Implausible:
    """Why touch samples are implausible: ``quantity`` ("speed", "acceleration" or "load"),
    ``index`` (0-based sample where it first happens), ``value`` (SI) and ``message`` (one line
    with the bound and a unit hint)."""

    quantity: str
    index: int
    value: float
    message: str


_CHUNK = 1 << 20  # samples per piece of the speed check
_HINTS = {"speed": "in mm? use metres", "acceleration": "in mm? use metres", "load": "in grams? use newtons"}


def _bound_message(quantity: str, value: float) -> str:
    bound, unit = {"speed": (MAX_SPEED, "m/s"), "acceleration": (MAX_ACCELERATION, "m/s^2"), "load": (MAX_LOAD, "N")}[quantity]
    return f"{quantity} {value:.4g} {unit} is beyond the plausible {bound:g} {unit} of a finger ({_HINTS[quantity]})"


def implausible(t: np.ndarray, x: np.ndarray, y: np.ndarray, load: np.ndarray) -> Implausible | None:
    """The first violation of the plausibility bounds (speed <= MAX_SPEED, acceleration <=
    MAX_ACCELERATION, load <= MAX_LOAD) by touch samples t (n,) s, x, y (n,) m, load (n,) N, or
    None. Speed and acceleration count only while touching (load > 0) at both ends: a lift may
    move the finger anywhere. Speed is the distance between consecutive samples over their time
    difference; acceleration the change of the velocity vector over ACCELERATION_WINDOW (20 ms,
    so a fast sensor's jitter does not inflate it)."""
    t, x, y, load = (np.asarray(a, dtype=float) for a in (t, x, y, load))
    over = np.nonzero(load > MAX_LOAD)[0]
    if over.size:
        return Implausible("load", int(over[0]), float(load[over[0]]), _bound_message("load", float(load[over[0]])))
    for lo in range(0, t.size - 1, _CHUNK):  # in pieces: a long recording at 10 kHz needs no copies of itself
        sl = slice(lo, min(t.size, lo + _CHUNK + 1))
        tc, xc, yc, lc = t[sl], x[sl], y[sl], load[sl]
        dt = np.diff(tc)
        contact = (lc[:-1] > 0) & (lc[1:] > 0)
        speed = np.where(contact, np.hypot(np.diff(xc), np.diff(yc)) / dt, 0.0)
        fast = np.nonzero(speed > MAX_SPEED * (1 + 1e-9))[0]
        if fast.size:
            v = float(speed[fast[0]])
            return Implausible("speed", lo + int(fast[0]) + 1, v, _bound_message("speed", v))
    return _acceleration(t, x, y, load)


def _acceleration(t, x, y, load) -> Implausible | None:
    """Acceleration over ACCELERATION_WINDOW: positions interpolated on a grid of half a window,
    velocities and their changes over one window, counted where the finger touched throughout."""
    w = ACCELERATION_WINDOW
    if t[-1] - t[0] < 2 * w:
        return None
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) / (w / 2))) + 1) * (w / 2)
    held = np.searchsorted(t, grid, side="right") - 1
    touching = load[held] > 0
    lifted_before = np.concatenate(([0], np.cumsum(load <= 0, dtype=np.int64 if t.size >= 2**31 else np.int32)))  # lifts among the samples before each index
    px, py = np.interp(grid, t, x), np.interp(grid, t, y)
    vx, vy = (px[2:] - px[:-2]) / w, (py[2:] - py[:-2]) / w  # velocity over [k, k+2]
    acc = np.hypot(vx[2:] - vx[:-2], vy[2:] - vy[:-2]) / w  # over [k, k+4]
    a, b = held[:-4], np.minimum(held[4:] + 2, t.size)  # samples that shape the span [k, k+4]
    through = (lifted_before[b] - lifted_before[a] == 0) & touching[:-4] & touching[4:]
    acc = np.where(through, acc, 0.0)
    jerk = np.nonzero(acc > MAX_ACCELERATION * (1 + 1e-9))[0]
    if not jerk.size:
        return None
    k = int(jerk[0])
    i = int(min(held[k + 2] + 1, t.size - 1))  # the sample in the middle of the span
    return Implausible("acceleration", i, float(acc[k]), _bound_message("acceleration", float(acc[k])))


def check_scan(speed: float, load: float, sensor_rate: float, duration: float | None = None) -> None:
    """The ranges of a synthetic scan (here and :func:`surfhap.shape.scan.straight_scan`); ConfigError naming the field."""
    if not (np.isfinite(speed) and 0 < speed <= MAX_SPEED):
        raise ConfigError(f"must be in (0, {MAX_SPEED:g}] m/s, got {speed:g} (in mm/s? use m/s)", field="speed")
    if not (np.isfinite(load) and 0 < load <= MAX_LOAD):
        raise ConfigError(f"must be in (0, {MAX_LOAD:g}] N, got {load:g} ({_HINTS['load']})", field="load")
    if not (np.isfinite(sensor_rate) and 10 <= sensor_rate <= 10_000):
        raise ConfigError(f"must be in [10, 10000] Hz, got {sensor_rate}", field="rate")  # the CLIs' rate=, --rate
    if duration is not None and not (np.isfinite(duration) and 0 < duration <= 3600):
        raise ConfigError(f"must be in (0, 3600] s, got {duration}", field="duration")


def constant_scan(speed: float, load: float, duration: float, sensor_rate: float = DEFAULT_SENSOR_RATE,
                  direction: float = 0.0) -> Trajectory:
    """A straight scan at constant speed (m/s) and load (N), heading ``direction`` (rad)."""
    check_scan(speed, load, sensor_rate, duration)
    t = np.arange(0.0, duration + 0.5 / sensor_rate, 1.0 / sensor_rate)
    s = speed * t
    return Trajectory(t, s * np.cos(direction), s * np.sin(direction), np.full(t.size, float(load)),
                      name=f"scan {speed * 1e3:g} mm/s, {load:g} N")


def strokes(speed: float, load: float, duration: float, length: float = 0.08,
            sensor_rate: float = DEFAULT_SENSOR_RATE) -> Trajectory:
    """Back-and-forth strokes of ``length`` m at constant ``speed`` (m/s), reversing at the ends."""
    check_scan(speed, load, sensor_rate, duration)
    if not (np.isfinite(length) and 0 < length <= 1.0):
        raise ConfigError(f"must be in (0, 1] m, got {length}", field="length")
    t = np.arange(0.0, duration + 0.5 / sensor_rate, 1.0 / sensor_rate)
    phase = (speed * t / length) % 2.0
    x = length * np.where(phase < 1.0, phase, 2.0 - phase)
    y, fn = np.zeros_like(t), np.full(t.size, float(load))
    bad = implausible(t, x, y, fn)  # the reversals: the bounds recorded trajectories are held to
    if bad is not None:
        raise ConfigError(f"strokes at {speed:g} m/s reverse at {bad.value:.4g} m/s^2, beyond the plausible "
                          f"{MAX_ACCELERATION:g} m/s^2 of a finger: lower the speed", field="speed")
    return Trajectory(t, x, y, fn, name=f"strokes {speed * 1e3:g} mm/s, {load:g} N, {length * 1e3:g} mm")
