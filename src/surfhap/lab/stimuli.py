"""Study stimuli played live: material textures, Zhao's square-wave baseline, Kim et al.'s 1-D
formative profiles (IP0.5 / IP0.7) and 3-D shapes and scenes, each behind the safety stage
with the session's limit; and the scene pictures of the visual tasks.

Render specs (the ``render`` of a :class:`~surfhap.lab.schema.Stimulus`)::

    {"material": name, "method": law, ["square_frequency": Hz, "square_amplitude": V]}
    {"profile1d": "bump" | "hole" | "flat", "mapping": "IP0.5" | "IP0.7", "grain": grain}
    {"scene": name, "haptic": bool} | {"mesh": built-in name or file, "grain": grain}
    {"real": name}                               (nothing to drive: the output is muted)
    {"effect": "follow" | "reverse" | "static"}  (force feedback, 004: :class:`FFStimulusPlayer`)

A session's ``stimulus_limit_s`` ends each stimulus that long after its first touch (004: 3.5 s):
the output is muted and the finger's samples are dropped until the next stimulus is selected.
"""

from __future__ import annotations

import json
import math

import numpy as np

from surfhap.runtime.commands import SetGain, SwapRenderer

__all__ = ["StimulusPlayer", "FFStimulusPlayer", "FFStudySession", "FF_EFFECTS", "make_profile_renderer",
           "scene_picture"]

CSS_PX_M = 0.0254 / 96.0  # one CSS pixel in metres


def make_profile_renderer(shape: str, mapping: str, surface, calibration, config, surface_size):
    """A live renderer of one of Kim et al.'s formative profiles (the class is built here: it
    derives from the live package's shape renderer, imported on first use)."""
    from surfhap.render.shape_chain import ShapeChain

    class ProfileRenderer(ShapeChain):
        """Kim et al.'s formative stimuli (Sec. 3.1): a 5 cm track across the middle of the
        touch surface, scanned left to right; the intensity at position x is the IP mapping
        of the lateral force of the 1-D Gaussian profile (:mod:`surfhap.shape.profiles`),
        played through the grain and device curve of the shape renderer. A flat surface has
        zero force: a constant intensity (the mapping's offset). Off the track: nothing."""

        def __init__(self, shape: str, mapping: str, surface, calibration, config, surface_size):
            from surfhap.shape.profiles import OFFSETS

            if shape not in ("bump", "hole", "flat"):
                raise ValueError(f"unknown profile shape {shape!r} (bump | hole | flat)")
            if mapping not in OFFSETS:
                raise ValueError(f"unknown mapping {mapping!r} ({' | '.join(OFFSETS)})")
            self.shape = shape
            self.offset = OFFSETS[mapping]
            super().__init__(surface, calibration, config, surface_size=surface_size)

        def touch_point(self, x: float, y: float) -> tuple[float, float]:
            from surfhap.shape.profiles import TRACK_LENGTH, ip_intensity, profile_force

            if not math.isfinite(x) or abs(x) > TRACK_LENGTH / 2:
                return 0.0, 0.0
            f = 0.0 if self.shape == "flat" else float(profile_force(np.array([x]), hole=self.shape == "hole")[0])
            return float(ip_intensity(np.array([f]), self.offset)[0]), 0.0

    return ProfileRenderer(shape, mapping, surface, calibration, config, surface_size)


class _TimedPlayer:
    """The stimulus time limit (``limit_s`` after the first touch of a selected stimulus), the
    one check both players make on every touch sample."""

    limit_s: float | None = None

    def _arm(self) -> None:
        self._first = None
        self._over = False

    def _within(self, t: float) -> bool:
        """False once the selected stimulus has played its ``limit_s`` (then muted once)."""
        if self.limit_s is None:
            return True
        if self._first is None:
            self._first = t
        if not self._over and t - self._first > self.limit_s:
            self._over = True
            self.mute()
        return not self._over


