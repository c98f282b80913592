"""Offline rendering: a whole trajectory through the texture chain and the simulated display.

``render(material, trajectory)`` is the one-call convenience; it runs exactly the processors
that live rendering runs (:class:`~surfhap.render.chain.TextureChain`), in blocks, on a
simulated clock, and returns a :class:`RenderResult` with named arrays, a summary and
``.plot()``. Writing files is :func:`surfhap.exchange.render_files.write_render`. For renders
too long to hold in memory, :func:`surfhap.render.stream.stream_render` runs the same blocks
into a sink (what ``surfhap render`` does).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from surfhap.models.material import Material
from surfhap.models.panel import SimulatedDisplay
from surfhap.models.trajectory import Trajectory
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.drive import LowBand, rendering_gain
from surfhap.render.expected import expected_texture_psd
from surfhap.render.hold import TouchHold, TrajectoryRows
from surfhap.render.kinematics import TouchPredictor
from surfhap.render.safety import SafetyCounters

__all__ = ["RenderResult", "RenderStats", "render", "render_blocks", "model_samples", "summary_dict", "saturation_warning",
           "expected_texture_psd", "render_settings", "fault_error", "RenderFaultError", "MAX_FAULT_FRACTION",
           "texture_warning", "MIN_TEXTURE_SHARE"]

MAX_FAULT_FRACTION = 0.01  # a render whose safety stage zeroed more drive samples than this failed
MIN_TEXTURE_SHARE = 0.01  # a texture below this share of the target force is reported (nearly flat friction)


class RenderFaultError(RuntimeError):
    """A render whose safety stage faulted (0 V for NaN/absurd input) on more than
    MAX_FAULT_FRACTION of its drive samples: its output is not the material, whatever it wrote."""


@dataclass
class RenderResult:
    """Everything one render produced. Arrays at the chain's model (control) rate unless
    named ``*_drive``; ``texture_rate`` is the rate the texture model was fitted at.

    t (n,) s; speed (n,) m/s; load (n,) N; texture (n,) in the texture quantity;
    mu_low, mu_tex (n,); target (n,) N target added friction; voltage (n,) V envelope
    before the carrier; t_drive, drive (m,) s and V after the safety stage;
    friction_sim (n,) N from the simulated display; acc (n,) m/s^2 or None.
    texture_gain, texture_relative_scale, friction_law (the low-band law the method used) and
    low_band (the drive law's :class:`~surfhap.render.drive.LowBand`: that law times the load it
    uses) are what :func:`~surfhap.render.expected.expected_texture_psd`, the figure's law line
    and the fidelity metrics need.
    """

    material: str
    method: str
    seed: int
    control_rate: int
    drive_rate: int
    carrier: float
    alpha: float
    beta: float
    alpha_calibrated: float
    t: np.ndarray
    speed: np.ndarray
    load: np.ndarray
    texture: np.ndarray
    mu_low: np.ndarray
    mu_tex: np.ndarray
    target: np.ndarray
    voltage: np.ndarray
    drive: np.ndarray
    friction_sim: np.ndarray
    acc: np.ndarray | None
    latency: float
    display_latency: float
    mu_panel: float
    k: float
    clipped: int
    touching: int
    safety: SafetyCounters
    texture_model: object | None = None
    trajectory_name: str = ""
    effective_mass: float = 0.05
    constant_load: float | None = 1.6
    v_max: float = 250.0
    texture_rate: int | None = None
    plan: object | None = None
    alpha_source: str = "plan"
    carrier_choice: str = ""
    display_info: dict | None = None
    square_amplitude: float | None = None
    square_reference: tuple[float, float] | None = None
    texture_gain: float = 1.0
    texture_relative_scale: float | None = None
    friction_law: object | None = None
    low_band: LowBand | None = None

    @property
    def t_drive(self) -> np.ndarray:
        """(m,) s, time of each drive sample."""
        return np.arange(self.drive.size) / self.drive_rate

    @property
    def clipped_fraction(self) -> float:
        """Fraction of touching model samples whose target force was negative (clipped to 0)."""
        return self.clipped / self.touching if self.touching else 0.0

    @property
    def saturated_fraction(self) -> float:
        """Fraction of drive samples the safety stage clamped to v_max ("saturated")."""
        s = self.safety
        return s.clamped / s.samples if s.samples else 0.0

    @property
    def saturation_onset_load(self) -> float | None:
        """N: the smallest load at which the drive envelope reached v_max, or None if it never did."""
        sat = (self.load > 0) & (self.voltage >= self.v_max)
        return float(np.min(self.load[sat])) if np.any(sat) else None

    def saturation_warning(self, threshold: float = 0.01) -> str | None:
        """One line saying where saturation starts and what to change, when more than
        ``threshold`` of the drive samples saturated; else None."""
        return saturation_warning(self, self.saturated_fraction, self.saturation_onset_load, threshold)

    def fault_error(self, threshold: float = MAX_FAULT_FRACTION) -> str | None:
        """One line when the safety stage faulted on more than ``threshold`` of the drive samples; else None."""
        return fault_error(self, threshold)

    def texture_warning(self, threshold: float = MIN_TEXTURE_SHARE) -> str | None:
        """One line when the texture is under ``threshold`` of the target force; else None."""
        return texture_warning(self, RenderStats.of(self).texture_share, threshold)

    @property
    def texture_quantity(self) -> str | None:
        """"cof" or "acceleration" for the rendered texture, None without one."""
        return None if self.texture_model is None else self.texture_model.quantity

    @property
    def rendering_gain(self) -> float:
        """(alpha / alpha_calibrated)^2: the added friction is this times the target force."""
        return rendering_gain(self.alpha, self.alpha_calibrated)

    @property
    def added_friction(self) -> np.ndarray:
        """(n,) N: simulated friction minus the bare panel's mu_panel * load (what the drive added)."""
        return self.friction_sim - self.mu_panel * self.load

    def expected_texture_psd(self, freqs: np.ndarray) -> np.ndarray | None:
        """PSD (N^2/Hz) the added friction's textural part should have, from the AR model at the
        median speed and load, or None for a method without texture."""
        touching = self.load > 0
        if not np.any(touching):
            return None
        return expected_texture_psd(self, freqs, float(np.median(self.speed[touching])), float(np.median(self.load[touching])))

    def summary(self) -> dict:
        """The JSON-ready summary of this render."""
        return summary_dict(self, RenderStats.of(self))

    def plot(self, fig=None):
        """Time course and spectrum of the rendered friction against the model (matplotlib Figure)."""
        from surfhap.render.preview import preview_of
        from surfhap.report.figures import plot_render

        return plot_render(preview_of(self), fig=fig)


