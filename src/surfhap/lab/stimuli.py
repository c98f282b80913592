"""Study stimuli played live: material textures, Zhao's square-wave baseline, Kim et al.'s 1-D
formative profiles (IP0.5 / IP0.7) and 3-D shapes and scenes, each behind the safety stage
with the session's limit; and the scene pictures of the visual tasks.

Render specs (the ``render`` of a :class:`~surfhap.lab.schema.Stimulus`)::

    {"material": name, "method": law, ["square_frequency": Hz, "square_amplitude": V]}
    {"profile1d": "bump" | "hole" | "flat", "mapping": "IP0.5" | "IP0.7", "grain": grain}
    {"scene": name, "haptic": bool} | {"mesh": built-in name or file, "grain": grain}
    {"real": name} | {"effect": name}            (nothing to drive: the output is muted)
"""

from __future__ import annotations

import json
import math

import numpy as np

from surfhap.runtime.commands import SetGain, SwapRenderer

__all__ = ["StimulusPlayer", "make_profile_renderer", "scene_picture"]

CSS_PX_M = 0.0254 / 96.0  # one CSS pixel in metres


def make_profile_renderer(shape: str, mapping: str, surface, calibration, config, surface_size):
    """A live renderer of one of Kim et al.'s formative profiles (the class is built here: it
    derives from the live package's shape renderer, imported on first use)."""
    from surfhap.live.shape_live import LiveShapeRenderer

    class ProfileRenderer(LiveShapeRenderer):
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


class StimulusPlayer:
    """Plays a trial's stimuli through a live session (engine + backend).

    ``session``: a started :class:`surfhap.live.session.LiveSession`; ``gain``: multiplier of
    the calibrated drive gain alpha; ``v_max``: the session's safety limit (V); ``display``: the
    DisplayModel rendered for (None: the documented assumptions)."""

    def __init__(self, session, *, gain: float = 1.0, v_max: float = 250.0, seed: int = 0, display=None):
        from surfhap.models.panel import DisplayModel

        self.display = display or DisplayModel()  # the panel rendered for (study run --display)
        self.session = session
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
        from surfhap.live.shape_live import LiveShapeRenderer
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
        return LiveShapeRenderer(surface, cal, cfg, surface_size=size)

    def select(self, render: dict) -> str:
        """Play ``render`` from now on; returns what is played ("muted" or a description)."""
        key = json.dumps(render, sort_keys=True)
        if key not in self._cache:
            self._cache[key] = self._build(render)
        chain, positions = self._cache[key]
        eng = self.session.engine
        if chain is None:
            eng.send(SetGain(0.0))
            self.current = None
            return "muted"
        if chain is not self.current:
            chain.reset()
            eng.send(SwapRenderer(chain))
            self.current = chain
        self.positions = positions
        eng.send(SetGain(1.0))
        return key

    def mute(self) -> None:
        self.session.engine.send(SetGain(0.0))
        self.current = None

    def touch(self, client: int, x: float, y: float, p: float, t_ms: float, w_px: float, h_px: float) -> None:
        sp = self.session.space
        load = (p if p > 0 else 0.5) * sp.max_load
        if self.positions == "surface":
            xm, ym = x * sp.width, y * sp.height
        else:
            xm, ym = x * w_px * CSS_PX_M, y * h_px * CSS_PX_M
        self.session.engine.push_touch(client, xm, ym, load, t_event=t_ms * 1e-3)

    def lift(self, client: int, t_ms: float) -> None:
        self.session.engine.push_touch(client, 0.0, 0.0, 0.0, t_event=t_ms * 1e-3)


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


