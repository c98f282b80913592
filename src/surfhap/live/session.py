"""What ``surfhap serve`` runs: an engine with its backend and touch sources, plus what the
page shows about it (:class:`LiveSession`, :func:`build_session`; the trace frames:
:class:`FrameBuilder`)."""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.sources import TouchSpace

if TYPE_CHECKING:
    from surfhap.runtime.protocols import ForceSensor
    from surfhap.live.backends.output import Output

__all__ = ["LiveSession", "build_session", "material_preview", "load_live_shape", "shape_preview", "backend_info",
           "page_info", "FrameBuilder", "bin_rows"]

log = logging.getLogger("surfhap.live")


def material_preview(material, width: int = 256, height: int = 64, seed: int = 0) -> dict:
    """A small grey image of a material for the page: its texture synthesized along x at
    0.1 m/s (rows are successive strokes), or flat for a friction-only material.

    Returns ``{"w": width, "h": height, "data": [height * width ints 0-255, row-major]}``."""
    data = np.full((height, width), 0.5)
    tex = material.texture
    if tex is not None:
        try:
            syn = tex.synthesizer(seed=seed)
            n = width * height
            s = syn.process(np.full(n, 0.1), np.full(n, 0.5)).reshape(height, width)
            s = (s - s.mean()) / (s.std() + 1e-12)
            data = 0.5 + 0.15 * np.clip(s, -3, 3)
        except Exception:  # noqa: BLE001 - a preview is cosmetic
            log.debug("no texture preview", exc_info=True)
    return {"w": width, "h": height, "data": np.round(255 * np.clip(data, 0, 1)).astype(int).ravel().tolist()}


def load_live_shape(path, drive_rate: int, surface_size: tuple[float, float], seed: int = 0, display=None):
    """Mesh file or built-in shape name -> (:class:`~surfhap.render.shape_chain.ShapeChain`, title).
    The mesh is scaled so its larger xy side spans 90 % of the smaller side of the touch
    surface; a ``MESH.calibration.json`` next to it (``surfhap shape calibrate``) is used when
    present, else it is calibrated now.
    ``display``: the DisplayModel rendered for (None: the documented assumptions)."""
    from surfhap.exchange.shape_files import default_calibration_path, read_calibration
    from surfhap.render.shape_chain import ShapeChain
    from surfhap.render.shape_renderer import ShapeConfig
    from surfhap.shape.calibration import calibrate
    from surfhap.shape.surfaces import load_surface

    size = 0.9 * min(surface_size)
    surface = load_surface(str(path), size=size)  # a file, an image or a built-in name, as `surfhap shape`
    cfg = ShapeConfig(drive_rate=int(drive_rate), seed=seed, **({} if display is None else {"display": display}))
    cal_path = default_calibration_path(path) if Path(path).is_file() else None
    cal = read_calibration(cal_path) if cal_path is not None and cal_path.is_file() else calibrate(surface, fz=cfg.fz)
    return ShapeChain(surface, cal, cfg, surface_size=surface_size), f"{surface.name} (mesh, {size * 100:.1f} cm)"


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


def backend_info(backend) -> dict:
    """``backend.info()`` (a runtime ``Sink``), or just its name when that fails (the page only displays it)."""
    try:
        return backend.info()
    except Exception:  # noqa: BLE001
        return {"name": backend.name}


def page_info(session) -> dict:
    """The page's ``/api/info`` for ``session``: title, preview, the engine's rates (Hz),
    block period (s), the full scale of the trace's drive column (``drive_full_scale`` in
    ``drive_unit``: V for a display, N for a force-feedback device), the touch surface size (m)
    and the output's info."""
    eng = session.engine
    return {"title": session.title, "preview": session.preview, "drive_rate": eng.drive_rate,
            "control_rate": eng.control_rate, "block_period": eng.block_period,
            "drive_full_scale": eng.drive_full_scale, "drive_unit": eng.drive_unit,
            "surface_m": [session.space.width, session.space.height], "output": backend_info(session.backend),
            "ff": session.ff}


# trace columns of the engine (LiveEngine.trace): t, x, y, speed, load, drive V, target, friction
_COLUMNS = (("t", 0, 4), ("v", 5, 2), ("f", 7, 4), ("target", 6, 4), ("speed", 3, 4))  # key, column, decimals


