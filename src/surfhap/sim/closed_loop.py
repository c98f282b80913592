"""Closed-loop friction on the simulated display (:class:`Drift` of its k) with a delayed, noisy
:class:`SimForceSensor`, run on the one loop (simulated clock, offline engine and recorder), and
the figures of issue 19's target (:func:`compare_loops`: the test and the benchmark)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numpy as np
from pydantic import Field
from scipy.signal import welch

from surfhap.checked import checked_dataclass
from surfhap.models.material import Material
from surfhap.models.panel import SimulatedDisplay
from surfhap.models.trajectory import Trajectory
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.offline import RenderResult, model_samples
from surfhap.results import Result, jsonable
from surfhap.runtime.clock import SimClock
from surfhap.runtime.closed_loop import LoopDesign, SensorLoop
from surfhap.runtime.loop import run
from surfhap.runtime.offline import OfflineEngine, RenderRecorder
from surfhap.runtime.sources import ReplayRows
from surfhap.signal.bands import BandSplit, band_average

__all__ = ["Drift", "SensorModel", "SimForceSensor", "simulate", "LoopFigures", "LoopComparison", "compare_loops"]


@checked_dataclass
class Drift:
    """``r(t) = k(t) / k = (1 + amplitude sin(2 pi t / period)) (1 + step [t >= step_time])``:
    issue 19's +-30 % over a minute and a step (+20 % at half of it keeps r within 0.84-1.3)."""

    amplitude: Annotated[float, Field(ge=0, lt=1)] = 0.3
    period: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 60.0
    step: Annotated[float, Field(gt=-1, allow_inf_nan=False)] = 0.2
    step_time: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 30.0

    def ratio(self, t: np.ndarray) -> np.ndarray:
        """(n,) k(t) / k at times t (n,) s."""
        t = np.asarray(t, dtype=float)
        return (1.0 + self.amplitude * np.sin(2.0 * np.pi * t / self.period)) * np.where(t >= self.step_time, 1.0 + self.step, 1.0)


@checked_dataclass
class SensorModel:
    """The simulated sensor. delay s (issue 19: 1-5 ms); noise standard deviations N: the
    normal and shear load cells of Otake et al. 2022 (003 Sec. II: dynamic resolution 0.01 N
    and < 0.001 N); ``dropout`` (start, end) s: samples taken then never arrive (a lost sensor)."""

    delay: Annotated[float, Field(ge=0, le=0.1)] = 0.005
    normal_noise: Annotated[float, Field(ge=0)] = 0.01
    shear_noise: Annotated[float, Field(ge=0)] = 0.001
    dropout: tuple[float, float] | None = None
    seed: int = 0


class SimForceSensor:
    """A :class:`~surfhap.runtime.protocols.ForceSensor` fed by the simulation: ``feed`` the
    samples taken at t (s, the simulation's clock); ``read`` returns those taken at least
    ``delay`` s before the newest sample fed (the simulated now)."""

    name = "sim"

    def __init__(self, model: SensorModel | None = None):
        self.model = model or SensorModel()
        self._rng = np.random.default_rng(self.model.seed)
        self._pending = np.zeros((3, 0))
        self._now = -np.inf

    def feed(self, t: np.ndarray, normal: np.ndarray, shear: np.ndarray) -> None:
        m = self.model
        keep = np.ones(t.shape[0], dtype=bool) if m.dropout is None else ~((t >= m.dropout[0]) & (t < m.dropout[1]))
        noisy = np.stack((t, normal + m.normal_noise * self._rng.standard_normal(t.shape[0]),
                          shear + m.shear_noise * self._rng.standard_normal(t.shape[0])))
        self._pending = np.concatenate((self._pending, noisy[:, keep]), axis=1)
        if t.shape[0]:
            self._now = float(t[-1])

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = int(np.searchsorted(self._pending[0], self._now - self.model.delay, side="right"))
        out, self._pending = self._pending[:, :k], self._pending[:, k:]
        return out[0], out[1], out[2]

    def close(self) -> None:
        self._pending = np.zeros((3, 0))