class StimulusPlayer(_TimedPlayer):
    """Plays a trial's stimuli through a live session (engine + backend).

    ``session``: a started :class:`surfhap.live.session.LiveSession`; ``gain``: multiplier of
    the calibrated drive gain alpha; ``v_max``: the session's safety limit (V); ``display``: the
    DisplayModel rendered for (None: the documented assumptions); ``limit_s``: the session's
    stimulus time limit (s from the first touch, None: none)."""

    def __init__(self, session, *, gain: float = 1.0, v_max: float = 250.0, seed: int = 0, display=None,
                 limit_s: float | None = None):
        from surfhap.models.panel import DisplayModel

        self.display = display or DisplayModel()  # the panel rendered for (study run --display)
        self.session = session
        self.limit_s = limit_s
        self._arm()
        self.gain = float(gain)
        self.v_max = float(v_max)
        self.seed = int(seed)
        self.positions = "physical"
        self.current = None
        self._cache: dict[str, object] = {}

    def _build(self, render: dict):
        from surfhap.render.safety import SafetyLimits

        eng = self.session.engine
        rate = int(eng.drive_rate)
        limits = SafetyLimits(v_max=self.v_max)
        if "material" in render:
            from surfhap.exchange.materials import load_material
            from surfhap.render.chain import ChainConfig, TextureChain

            kw = {key: float(render[key]) for key in ("square_frequency", "square_amplitude") if key in render}
            mat = load_material(str(render["material"]))
            cfg = ChainConfig(method=str(render.get("method", "auto")), drive_rate=rate, seed=self.seed,
                              limits=limits, display=self.display, **kw)
            chain = TextureChain(mat, cfg)  # the law's own alpha (calibrated; Zhao's load scaling)
            if self.gain != 1.0:
                from dataclasses import replace

                chain = TextureChain(mat, replace(cfg, alpha=self.gain * chain.params.alpha))
            return chain, "physical"
        if "profile1d" in render:
            return self._shape_chain(None, rate, limits, str(render.get("grain", "area-even")),
                                     (str(render["profile1d"]), str(render.get("mapping", "IP0.5")))), "surface"
        name = render.get("scene") or render.get("mesh")
        if name and name != "flat" and render.get("haptic", True):
            return self._shape_chain(str(name), rate, limits, str(render.get("grain", "area-even"))), "surface"
        return None, "physical"  # real sample, visual only, flat, force-feedback effect: nothing to drive

    def _shape_chain(self, name: str | None, rate: int, limits, grain: str, profile: tuple[str, str] | None = None):
        """A built-in shape or scene (in its physical size, centred on the touch surface), a
        mesh file (scaled as by 'surfhap serve --mesh'), or with ``profile`` (shape, mapping)
        one of Kim et al.'s 1-D profiles (on the Gaussian bump's geometry, without edges)."""
        from surfhap.render.shape_chain import ShapeChain
        from surfhap.render.shape_renderer import ShapeConfig
        from surfhap.shape.calibration import calibrate
        from surfhap.shape.scenes import builtin_shape
        from surfhap.shape.topsurface import TopSurface

        sp = self.session.space
        surface = builtin_shape("gaussian-bump" if profile else name)
        if surface is None:
            surface = TopSurface.from_file(name, size=0.9 * min(sp.width, sp.height))
        cfg = ShapeConfig(drive_rate=rate, seed=self.seed, grain=grain, limits=limits, edges=profile is None,
                          display=self.display, alpha=self.gain * self.display.calibrated_alpha)
        cal, size = calibrate(surface, fz=cfg.fz), (sp.width, sp.height)
        if profile:
            return make_profile_renderer(*profile, surface, cal, cfg, size)
        return ShapeChain(surface, cal, cfg, surface_size=size)

    def _get(self, render: dict):
        key = json.dumps(render, sort_keys=True)
        if key not in self._cache:
            self._cache[key] = self._build(render)
        return key, self._cache[key]

    def prepare(self, renders) -> int:
        """Build every stimulus of ``renders`` and run each renderer once through the engine
        (:meth:`~surfhap.live.engine.LiveEngine.warm_up`), BEFORE the session starts: built
        or first run under the running engine, a scene's renderer held the GIL past the
        output's stall limit and the engine halted at 0 V for the rest of the session.
        Afterwards a stimulus switch is one :class:`SwapRenderer`. Returns the renderers built."""
        eng = self.session.engine
        chains = {id(c): c for c in (self._get(r)[1][0] for r in renders) if c is not None}
        for chain in [*chains.values(), eng.renderer]:  # the session's own renderer last
            eng.send(SwapRenderer(chain))
            eng.warm_up()
        return len(chains)

    def select(self, render: dict) -> str:
        """Play ``render`` from now on; returns what is played ("muted" or a description)."""
        self._arm()
        key, (chain, positions) = self._get(render)
        eng = self.session.engine
        if chain is None:
            eng.send(SetGain(0.0))
            self.current = None
            return "muted"
        if chain is not self.current:  # the engine resets it when it takes it (its own thread)
            eng.send(SwapRenderer(chain))
            self.current = chain
        self.positions = positions
        eng.send(SetGain(1.0))
        return key

    def mute(self) -> None:
        self.session.engine.send(SetGain(0.0))
        self.current = None

    def touch(self, client: int, x: float, y: float, p: float, t_ms: float, w_px: float, h_px: float) -> None:
        if not self._within(t_ms * 1e-3):
            return self.lift(client, t_ms)
        sp = self.session.space
        load = (p if p > 0 else 0.5) * sp.max_load
        if self.positions == "surface":
            xm, ym = x * sp.width, y * sp.height
        else:
            xm, ym = x * w_px * CSS_PX_M, y * h_px * CSS_PX_M
        self.session.engine.push_touch(client, xm, ym, load, t_event=t_ms * 1e-3)

    def lift(self, client: int, t_ms: float) -> None:
        self.session.engine.push_touch(client, 0.0, 0.0, 0.0, t_event=t_ms * 1e-3)