def bin_rows(rows: np.ndarray, points: int) -> np.ndarray:
    """Trace ``rows`` (``(n, c) float``, c >= 8, see ``LiveEngine.trace``) binned to at most
    ``points`` rows (each bin: its last row, with the bin's peak drive voltage), NaN and
    infinities as 0: ``(m, c) float``, m <= points."""
    if rows.shape[0] > points:
        edges = np.linspace(0, rows.shape[0], points + 1).astype(int)
        keep = rows[edges[1:] - 1].copy()
        keep[:, 5] = np.maximum.reduceat(rows[:, 5], edges[:-1])
        rows = keep
    return np.nan_to_num(rows, nan=0.0, posinf=0.0, neginf=0.0)


class FrameBuilder:
    """Engine side of the trace stream, what the page plots (at ``trace_hz``): the rows an engine
    wrote since the last :meth:`frame`, and its status, as plain JSON-able values sent
    in-process (:class:`surfhap.web.link.LocalLink`) or over a pipe to the web process
    (:mod:`surfhap.web.process`)."""

    def __init__(self, engine, backend, points: int = 64):
        self.engine, self.backend, self.points = engine, backend, int(points)
        self._idx = 0

    def frame(self) -> dict:
        """The next frame: the trace rows since the last call (at most half the trace ring),
        :func:`bin_rows` and rounded: ``{"t": s, "v": V, "f": N, "target": N, "speed": m/s}``,
        lists of equal length. An engine whose ``frame_extra`` is a method (the force-feedback
        view, :class:`surfhap.web.ff.FFWebEngine`; the texture engine's is None) adds its part
        of the same binned rows under ``"ff"``."""
        eng = self.engine
        rows, self._idx = eng.trace_since(self._idx, limit=eng.trace.shape[0] // 2)
        r = bin_rows(rows, self.points)
        frame = {key: np.round(r[:, col], dec).tolist() for key, col, dec in _COLUMNS}
        if eng.frame_extra is not None:
            frame["ff"] = eng.frame_extra(r)
        return frame

    def status(self) -> dict:
        """``engine.status()`` with the output backend's info under ``"output"``."""
        st = self.engine.status()
        st["output"] = backend_info(self.backend)
        return st


@dataclass(eq=False)
class LiveSession:
    """An engine with its backend and touch sources, plus what the page shows.

    positions : "physical" maps page positions to metres through CSS pixels (a material: the
                finger speed is real); "surface" maps the page onto the whole touch surface (a
                mesh: the shaded preview and the felt shape line up).
    ff        : the force-feedback panel's description (:func:`surfhap.web.ff.ff_page_info`),
                None for a texture or shape session.
    sensors   : force sensors the session closes when it stops.
    """

    engine: Any
    backend: Any
    title: str = ""
    preview: dict = field(default_factory=lambda: {"w": 1, "h": 1, "data": [128]})
    space: TouchSpace = field(default_factory=TouchSpace)
    sources: list = field(default_factory=list)
    positions: str = "physical"
    ff: dict | None = None
    sensors: list = field(default_factory=list)
    started: bool = field(default=False, init=False)

    def start(self) -> None:
        # The engine thread competes for the GIL with the web server: a short switch
        # interval (process-wide; restored on stop) bounds how long it can wait.
        self._switch = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch, 0.0002))
        self.engine.warm_up()
        self.backend.start(self.engine)
        for s in self.sources:
            s.start()
        self.started = True

    def run_simulated(self, trajectory, clock) -> int:
        """Render ``trajectory`` through the engine into the backend on the simulated
        ``clock`` (the engine's clock, starting at 0), as fast as possible: its samples arrive
        at their stamps, the run lasts the trajectory's model samples, then the stop ramp.
        Needs a backend driven block by block (sim, file, OSC); returns the frames emitted."""
        from surfhap.live.backends.base import PacedBackend
        from surfhap.runtime.loop import run
        from surfhap.runtime.sources import TrajectorySource, drive_frames, model_samples

        if not isinstance(self.backend, PacedBackend) or self.backend.paced_by_device:
            raise ConfigError("a simulated clock needs an output without its own clock (sim, file:, osc://)",
                              source="--clock")
        eng = self.engine
        eng.reset()
        source = TrajectorySource(eng, trajectory)
        self.backend.open(eng)
        try:
            total = drive_frames(model_samples(trajectory, eng.control_rate), eng.control_rate, eng.drive_rate)
            n = run(source, eng, clock, self.backend, total_frames=total)
            eng.request_stop()  # the end: the same stop ramp as a live output
            ramp = int(eng.config.stop_ramp * eng.drive_rate) + 4 * eng.block_frames
            n += run(source, eng, clock, self.backend, total_frames=ramp, keep_running=lambda: not eng.stopped)
        finally:
            self.backend.close()
        self.replay_sent = source.sent
        return n

    def stop(self) -> None:
        # the backend first: its stop ramp runs on the live signal (a source's final lift
        # would cut it short), then the sources
        if self.started:
            self.backend.stop()
            sys.setswitchinterval(self._switch)
        for s in self.sources:
            s.stop()
        for sensor in self.sensors:
            sensor.close()
        self.started = False


