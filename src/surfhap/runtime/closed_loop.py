"""Closed-loop friction: a force sensor corrects the electroadhesion gain of the low band.

Electroadhesion drifts (humidity, finger moisture, charge leakage): the same voltage gives
``r(t) = k(t) / k`` times the friction the display model predicts. With a force sensor the
low band (0 - ``cutoff`` Hz, :class:`~surfhap.signal.bands.BandSplit`) is made to track the
material's law; the texture band stays open loop:

* feed-forward: the drive law's own map from target force to voltage (``DriveLaw.voltage_for``,
  the display model's inverse);
* correction: the law's low-band target ``F_low`` (``LowBand.force``) is scaled by ``u``, the
  texture part is left alone: ``F = target + (u - 1) F_low``. ``u`` integrates the normalised
  low-band error ``e = 1 - low(f_meas) / low(G F_low)`` (``f_meas = shear - mu_panel normal``,
  G the rendering gain), so the loop is ``du/dt = Ki (1 - r u)``;
* bounds and anti-windup: ``u`` is clamped to ``[1 / (1 + D), 1 / (1 - D)]`` and does not
  integrate in a block after the safety stage clamped or the headroom limit bound; the headroom
  limit keeps each corrected sample at or below ``max(v_ff, v_max)`` so the loop never sends
  to the safety stage a sample that goes over v_max where the open loop's did not;
* fall-back: no sensor sample for ``loss_timeout`` s -> ``u`` ramps back to 1 (open loop).

Derivation of the gain (:class:`LoopDesign`). The low band is computed over the last
``2 / cutoff`` s, from means over one block period (the update rate), and read ``lag = 1 / (2
cutoff)`` s before the window's end (the zero-phase filter then has signal on both sides), so
the loop's delay is ``tau = sensor_delay + lag + block``. An integrator behind a
delay has the phase margin ``pi/2 - w_c tau`` at its crossover ``w_c = r Ki``; a margin of 60
degrees (the usual design rule, Astrom & Murray, Feedback Systems, Sec. 11.4) at the largest
gain ``r = 1 + D`` gives ``Ki = (pi/6) / ((1 + D) tau)``. A drift ``D sin(2 pi t / P)`` moves
at most ``rho = 2 pi D / P`` per second; a type-1 loop follows a ramp with the error
``rho / ((1 - D) Ki)`` (:attr:`LoopDesign.tracking_error`). The fall-back ramp moves ``u`` at
``(1 - D) Ki`` per second, the loop's own slowest rate.
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
    """What the loop's gain and bounds are derived from (see the module docstring), SI.

    sensor_delay    : s, delay of the force samples (issue 19: 1-5 ms; default its upper end).
    drift_amplitude : largest |k(t) / k - 1| corrected (issue 19: +-30 %).
    drift_period    : s, period of the slow drift (issue 19: over a minute).
    block           : s, the control update period (one block of the chain).
    cutoff          : Hz, low band / texture band split (3.5 Hz, Otake et al. 2022, 003 Sec. II).
    loss_timeout    : s, no sensor sample for this long -> open loop (issue 19: 20 ms).
    """

    sensor_delay: Annotated[float, Field(ge=0, le=0.1)] = 0.005
    drift_amplitude: Annotated[float, Field(gt=0, lt=1)] = 0.3
    drift_period: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 60.0
    block: Annotated[float, Field(gt=0, le=0.1)] = 0.010
    cutoff: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 3.5
    loss_timeout: Annotated[float, Field(gt=0, le=1)] = 0.020

    @property
    def lag(self) -> float:
        """s, how far before the window's end the low band is read: half a cut-off period."""
        return 0.5 / self.cutoff

    @property
    def window(self) -> float:
        """s, the history the low band is computed over: two cut-off periods."""
        return 2.0 / self.cutoff

    @property
    def loop_delay(self) -> float:
        return self.sensor_delay + self.lag + self.block

    @property
    def ki(self) -> float:
        """1/s, integral gain: 60 degrees of phase margin at the largest plant gain 1 + D."""
        return (math.pi / 6.0) / ((1.0 + self.drift_amplitude) * self.loop_delay)

    @property
    def bounds(self) -> tuple[float, float]:
        """(lowest, highest) correction u of the low-band target: 1 / (1 +- D)."""
        return 1.0 / (1.0 + self.drift_amplitude), 1.0 / (1.0 - self.drift_amplitude)

    @property
    def tracking_error(self) -> float:
        """Relative low-band error left while following the fastest drift (a ramp)."""
        rho = 2.0 * math.pi * self.drift_amplitude / self.drift_period
        return rho / ((1.0 - self.drift_amplitude) * self.ki)