@dataclass
class RenderStats:
    """What the summary needs from the arrays of a render, accumulable block by block.

    n_model: model samples; max_abs_drive: V; friction_sum: N summed over model samples
    (for the mean); onset_load: N, smallest load whose envelope reached v_max, or None.
    touching / target_sum / texture_sq_sum: while touching, samples, the target force (N) and
    the squared textural target (target minus the law's low band, N^2) summed, for the texture
    share; ``has_texture`` False for a method without texture.
    """

    n_model: int = 0
    max_abs_drive: float = 0.0
    friction_sum: float = 0.0
    onset_load: float | None = None
    has_texture: bool = False
    touching: int = 0
    target_sum: float = 0.0
    texture_sq_sum: float = 0.0

    @classmethod
    def of(cls, r: "RenderResult") -> "RenderStats":
        n = int(r.t.size)
        stats = cls(n, float(np.max(np.abs(r.drive))) if r.drive.size else 0.0,
                    float(np.sum(r.friction_sim)) if n else 0.0, r.saturation_onset_load, has_texture=r.texture_model is not None)
        if r.low_band is not None:
            stats.add_texture(r.load, r.target, r.low_band.force(r.load, r.mu_low))
        return stats

    @property
    def texture_share(self) -> float | None:
        """rms of the textural target over the mean target while touching (a force ratio; the
        built-in textures at their calibrated 10:3-ish voltage ratios give ~0.1), or None
        without a texture or a touch."""
        if not self.has_texture or not self.touching or self.target_sum <= 0:
            return None
        return float(np.sqrt(self.texture_sq_sum / self.touching) / (self.target_sum / self.touching))

    def add_texture(self, load: np.ndarray, target: np.ndarray, low: np.ndarray) -> None:
        """Account one block: load (n,) N, the law's target (n,) N and its low band (n,) N."""
        on = load > 0
        self.touching += int(np.count_nonzero(on))
        self.target_sum += float(np.sum(target[on]))
        self.texture_sq_sum += float(np.sum(np.square(target[on] - low[on])))

    def add_model(self, load: np.ndarray, voltage: np.ndarray, v_max: float) -> None:
        """Account one block of control-rate load (n,) N and envelope (n,) V."""
        self.n_model += int(load.shape[0])
        sat = (load > 0) & (voltage >= v_max)
        if np.any(sat):
            low = float(np.min(load[sat]))
            self.onset_load = low if self.onset_load is None else min(self.onset_load, low)

    def add_drive(self, drive: np.ndarray) -> None:
        if drive.size:
            self.max_abs_drive = max(self.max_abs_drive, float(np.max(np.abs(drive))))

    def add_friction(self, friction: np.ndarray) -> None:
        self.friction_sum += float(np.sum(friction))


