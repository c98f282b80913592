"""Kinematics stage: touch-latency prediction and finger speed, one law for live and offline.

Touch panels report the finger late: a few tens of ms on the tablet of KinesTouch
(paper 004, Sec. 4.2), up to 2 cm of position error in ordinary slides. The live engine can lead the measured position by a
configurable latency with the prediction-correction filter of that paper:

* linear prediction (eq. 6):  f_pred = f_mes + k_pred (f_mes - f_mes_prev)
* exponential smoothing (eq. 7): the printed equation, ``f = alpha f_pred (1 - alpha) f_pred_prev``,
  lacks a '+' between its two terms. What is physically meant, and what "exponential
  smoothing" names, is the recursive filter

      f = alpha * f_pred + (1 - alpha) * f_prev

  with ``f_prev`` the previous *corrected* position (the filter's own output; the paper's
  ``f_pred_prev`` read literally would make a two-tap average, which is not an exponential
  smoother). This is what :meth:`TouchPredictor.update` computes.

The paper fixes k_pred = 8 samples and alpha = 0.15 for a 60 Hz tablet. Here samples carry
their own time stamps, so k_pred is derived per sample from the latency to compensate: the
smoother lags a ramp by ``dt (1 - alpha) / alpha`` seconds, so leading by ``latency``
seconds needs ``k_pred = latency / dt + (1 - alpha) / alpha`` (paper values: 8 samples at
60 Hz with alpha 0.15 is a net lead of (8 - 5.67) / 60 s = 39 ms, "a few dozens of ms").
A fixed ``k_pred`` can be given instead to reproduce the paper exactly.

Speed is the distance between consecutive (corrected) positions over their time
difference, smoothed by a one-pole low-pass of ``cutoff`` Hz (hand motion lies below a few
Hz, Otake et al. 2021 Sec. III-B). Without prediction (the default) the position is the
measured one and this is the speed every render uses, live and offline (through
:class:`surfhap.render.hold.TouchHold`). The velocity vector (``vx``, ``vy``, m/s)
is the same difference per axis and filter. ``velocity_alpha`` replaces that low-pass by
the paper's own velocity filter: exponential smoothing per sample with factor 0.45
(004 Sec. 4.2, last sentence of "Handling latency issues"); ``speed`` is then the norm of
the smoothed velocity. All arithmetic is on Python floats:
nothing allocates per sample, so it may run inside the real-time callback.
"""

from __future__ import annotations

import math

__all__ = ["TouchPredictor"]


class TouchPredictor:
    """``update(t, x, y) -> None`` per touch sample, then read ``x``, ``y``, ``speed``.

    latency : s, touch latency to compensate (0 = no prediction).
    alpha   : smoothing factor of eq. 7 in (0, 1]; 1 = no smoothing.
    k_pred  : fixed prediction gain of eq. 6 (samples); None = derived from ``latency``.
    cutoff  : Hz, low-pass of the speed estimate.
    max_gap : s, a gap between samples longer than this restarts the filters.
    max_k   : largest prediction gain used (bounds the noise amplification at fast sensors).
    velocity_alpha : per-sample exponential smoothing factor of the velocity in (0, 1]
              (paper: 0.45); None = the ``cutoff`` low-pass.
    """

    def __init__(self, latency: float = 0.0, alpha: float = 1.0, k_pred: float | None = None,
                 cutoff: float = 20.0, max_gap: float = 0.1, max_k: float = 20.0,
                 velocity_alpha: float | None = None):
        if not (math.isfinite(latency) and 0.0 <= latency <= 0.2):
            raise ValueError("latency must be within 0-0.2 s")
        if not (math.isfinite(alpha) and 0.0 < alpha <= 1.0):
            raise ValueError("alpha must be in (0, 1]")
        if k_pred is not None and not (math.isfinite(k_pred) and 0.0 <= k_pred <= 100.0):
            raise ValueError("k_pred must be within 0-100")
        if not (math.isfinite(cutoff) and cutoff > 0):
            raise ValueError("cutoff must be > 0 Hz")
        if velocity_alpha is not None and not (math.isfinite(velocity_alpha) and 0.0 < velocity_alpha <= 1.0):
            raise ValueError("velocity_alpha must be in (0, 1]")
        self.velocity_alpha = None if velocity_alpha is None else float(velocity_alpha)
        self.latency = float(latency)
        self.alpha = float(alpha)
        self.k_pred = None if k_pred is None else float(k_pred)
        self.cutoff = float(cutoff)
        self.max_gap = float(max_gap)
        self.max_k = float(max_k)
        self._tau = 1.0 / (2.0 * math.pi * self.cutoff)
        self.reset()

    def reset(self) -> None:
        self.started = False
        self.t = 0.0
        self.mx = 0.0  # previous measured position (eq. 6 f_mes_prev)
        self.my = 0.0
        self.x = 0.0  # corrected position (eq. 7 output)
        self.y = 0.0
        self.speed = 0.0
        self.vx = 0.0  # smoothed velocity, m/s
        self.vy = 0.0

    def gain(self, dt: float) -> float:
        """k_pred of eq. 6 for a sample interval ``dt``."""
        if self.k_pred is not None:
            return self.k_pred
        if self.latency == 0.0:
            return 0.0
        k = self.latency / dt + (1.0 - self.alpha) / self.alpha
        return k if k < self.max_k else self.max_k

    def update(self, t: float, x: float, y: float) -> None:
        if not (math.isfinite(t) and math.isfinite(x) and math.isfinite(y)):
            return  # sources validate; this keeps the state finite whatever reaches it
        if not self.started or not (0.0 < t - self.t <= self.max_gap):
            if self.started and t - self.t <= 0.0 and t > self.t - self.max_gap:
                # duplicate / out-of-order time stamp: keep the state, take the position
                self.mx, self.my = x, y
                return
            self.started = True
            self.t, self.mx, self.my, self.x, self.y = t, x, y, x, y
            self.speed = self.vx = self.vy = 0.0
            return
        dt = t - self.t
        k = self.gain(dt)
        # eq. 6: linear prediction from the last two measured positions
        px = x + k * (x - self.mx)
        py = y + k * (y - self.my)
        # eq. 7 with its missing '+' restored: exponential smoothing on the previous output
        a = self.alpha
        nx = a * px + (1.0 - a) * self.x
        ny = a * py + (1.0 - a) * self.y
        rvx = (nx - self.x) / dt
        rvy = (ny - self.y) / dt
        if self.velocity_alpha is None:
            g = dt / (self._tau + dt)
            self.speed += g * (math.hypot(rvx, rvy) - self.speed)
        else:
            g = self.velocity_alpha
        self.vx += g * (rvx - self.vx)
        self.vy += g * (rvy - self.vy)
        if self.velocity_alpha is not None:
            self.speed = math.hypot(self.vx, self.vy)
        self.t, self.mx, self.my, self.x, self.y = t, x, y, nx, ny
