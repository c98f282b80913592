"""Streaming offline render: the same chain as :func:`surfhap.render.offline.render`, block by
block, handing each block to a sink instead of keeping it, in memory independent of the duration.

:func:`stream_render` samples the trajectory onto the control-rate grid one block at a time
(the one offline loop, :func:`~surfhap.render.offline.render_blocks`, that ``render()`` runs too), runs the
:class:`~surfhap.render.chain.TextureChain` (whose last stage is the safety stage) and the
simulated display, and calls ``sink(channel, block)`` for every channel of :data:`CHANNELS`.
The summary statistics (:class:`~surfhap.render.offline.RenderStats`) and the figure's
bounded copies (:class:`~surfhap.render.preview.PreviewRecorder`) accumulate on the way.
The drive it hands out is sample for sample the drive of ``render()`` for the same inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from surfhap.exchange.render_store import RENDER_CHANNELS as CHANNELS
from surfhap.models.material import Material
from surfhap.models.panel import SimulatedDisplay
from surfhap.models.trajectory import Trajectory
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.expected import expected_texture_psd
from surfhap.render.offline import (MAX_FAULT_FRACTION, MIN_TEXTURE_SHARE, RenderStats, fault_error, model_samples,
                                    render_blocks, render_settings, saturation_warning, summary_dict, texture_warning)
from surfhap.render.preview import PreviewRecorder, RenderPreview

__all__ = ["CHANNELS", "StreamedRender", "stream_render", "model_samples"]

# channel -> (rate: "model" | "drive", unit); "texture" is in the material's texture quantity
Sink = Callable[[str, np.ndarray], None]


@dataclass
class StreamedRender:
    """The outcome of :func:`stream_render`: the settings of the render (the non-array fields of
    :class:`~surfhap.render.offline.RenderResult`, as attributes), the accumulated statistics,
    the figure's preview, and how far it got.

    n_model / n_drive: samples handed to the sink (model / drive rate); n_total: model samples of
    the whole trajectory; interrupted: True if ``stop()`` ended it early.
    """

    settings: dict
    stats: RenderStats
    preview: RenderPreview
    n_model: int
    n_drive: int
    n_total: int
    interrupted: bool

    def __getattr__(self, name):
        settings = self.__dict__.get("settings", {})
        if name in settings:
            return settings[name]
        raise AttributeError(name)

    @property
    def saturated_fraction(self) -> float:
        s = self.safety
        return s.clamped / s.samples if s.samples else 0.0

    @property
    def texture_quantity(self) -> str | None:
        return None if self.texture_model is None else self.texture_model.quantity

    def summary(self) -> dict:
        """The same JSON-ready summary as ``RenderResult.summary()`` for the rendered part, plus
        ``interrupted`` and ``rendered_s`` / ``requested_s``."""
        return summary_dict(self, self.stats) | {
            "interrupted": self.interrupted,
            "rendered_s": self.n_model / self.control_rate,
            "requested_s": self.n_total / self.control_rate,
        }

    def saturation_warning(self, threshold: float = 0.01) -> str | None:
        return saturation_warning(self, self.saturated_fraction, self.stats.onset_load, threshold)

    def fault_error(self, threshold: float = MAX_FAULT_FRACTION) -> str | None:
        return fault_error(self, threshold)

    def texture_warning(self, threshold: float = MIN_TEXTURE_SHARE) -> str | None:
        return texture_warning(self, self.stats.texture_share, threshold)

    def plot(self, ax=None):
        """The render figure, drawn from the preview (matplotlib Figure)."""
        from surfhap.report.figures import plot_render

        return plot_render(self.preview, ax)


def stream_render(material: Material, trajectory: Trajectory, config: ChainConfig | None, sink: Sink, *,
                  block_seconds: float = 1.0, progress: Callable[[float], None] | None = None,
                  stop: Callable[[], bool] | None = None, preview_columns: int = 1200) -> StreamedRender:
    """Render ``trajectory`` over ``material`` block by block, calling ``sink(channel, array)``
    for each block of each channel of :data:`CHANNELS` (control-rate channels (n,) float64 in
    order, ``drive`` (m,) V after the safety stage). ``stop()`` is polled between blocks: when it
    returns True the render ends there, every channel consistent up to the last whole block."""
    cfg = config or ChainConfig()
    chain = TextureChain(material, cfg)
    display = SimulatedDisplay(cfg.display, chain.drive_rate, chain.control_rate)
    fm = chain.control_rate
    n = model_samples(trajectory, fm)
    block = max(1, int(round(block_seconds * fm)))
    meta = _Meta(render_settings(material, trajectory, cfg, chain, display))  # settings; counters taken again at the end
    preview = PreviewRecorder(n, math.ceil(n * chain.drive_rate / fm), fm, chain.drive_rate, meta, expected_texture_psd,
                              columns=preview_columns)
    stats = RenderStats(has_texture=chain.law.uses_texture)
    low_band = chain.law.low_band
    v_max = cfg.limits.v_max
    n_done = n_drive = n_fric = 0
    last_fric = 0.0
    for start, speed, load, out, fric in render_blocks(chain, trajectory, display, block_seconds=block_seconds, stop=stop):
        end = start + speed.size
        law = out.drive_law
        for key, arr in (("speed", speed), ("load", load), ("texture", out.texture), ("mu_low", law.mu_low),
                         ("mu_tex", law.mu_tex), ("target", law.target), ("voltage", law.voltage)):
            sink(key, arr)
        sink("drive", out.drive)
        stats.add_model(load, law.voltage, v_max)
        stats.add_texture(load, law.target, low_band.force(load, law.mu_low))
        stats.add_drive(out.drive)
        preview.add_model(start, speed, load, law.target, law.mu_low, law.voltage)
        preview.add_drive(n_drive, out.drive)
        n_drive += out.drive.shape[0]
        fric = fric[:end - n_fric]
        _friction(sink, stats, preview, n_fric, fric)
        n_fric += fric.shape[0]
        if fric.shape[0]:
            last_fric = float(fric[-1])
        n_done = end
        if progress is not None:
            progress(end / n)
    # the display's decimator lags: hold its last value over the tail, as render() does
    while n_fric < n_done:
        k = min(block, n_done - n_fric)
        _friction(sink, stats, preview, n_fric, np.full(k, last_fric))
        n_fric += k
    settings = render_settings(material, trajectory, cfg, chain, display)
    return StreamedRender(settings, stats, preview.finish(n_done), n_done, n_drive, n, n_done < n)


def _friction(sink: Sink, stats: RenderStats, preview: PreviewRecorder, start: int, fric: np.ndarray) -> None:
    sink("friction_sim", fric)
    stats.add_friction(fric)
    preview.add_friction(start, fric)


class _Meta:
    """Attribute view of render settings, for the preview's labels and model spectrum."""

    def __init__(self, settings: dict):
        self.__dict__.update(settings)
