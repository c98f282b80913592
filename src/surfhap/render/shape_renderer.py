"""Shape rendering on an electrostatic friction display (Kim et al. 2017, Sec. 4).

Two stateful processors, one per rate:

* :class:`ShapeRenderer` (touch rate): touch points -> vertical ray hits on the mesh
  (:class:`~surfhap.shape.topsurface.TopSurface`) -> lateral force from consecutive hits
  (eq. 3-7) -> signed square root (eq. 8) -> area-grain intensity (eq. 9), and in parallel
  the edge ticks from the dihedral angle between the previous and current hit faces
  (eq. 10-11).
* :class:`ShapeDrive` (drive rate): grain synthesis (area grain at the held intensity, edge
  ticks), device curve intensity -> force, the display's force -> voltage map
  (:meth:`~surfhap.models.panel.DisplayModel.voltage_for_force`: ``V = alpha sqrt(F)``, or the
  inverse of a measured device curve) so the display adds the grain's force, polarity carrier,
  and the safety stage last.

:func:`surfhap.render.shape_chain.render_shape` runs both over a whole trajectory on the simulated display and returns a
:class:`ShapeResult` (named arrays, ``summary()``, ``plot()``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, NamedTuple

import numba
import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from surfhap.checked import checked_dataclass
from surfhap.models.panel import DisplayModel, display_block
from surfhap.render.carrier import PolarityCarrier, check_carrier
from surfhap.render.drive_kernel import target_to_voltage
from surfhap.models.device_curve import DeviceCurve
from surfhap.render.grains import GrainParams, GrainPlayer, grain_block, grain_name
from surfhap.render.hold import drive_tail, tail_state
from surfhap.render.safety import SafetyCounters, SafetyLimits, SafetyStage
from surfhap.results import Result, jsonable
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.edges import EDGE_THRESHOLD_DEG, edge_ticks_walk, walk_spacing
from surfhap.shape.gradient import FZ_DEFAULT
from surfhap.shape.topsurface import TopSurface
from surfhap.shape.touch import new_state, touch_block

__all__ = ["display_device_curve", "ShapeConfig", "ShapeBlock", "ShapeRenderer", "ShapeDrive", "ShapeResult"]


@checked_dataclass
class ShapeConfig:
    """Settings of shape rendering (SI).

    fz                 : N, assumed normal force of eq. 6-7 (1 N, Sec. 3.1.1), in (0, 20].
    grain              : area grain (area-even | area-grainy; alias edge-soft = area-even).
    edges              : play edge ticks (Sec. 4.3).
    edge_threshold_deg : convex edges with a dihedral angle up to this (0-180 deg) tick (135:
                         Fig. 10's "relatively sharp"; 180: every convex edge).
    edge_walk          : also find edges crossed *between* touch samples by walking the
                         segment (an extension; the paper compares consecutive hit faces).
    drive_rate         : Hz, DAC rate (2-48 kHz).
    carrier            : Hz, polarity carrier (0 = off, else 2-20 kHz).
    friction_rate      : Hz, rate of the simulated display's friction output (100 Hz to the drive rate).
    alpha              : V/sqrt(N); None = calibrated to the display (a given alpha scales the
                         target force by (alpha / calibrated alpha)^2 before the display's map).
    seed               : seed of the grainy grain.
    device             : intensity -> target force curve; None = the square law of the display's
                         model (intensity 1 = v_max), see :func:`display_device_curve`.
    display            : the display rendered for: its force -> voltage map (a measured device
                         curve when it has one) and the simulated panel.
    grain_params       : waveform parameters of the grains.
    """

    fz: Annotated[float, Field(gt=0, le=20)] = FZ_DEFAULT
    grain: str = "area-even"
    edges: bool = True
    edge_threshold_deg: Annotated[float, Field(gt=0, le=180)] = EDGE_THRESHOLD_DEG
    edge_walk: bool = False
    drive_rate: Annotated[int, Field(ge=2000, le=48000)] = 20000
    carrier: float = 2000.0
    friction_rate: Annotated[int, Field(ge=100)] = 2000
    alpha: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None
    seed: int = 0
    device: DeviceCurve | None = None
    grain_params: GrainParams = field(default_factory=GrainParams)
    limits: SafetyLimits = field(default_factory=SafetyLimits)
    display: DisplayModel = field(default_factory=DisplayModel)

    @field_validator("grain")
    @classmethod
    def _area_grain(cls, grain: str) -> str:
        name = grain_name(grain)
        if name == "edge-tick":
            raise ValueError("edge-tick is the edge grain; choose an area grain (area-even | area-grainy)")
        return name

    @field_validator("carrier")
    @classmethod
    def _carrier(cls, carrier: float, info: ValidationInfo) -> float:
        return check_carrier(carrier, info.data.get("drive_rate", 48000))

    @field_validator("friction_rate")
    @classmethod
    def _friction_rate(cls, rate: int, info: ValidationInfo) -> int:
        if rate > info.data.get("drive_rate", 48000):
            raise ValueError("must not exceed the drive rate")
        return rate


def display_device_curve(config: "ShapeConfig") -> DeviceCurve:
    """The default target curve: the display model's square law ``F = mu_panel k (I v_max)^2``."""
    d = config.display
    return DeviceCurve.square_law(d.mu_panel * d.k * config.limits.v_max ** 2)


class ShapeBlock(NamedTuple):
    """Touch-rate output, all (n,): z (hit height, NaN off the mesh), face (int, -1 off),
    force (N, lateral), fsq (sqrt(N)), intensity (area grain, [0.3, 1.0]), edge (tick
    intensity Ie, 0 where none), theta (deg, dihedral angle at face changes, NaN elsewhere)."""

    z: np.ndarray
    face: np.ndarray
    force: np.ndarray
    fsq: np.ndarray
    intensity: np.ndarray
    edge: np.ndarray
    theta: np.ndarray


class ShapeRenderer:
    """Touch-rate processor: ``process(x, y, touching=None) -> ShapeBlock``.

    x, y (n,) float touch positions (mesh units, m); ``touching`` (n,) bool (default all):
    samples without touch break the chain of hit points, so no force or edge spans a lift.
    """

    def __init__(self, surface: TopSurface, calibration: ShapeCalibration, config: ShapeConfig | None = None):
        self.surface = surface
        self.calibration = calibration
        self.config = config or ShapeConfig()
        self.theta_min = float(surface.theta_min) if self.config.edges else 0.0
        self._normals = surface.up_normals
        self._spacing = walk_spacing(surface) if self.config.edge_walk else 0.0
        self.reset()

    def reset(self) -> None:
        self.state = new_state()  # (x, y, z, force, face) of the previous touch sample

    def process(self, x: np.ndarray, y: np.ndarray, touching: np.ndarray | None = None) -> ShapeBlock:
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if x.shape != y.shape or x.ndim != 1:
            raise ValueError("x and y must be (n,) arrays of one length")
        if touching is not None:
            touching = np.asarray(touching, dtype=bool)
            x = np.where(touching, x, np.nan)
            y = np.where(touching, y, np.nan)
        cfg = self.config
        cal = self.calibration
        walk = cfg.edges and cfg.edge_walk
        prev = (float(self.state[0]), float(self.state[1]), int(self.state[4]))
        z, face, force, fsq, inten, edge, theta = touch_block(
            self.surface, x, y, self.state, fz=cfg.fz, fmin=float(cal.fmin), fmax=float(cal.fmax),
            edges=cfg.edges and not walk, theta_min=self.theta_min, threshold_deg=cfg.edge_threshold_deg)
        if walk and x.shape[0]:
            edge, theta = edge_ticks_walk(self.surface, x, y, face, self.theta_min, threshold_deg=cfg.edge_threshold_deg,
                                          spacing=self._spacing, prev=prev)
        return ShapeBlock(z, face, force, fsq, inten, edge, theta)


class ShapeDrive:
    """Drive-rate processor: ``process(intensity, tick, load, touch_time, display=None) -> (drive, target, load_drive,
    friction)``.

    intensity (held area intensity, 0 = silent) and tick (tick intensity at tick onsets): (m,)
    float at the drive rate; load (N) and touch_time (s, chain clock) (n,) of the model samples
    at ``control_rate``, held at the drive rate for the safety stage. Returns the drive (m,) V
    after carrier and safety stage, the grains' target added friction (m,) N and the held load
    (m,) N, and the simulated ``display``'s friction of the drive (None without one); one compiled call
    (:func:`_shape_drive`, the display included) unless a measured device curve maps the force.
    """

    def __init__(self, config: ShapeConfig | None = None, control_rate: int | None = None):
        cfg = config or ShapeConfig()
        self.config = cfg
        self.drive_rate = int(cfg.drive_rate)
        self.control_rate = self.drive_rate if control_rate is None else int(control_rate)
        self.alpha = float(cfg.alpha if cfg.alpha is not None else cfg.display.calibrated_alpha)
        self._gain = (self.alpha / cfg.display.calibrated_alpha) ** 2  # rendering gain on the target force
        self.device = cfg.device if cfg.device is not None else display_device_curve(cfg)
        self.grains = GrainPlayer(cfg.grain, self.drive_rate, self.device, seed=cfg.seed, params=cfg.grain_params)
        self.carrier = PolarityCarrier(cfg.carrier, self.drive_rate)
        self.safety = SafetyStage(self.drive_rate, cfg.limits)
        self._work = np.zeros((2, 0))
        self._index = np.zeros(0, dtype=np.int64)
        self._device_map = None if cfg.display.device_curve is None else cfg.display  # None: the compiled map
        self.reset()

    def reset(self) -> None:
        self.grains.reset()
        self.safety.reset()
        self._state = tail_state(self.control_rate, self.drive_rate, self.carrier.step)
        self._safety = self.safety.kernel_args()

    def process(self, intensity, tick, load, touch_time, display=None):
        f = np.float64
        return self.block(np.ascontiguousarray(intensity, dtype=f), np.ascontiguousarray(tick, dtype=f),
                          np.ascontiguousarray(load, dtype=f), np.ascontiguousarray(touch_time, dtype=f), display)

    def block(self, inten, tick, load, touch_time, display=None):
        """:meth:`process` on contiguous float64 arrays (the shape chain's own buffers)."""
        m, n = inten.shape[0], load.shape[0]
        if self._work.shape[1] < n + m:  # drive_tail's scratch: n model + m drive samples
            self._work, self._index = np.zeros((2, 2 * (n + m))), np.zeros(2 * (n + m), dtype=np.int64)
        drive, target, load_drive = np.empty(m), np.empty(m), np.empty(m)
        tail = (self._state, self._work, self._index, self._safety, drive, load_drive)
        if self._device_map is None:  # the compiled form of the display's map: alpha sqrt(max(F, 0))
            sim = None if display is None else display.kernel_args(m)
            k = _shape_drive(inten, tick, *self.grains.kernel_args(inten), self.alpha, load, touch_time, *tail, target, sim)
            friction = None if display is None else display.friction(k)
        else:
            grain_block(inten, tick, *self.grains.kernel_args(inten), target)
            drive[:] = self._device_map.voltage_for_force(self._gain * target, self.config.limits.v_max)
            drive_tail(m, load, touch_time, *tail)
            friction = None if display is None else display.process(drive, load_drive)
        return drive, target, load_drive, friction


@numba.njit(cache=True, nogil=True)
def _shape_drive(inten, tick, env, even, curve, pulse, ticks, alpha, load, touch_time, state, work, index, safety, drive,
                 load_drive, target, display):
    # a shape block after the touch-rate stage, in one call: grains, V = alpha sqrt(max(F, 0)), the chains' tail,
    # the simulated display (display_block's args); returns its friction samples
    grain_block(inten, tick, env, even, curve, pulse, ticks, target)
    m = target.shape[0]
    target_to_voltage(target, target, alpha, drive[:m])
    drive_tail(m, load, touch_time, state, work, index, safety, drive, load_drive)
    return display_block(drive, load_drive, display)


@dataclass
class ShapeResult(Result):
    """One shape render. Touch-rate arrays (n,): t (s, from 0), x, y (m), load (N), z (hit
    height, NaN off the mesh), face (-1 off), force (N lateral), fsq, intensity ([0.3, 1]),
    edge (tick Ie, 0 where none), theta (deg). Drive-rate arrays (m,): t_drive, drive (V,
    after safety), target (N). friction_sim (k,) N at ``friction_rate`` from the simulated
    display."""

    mesh: str
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    load: np.ndarray
    z: np.ndarray
    face: np.ndarray
    force: np.ndarray
    fsq: np.ndarray
    intensity: np.ndarray
    edge: np.ndarray
    theta: np.ndarray
    t_drive: np.ndarray
    drive: np.ndarray
    target: np.ndarray
    friction_sim: np.ndarray
    friction_rate: int
    drive_rate: int
    calibration: ShapeCalibration
    config: ShapeConfig
    theta_min: float
    safety: SafetyCounters
    trajectory_name: str = ""
    surface: TopSurface | None = None

    @property
    def on_mesh(self) -> np.ndarray:
        return self.face >= 0

    @property
    def n_ticks(self) -> int:
        return int(np.count_nonzero(self.edge > 0))

    panels = 4

    def summary(self) -> dict:
        s = self.safety
        on = self.on_mesh
        return jsonable({
            "mesh": self.mesh,
            "trajectory": self.trajectory_name,
            "samples": int(self.t.size),
            "duration_s": float(self.t[-1]) if self.t.size else 0.0,
            "on_mesh_fraction": float(on.mean()) if on.size else 0.0,
            "fsq_range": [self.calibration.fmin, self.calibration.fmax],
            "calibration_method": self.calibration.method,
            "fz_n": self.config.fz,
            "grain": self.config.grain,
            "edge_threshold_deg": self.config.edge_threshold_deg,
            "edge_walk": self.config.edge_walk,
            "theta_min_deg": self.theta_min,
            "ticks": self.n_ticks,
            "tick_intensities": [float(v) for v in self.edge[self.edge > 0]],
            "force_range_n": [float(np.min(self.force)), float(np.max(self.force))] if self.force.size else [0.0, 0.0],
            "intensity_range": [float(np.min(self.intensity)), float(np.max(self.intensity))] if self.intensity.size else [0.0, 0.0],
            "saturated_fraction": float(np.mean((self.fsq <= self.calibration.fmin) | (self.fsq >= self.calibration.fmax)))
            if self.fsq.size else 0.0,
            "drive_rate_hz": self.drive_rate,
            "carrier_hz": self.config.carrier,
            "max_abs_voltage": float(np.max(np.abs(self.drive))) if self.drive.size else 0.0,
            "safety": {"samples": s.samples, "clamped": s.clamped, "rise_limited": s.rise_limited,
                       "faults": s.faults, "lifted": s.lifted, "watchdog": s.watchdog},
        })

    def plot(self, ax=None):
        """Height along the path, lateral force, intensity and edge ticks, and a top view
        (matplotlib Figure)."""
        from surfhap.report.shape_figures import plot_shape_result

        return plot_shape_result(self, ax)