def _closed_loop(sensor: str | ForceSensor, chain, display):
    """The display of a session whose texture ``chain`` closes its loop over ``sensor``: a
    :class:`~surfhap.runtime.protocols.ForceSensor` on the rig (the display is the rig's), or
    "sim", a simulated sensor on the simulated display, whose k drifts."""
    if chain is None:
        raise ConfigError("closes a material's friction loop, not a mesh's (--mesh)", source="--sensor")
    from surfhap.runtime.closed_loop import SensorLoop

    if not isinstance(sensor, str):
        SensorLoop(chain, sensor)
        return display
    if sensor != "sim":
        raise ConfigError(f"unknown sensor {sensor!r} (choose: sim, netft://HOST[:PORT])", source="--sensor")
    if display is None:
        raise ConfigError("'sim' needs the simulated display", source="--sensor")
    from surfhap.sim.closed_loop import Drift, SensedDisplay, SimForceSensor

    probe = SimForceSensor()
    SensorLoop(chain, probe)
    return SensedDisplay(display, Drift(), probe)


def build_session(material: str = "cork", output: Output | None = None, *, drive_rate: int | None = None,
                  engine_config=None, amp_gain: float = 250.0, space: TouchSpace | None = None,
                  osc_in: tuple[str, int] | None = None, replay=None, replay_loop: bool = False,
                  seed: int = 0, channels: tuple[int, ...] | None = None, max_seconds: float | None = None,
                  mesh=None, display=None, clock=None, sensor: str | ForceSensor | None = None) -> LiveSession:
    """Everything ``surfhap serve`` runs: material (or ``mesh`` file) -> renderer -> engine
    -> backend (``output``, a typed output spec; default the simulated display), plus optional
    OSC touch input ``(host, port)`` and a replayed trajectory.
    ``amp_gain``, ``channels``, ``max_seconds``: the output's options
    (:class:`~surfhap.live.backends.output.OutputOptions`). ``clock``: the engine's
    :class:`~surfhap.runtime.clock.Clock` (default: wall time). ``sensor``: a force sensor on
    the rig closes the friction loop (:mod:`surfhap.runtime.closed_loop`) and is closed with the
    session; "sim" closes it over a simulated sensor measuring the simulated display, whose k
    drifts (:mod:`surfhap.sim.closed_loop`)."""
    from surfhap.exchange.materials import load_material
    from surfhap.live.backends.output import OutputOptions, SimOutput, open_backend
    from surfhap.live.engine import LiveEngine
    from surfhap.live.engine_config import EngineConfig
    from surfhap.live.sources import OscTouchSource
    from surfhap.render.chain import ChainConfig, TextureChain
    from surfhap.models.panel import SimulatedDisplay

    output = output if output is not None else SimOutput()
    rate = int(drive_rate or output.default_drive_rate)
    space = space or TouchSpace()
    cfg = engine_config or EngineConfig()
    if mesh is not None:
        chain, title = load_live_shape(mesh, rate, (space.width, space.height), seed=seed, display=display)
        preview = shape_preview(chain.surface, (space.width, space.height))
        display_model = chain.config.display
    else:
        mat = load_material(material)
        chain = TextureChain(mat, ChainConfig(drive_rate=rate, seed=seed, **({} if display is None else {"display": display})))
        title, preview, display_model = f"{mat.name} ({chain.method})", material_preview(mat), chain.config.display
    display = SimulatedDisplay(display_model, chain.drive_rate, chain.control_rate) if cfg.simulate_display else None
    if sensor is not None:
        display = _closed_loop(sensor, chain if mesh is None else None, display)
    engine = LiveEngine(chain, cfg, display=display, clock=None if clock is None else clock.now)
    backend = open_backend(output, OutputOptions(amp_gain, channels, max_seconds))
    sources = []
    if osc_in is not None:
        sources.append(OscTouchSource(engine, osc_in[0], osc_in[1], space=space))
    if replay is not None:
        from surfhap.runtime.sources import TrajectorySource

        sources.append(TrajectorySource(engine, replay, loop=replay_loop, wall_clock=True))
    return LiveSession(engine, backend, title=title, preview=preview, space=space, sources=sources,
                       positions="surface" if mesh is not None else "physical",
                       sensors=[] if sensor is None or isinstance(sensor, str) else [sensor])
