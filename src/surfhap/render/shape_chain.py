"""The shape chain: Kim et al.'s shape rendering (2017, Sec. 4) as a block :class:`Renderer`.

The live engine hands it, per chunk, the held finger state at ``model_rate`` (1 kHz: one
sample per 1 ms block) including the (predicted) position. The touch-rate stage (vertical
ray, eq. 3-9 gradient and intensity, eq. 10-11 edge tick: the compiled
:func:`surfhap.shape.touch.touch_step`, the same kernel the offline
:class:`~surfhap.render.shape_renderer.ShapeRenderer` loops over) runs once per *new*
position, so the gradient is taken between successive finger positions as in the paper, not
between repeated copies of one sample. The drive-rate stage
(:class:`~surfhap.render.shape_renderer.ShapeDrive`: grains, carrier, safety stage with its
watchdog) runs every chunk, on the load and touch age held by
:func:`surfhap.render.hold.hold_latest` (the texture chain's hold).

Coordinates: the page's touch surface (metres, y down, ``surface_size`` = (W, H)) is mapped
onto the mesh (metres, centred on x = y = 0, y up) as ``x_mesh = x - W/2``,
``y_mesh = H/2 - y``.
"""

from __future__ import annotations

import math

import numpy as np

from surfhap.render.block import RenderBlock
from surfhap.render.hold import hold_latest, model_times
from surfhap.render.shape_renderer import ShapeConfig, ShapeDrive, ShapeRenderer
from surfhap.shape.touch import touch_step

__all__ = ["ShapeChain"]


class ShapeChain:
    """:class:`~surfhap.render.block.Renderer` of a mesh (``TopSurface``) with its Fsq
    calibration (``ShapeCalibration``); ``model_rate`` Hz must divide the drive rate."""

    uses_position = True

    def __init__(self, surface, calibration, config: ShapeConfig | None = None, *, model_rate: int = 1000,
                 surface_size: tuple[float, float] = (0.217, 0.136), max_block: int = 1 << 14):
        cfg = config or ShapeConfig()
        if cfg.drive_rate % model_rate:
            raise ValueError("the drive rate must be a multiple of the model rate")
        self.config = cfg
        self.surface = surface
        self.calibration = calibration
        self.touch_stage = ShapeRenderer(surface, calibration, cfg)
        self.drive_stage = ShapeDrive(cfg)
        self.safety = self.drive_stage.safety
        self.drive_rate = int(cfg.drive_rate)
        self.model_rate = int(model_rate)
        self.ratio = self.drive_rate // self.model_rate
        self.half = (surface_size[0] / 2.0, surface_size[1] / 2.0)
        self.lift = cfg.limits.lift_threshold
        self._hold_tol = 1e-9 / self.model_rate
        self._fmin = float(calibration.fmin)
        self._fmax = float(calibration.fmax)
        self._edges = bool(cfg.edges) and not cfg.edge_walk
        self._theta_min = self.touch_stage.theta_min
        self._normals = surface.up_normals
        mb = int(max_block)
        self._inten = np.zeros(mb)
        self._tick = np.zeros(mb)
        self._load = np.zeros(mb)
        self._age = np.zeros(mb)
        self._index = np.zeros(mb, dtype=np.int64)
        self._src_time = np.zeros(mb)
        self._px = np.zeros(1)
        self._py = np.zeros(1)
        self._on = np.ones(1, dtype=bool)
        self.reset()

    def reset(self) -> None:
        self.reset_touch()
        self.drive_stage.reset()
        self._n_drive = 0
        self._n_model = 0
        self._last_load = 0.0
        self._last_touch = -math.inf
        self._have = False
        self._lx = self._ly = math.nan
        self._intensity = 0.0

    def reset_touch(self) -> None:
        """Break the chain of hit points (a lift)."""
        self.touch_stage.reset()
        self.state = self.touch_stage.state

    def touch_point(self, x: float, y: float) -> tuple[float, float]:
        """The touch-rate stage for one new position (mesh coordinates, m): ``(intensity,
        tick)``, both 0 off the mesh. One call of the compiled :func:`touch_step` (the
        offline renderer's kernel); ``edge_walk`` uses the offline array path."""
        if self.config.edge_walk:
            self._px[0], self._py[0] = x, y
            blk = self.touch_stage.process(self._px, self._py, self._on)
            on = blk.face[0] >= 0
            return (float(blk.intensity[0]) if on else 0.0), (float(blk.edge[0]) if on else 0.0)
        cfg = self.config
        _, face, _, _, inten, tick, _ = touch_step(
            x, y, self.state, cfg.fz, self._fmin, self._fmax, self._edges, self._theta_min, cfg.edge_threshold_deg,
            self._normals, *self.surface._args)
        if face < 0:
            return 0.0, 0.0
        return inten, tick

    def process(self, speed, load, touch_time, x=None, y=None) -> RenderBlock:
        """One block (see :class:`~surfhap.render.block.Renderer`): speed unused; load (n,) N,
        touch_time (n,) s, x, y (n,) m page coordinates; the finger state of the block's first
        sample applies (the engine holds it over the block)."""
        n = load.shape[0]
        m = n * self.ratio
        ld = float(load[0]) if n else 0.0
        tick = 0.0
        if n and ld > self.lift and x is not None and math.isfinite(x[0]) and math.isfinite(y[0]):
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
        age = self._age[:m]
        src = self._src_time[:n]
        model_times(self._n_model, float(self.model_rate), src)
        hold_latest(self._n_drive, float(self.drive_rate), src, self._hold_tol, load, touch_time, self._last_load,
                    self._last_touch, loads, age, self._index[:m])
        drive, target = self.drive_stage.process(inten, ticks, loads, age)
        self._n_drive += m
        self._n_model += n
        if n:
            self._last_load = float(load[n - 1])
            self._last_touch = float(touch_time[n - 1])
        return RenderBlock(drive, loads, target[::self.ratio])
