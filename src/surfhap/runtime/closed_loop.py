"""Closed-loop friction: a force sensor corrects the electroadhesion gain on the low band.

The display's gain drifts (``r(t) = k(t) / k``). The law's low-band target ``F_low``
(``LowBand.force``) is scaled by ``u`` and the texture part left open loop,
``F = target + (u - 1) F_low``, then mapped by the law's own feed-forward (``DriveLaw.voltage_for``).
``u`` integrates ``e = 1 - low(f_meas) / low(G F_low)`` (``f_meas = shear - mu_panel normal``, G
the rendering gain, ``low`` the one :class:`~surfhap.signal.bands.BandSplit`): ``du/dt = Ki (1 - r u)``.
Bounds ``u`` in ``[1/(1+D), 1/(1-D)]``; headroom: a block takes the share of the correction that
keeps each sample at most ``max(v_open_loop, v_max)``; anti-windup: no integration in a block
after the safety stage clamped or the headroom limit bound;
fall-back: no sensor sample for ``loss_timeout`` -> ``u`` ramps to 1 at ``(1 - D) Ki`` per s.

Gain (:class:`LoopDesign`): the low band is computed over ``2 / cutoff`` s of means over one
update period and read ``1 / (2 cutoff)`` s before the end, so the loop delay is ``tau =
sensor_delay + 1 / (2 cutoff) + block``. An integrator behind a delay has the phase margin
``pi/2 - w_c tau`` at ``w_c = r Ki``; 60 degrees (the well-damped end of the usual 30-60 degree
design range, Astrom & Murray, Feedback Systems, loop shaping) at the largest gain ``r = 1 + D``
gives ``Ki = (pi/6) / ((1 + D) tau)``. A
drift ``D sin(2 pi t / P)`` moves at most ``2 pi D / P`` per s; a type-1 loop follows it with
the error ``2 pi D / (P (1 - D) Ki)`` (:attr:`LoopDesign.tracking_error`).
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from pydantic import Field

from surfhap.checked import checked_dataclass
from surfhap.render.drive import DriveBlock, rendering_gain
from surfhap.runtime.protocols import ForceSensor
from surfhap.signal.bands import BandSplit

__all__ = ["LoopDesign", "FrictionController", "SensorLoop"]


@checked_dataclass
class LoopDesign:
    """What the gain and bounds derive from (module docstring), SI: sensor_delay (issue 19:
    1-5 ms, default its upper end), drift_amplitude D and drift_period (issue 19: +-30 % over
    a minute), block (the update period), cutoff (3.5 Hz, 003 Sec. II), loss_timeout (issue
    19: 20 ms); ``block`` is a stated choice (10 ms: the simulation's update; a shorter live
    block only shortens the delay, i.e. adds margin)."""

    sensor_delay: Annotated[float, Field(ge=0, le=0.1)] = 0.005
    drift_amplitude: Annotated[float, Field(gt=0, lt=1)] = 0.3
    drift_period: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 60.0
    block: Annotated[float, Field(gt=0, le=0.1)] = 0.010
    cutoff: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 3.5
    loss_timeout: Annotated[float, Field(gt=0, le=1)] = 0.020

    @property
    def ki(self) -> float:
        """1/s: 60 degrees of phase margin at the largest gain 1 + D."""
        return (math.pi / 6.0) / ((1.0 + self.drift_amplitude) * (self.sensor_delay + 0.5 / self.cutoff + self.block))

    @property
    def bounds(self) -> tuple[float, float]:
        return 1.0 / (1.0 + self.drift_amplitude), 1.0 / (1.0 - self.drift_amplitude)

    @property
    def tracking_error(self) -> float:
        return 2.0 * math.pi * self.drift_amplitude / (self.drift_period * (1.0 - self.drift_amplitude) * self.ki)


class FrictionController:
    """The numerical loop (allocated once, ``reset()``, ``process`` per block): ``voltage_for``
    maps a target (n,) N to (n,) V, ``gain`` is G, ``v_max`` V the safety stage's limit, ``rate`` Hz."""

    def __init__(self, design: LoopDesign, rate: int, gain: float, v_max: float, voltage_for):
        self.design, self.rate, self.gain, self.v_max, self.voltage_for = design, int(rate), float(gain), float(v_max), voltage_for
        self.ki, (self.u_lo, self.u_hi) = design.ki, design.bounds
        self._d = max(1, int(round(design.block * self.rate)))  # control samples per mean
        m = int(round(2.0 / design.cutoff / design.block))  # means in the window
        self._hist = np.zeros((2, self._d * m))  # G F_low, f_meas (N)
        # BandSplit.low is linear: its value half a cut-off period before the end is means @ weights
        lag = int(round(0.5 / design.cutoff / design.block))
        self._weights = np.ascontiguousarray(BandSplit(cutoff=design.cutoff).low(np.eye(m), self.rate / self._d)[:, m - 1 - lag])
        self.reset()

    def reset(self) -> None:
        self.u, self._valid, self._limited = 1.0, 0, False
        self._hist[:] = 0.0

    def process(self, target: np.ndarray, low: np.ndarray, voltage: np.ndarray, measured: np.ndarray,
                sensed: bool, saturated: bool) -> np.ndarray:
        """One block: target (n,) N, its low band ``low`` (n,) N, the open-loop drive ``voltage``
        (n,) V, the sensor's added friction ``measured`` (n,) N; ``sensed``: a sample arrived
        within the loss timeout; ``saturated``: the safety stage clamped in the last block.
        Returns the corrected drive envelope (n,) V."""
        n, h = target.shape[0], self._hist
        k = min(n, h.shape[1])
        h[:, :h.shape[1] - k] = h[:, k:]
        h[0, -k:], h[1, -k:] = self.gain * low[n - k:], measured[n - k:]
        self._valid = self._valid + n if (sensed and np.all(low > 0.0)) else 0
        dt = n / self.rate
        if not sensed:  # fall back: ramp to open loop
            step = (1.0 - self.design.drift_amplitude) * self.ki * dt
            self.u = max(self.u - step, 1.0) if self.u > 1.0 else min(self.u + step, 1.0)
        elif self._valid >= h.shape[1] and not (saturated or self._limited):
            lo = h.reshape(2, -1, self._d).mean(axis=2) @ self._weights
            if lo[0] > 0.0:
                self.u = float(np.clip(self.u + self.ki * (1.0 - lo[1] / lo[0]) * dt, self.u_lo, self.u_hi))
        if self.u == 1.0:
            self._limited = False
            return voltage
        # headroom: the correction's share rho in [0, 1] of the block (one factor, no corners)
        # that keeps every sample at most max(open loop, v_max)
        change = self.voltage_for(target + (self.u - 1.0) * low) - voltage
        room = np.maximum(voltage, self.v_max) - voltage
        over = change > room
        rho = float(np.min(room[over] / change[over])) if over.any() else 1.0
        self._limited = rho < 1.0
        return voltage + rho * change


