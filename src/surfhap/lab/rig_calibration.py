"""Display calibration on the rig: play Kim et al.'s intensity steps, record the force sensor.

Steps (shared/papers/002 Sec. 2.2): intensities 0.1, 0.2, ..., 1.0, 20 s each; the drive on while
the pen crosses one of eight sectors of its circle (Fig. 3a), i.e. for 1/8 of each revolution of
2 pi r / v = 2 pi 0.03 m / 0.065 m/s = 2.9 s (Sec. 2.1). Intensity ``I`` is played as the envelope
``I v_max`` under the 2 kHz polarity carrier, so each step is a voltage-input tribometer recording
for the existing fit (:func:`surfhap.lab.calibration.calibrate`). Each batch of sensor records is
one touch sample (load = measured normal force) of the engine: the safety stage's watchdog (its
timeout = the sensor timeout) ramps the drive to zero when the sensor falls silent.
"""

from __future__ import annotations

import math
import time

import numpy as np

from surfhap.errors import ConfigError
from surfhap.render.block import RenderBlock
from surfhap.render.carrier import PolarityCarrier
from surfhap.render.chain import DEFAULT_CARRIER
from surfhap.render.safety import SafetyLimits, SafetyStage

__all__ = ["KIM_LEVELS", "STEP_SECONDS", "REVOLUTION", "StepSchedule", "StepRenderer",
           "record_steps", "step_recordings"]

KIM_LEVELS = tuple(round(0.1 * i, 1) for i in range(1, 11))  # 002 Sec. 2.2: 0.1-1.0, step 0.1
STEP_SECONDS = 20.0  # 002 Sec. 2.2: 20 s of data per trial
REVOLUTION = 2 * math.pi * 0.03 / 0.065  # s, 002 Sec. 2.1: 3 cm radius at 6.5 cm/s
SECTORS = 8  # 002 Sec. 2.2, Fig. 3a: the drive on in one of eight sectors
CONTROL_RATE = 1000  # Hz, model rate of the step renderer (the level changes at most every revolution / 8)


class StepSchedule:
    """``level(t)``: intensity ``levels[j]`` in step ``j`` (``step_seconds`` each) during the last
    1/8 of each ``revolution``, else 0 (and 0 after the end); ``t`` (n,) s."""

    def __init__(self, levels=KIM_LEVELS, step_seconds: float = STEP_SECONDS, revolution: float = REVOLUTION):
        self.levels = np.asarray(levels, float)
        if self.levels.size < 3 or not np.all((self.levels > 0) & (self.levels <= 1)):
            raise ConfigError("need three intensities or more, each in (0, 1]", field="levels")
        if not (step_seconds >= revolution > 0):
            raise ConfigError("a step must last one revolution or more", field="step_seconds")
        self.step_seconds, self.revolution = float(step_seconds), float(revolution)
        self.duration = self.levels.size * self.step_seconds

    def step(self, t: np.ndarray) -> np.ndarray:
        return np.floor(np.asarray(t, float) / self.step_seconds).astype(int)

    def level(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        j = self.step(t)
        on = np.mod(t, self.revolution) >= self.revolution * (1 - 1 / SECTORS)
        ok = (j >= 0) & (j < self.levels.size)
        return np.where(ok & on, self.levels[np.clip(j, 0, self.levels.size - 1)], 0.0)


class StepRenderer:
    """The steps as a :class:`~surfhap.runtime.protocols.Renderer`: envelope ``level v_max``,
    polarity carrier, then its safety stage. The schedule runs on ``clock`` (the engine's) from
    the last :meth:`reset` (``t0``), so a block the output skipped does not shift the steps."""

    uses_position = False
    control_rate = CONTROL_RATE

    def __init__(self, schedule: StepSchedule, drive_rate: int, limits: SafetyLimits, clock):
        if drive_rate % CONTROL_RATE:
            raise ConfigError(f"must be a multiple of {CONTROL_RATE} Hz", field="drive_rate")
        self.schedule, self.drive_rate, self.ratio = schedule, int(drive_rate), int(drive_rate) // CONTROL_RATE
        self.v_max, self.clock = limits.v_max, clock
        self.safety = SafetyStage(drive_rate, limits)
        self._carrier = PolarityCarrier(DEFAULT_CARRIER, drive_rate)
        self.reset()

    def reset(self) -> None:
        self._n, self.t0 = 0, self.clock()
        self.safety.reset()
        self._carrier.reset()

    def process(self, speed, load, touch_time, x=None, y=None, display=None) -> RenderBlock:
        n = np.asarray(load).shape[0]
        td = (self._n * self.ratio + np.arange(n * self.ratio)) / self.drive_rate  # the touch ages: model time
        self._n += n
        drive = self._carrier.process(self.schedule.level(self.clock() - self.t0 + td - td[:1]) * self.v_max)
        load_d = np.repeat(np.asarray(load, float), self.ratio)
        age = td - np.repeat(np.asarray(touch_time, float), self.ratio)
        drive = self.safety.process(drive, load_d, age)
        return RenderBlock(drive, load_d, np.zeros(n), None, None if display is None else display.process(drive, load_d))


def record_steps(sensor, engine, schedule: StepSchedule, *, keep_running=lambda: True):
    """Poll ``sensor`` while a started ``engine`` plays its :class:`StepRenderer`; returns (t,
    normal, shear, intensity) (n,) on the schedule's clock. A silent sensor raises
    :class:`~surfhap.live.netft.SensorSilent` (the watchdog has begun the ramp to zero)."""
    parts, offset = [], np.inf  # schedule clock - sensor clock: the smallest lag seen (records arrive late, never early)
    while keep_running() and not engine.halted:
        t, fn, fs = sensor.read()
        if t.size:
            engine.push_touch(-1, 0.0, 0.0, float(fn[-1]))
            offset = min(offset, engine.clock() - engine.renderer.t0 - float(t[-1]))
            parts.append((t, fn, fs))
            if t[-1] + offset >= schedule.duration:
                break
        time.sleep(0.001)  # poll: ~7 records at the Net F/T's 7 kHz, far inside a 20 ms timeout
    if not parts:
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
    t, fn, fs = (np.concatenate(c) for c in zip(*parts))
    t = t + offset
    return t, fn, fs, schedule.level(t)


def step_recordings(t, normal, shear, intensity, schedule: StepSchedule, sample_rate: float, v_max: float, source: str):
    """One voltage-input :class:`~surfhap.exchange.tribometer.TribometerRecording` per step."""
    from surfhap.exchange.tribometer import TribometerRecording

    j = schedule.step(t)
    recs = []
    for k in range(schedule.levels.size):
        m = j == k
        recs.append(TribometerRecording.from_arrays(
            input="voltage", lateral_force=shear[m], normal_force=normal[m], level=intensity[m] * v_max,
            sample_rate=sample_rate, source=f"{source} step {k + 1} (intensity {schedule.levels[k]:g})"))
    return recs
