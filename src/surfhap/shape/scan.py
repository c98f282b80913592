"""Straight virtual scans and the orthographic top view of a shape (pure functions)."""

from __future__ import annotations

import numpy as np

from surfhap.errors import ConfigError
from surfhap.models.trajectory import Trajectory, check_scan

__all__ = ["straight_scan", "parse_scan", "top_view", "DEFAULT_TOUCH_RATE", "DEFAULT_LOAD"]

DEFAULT_TOUCH_RATE = 60.0  # Hz, update rate of Kim et al.'s app (Sec. 5.1.3)
DEFAULT_LOAD = 1.0  # N, the normal force Kim et al. assume (Sec. 3.1.1)


def straight_scan(x0: float, y0: float, x1: float, y1: float, speed: float, *, rate: float = DEFAULT_TOUCH_RATE,
                  load: float = DEFAULT_LOAD) -> Trajectory:
    """A straight scan from (x0, y0) to (x1, y1) (m) at ``speed`` m/s, sampled at ``rate`` Hz,
    with constant ``load`` N; the last sample lands on (x1, y1)."""
    vals = (x0, y0, x1, y1, speed, rate, load)
    if not all(np.isfinite(v) for v in vals):
        raise ConfigError("scan values must be finite numbers", field="scan")
    length = float(np.hypot(x1 - x0, y1 - y0))
    if not length > 0:
        raise ConfigError("start and end of the scan coincide", field="scan")
    check_scan(speed, load, rate)  # the plausibility bounds of every trajectory (models.trajectory)
    duration = length / speed
    n = int(np.floor(duration * rate + 1e-9)) + 1
    if n > 10_000_000:
        raise ConfigError(f"the scan would take {n} samples; shorten it or speed up", field="scan")
    t = np.arange(n) / rate
    s = np.minimum(t * speed / length, 1.0)
    if duration - t[-1] > 1e-6 / rate:  # end exactly at (x1, y1)
        t = np.append(t, duration)
        s = np.append(s, 1.0)
    else:
        s[-1] = 1.0
    return Trajectory(t, x0 + s * (x1 - x0), y0 + s * (y1 - y0), np.full(t.size, float(load)),
                      name=f"scan ({x0:g}, {y0:g}) -> ({x1:g}, {y1:g}) m at {speed * 100:g} cm/s, {rate:g} Hz")


def parse_scan(text: str, rate: float = DEFAULT_TOUCH_RATE, load: float = DEFAULT_LOAD) -> Trajectory:
    """``"x0,y0,x1,y1,speed"`` (m, m/s) -> :func:`straight_scan`."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 5:
        raise ConfigError("expected x0,y0,x1,y1,speed (m, m/s)", source="--scan")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(f"not numbers: {text!r}", source="--scan") from None
    try:
        return straight_scan(*vals, rate=rate, load=load)
    except ConfigError as exc:
        raise ConfigError(exc.message, source="--scan", field=exc.field) from None


def top_view(surface, light: np.ndarray, n: int = 400) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float, float]]:
    """Orthographic top view with Lambert shading.

    light : (3,) vector towards the light. Returns ``(shade (ny, nx) float in [0, 1], NaN off
    the mesh; height (ny, nx) float; extent (x0, x1, y0, y1))``; row 0 is the lowest y.
    """
    lo, hi = surface.bounds
    w, h = hi[0] - lo[0], hi[1] - lo[1]
    if w <= 0 or h <= 0:
        raise ValueError("the surface has no xy extent")
    nx = int(n) if w >= h else max(2, int(n * w / h))
    ny = int(n) if h >= w else max(2, int(n * h / w))
    xs = lo[0] + (np.arange(nx) + 0.5) * w / nx
    ys = lo[1] + (np.arange(ny) + 0.5) * h / ny
    X, Y = np.meshgrid(xs, ys)
    z, f = surface.query(np.column_stack([X.ravel(), Y.ravel()]))
    nrm = surface.normals_of(f)
    ld = np.asarray(light, dtype=float)
    ld = ld / np.linalg.norm(ld)
    shade = np.clip(nrm @ ld, 0.0, 1.0)
    shade = np.where(f >= 0, 0.15 + 0.85 * shade, np.nan)
    return shade.reshape(ny, nx), z.reshape(ny, nx), (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]))