class SensedDisplay:
    """The recorder's display: the simulated display with a drifting k, its friction (control
    rate) and the load fed to ``sensor`` at each friction sample's time."""

    def __init__(self, display: SimulatedDisplay, drift: Drift, sensor: SimForceSensor):
        self.display, self.drift, self.sensor = display, drift, sensor
        self.delay = display.delay
        self._m = self._k = 0

    def reset(self) -> None:
        self.display.reset()
        self.sensor.close()
        self._m = self._k = 0

    def process(self, drive: np.ndarray, load: np.ndarray) -> np.ndarray:
        m = drive.shape[0]
        gain = self.drift.ratio((self._m + np.arange(m)) / self.display.drive_rate)
        friction = self.display.process(drive, load, gain)
        k = friction.shape[0]
        normal = load[np.minimum((np.arange(k) * m) // max(k, 1), m - 1)] if m else np.zeros(k)
        self.sensor.feed((self._k + np.arange(k)) / self.display.friction_rate, normal, friction)
        self._m, self._k = self._m + m, self._k + k
        return friction


def simulate(material: Material, trajectory: Trajectory, config: ChainConfig | None = None, *, drift: Drift | None = None,
             sensor: SensorModel | None = None, design: LoopDesign | None = None, closed: bool = True) -> RenderResult:
    """Render ``trajectory`` on the drifting simulated display, with the closed loop over the
    simulated sensor (``closed``, blocks of ``design.block`` s) or open loop. The result's
    ``voltage`` is the corrected envelope, ``friction_sim`` the display's friction."""
    design = design or LoopDesign()
    chain = TextureChain(material, config or ChainConfig())
    probe = SimForceSensor(sensor)
    if closed:
        SensorLoop(chain, probe, design)
    display = SensedDisplay(SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate,
                                             v_max=chain.config.limits.v_max), drift or Drift(), probe)
    n = model_samples(trajectory, chain.control_rate)
    rows = ReplayRows(trajectory)
    block = design.block if closed else 1.0  # the open loop's samples do not depend on the block length
    engine = OfflineEngine(chain, rows, max(1, int(round(block * chain.control_rate))))
    recorder = RenderRecorder(engine, display, n, keep=True)
    run(rows, engine, SimClock(), recorder, total_frames=n)
    return recorder.finish(material, trajectory)


@dataclass(frozen=True)
class LoopFigures:
    """One render against the law after ``warmup`` s while touching: low_band_rms N (RMS of
    BandSplit.low(added friction) - G F_low), law_rms N (of G F_low), clamped (drive samples the
    safety stage clamped) and at_limit (at v_max), envelope_over (control-rate envelope samples
    above v_max, before the tail), texture_band (b,) dB re 1 N^2/Hz in octave
    bands (centres (b,) Hz) from the cut-off to half the texture model's rate."""

    low_band_rms: float
    law_rms: float
    clamped: int
    at_limit: int
    envelope_over: int
    centres: np.ndarray
    texture_band: np.ndarray


def loop_figures(r: RenderResult, warmup: float = 1.0, cutoff: float = 3.5) -> LoopFigures:
    rate = float(r.control_rate)
    low, high = BandSplit(cutoff=cutoff).split(r.added_friction, rate)
    law = r.rendering_gain * r.low_band.force(r.load, r.mu_low)
    steady = (r.t >= warmup) & (r.load > 0)
    f, psd = welch(high[steady], fs=rate, nperseg=int(2 ** np.ceil(np.log2(4 * rate / cutoff))))
    centres, bands = band_average(f, psd, cutoff, min(rate, r.texture_rate or rate) / 2, fraction=1)
    return LoopFigures(float(np.sqrt(np.mean((low - law)[steady] ** 2))), float(np.sqrt(np.mean(law[steady] ** 2))),
                       int(r.safety.clamped), int(np.count_nonzero(np.abs(r.drive) >= r.v_max * (1 - 1e-9))),
                       int(np.count_nonzero(r.voltage > r.v_max)), centres, 10.0 * np.log10(bands))


@dataclass(frozen=True)
class LoopComparison(Result):
    """Open and closed loop under one drift: ``ratio`` closed / open low-band RMS error (target
    <= 1/3), ``texture_db`` the largest |closed - open| octave-band change of the texture band
    (target <= 1 dB)."""

    open: LoopFigures
    closed: LoopFigures

    @property
    def ratio(self) -> float:
        return self.closed.low_band_rms / self.open.low_band_rms

    @property
    def texture_db(self) -> float:
        return float(np.max(np.abs(self.closed.texture_band - self.open.texture_band)))

    def summary(self) -> dict:
        o, c = self.open, self.closed
        return jsonable({"open_low_band_rms_n": o.low_band_rms, "closed_low_band_rms_n": c.low_band_rms, "ratio": self.ratio,
                         "law_rms_n": o.law_rms, "texture_band_max_db": self.texture_db, "open_clamped": o.clamped,
                         "closed_clamped": c.clamped, "open_at_limit": o.at_limit, "closed_at_limit": c.at_limit,
                         "open_envelope_over": o.envelope_over, "closed_envelope_over": c.envelope_over})

    def plot(self, ax=None):
        from surfhap.report.figures import plot_loop_comparison

        return plot_loop_comparison(self, ax)


def compare_loops(material: Material, trajectory: Trajectory, config: ChainConfig | None = None, *, drift: Drift | None = None,
                  sensor: SensorModel | None = None, design: LoopDesign | None = None, warmup: float = 1.0) -> LoopComparison:
    """Open and closed loop under the same drift and seeds."""
    design = design or LoopDesign()
    runs = [simulate(material, trajectory, config, drift=drift, sensor=sensor, design=design, closed=c) for c in (False, True)]
    return LoopComparison(*(loop_figures(r, warmup, design.cutoff) for r in runs))