class FrictionController:
    """The numerical loop: allocated once, ``reset()``, then ``process`` per block.

    ``voltage_for(target (n,) N) -> (n,) V`` is the feed-forward (the drive law's map), ``gain``
    the rendering gain G, ``v_max`` V the safety stage's limit, ``rate`` Hz the control rate.
    """

    def __init__(self, design: LoopDesign, rate: int, gain: float, v_max: float, voltage_for):
        self.design, self.rate, self.gain, self.v_max = design, int(rate), float(gain), float(v_max)
        self.voltage_for = voltage_for
        self.split = BandSplit(cutoff=design.cutoff)
        self.ki = design.ki
        self.u_lo, self.u_hi = design.bounds
        self._fallback_rate = (1.0 - design.drift_amplitude) * self.ki
        self._d = max(1, int(round(design.block * self.rate)))  # control samples per mean of the history
        self._hist = np.zeros((2, self._d * int(round(design.window / design.block))))  # G F_low, f_meas (N)
        m = self._hist.shape[1] // self._d
        # BandSplit.low is linear: its value lag means before the window's end is weights @ means,
        # the weights (m,) its response to each unit mean (computed once)
        self._weights = np.ascontiguousarray(self.split.low(np.eye(m), self.rate / self._d)[:, m - 1 - int(round(design.lag / design.block))])
        self.reset()

    def reset(self) -> None:
        self.u = 1.0
        self._valid = 0  # newest samples in the history that are in contact and sensed
        self._limited = False  # the headroom limit bound in the last block
        self._hist[:] = 0.0

    def _push(self, ref: np.ndarray, meas: np.ndarray) -> None:
        h, n = self._hist, ref.shape[0]
        if n >= h.shape[1]:
            h[0], h[1] = ref[n - h.shape[1]:], meas[n - h.shape[1]:]
        else:
            h[:, :-n] = h[:, n:]
            h[0, -n:], h[1, -n:] = ref, meas

    def process(self, target: np.ndarray, low: np.ndarray, voltage: np.ndarray, measured: np.ndarray,
                sensed: bool, saturated: bool) -> np.ndarray:
        """One block of n control samples; returns the corrected drive envelope (n,) V.

        target (n,) N the law's target, low (n,) N its low band (``LowBand.force``), voltage (n,) V
        the open-loop drive of ``target``, measured (n,) N the sensor's added friction on the
        control grid; ``sensed``: a sensor sample arrived within the loss timeout; ``saturated``:
        the safety stage clamped in the last block."""
        n = target.shape[0]
        dt = n / self.rate
        self._push(self.gain * low, measured)
        self._valid = self._valid + n if (sensed and np.all(low > 0.0)) else 0
        if not sensed:  # fall back: ramp to open loop
            step = self._fallback_rate * dt
            self.u = max(self.u - step, 1.0) if self.u > 1.0 else min(self.u + step, 1.0)
        elif self._valid >= self._hist.shape[1] and not (saturated or self._limited):
            lo = self._hist.reshape(2, -1, self._d).mean(axis=2) @ self._weights  # low band of means over block periods
            if lo[0] > 0.0:
                self.u = float(np.clip(self.u + self.ki * (1.0 - lo[1] / lo[0]) * dt, self.u_lo, self.u_hi))
        if self.u == 1.0:
            self._limited = False
            return voltage
        corrected = self.voltage_for(target + (self.u - 1.0) * low)
        out = np.minimum(corrected, np.maximum(voltage, self.v_max))
        self._limited = bool(np.any(out < corrected))
        return out


class SensorLoop:
    """Closes a :class:`~surfhap.render.chain.TextureChain`'s loop over a :class:`ForceSensor`:
    it becomes the chain's ``correction`` (called with each block's DriveBlock and load) and
    is reset with the chain. The loop's clock is the chain's (samples processed); the sensor's
    time stamps are not compared with it, only the arrival of samples is."""

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

    def _grid(self, x: np.ndarray, n: int) -> np.ndarray:
        """The k samples x that arrived during a block onto its n control samples: the mean of
        each of n equal runs of x, the previous value where a run is empty."""
        k = x.shape[0]
        if k == 0:
            return np.full(n, self._last)
        edges = (np.arange(n + 1) * k) // n
        sums = np.concatenate(([0.0], np.cumsum(x)))
        count = np.diff(edges)
        means = (sums[edges[1:]] - sums[edges[:-1]]) / np.maximum(count, 1)
        idx = np.maximum.accumulate(np.where(count > 0, np.arange(n), -1))
        out = np.where(idx >= 0, means[np.maximum(idx, 0)], self._last)
        self._last = float(out[-1])
        return out

    def __call__(self, law: DriveBlock, load: np.ndarray) -> DriveBlock:
        n = load.shape[0]
        now = self._n / self.chain.control_rate
        self._n += n
        t, normal, shear = self.sensor.read()
        if t.shape[0]:
            self._seen = now
        clamped = self.chain.safety.counters.clamped
        saturated, self._clamped = clamped > self._clamped, clamped
        low = self.chain.law.low_band.force(load, law.mu_low)
        v = self.controller.process(law.target, low, law.voltage, self._grid(shear - self.mu_panel * normal, n),
                                    now - self._seen <= self.design.loss_timeout, saturated)
        return law._replace(voltage=v)
