"""Adapter that puts the shape renderer (Kim et al. 2017; :mod:`surfhap.render.shape_renderer`)
behind the live engine's renderer protocol.

The engine hands it, per chunk, the held finger state at ``model_rate`` (1 kHz: one
sample per 1 ms block) including the (predicted) position. The touch-rate stage
(:class:`~surfhap.render.shape_renderer.ShapeRenderer`: vertical ray, gradient force,
intensity, edge ticks) runs once per *new* position, so the gradient is taken between
successive finger positions as in the paper, not between repeated copies of one sample.
The drive-rate stage (:class:`~surfhap.render.shape_renderer.ShapeDrive`: grains, carrier,
safety stage with its watchdog) runs every chunk.

Coordinates: the page's touch surface (``TouchSpace``, metres, y down) is mapped onto the
mesh (metres, centred on x = y = 0 by ``size``, y up) as ``x_mesh = x - W/2``,
``y_mesh = H/2 - y``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np

__all__ = ["LiveShapeRenderer", "load_live_shape", "shape_preview"]


class _Block(NamedTuple):
    drive: np.ndarray
    load_drive: np.ndarray
    drive_law: SimpleNamespace


class LiveShapeRenderer:
    """Renderer protocol of :class:`~surfhap.live.engine.LiveEngine` for a mesh."""

    uses_position = True

    def __init__(self, surface, calibration, config=None, *, model_rate: int = 1000,
                 surface_size: tuple[float, float] = (0.217, 0.136), max_block: int = 1 << 14):
        from surfhap.render.shape_renderer import ShapeConfig, ShapeDrive, ShapeRenderer

        cfg = config or ShapeConfig()
        if cfg.drive_rate % model_rate:
            raise ValueError("the drive rate must be a multiple of the model rate")
        self.config = cfg
        self.surface = surface
        self.touch_stage = ShapeRenderer(surface, calibration, cfg)
        self.drive_stage = ShapeDrive(cfg)
        self.safety = self.drive_stage.safety
        self.drive_rate = int(cfg.drive_rate)
        self.model_rate = int(model_rate)
        self.ratio = self.drive_rate // self.model_rate
        self.half = (surface_size[0] / 2.0, surface_size[1] / 2.0)
        self.lift = cfg.limits.lift_threshold
        self._inten = np.zeros(max_block)
        self._tick = np.zeros(max_block)
        self._load = np.zeros(max_block)
        self._age = np.zeros(max_block)
        self._ramp = np.arange(max_block) / self.drive_rate
        self._px = np.zeros(1)
        self._py = np.zeros(1)
        self._on = np.ones(1, dtype=bool)
        self.reset()

    def reset(self) -> None:
        self.reset_touch()
        self.drive_stage.reset()
        self._n_drive = 0
        self._have = False
        self._lx = self._ly = np.nan
        self._intensity = 0.0

    def reset_touch(self) -> None:
        self.touch_stage.reset()
        self._prev = None  # (x, y, z, force) of the previous touch sample
        self._prev_face = -1
        self._prev_point = np.full(3, np.nan)

    def touch_point(self, x: float, y: float) -> tuple[float, float]:
        """The touch-rate stage for one new position: ``(intensity, tick)``.

        Same results as ``ShapeRenderer.process`` on a one-sample block (asserted in the
        tests) with scalar arithmetic, because its array code costs ~50 us per call, half
        the block budget: vertical ray (``TopSurface.query_point``), lateral force from the
        previous hit (eq. 3-7, held while the finger rests), signed square root (eq. 8),
        intensity (eq. 9); edge ticks (eq. 10-11) only where the hit face changes, through
        the shape package's own function. ``edge_walk`` uses the array path.
        """
        if self.config.edge_walk:
            self._px[0], self._py[0] = x, y
            blk = self.touch_stage.process(self._px, self._py, self._on)
            on = np.isfinite(blk.z[0])
            return (float(blk.intensity[0]) if on else 0.0), (float(blk.edge[0]) if on else 0.0)
        from surfhap.shape.edges import edge_ticks
        from surfhap.shape.gradient import I_MAX, I_MIN

        cfg = self.config
        z, face = self.surface.query_point(x, y)
        on = face >= 0 and math.isfinite(z)
        prev = self._prev
        force = 0.0
        if prev is not None:
            px, py, pz, pf = prev
            dr = math.hypot(x - px, y - py)
            if dr > 0.0:
                if on and math.isfinite(pz):
                    force = -cfg.fz * (z - pz) / dr
            elif math.isfinite(px):
                force = pf  # at rest: hold
        fsq = math.copysign(math.sqrt(abs(force)), force) if force else 0.0
        cal = self.touch_stage.calibration
        fmin, fmax = float(cal.fmin), float(cal.fmax)
        if fsq <= fmin:
            inten = I_MAX
        elif fsq >= fmax:
            inten = I_MIN
        else:
            inten = ((I_MAX - I_MIN) * fsq + I_MIN * fmin - I_MAX * fmax) / (fmin - fmax)
            inten = min(max(inten, I_MIN), I_MAX)
        tick = 0.0
        if cfg.edges and on and self._prev_face >= 0 and face != self._prev_face:
            t, _ = edge_ticks(np.array([face]), np.array([[x, y, z]]), self.touch_stage._normals,
                              self.touch_stage.theta_min, threshold_deg=cfg.edge_threshold_deg,
                              prev=(self._prev_face, self._prev_point))
            tick = float(t[0])
        self._prev = (x, y, z, force)
        self._prev_face = int(face)
        self._prev_point = np.array([x, y, z])
        return (inten if on else 0.0), (tick if on else 0.0)

    def process(self, speed, load, touch_time, x, y) -> _Block:
        n = speed.shape[0]
        m = n * self.ratio
        ld = float(load[0]) if n else 0.0
        tick = 0.0
        if n and ld > self.lift and np.isfinite(x[0]) and np.isfinite(y[0]):
            xm = float(x[0]) - self.half[0]
            ym = self.half[1] - float(y[0])
            if not self._have or xm != self._lx or ym != self._ly:
                self._intensity, tick = self.touch_point(xm, ym)
                self._have = True
                self._lx, self._ly = xm, ym
        elif self._have:
            self.reset_touch()  # a lift breaks the chain of hit points
            self._have = False
            self._intensity = 0.0
        inten = self._inten[:m]
        inten.fill(self._intensity)
        ticks = self._tick[:m]
        ticks.fill(0.0)
        if m and tick > 0.0:
            ticks[0] = tick
        loads = self._load[:m]
        loads.fill(ld)
        age = self._age[:m]
        t0 = self._n_drive / self.drive_rate - (float(touch_time[0]) if n else -1e6)
        np.add(self._ramp[:m], t0, out=age)
        drive, target = self.drive_stage.process(inten, ticks, loads, age)
        self._n_drive += m
        return _Block(drive, loads, SimpleNamespace(target=target[:1] if m else np.zeros(1)))


def load_live_shape(path, drive_rate: int, surface_size: tuple[float, float], seed: int = 0):
    """Mesh file -> (LiveShapeRenderer, title). The mesh is scaled so its larger xy side
    spans 90 % of the smaller side of the touch surface; a ``MESH.calibration.json`` next
    to it (``surfhap shape calibrate``) is used when present, else it is calibrated now."""
    from pathlib import Path

    from surfhap.exchange.shape_files import default_calibration_path, read_calibration
    from surfhap.render.shape_renderer import ShapeConfig
    from surfhap.shape.calibration import calibrate
    from surfhap.shape.topsurface import TopSurface

    size = 0.9 * min(surface_size)
    surface = TopSurface.from_file(path, size=size)
    cfg = ShapeConfig(drive_rate=int(drive_rate), seed=seed)
    cal_path = default_calibration_path(path)
    cal = read_calibration(cal_path) if Path(cal_path).is_file() else calibrate(surface, fz=cfg.fz)
    return LiveShapeRenderer(surface, cal, cfg, surface_size=surface_size), f"{surface.name} (mesh, {size * 100:.1f} cm)"


def shape_preview(surface, surface_size: tuple[float, float], width: int = 256, height: int = 160) -> dict:
    """Hill-shaded grey image of the mesh over the touch surface (page orientation)."""
    w_m, h_m = surface_size
    xs = (np.arange(width) + 0.5) / width * w_m - w_m / 2
    ys = h_m / 2 - (np.arange(height) + 0.5) / height * h_m
    gx, gy = np.meshgrid(xs, ys)
    z, _ = surface.query(np.column_stack([gx.ravel(), gy.ravel()]))
    z = z.reshape(height, width)
    off = ~np.isfinite(z)
    zf = np.where(off, np.nanmin(z) if np.any(~off) else 0.0, z)
    dzdy, dzdx = np.gradient(zf, h_m / height, w_m / width)
    # light from the upper left (page), normals of the height field
    nx, ny, nz = -dzdx, dzdy, np.ones_like(zf)
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    light = np.array([-0.5, 0.5, 0.7])
    light /= np.linalg.norm(light)
    shade = np.clip((nx * light[0] + ny * light[1] + nz * light[2]) / norm, 0, 1)
    img = 0.15 + 0.8 * shade
    img[off] = 0.08
    return {"w": width, "h": height, "data": np.round(255 * img).astype(int).ravel().tolist()}
