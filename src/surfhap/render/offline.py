"""The one result of a texture render (:class:`RenderResult`) and what it is built from.

The entry points that run a render, :func:`surfhap.runtime.offline.render` (arrays kept in
memory) and :func:`surfhap.runtime.offline.stream_render` (blocks handed to a sink, constant
memory; what ``surfhap render`` uses), drive the :class:`~surfhap.render.chain.TextureChain`
through :func:`surfhap.runtime.loop.run` and both return a :class:`RenderResult`: settings,
the statistics accumulated block by block (:class:`RenderStats`), the figure's bounded
preview, and the arrays when they were kept. Writing files is
:func:`surfhap.exchange.render_files.write_render`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from surfhap.models.trajectory import Trajectory
from surfhap.render.drive import LowBand, rendering_gain
from surfhap.render.expected import expected_texture_psd
from surfhap.render.preview import RenderPreview
from surfhap.render.safety import SafetyCounters
from surfhap.results import Result

__all__ = ["RenderResult", "RenderStats", "model_samples", "render_settings", "RenderFaultError", "MAX_FAULT_FRACTION",
           "MIN_TEXTURE_SHARE"]

MAX_FAULT_FRACTION = 0.01  # a render whose safety stage zeroed more drive samples than this failed
MIN_TEXTURE_SHARE = 0.01  # a texture below this share of the target force is reported (nearly flat friction)


class RenderFaultError(RuntimeError):
    """A render whose safety stage faulted (0 V for NaN/absurd input) on more than
    MAX_FAULT_FRACTION of its drive samples: its output is not the material, whatever it wrote."""


class _Deferred:
    """A :class:`RenderStats` field: reading it first runs the reductions deferred by
    :meth:`RenderStats.add_blocks` (so a deferred statistic is exact whenever it is read)."""

    def __init__(self, default):
        self.default = default

    def __set_name__(self, owner, name):
        self.key = "_" + name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self.default  # the dataclass field's default
        obj.settle()
        return obj.__dict__[self.key]

    def __set__(self, obj, value):
        obj.__dict__[self.key] = value


@dataclass
class RenderStats:
    """What the summary needs from the arrays of a render, accumulated block by block.

    n_model / n_drive: samples rendered (model / drive rate); max_abs_drive: V; friction_sum:
    N summed over model samples (for the mean); onset_load: N, smallest load whose envelope
    reached v_max, or None. touching / target_sum / texture_sq_sum: while touching, samples,
    the target force (N) and the squared textural target (target minus the law's low band,
    N^2) summed, for the texture share; ``has_texture`` False for a method without texture.
    ``pending``: reductions deferred by :meth:`add_blocks`, run when one of them is first read.
    """

    has_texture: bool = False
    n_model: int = 0
    n_drive: int = 0
    max_abs_drive: float = _Deferred(0.0)
    friction_sum: float = _Deferred(0.0)
    onset_load: float | None = _Deferred(None)
    touching: int = _Deferred(0)
    target_sum: float = _Deferred(0.0)
    texture_sq_sum: float = _Deferred(0.0)
    pending: list = field(default_factory=list, repr=False, compare=False)

    def add_blocks(self, low_band: LowBand, v_max: float, load, target, mu_low, voltage, drive, friction=None, *,
                   defer: bool = False) -> None:
        """Account model samples (load, target, mu_low, voltage (n,); the law's ``low_band``),
        their drive (m,) V and friction (n,) N (None: later). ``defer``: count them now but
        reduce them when a statistic is first read (arrays the caller keeps unchanged: a
        render whose arrays are kept reduces them only if asked)."""
        self.n_model += load.shape[0]
        self.n_drive += drive.shape[0]

        def reduce():
            self.add_model(load, voltage, target, low_band.force(load, mu_low), v_max)
            self.add_drive(drive)
            if friction is not None:
                self.add_friction(friction)

        if defer:
            self.pending.append(reduce)
        else:
            reduce()

    def settle(self) -> None:
        """Run the deferred reductions (reading a statistic, a copy or a pickle does)."""
        while self.pending:
            self.pending.pop()()

    def __getstate__(self) -> dict:
        self.settle()
        return self.__dict__.copy()

    @property
    def texture_share(self) -> float | None:
        """rms of the textural target over the mean target while touching (a force ratio; the
        built-in textures at their calibrated 10:3-ish voltage ratios give ~0.1), or None
        without a texture or a touch."""
        if not self.has_texture or not self.touching or self.target_sum <= 0:
            return None
        return float(np.sqrt(self.texture_sq_sum / self.touching) / (self.target_sum / self.touching))

    def add_model(self, load: np.ndarray, voltage: np.ndarray, target: np.ndarray, low: np.ndarray, v_max: float) -> None:
        """Reduce one block at the control rate (:meth:`add_blocks` counts it): load (n,) N,
        envelope (n,) V, the law's target (n,) N and its low band (n,) N."""
        on = load > 0
        n, touching = load.shape[0], int(np.count_nonzero(on))
        if touching < n:  # the touching samples (all of them, the usual block: no copies)
            load, voltage, target, low = load[on], voltage[on], target[on], low[on]
        sat = voltage >= v_max
        if sat.any():
            lowest = float(load[sat].min())
            self.onset_load = lowest if self.onset_load is None else min(self.onset_load, lowest)
        self.touching += touching
        self.target_sum += float(target.sum())
        self.texture_sq_sum += float(np.square(target - low).sum())

    def add_drive(self, drive: np.ndarray) -> None:
        if drive.size:
            self.max_abs_drive = max(self.max_abs_drive, float(drive.max()), -float(drive.min()))

    def add_friction(self, friction: np.ndarray) -> None:
        self.friction_sum += float(friction.sum())


@dataclass
class RenderResult(Result):
    """Everything one render produced. Arrays (None when the render streamed them to a sink)
    at the chain's control rate unless named ``*_drive``; ``texture_rate`` is the rate the
    texture model was fitted at.

    speed (n,) m/s; load (n,) N; texture (n,) in the texture quantity; mu_low, mu_tex (n,);
    target (n,) N target added friction; voltage (n,) V envelope before the carrier; drive
    (m,) V after the safety stage; friction_sim (n,) N from the simulated display; acc (n,)
    m/s^2 or None; ``t`` and ``t_drive`` their times (s).
    stats, preview: the statistics and the figure's bounded copy, accumulated block by block;
    n_total: model samples of the whole trajectory; interrupted: True when ``stop()`` ended it.
    low_band (the drive law's :class:`~surfhap.render.drive.LowBand`: the low-band law times the
    load it uses) is what :func:`~surfhap.render.expected.expected_texture_psd`, the figure's law line
    and the fidelity metrics need.
    """

    panels = 4

    material: str
    method: str
    seed: int
    control_rate: int
    drive_rate: int
    carrier: float
    alpha: float
    beta: float
    alpha_calibrated: float
    latency: float
    display_latency: float
    mu_panel: float
    k: float
    clipped: int
    touching: int
    safety: SafetyCounters
    stats: RenderStats
    preview: RenderPreview
    n_total: int
    interrupted: bool = False
    texture_model: object | None = None
    trajectory_name: str = ""
    v_max: float = 250.0
    texture_rate: int | None = None
    plan: object | None = None
    alpha_source: str = "plan"
    carrier_choice: str = ""
    display_info: dict | None = None
    square_amplitude: float | None = None
    square_reference: tuple[float, float] | None = None
    low_band: LowBand | None = None
    speed: np.ndarray | None = None
    load: np.ndarray | None = None
    texture: np.ndarray | None = None
    mu_low: np.ndarray | None = None
    mu_tex: np.ndarray | None = None
    target: np.ndarray | None = None
    voltage: np.ndarray | None = None
    drive: np.ndarray | None = None
    friction_sim: np.ndarray | None = None
    acc: np.ndarray | None = None

    @property
    def n_model(self) -> int:
        return self.stats.n_model

    @property
    def t(self) -> np.ndarray:
        """(n,) s, time of each model sample."""
        return np.arange(self.stats.n_model) / self.control_rate

    @property
    def t_drive(self) -> np.ndarray:
        """(m,) s, time of each drive sample."""
        return np.arange(self.stats.n_drive) / self.drive_rate

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
        return self.stats.onset_load

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

    def saturation_warning(self, threshold: float = 0.01) -> str | None:
        """One line saying where saturation starts and what to change, when more than
        ``threshold`` of the drive samples saturated; else None."""
        fraction, onset = self.saturated_fraction, self.stats.onset_load
        if fraction <= threshold:
            return None
        where = f"from {onset:.2f} N load on" if onset is not None else "at onsets"
        if self.alpha_source == "plan" and self.plan is not None:
            rng = self.plan.operating_range
            fix = (f"widen --load-range/--speed-range to cover this scan (the gain plan covers {rng.loads[0]:g}-{rng.loads[1]:g} N, "
                   f"{rng.speeds[0]:g}-{rng.speeds[1]:g} m/s)")
        else:
            fix = "lower --alpha, or drop --alpha to use the gain plan"
        return (f"{fraction:.1%} of drive samples saturated at {self.v_max:g} V ({where}); "
                f"the friction no longer follows the model there: {fix}")

    def texture_warning(self, threshold: float = MIN_TEXTURE_SHARE) -> str | None:
        """One line when the texture is under ``threshold`` of the target force (the display
        renders nearly flat friction); else None."""
        share = self.stats.texture_share
        if share is None or share >= threshold:
            return None
        hint = ("its texture is m_eff x acceleration (Zhao et al.), far weaker than the calibrated texture otake2022/otake2021 "
                "render" if self.method == "zhao" else "raise the texture (texture_gain / the material's texture) or choose another method")
        return (f"the texture is {share:.2%} of the target force (under {threshold:.0%}): {self.method} renders nearly flat friction "
                f"on {self.material}; {hint} (docs/texture.md, \"Texture share\")")

    def fault_error(self, threshold: float = MAX_FAULT_FRACTION) -> str | None:
        """One line when the safety stage zeroed more than ``threshold`` of the drive samples
        as faults, and the usual causes; else None."""
        s = self.safety
        fraction = s.faults / s.samples if s.samples else 0.0
        if fraction <= threshold:
            return None
        return (f"{fraction:.1%} of the drive samples ({s.faults} of {s.samples}) were zeroed by the safety stage as faults "
                f"(NaN, a drive far beyond {self.v_max:g} V, or an absurd load): the render does not show the material; "
                f"check the trajectory's units and --alpha")

    def summary(self) -> dict:
        """The JSON-ready summary of this render (of its rendered part when interrupted)."""
        s, st, fm = self.safety, self.stats, self.control_rate
        return {
            "material": self.material, "method": self.method, "seed": self.seed, "trajectory": self.trajectory_name,
            "duration_s": float(st.n_model / fm),
            "control_rate_hz": fm, "texture_rate_hz": self.texture_rate, "drive_rate_hz": self.drive_rate,
            "carrier_hz": self.carrier, "alpha_v_per_sqrt_n": float(self.alpha), "beta": self.beta,
            "rendering_gain": self.rendering_gain, "max_abs_voltage": st.max_abs_drive, "alpha_source": self.alpha_source,
            "clipped_fraction": self.clipped_fraction, "saturated_fraction": self.saturated_fraction,
            "saturation_onset_load_n": st.onset_load,
            "safety": {k: v for k, v in asdict(s).items() if k != "halted"},  # a renderer's stage never halts
            "latency_s": self.latency,
            "mean_friction_sim_n": st.friction_sum / st.n_model if st.n_model else 0.0,
            "texture_share": st.texture_share, "texture_warning": self.texture_warning(),
            "v_max": self.v_max, "mu_panel": self.mu_panel, "k_n_per_v2": self.k, "carrier_choice": self.carrier_choice,
            "display": self.display_info, "gain_plan": self.plan.to_dict() if self.plan is not None else None,
            "interrupted": self.interrupted, "rendered_s": st.n_model / fm, "requested_s": self.n_total / fm,
        } | ({} if self.square_amplitude is None else {
            "square_baseline": {
                "amplitude_v": self.square_amplitude,
                "reference_load_n": self.square_reference[0], "reference_speed_m_per_s": self.square_reference[1],
                "rule": "constant amplitude; mean added friction equals the friction-only mean at the reference load and speed",
            }})

    def plot(self, ax=None):
        """Time course and spectrum of the rendered friction against the model, drawn from the
        preview (matplotlib Figure; ``ax``: None or 4 Axes)."""
        from surfhap.report.figures import plot_render

        return plot_render(self.preview, ax)


def model_samples(trajectory: Trajectory, control_rate: float) -> int:
    """Number of control-rate samples a render of ``trajectory`` has."""
    return int(np.floor((trajectory.t[-1] - trajectory.t[0]) * control_rate + 1e-9)) + 1


def render_settings(material, trajectory: Trajectory, chain, display) -> dict:
    """The non-array fields of a :class:`RenderResult` (settings, counters, models) of a
    :class:`~surfhap.render.chain.TextureChain` that has run, and its simulated ``display``."""
    cfg = chain.config
    law = chain.law
    return dict(
        material=material.name, method=chain.method, seed=cfg.seed, control_rate=chain.control_rate, drive_rate=chain.drive_rate,
        carrier=chain.carrier_hz, alpha=chain.params.alpha, beta=chain.params.beta, alpha_calibrated=chain.alpha_calibrated,
        latency=chain.latency, display_latency=display.delay, mu_panel=cfg.display.mu_panel, k=cfg.display.k,
        clipped=law.clipped, touching=law.touching, safety=chain.safety.counters,
        texture_model=material.texture if law.uses_texture else None, trajectory_name=trajectory.name,
        v_max=cfg.limits.v_max, texture_rate=chain.texture_rate,
        plan=chain.plan, alpha_source=chain.alpha_source, carrier_choice=chain.carrier_choice,
        display_info=cfg.display.describe(), square_amplitude=law.square_amplitude,
        square_reference=(cfg.square_reference_load, cfg.square_reference_speed) if law.square_amplitude is not None else None,
        low_band=law.low_band,
    )
