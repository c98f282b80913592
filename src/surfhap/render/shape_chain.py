"""The shape chain: Kim et al.'s shape rendering (2017, Sec. 4) as a block :class:`Renderer`.

The runtime hands it, per chunk, the held finger state at ``control_rate`` (live 1 kHz: one
sample per 1 ms block; :func:`render_shape` runs it at the drive
rate) including the (predicted) position. The touch-rate stage (vertical
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

from typing import Callable

from surfhap.models.panel import SimulatedDisplay
from surfhap.models.trajectory import Trajectory
from surfhap.render.block import RenderBlock
from surfhap.render.hold import TouchHold, TrajectoryRows
from surfhap.render.kinematics import TouchPredictor
from surfhap.render.shape_renderer import ShapeBlock, ShapeConfig, ShapeDrive, ShapeRenderer, ShapeResult
from surfhap.shape.calibration import ShapeCalibration, calibrate
from surfhap.shape.topsurface import TopSurface
from surfhap.shape.touch import touch_step

__all__ = ["ShapeChain", "render_shape"]


class ShapeChain:
    """:class:`~surfhap.render.block.Renderer` of a mesh (``TopSurface``) with its Fsq
    calibration (``ShapeCalibration``); ``control_rate`` Hz must divide the drive rate."""

    uses_position = True

    def __init__(self, surface, calibration, config: ShapeConfig | None = None, *, control_rate: int = 1000,
                 surface_size: tuple[float, float] = (0.217, 0.136), max_block: int = 1 << 14):
        cfg = config or ShapeConfig()
        if cfg.drive_rate % control_rate:
            raise ValueError("the drive rate must be a multiple of the control rate")
        self.config = cfg
        self.surface = surface
        self.calibration = calibration
        self.touch_stage = ShapeRenderer(surface, calibration, cfg)
        self.drive_stage = ShapeDrive(cfg, control_rate)
        self.safety = self.drive_stage.safety
        self.drive_rate = int(cfg.drive_rate)
        self.control_rate = int(control_rate)
        self.ratio = self.drive_rate // self.control_rate
        self.half = (surface_size[0] / 2.0, surface_size[1] / 2.0)
        self.lift = cfg.limits.lift_threshold
        self._fmin = float(calibration.fmin)
        self._fmax = float(calibration.fmax)
        self._edges = bool(cfg.edges) and not cfg.edge_walk
        self._theta_min = self.touch_stage.theta_min
        self._normals = surface.up_normals
        mb = int(max_block)
        self._inten = np.zeros(mb)
        self._tick = np.zeros(mb)
        self._px = np.zeros(1)
        self._py = np.zeros(1)
        self._on = np.ones(1, dtype=bool)
        self.reset()

    def reset(self) -> None:
        self.reset_touch()
        self.drive_stage.reset()
        self._have = False
        self._lx = self._ly = math.nan
        self._intensity = 0.0

    def reset_touch(self) -> None:
        """Break the chain of hit points (a lift)."""
        self.touch_stage.reset()
        self.state = self.touch_stage.state

    def _state_at(self, ld: float, x, y, i: int) -> float:
        """Take the finger state of model sample ``i``; returns the edge tick it starts (0 if none)."""
        if ld > self.lift and x is not None and math.isfinite(x[i]) and math.isfinite(y[i]):
            xm = float(x[i]) - self.half[0]
            ym = self.half[1] - float(y[i])
            if not self._have or xm != self._lx or ym != self._ly:
                self._intensity, tick = self.touch_point(xm, ym)
                self._have = True
                self._lx, self._ly = xm, ym
                return tick
        elif self._have:
            self.reset_touch()  # a lift breaks the chain of hit points
            self._have = False
            self._intensity = 0.0
        return 0.0

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

    def process(self, speed, load, touch_time, x=None, y=None, display: SimulatedDisplay | None = None) -> RenderBlock:
        """One block (see :class:`~surfhap.runtime.protocols.Renderer`): speed unused; load (n,)
        N, touch_time (n,) s, x, y (n,) m page coordinates. Each model sample holds the finger
        state in force at it; a new position runs the touch-rate stage once and its tick starts
        at the model sample's first drive sample. ``display``: see
        :meth:`~surfhap.runtime.protocols.Renderer.process`."""
        n = load.shape[0]
        r = self.ratio
        inten = self._inten[:n * r]
        ticks = self._tick[:n * r]
        ticks.fill(0.0)
        if n == 1:  # a live chunk: one finger state
            tick = self._state_at(float(load[0]), x, y, 0)
            inten.fill(self._intensity)
            ticks[0] = tick if tick > 0.0 else 0.0
        else:
            starts = [0]  # the runs of model samples holding one finger state
            if n > 1:
                change = load[1:] != load[:-1]
                if x is not None:
                    change |= (x[1:] != x[:-1]) | (y[1:] != y[:-1])
                starts += (np.flatnonzero(change) + 1).tolist()
            starts.append(n)
            for i, j in zip(starts[:-1], starts[1:]):
                if i >= n:
                    break
                tick = self._state_at(float(load[i]), x, y, i)
                inten[i * r:j * r] = self._intensity
                if tick > 0.0:
                    ticks[i * r] = tick
        drive, target, loads, friction = self.drive_stage.block(inten, ticks, np.ascontiguousarray(load, dtype=np.float64),
                                                                np.ascontiguousarray(touch_time, dtype=np.float64), display)
        return RenderBlock(drive, loads, target[::self.ratio], None, friction)


def render_shape(surface: TopSurface, trajectory: Trajectory, calibration: ShapeCalibration | None = None,
                 config: ShapeConfig | None = None, *, block_seconds: float = 1.0,
                 progress: Callable[[float], None] | None = None) -> ShapeResult:
    """Render ``trajectory`` over ``surface`` on the simulated display.

    Without ``calibration`` the Fsq range is measured by simulated scans first
    (:func:`surfhap.shape.calibration.calibrate`, default plan).
    """
    cfg = config or ShapeConfig()
    cal = calibration if calibration is not None else calibrate(surface, fz=cfg.fz)
    renderer = ShapeRenderer(surface, cal, cfg)
    display = SimulatedDisplay(cfg.display, cfg.drive_rate, cfg.friction_rate, v_max=cfg.limits.v_max)
    t = trajectory.t - trajectory.t[0]
    touching = trajectory.load > cfg.limits.lift_threshold
    # the touch-rate quantities of the result (z, face, Fsq, intensity, edge), in blocks
    n = t.size
    blk = max(1, int(round(block_seconds * trajectory.sensor_rate)))
    parts = [renderer.process(trajectory.x[s:s + blk], trajectory.y[s:s + blk], touching[s:s + blk])
             for s in range(0, n, blk)]
    out = ShapeBlock(*(np.concatenate([getattr(p, f) for p in parts]) for f in ShapeBlock._fields))
    # the drive: the live ShapeChain at the drive rate, each touch sample in force from the drive
    # sample at its stamp (the runtime's TouchHold); the trajectory is in mesh coordinates
    # (a zero page size maps x -> x, and the page's downward y -> -y)
    fs = cfg.drive_rate
    chain = ShapeChain(surface, cal, cfg, control_rate=fs, surface_size=(0.0, 0.0))
    mirrored = Trajectory(trajectory.t, trajectory.x, -trajectory.y, trajectory.load, name=trajectory.name)
    hold = TouchHold(TrajectoryRows(mirrored), TouchPredictor(), 0.05)
    hold.take(0.0, 0.0)
    m = int(np.floor(t[-1] * fs + 1e-9)) + int(round(0.05 * fs))  # 50 ms tail for the last grain
    block_d = min(8192, max(1, int(round(block_seconds * fs))))
    drives, targets, frictions = [], [], []
    for s in range(0, m, block_d):
        k = min(m, s + block_d) - s
        inputs = np.empty((5, k))
        hold.fill(s, fs, inputs)
        speed, load, touch_time, xs, ys = inputs
        b = chain.process(speed, load, touch_time, xs, ys, display)
        drives.append(b.drive)
        targets.append(b.target)
        frictions.append(b.friction)
        if progress is not None:
            progress((s + k) / m)
    drive_proc = chain.drive_stage
    t_drive = np.arange(m) / fs
    drive = np.concatenate(drives) if drives else np.zeros(0)
    return ShapeResult(
        mesh=surface.name, t=t, x=trajectory.x.copy(), y=trajectory.y.copy(), load=trajectory.load.copy(),
        z=out.z, face=out.face, force=out.force, fsq=out.fsq, intensity=out.intensity, edge=out.edge,
        theta=out.theta, t_drive=t_drive, drive=drive, target=np.concatenate(targets) if targets else np.zeros(0),
        friction_sim=np.concatenate(frictions) if frictions else np.zeros(0), friction_rate=int(cfg.friction_rate),
        drive_rate=int(fs), calibration=cal, config=cfg, theta_min=renderer.theta_min,
        safety=drive_proc.safety.counters, trajectory_name=trajectory.name, surface=surface,
    )