#: the force-feedback stimuli of 004 Sec. 5.2: built-in ff scene of each (None: STATIC, the
#: tablet held at X0 by the centring of eq. 5, no effect)
FF_EFFECTS = {"follow": "follow", "reverse": "reverse", "static": None}


class FFStudySession:
    """The force-feedback loop of a study (:class:`surfhap.live.ff_loop.FFLoop`, the one of
    ``ff run`` / ``ff simulate``) on the simulated device (:mod:`surfhap.sim.ff_device`) or on
    ``backend`` (a device of :mod:`surfhap.live.ff_devices` / :mod:`surfhap.live.ff_haply`):
    ``start`` / ``stop`` it; ``space``
    is the content rectangle of the 004 scenes (the page's pad spans it). With ``simulated``
    the loop runs on a :class:`~surfhap.runtime.clock.SimClock`, advanced only by
    :meth:`FFStimulusPlayer.explore` (a simulated participant), else on its wall-clock thread."""

    def __init__(self, simulated: bool = False, backend=None):
        from surfhap.ff.engine import FFEngine
        from surfhap.ff.params import SMOOTHING, TOUCH_LATENCY, VELOCITY_ALPHA, DeviceParams
        from surfhap.ff.scene import load_scene
        from surfhap.live.ff_devices import SimDeviceBackend
        from surfhap.live.ff_loop import FFLoop
        from surfhap.live.sources import TouchSpace
        from surfhap.render.kinematics import TouchPredictor
        from surfhap.runtime.clock import SimClock
        from surfhap.sim.ff_device import SimDevice

        self.device = DeviceParams()
        self.effects = {name: [] if sc is None else load_scene(sc, self.device).effects for name, sc in FF_EFFECTS.items()}
        w, h = load_scene("follow", self.device).size
        self.space = TouchSpace(width=w, height=h, max_load=2.0)
        self.engine = FFEngine([], self.device, TouchPredictor(latency=TOUCH_LATENCY, alpha=SMOOTHING,
                                                               velocity_alpha=VELOCITY_ALPHA), touch_latency=TOUCH_LATENCY)
        # another device (:mod:`surfhap.live.ff_devices`, e.g. a Haply Inverse3) only on the wall clock
        self.backend = backend if backend is not None else SimDeviceBackend(SimDevice(gain=self.device.gain),
                                                                          self.device.gain)
        self.simulated = simulated
        self.loop = FFLoop(self.engine, self.backend, clock=SimClock() if simulated else None, realtime=not simulated)

    def start(self) -> None:
        if not self.simulated:
            return self.loop.start()
        self.engine.reset()
        self.backend.start()

    def stop(self) -> None:
        """The safety stage ramps the force to zero and puts the tablet down."""
        if not self.simulated:
            return self.loop.stop()
        from surfhap.runtime.loop import run

        clock = self.loop.clock
        clock.wait_until(clock.now() + self.loop.period)  # run() starts at now: the tick after the last
        self.loop.request_stop()
        run(None, self.loop, clock, self.loop, keep_running=self.loop.running, lead=0.0)