def summary_dict(r, stats: RenderStats) -> dict:
    """The JSON-ready summary of a render ``r`` (a RenderResult, or a streamed render with the
    same settings attributes) from its accumulated ``stats``."""
    s = r.safety
    clipped = r.clipped / r.touching if r.touching else 0.0
    saturated = s.clamped / s.samples if s.samples else 0.0
    gain = rendering_gain(r.alpha, r.alpha_calibrated)
    return {
        "material": r.material,
        "method": r.method,
        "seed": r.seed,
        "trajectory": r.trajectory_name,
        "duration_s": float((stats.n_model - 1) / r.control_rate + 1.0 / r.control_rate) if stats.n_model else 0.0,
        "control_rate_hz": r.control_rate,
        "texture_rate_hz": r.texture_rate,
        "drive_rate_hz": r.drive_rate,
        "carrier_hz": r.carrier,
        "alpha_v_per_sqrt_n": float(r.alpha),
        "beta": r.beta,
        "rendering_gain": gain,
        "max_abs_voltage": stats.max_abs_drive,
        "alpha_source": r.alpha_source,
        "clipped_fraction": clipped,
        "saturated_fraction": saturated,
        "saturation_onset_load_n": stats.onset_load,
        "safety": {
            "samples": s.samples, "clamped": s.clamped, "rise_limited": s.rise_limited,
            "faults": s.faults, "lifted": s.lifted, "watchdog": s.watchdog,
        },
        "latency_s": r.latency,
        "mean_friction_sim_n": stats.friction_sum / stats.n_model if stats.n_model else 0.0,
        "texture_share": stats.texture_share,
        "texture_warning": texture_warning(r, stats.texture_share),
        "v_max": r.v_max,
        "mu_panel": r.mu_panel,
        "k_n_per_v2": r.k,
        "carrier_choice": r.carrier_choice,
        "display": r.display_info,
        "gain_plan": r.plan.to_dict() if r.plan is not None else None,
    } | ({} if r.square_amplitude is None else {
        "square_baseline": {
            "amplitude_v": r.square_amplitude,
            "reference_load_n": r.square_reference[0], "reference_speed_m_per_s": r.square_reference[1],
            "rule": "constant amplitude; mean added friction equals the friction-only mean at the reference load and speed",
        }})


