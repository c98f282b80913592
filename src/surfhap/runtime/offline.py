"""Offline texture renders on the one loop: :func:`render` and :func:`stream_render`.

Both drive :func:`surfhap.runtime.loop.run` with a :class:`~surfhap.runtime.clock.SimClock`,
the trajectory replayed at its stamps (:class:`~surfhap.runtime.sources.ReplayRows`), an
:class:`OfflineEngine` (the touch hold and the :class:`~surfhap.render.chain.TextureChain`,
whose last stage is the safety stage) and a :class:`RenderRecorder` sink (the simulated
display, the statistics, the figure's bounded preview, the channels). Both return one
:class:`~surfhap.render.offline.RenderResult`; ``render`` keeps the arrays in it,
``stream_render`` hands each block to a channel sink instead, in memory independent of the
duration (what ``surfhap render`` does). The drive is sample for sample the same.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from surfhap.exchange.render_store import RENDER_CHANNELS as CHANNELS
from surfhap.models.material import Material
from surfhap.models.panel import SimulatedDisplay
from surfhap.models.trajectory import Trajectory
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.hold import TouchHold
from surfhap.render.kinematics import TouchPredictor
from surfhap.render.offline import RenderResult, RenderStats, model_samples, render_settings
from surfhap.render.preview import PreviewRecorder
from surfhap.runtime.clock import SimClock
from surfhap.runtime.loop import run
from surfhap.runtime.sources import ReplayRows

__all__ = ["CHANNELS", "render", "stream_render", "OfflineEngine", "RenderRecorder"]

ChannelSink = Callable[[str, np.ndarray], None]


class OfflineEngine:
    """The :class:`~surfhap.runtime.loop.BlockEngine` of an offline render. Its frames are
    model samples: ``drive_rate`` (the rate of the loop's frames) is the chain's control
    rate, and ``render(n, now)`` returns the drive samples of ``n`` model samples
    (``n * drive_rate / control_rate`` on average). The touch samples come from ``rows``,
    in force from the model sample at their stamps (the live engine's
    :class:`~surfhap.render.hold.TouchHold` and :class:`~surfhap.render.kinematics.TouchPredictor`);
    ``block`` is the last block: (start, speed, load, the chain's block)."""

    LAW_ROWS = ("voltage", "target", "mu_low", "mu_tex", "texture")  # what the chain writes into law_out

    def __init__(self, chain: TextureChain, rows: ReplayRows, block_frames: int):
        self.chain = chain
        self.drive_rate = chain.control_rate
        self.block_frames = int(block_frames)
        self.counters = {"touches": 0, "touches_ignored": 0, "stale_stamps": 0, "underruns": 0}
        self.hold = TouchHold(rows, TouchPredictor(), 0.05, self.counters)
        self.n = self.n_drive = 0
        # where the chain writes the drive and LAW_ROWS ((5, n) rows; kept arrays), else into new arrays
        self.block = self.drive_out = self.law_out = None

    def render(self, frames: int, now: float | None = None) -> np.ndarray:
        fm, k0 = self.drive_rate, self.n
        self.hold.take(k0 / fm if now is None else now, k0 / fm)  # model sample 0 is the trajectory's first stamp
        inputs = np.empty((5, frames))
        self.hold.fill(k0, fm, inputs)
        speed, load, touch_time, xs, ys = inputs
        out = self.chain.process(speed, load, touch_time, xs, ys, None if self.drive_out is None else self.drive_out[self.n_drive:],
                                 None if self.law_out is None else self.law_out[:, k0:])
        self.block = (k0, speed, load, out)
        self.n += frames
        self.n_drive += out.drive.shape[0]
        return out.drive


class RenderRecorder:
    """The sink of an offline render: each block's drive through the simulated ``display``,
    into :class:`~surfhap.render.offline.RenderStats`, the preview, ``channels(name, block)``
    for each channel of :data:`CHANNELS` (when given) and the kept arrays (``keep``)."""

    def __init__(self, engine: OfflineEngine, display: SimulatedDisplay, n_total: int, *, channels: ChannelSink | None = None,
                 keep: bool = False, progress: Callable[[float], None] | None = None, preview_columns: int = 1200):
        chain = engine.chain
        self.engine, self.display, self.n_total, self.progress = engine, display, n_total, progress
        self.channels = channels
        n_drive = math.ceil(n_total * chain.drive_rate / chain.control_rate)  # the resampler's exact total
        # kept arrays allocated once at full length, blocks written in; the chain writes the drive (+2: its bound)
        # and the law's rows. The model-rate channels are the rows of one allocation: one large block is mapped
        # in huge pages, separate ~1 MB arrays fault in page by page (5 ms of a 60 s render).
        self.arrays = None
        if keep:
            model = list(engine.LAW_ROWS) + [k for k in CHANNELS if k not in engine.LAW_ROWS and k != "drive"]
            rows = np.empty((len(model), n_total))
            self.arrays = dict(zip(model, rows)) | {"drive": np.empty(n_drive + 2)}
            engine.law_out = rows[:len(engine.LAW_ROWS)]
        engine.drive_out = self.arrays["drive"] if keep else None
        self.stats = RenderStats(has_texture=chain.law.uses_texture)
        self.low_band, self.v_max = chain.law.low_band, chain.config.limits.v_max
        self.preview = PreviewRecorder(n_total, n_drive, chain.control_rate, chain.drive_rate, chain.law.low_band,
                                       columns=preview_columns)
        self.n_fric = 0
        self.last_fric = 0.0

    def _put(self, name: str, arr: np.ndarray, at: int) -> None:
        if self.channels is not None:
            self.channels(name, arr)
        if self.arrays is not None:
            kept = self.arrays[name][at:at + arr.shape[0]]
            if not np.may_share_memory(kept, arr):  # else the chain wrote it there
                kept[:] = arr

    def _account(self, start: int, speed, load, target, mu_low, voltage, drive, friction, defer: bool = False) -> None:
        """Statistics and preview of model samples from ``start``, their drive and friction (None:
        later); ``defer``: the statistics when first read (:meth:`~surfhap.render.offline.RenderStats.add_blocks`)."""
        self.preview.add_model(start, speed, load, target, mu_low, voltage)
        self.preview.add_drive(self.stats.n_drive, drive)
        if friction is not None:
            self.preview.add_friction(start, friction)
        self.stats.add_blocks(self.low_band, self.v_max, load, target, mu_low, voltage, drive, friction, defer=defer)

    def emit(self, volts: np.ndarray) -> None:
        start, speed, load, out = self.engine.block
        law = out.drive_law
        for name, arr in (("speed", speed), ("load", load), ("texture", out.texture), ("mu_low", law.mu_low),
                          ("mu_tex", law.mu_tex), ("target", law.target), ("voltage", law.voltage)):
            self._put(name, arr, start)
        if self.channels is not None:
            self.channels("drive", volts)  # a kept drive is in place already (engine.drive_out)
        if self.arrays is None:  # kept arrays are accounted in one pass at the end (finish)
            self._account(start, speed, load, law.target, law.mu_low, law.voltage, volts, None)
        end = start + speed.shape[0]
        self._friction(self.display.process(volts, out.load_drive)[:end - self.n_fric])
        if self.progress is not None:
            self.progress(end / self.n_total)

    def _friction(self, fric: np.ndarray) -> None:
        self._put("friction_sim", fric, self.n_fric)
        if self.arrays is None:
            self.stats.add_friction(fric)
            self.preview.add_friction(self.n_fric, fric)
        self.n_fric += fric.shape[0]
        if fric.shape[0]:
            self.last_fric = float(fric[-1])

    def finish(self, material: Material, trajectory: Trajectory) -> RenderResult:
        n_done = self.engine.n
        while self.n_fric < n_done:  # the display's decimator lags: hold its last value over the tail
            self._friction(np.full(min(self.engine.block_frames, n_done - self.n_fric), self.last_fric))
        arrays = {}
        if self.arrays is not None:
            a = arrays = {k: v[:self.engine.n_drive if k == "drive" else n_done] for k, v in self.arrays.items()}
            self._account(0, a["speed"], a["load"], a["target"], a["mu_low"], a["voltage"], a["drive"], a["friction_sim"], defer=True)
            chain = self.engine.chain
            uses_acc = chain.law.uses_texture and material.texture.quantity == "acceleration"
            arrays["acc"] = arrays["texture"] if uses_acc else None
        result = RenderResult(**render_settings(material, trajectory, self.engine.chain, self.display), stats=self.stats,
                              preview=None, n_total=self.n_total, interrupted=n_done < self.n_total, **arrays)
        result.preview = self.preview.finish(result, n_done)
        return result


def stream_render(material: Material, trajectory: Trajectory, config: ChainConfig | None, sink: ChannelSink | None, *,
                  block_seconds: float = 1.0, progress: Callable[[float], None] | None = None,
                  stop: Callable[[], bool] | None = None, preview_columns: int = 1200, keep: bool = False) -> RenderResult:
    """Render ``trajectory`` over ``material`` block by block on the simulated display,
    calling ``sink(channel, array)`` for each block of each channel of :data:`CHANNELS`
    (control-rate channels (n,) float64 in order, ``drive`` (m,) V after the safety stage);
    ``keep`` also keeps the arrays in the result. ``stop()`` is polled between blocks: when it
    returns True the render ends there, every channel consistent up to the last whole block."""
    chain = TextureChain(material, config or ChainConfig())
    display = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate)
    n = model_samples(trajectory, chain.control_rate)
    rows = ReplayRows(trajectory)
    engine = OfflineEngine(chain, rows, max(1, int(round(block_seconds * chain.control_rate))))
    recorder = RenderRecorder(engine, display, n, channels=sink, keep=keep, progress=progress, preview_columns=preview_columns)
    run(rows, engine, SimClock(), recorder, total_frames=n, keep_running=None if stop is None else (lambda: not stop()))
    return recorder.finish(material, trajectory)


def render(material: Material, trajectory: Trajectory, config: ChainConfig | None = None, *,
           block_seconds: float = 4.0, progress: Callable[[float], None] | None = None) -> RenderResult:
    """Render ``trajectory`` over ``material`` on the simulated display, arrays kept in memory;
    see :class:`~surfhap.render.offline.RenderResult`. The block length changes only the speed
    (fewer per-block calls), never a sample."""
    return stream_render(material, trajectory, config, None, block_seconds=block_seconds, progress=progress, keep=True)