class SensorLoop:
    """Closes a :class:`~surfhap.render.chain.TextureChain`'s loop over a :class:`ForceSensor`:
    it becomes the chain's ``correction`` and is reset with it. Time is the chain's (samples
    processed); the sensor's stamps are not compared with it, only arrivals count."""

    def __init__(self, chain, sensor: ForceSensor, design: LoopDesign | None = None):
        self.chain, self.sensor, self.design = chain, sensor, design or LoopDesign()
        cfg = chain.config
        self.mu_panel = cfg.display.mu_panel
        self.controller = FrictionController(self.design, chain.control_rate, rendering_gain(chain.params.alpha, chain.alpha_calibrated),
                                             cfg.limits.v_max, chain.law.voltage_for)
        chain.correction = self
        self.reset()

    def reset(self) -> None:
        self.controller.reset()
        self._n, self._seen, self._clamped, self._last = 0, -math.inf, 0, 0.0

    def __call__(self, law: DriveBlock, load: np.ndarray) -> DriveBlock:
        n, now = load.shape[0], self._n / self.chain.control_rate
        self._n += n
        t, normal, shear = self.sensor.read()
        if t.shape[0]:  # the block's measurement: the mean of the samples that arrived, else the last one
            self._seen, self._last = now, float(np.mean(shear - self.mu_panel * normal))
        clamped = self.chain.safety.counters.clamped
        saturated, self._clamped = clamped > self._clamped, clamped
        v = self.controller.process(law.target, self.chain.law.low_band.force(load, law.mu_low), law.voltage,
                                    np.full(n, self._last), now - self._seen <= self.design.loss_timeout, saturated)
        return law._replace(voltage=v)