def saturation_warning(r, fraction: float, onset: float | None, threshold: float = 0.01) -> str | None:
    """One line saying where saturation starts (``onset`` N) and what to change when more than
    ``threshold`` of the drive samples saturated (``fraction``); else None."""
    if fraction <= threshold:
        return None
    where = f"from {onset:.2f} N load on" if onset is not None else "at onsets"
    if r.alpha_source == "plan" and r.plan is not None:
        rng = r.plan.operating_range
        fix = (f"widen --load-range/--speed-range to cover this scan (the gain plan covers {rng.loads[0]:g}-{rng.loads[1]:g} N, "
               f"{rng.speeds[0]:g}-{rng.speeds[1]:g} m/s)")
    else:
        fix = "lower --alpha, or drop --alpha to use the gain plan"
    return (f"{fraction:.1%} of drive samples saturated at {r.v_max:g} V ({where}); "
            f"the friction no longer follows the model there: {fix}")


def texture_warning(r, share: float | None, threshold: float = MIN_TEXTURE_SHARE) -> str | None:
    """One line when the texture of render ``r`` is under ``threshold`` of its target force
    (``share``, :attr:`RenderStats.texture_share`): the display renders nearly flat friction."""
    if share is None or share >= threshold:
        return None
    hint = ("its texture is m_eff x acceleration (Zhao et al.), far weaker than the calibrated texture otake2022/otake2021 "
            "render" if r.method == "zhao" else "raise the texture (texture_gain / the material's texture) or choose another method")
    return (f"the texture is {share:.2%} of the target force (under {threshold:.0%}): {r.method} renders nearly flat friction "
            f"on {r.material}; {hint} (docs/texture.md, \"Texture share\")")


def fault_error(r, threshold: float = MAX_FAULT_FRACTION) -> str | None:
    """One line saying that the safety stage of render ``r`` (anything with ``safety`` counters,
    ``v_max``) zeroed more than ``threshold`` of the drive samples as faults, and the usual
    causes; else None."""
    s = r.safety
    fraction = s.faults / s.samples if s.samples else 0.0
    if fraction <= threshold:
        return None
    return (f"{fraction:.1%} of the drive samples ({s.faults} of {s.samples}) were zeroed by the safety stage as faults "
            f"(NaN, a drive far beyond {r.v_max:g} V, or an absurd load): the render does not show the material; "
            f"check the trajectory's units and --alpha")


def render_blocks(chain, trajectory: Trajectory, display: SimulatedDisplay, *, block_seconds: float = 1.0,
                  stop: Callable[[], bool] | None = None):
    """The offline block loop: the trajectory's samples in force from the model sample at their
    stamps (the live engine's :class:`~surfhap.render.hold.TouchHold` and
    :class:`~surfhap.render.kinematics.TouchPredictor`), through ``chain`` and the simulated
    ``display``. Yields ``(start, speed, load, block, friction)`` per block: model sample index,
    (n,) m/s and N inputs, the chain's block and the display's friction; ends early when
    ``stop()`` is True. :func:`render` and :func:`surfhap.render.stream.stream_render` consume it."""
    fm = chain.control_rate
    n = model_samples(trajectory, fm)
    hold = TouchHold(TrajectoryRows(trajectory), TouchPredictor(), 0.05)
    hold.take(0.0, 0.0)  # the chain's model sample 0 is the trajectory's first stamp
    block = max(1, int(round(block_seconds * fm)))
    for start in range(0, n, block):
        if stop is not None and stop():
            return
        k = min(n, start + block) - start
        inputs = np.empty((5, k))
        hold.fill(start, fm, inputs)
        speed, load, touch_time, xs, ys = inputs
        out = chain.process(speed, load, touch_time, xs, ys)
        yield start, speed, load, out, display.process(out.drive, out.load_drive)


