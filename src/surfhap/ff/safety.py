"""The force safety stage: the last processor before any device backend.

Per tick it turns the control law's force (N, device frame) into the force sent to the
device, and for *any* input sequence (property-tested with hypothesis) guarantees:

* ``|F_i| <= f_max_i`` on each axis;
* ``|F_i[n] - F_i[n-1]| <= slew / rate`` on each axis (no jumps, including at effect
  switches, touch / lift, faults and stop: every change, towards zero too, is a ramp);
* a non-finite force or device position -> the output ramps to zero (fault);
* no device position for ``device_timeout`` (10 ms) -> the output ramps to zero (a full
  scale force reaches zero within ``f_max / slew`` more);
* ``stop`` -> ramp to zero (clean stop);
* workspace: beyond the box ``|X_t,i| <= workspace_i`` a component pushing further out is
  dropped and a wall spring ``wall_k`` pushes back in.

The newtons are converted into device units (``gain``) by the backend, after this stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from surfhap.ff.params import DeviceParams

__all__ = ["ForceSafety", "ForceSafetyCounters"]


@dataclass(frozen=True)
class ForceSafetyCounters:
    """Tick counts since the last reset."""

    ticks: int
    clamped: int
    slew_limited: int
    faults: int
    device_lost: int
    workspace: int
    stopped: int


class ForceSafety:
    """``process(force, t, t_pos, px, py, pz, stop=False) -> (3,) N``.

    force        : (3,) requested force, N.
    t            : s, now (engine clock).
    t_pos        : s, time of the freshest device position.
    px, py, pz   : m, that position relative to X0.
    stop         : ramp to zero and stay there.
    """

    def __init__(self, device: DeviceParams, rate: float = 1000.0):
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError("rate must be > 0 Hz")
        self.device = device
        self.rate = float(rate)
        self.f_max = tuple(device.f_max)
        self.ws = tuple(device.workspace)
        self.step = device.slew / self.rate  # N per tick
        self.wall_k = device.wall_k
        self.timeout = device.device_timeout
        self.out = np.zeros(3)
        self._prev = [0.0, 0.0, 0.0]
        self.reset()

    def reset(self) -> None:
        self._prev[0] = self._prev[1] = self._prev[2] = 0.0
        self.out[:] = 0.0
        self.n_ticks = self.n_clamped = self.n_slew = self.n_faults = self.n_lost = self.n_ws = self.n_stop = 0

    @property
    def counters(self) -> ForceSafetyCounters:
        return ForceSafetyCounters(self.n_ticks, self.n_clamped, self.n_slew, self.n_faults, self.n_lost, self.n_ws,
                                   self.n_stop)

    def process(self, force, t: float, t_pos: float, px: float, py: float, pz: float, stop: bool = False) -> np.ndarray:
        """Safe force (3,) N (a view of ``self.out``) for the requested ``force`` (3,)."""
        return self.process_xyz(float(force[0]), float(force[1]), float(force[2]), t, t_pos, px, py, pz, stop)

    def process_xyz(self, f0: float, f1: float, f2: float, t: float, t_pos: float, px: float, py: float, pz: float,
                    stop: bool = False) -> np.ndarray:
        """:meth:`process` with the force as three floats (the engine's path)."""
        self.n_ticks += 1
        zero = False
        if not (math.isfinite(f0) and math.isfinite(f1) and math.isfinite(f2) and math.isfinite(px)
                and math.isfinite(py) and math.isfinite(pz) and math.isfinite(t)):
            self.n_faults += 1
            zero = True
        elif not t - t_pos <= self.timeout:  # also no position ever (t_pos = -inf) or NaN
            self.n_lost += 1
            zero = True
        if stop:
            self.n_stop += 1
            zero = True
        if zero:
            f0 = f1 = f2 = 0.0
        else:
            ws = self.ws
            wk = self.wall_k
            hit = False
            if px > ws[0]:
                f0 = min(f0, 0.0) - wk * (px - ws[0]); hit = True
            elif px < -ws[0]:
                f0 = max(f0, 0.0) + wk * (-ws[0] - px); hit = True
            if py > ws[1]:
                f1 = min(f1, 0.0) - wk * (py - ws[1]); hit = True
            elif py < -ws[1]:
                f1 = max(f1, 0.0) + wk * (-ws[1] - py); hit = True
            if pz > ws[2]:
                f2 = min(f2, 0.0) - wk * (pz - ws[2]); hit = True
            elif pz < -ws[2]:
                f2 = max(f2, 0.0) + wk * (-ws[2] - pz); hit = True
            if hit:
                self.n_ws += 1
        prev = self._prev
        out = self.out
        step = self.step
        m0, m1, m2 = self.f_max
        clamped = slewed = False
        # per axis: clamp to +-f_max, then limit the change from the previous output
        if f0 > m0:
            f0 = m0; clamped = True
        elif f0 < -m0:
            f0 = -m0; clamped = True
        if f1 > m1:
            f1 = m1; clamped = True
        elif f1 < -m1:
            f1 = -m1; clamped = True
        if f2 > m2:
            f2 = m2; clamped = True
        elif f2 < -m2:
            f2 = -m2; clamped = True
        p0, p1, p2 = prev
        if f0 > p0 + step:
            f0 = p0 + step; slewed = True
        elif f0 < p0 - step:
            f0 = p0 - step; slewed = True
        if f1 > p1 + step:
            f1 = p1 + step; slewed = True
        elif f1 < p1 - step:
            f1 = p1 - step; slewed = True
        if f2 > p2 + step:
            f2 = p2 + step; slewed = True
        elif f2 < p2 - step:
            f2 = p2 - step; slewed = True
        prev[0] = f0
        prev[1] = f1
        prev[2] = f2
        out[0] = f0
        out[1] = f1
        out[2] = f2
        if clamped:
            self.n_clamped += 1
        if slewed:
            self.n_slew += 1
        return out