class FFStimulusPlayer(_TimedPlayer):
    """Plays ``{"effect": name}`` stimuli (:data:`FF_EFFECTS`) on the force-feedback loop of
    ``session`` (:class:`FFStudySession`): selecting one switches the engine's effects from the
    next haptic tick, the loop and its safety stage running on; anything else holds the tablet
    still. Pad positions (0-1) span the scene's content rectangle. ``force_log``: with a
    simulated session, one record per explored stimulus (:meth:`explore`)."""

    def __init__(self, session: FFStudySession, *, limit_s: float | None = None):
        self.session = session
        self.limit_s = limit_s
        self.force_log: list[dict] = []
        self.current: str | None = None
        self._arm()

    def select(self, render: dict) -> str:
        name = render.get("effect")
        if name not in FF_EFFECTS:
            self.mute()
            return "muted"
        self.session.engine.switch(self.session.effects[name])
        self.current = name
        self._arm()
        return f"effect {name}"

    def mute(self) -> None:
        self.session.engine.switch([])
        self.current = None

    def _push(self, client: int, x: float, y: float, load: float, t: float, t_arrival: float | None = None) -> None:
        if load > 0.0 and not self._within(t):
            load = 0.0
        self.session.loop.push_touch(client, x, y, load, t_event=t, t_arrival=t_arrival)

    def touch(self, client: int, x: float, y: float, p: float, t_ms: float, w_px: float, h_px: float) -> None:
        sp = self.session.space
        self._push(client, x * sp.width, y * sp.height, (p if p > 0 else 0.5) * sp.max_load, t_ms * 1e-3)

    def lift(self, client: int, t_ms: float) -> None:
        self.session.loop.push_touch(client, 0.0, 0.0, 0.0, t_event=t_ms * 1e-3)

    def explore(self, duration: float, label: str = "") -> dict:
        """A simulated finger strokes the middle of the content back and forth at 0.5 Hz, +-3 cm,
        1 N (the study's pace, 004 Sec. 5.2) for ``duration`` s, then lifts; the loop runs on its
        simulated clock through :func:`surfhap.runtime.loop.run`. Appends to ``force_log`` and
        returns ``{"label", "effect", "t", "force" (n, 3) N, "screen" (n, 3) m, "finger_v" (n,)
        m/s, "mask" (n,)}``, one row per tick."""
        from surfhap.models.trajectory import Trajectory
        from surfhap.runtime.loop import run
        from surfhap.ff.params import TOUCH_LATENCY
        from surfhap.sim.ff_device import SimFinger

        ses = self.session
        loop, rate = ses.loop, ses.loop.rate
        loop.clock.wait_until(loop.clock.now() + 1.0 / rate)  # run() starts at now: the tick after the last
        t0 = loop.clock.now() + 0.1
        t = np.arange(0.0, duration, 1.0 / rate)
        sp = ses.space
        finger = SimFinger(Trajectory(t0 + t, sp.width / 2 + 0.03 * np.sin(np.pi * t), np.full(t.size, sp.height / 2),
                                      np.ones(t.size), name="0.5 Hz strokes"), latency=TOUCH_LATENCY)
        rec = _Explore(self, finger, int(round((duration + 0.4) * rate)))
        effect = self.current  # muted at the time limit
        run(rec, loop, loop.clock, rec, total_frames=rec.n, lead=0.0)
        out = {"label": label, "effect": effect, **rec.cols}
        self.force_log.append(out)
        return out


class _Explore:
    """The simulated finger's touch reports (through the player's time limit) and the per-tick
    force log of :meth:`FFStimulusPlayer.explore`."""

    def __init__(self, player: FFStimulusPlayer, finger, n: int):
        self.player, self.finger, self.n, self.k = player, finger, n, 0
        self.cols = {"t": np.zeros(n), "force": np.zeros((n, 3)), "screen": np.zeros((n, 3)),
                     "finger_v": np.zeros(n), "mask": np.zeros(n, dtype=np.int64)}

    def deliver(self, until: float) -> None:
        dev = self.player.session.backend.device
        self.finger.record_screen(until, dev.p)
        for tr, x, y, load, ts in self.finger.touches(until):
            self.player._push(0, x, y, load, ts, t_arrival=tr)

    def emit(self, force: np.ndarray) -> None:
        loop, c, k = self.player.session.loop, self.cols, self.k
        loop.emit(force)
        c["t"][k], c["force"][k], c["screen"][k] = loop._t, force, self.player.session.backend.device.p
        c["finger_v"][k], c["mask"][k] = self.finger.velocity(loop._t)[0], loop.engine.mask
        self.k += 1


def scene_picture(name: str, surface_size: tuple[float, float], width: int = 640) -> bytes:
    """PNG of a built-in scene or shape seen from the top (orthographic, Lambert shading under
    the scene's light, Kim et al. Sec. 5.1.1), drawn over the whole touch surface so that the
    picture and the felt shape line up on the pad (the shape centred, in its physical size)."""
    import io

    from matplotlib.image import imsave

    from surfhap.shape.scenes import builtin_shape, get_scene

    surface = builtin_shape(name)
    if surface is None:
        raise ValueError(f"{name!r} is not a built-in shape or scene")
    try:
        light = get_scene(name).light_direction
    except ValueError:
        light = np.array([0.0, 0.0, 1.0])
    w_m, h_m = surface_size
    height = max(2, int(round(width * h_m / w_m)))
    xs = (np.arange(width) + 0.5) / width * w_m - w_m / 2
    ys = h_m / 2 - (np.arange(height) + 0.5) / height * h_m
    gx, gy = np.meshgrid(xs, ys)
    z, face, normal = surface.query_normals(np.column_stack([gx.ravel(), gy.ravel()]))
    shade = np.clip(normal @ (light / np.linalg.norm(light)), 0.0, 1.0)
    img = np.where(face >= 0, 0.15 + 0.85 * np.nan_to_num(shade), 0.05).reshape(height, width)
    buf = io.BytesIO()
    imsave(buf, img, cmap="gray", vmin=0.0, vmax=1.0, format="png")
    return buf.getvalue()