def model_samples(trajectory: Trajectory, control_rate: float) -> int:
    """Number of control-rate samples a render of ``trajectory`` has."""
    return int(np.floor((trajectory.t[-1] - trajectory.t[0]) * control_rate + 1e-9)) + 1


def render(material: Material, trajectory: Trajectory, config: ChainConfig | None = None, *,
           block_seconds: float = 1.0, progress: Callable[[float], None] | None = None) -> RenderResult:
    """Render ``trajectory`` over ``material`` on the simulated display; see :class:`RenderResult`."""
    cfg = config or ChainConfig()
    chain = TextureChain(material, cfg)
    display = SimulatedDisplay(cfg.display, chain.drive_rate, chain.control_rate)
    n = model_samples(trajectory, chain.control_rate)
    keys = ("speed", "load", "texture", "voltage", "target", "mu_low", "mu_tex")
    parts: dict[str, list] = {k: [] for k in (*keys, "drive", "friction")}
    for start, speed, load, out, fric in render_blocks(chain, trajectory, display, block_seconds=block_seconds):
        law = out.drive_law
        for key, arr in zip(keys, (speed, load, out.texture, law.voltage, law.target, law.mu_low, law.mu_tex)):
            parts[key].append(arr)
        parts["drive"].append(out.drive)
        parts["friction"].append(fric)
        if progress is not None:
            progress((start + speed.size) / n)
    arr = {k: np.concatenate(v) if v else np.zeros(0) for k, v in parts.items()}
    # the display's decimator lags: hold its last value over the tail
    friction = np.full(n, arr["friction"][-1] if arr["friction"].size else 0.0)
    friction[:min(n, arr["friction"].size)] = arr["friction"][:n]
    uses_acc = chain.law.uses_texture and material.texture.quantity == "acceleration"
    return RenderResult(
        t=np.arange(n) / chain.control_rate, speed=arr["speed"], load=arr["load"], texture=arr["texture"], mu_low=arr["mu_low"],
        mu_tex=arr["mu_tex"], target=arr["target"], voltage=arr["voltage"], drive=arr["drive"], friction_sim=friction,
        acc=arr["texture"] if uses_acc else None, **render_settings(material, trajectory, cfg, chain, display),
    )


def render_settings(material: Material, trajectory: Trajectory, cfg: ChainConfig, chain: TextureChain,
                    display: SimulatedDisplay) -> dict:
    """The non-array fields of a :class:`RenderResult` (settings, counters, models) of a chain
    that has run; shared by :func:`render` and the streaming render."""
    return dict(
        material=material.name, method=chain.method, seed=cfg.seed, control_rate=chain.control_rate, drive_rate=chain.drive_rate,
        carrier=chain.carrier_hz, alpha=chain.params.alpha, beta=chain.params.beta, alpha_calibrated=chain.alpha_calibrated,
        latency=chain.latency, display_latency=display.delay, mu_panel=cfg.display.mu_panel, k=cfg.display.k,
        clipped=chain.law.clipped, touching=chain.law.touching, safety=chain.safety.counters,
        texture_model=material.texture if chain.law.uses_texture else None, trajectory_name=trajectory.name,
        effective_mass=cfg.effective_mass, constant_load=cfg.constant_load, v_max=cfg.limits.v_max, texture_rate=chain.texture_rate,
        plan=chain.plan, alpha_source=chain.alpha_source, carrier_choice=chain.carrier_choice,
        display_info=cfg.display.describe(), square_amplitude=chain.law.square_amplitude,
        square_reference=(cfg.square_reference_load, cfg.square_reference_speed) if chain.law.square_amplitude is not None else None,
        texture_gain=cfg.texture_gain, texture_relative_scale=material.texture_relative_scale,
        friction_law=chain.law.friction_law, low_band=chain.law.low_band,
    )
