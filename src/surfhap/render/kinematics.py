"""Kinematics stage: touch-latency prediction and finger speed, one law for live and offline.

Touch panels report the finger late (a few tens of ms, up to 2 cm in ordinary slides: 004
Sec. 4.2); the position can lead by a configurable latency with that paper's filter:

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
measured one and this is the speed every render uses, live and offline. The velocity
(``vx``, ``vy``, m/s) is the same difference per axis and filter; ``velocity_alpha`` replaces
the low-pass by the paper's per-sample smoothing with factor 0.45 (004 Sec. 4.2), ``speed``
then being the norm of the smoothed velocity. The step is one compiled function
(:func:`predict`) on a state array: the touch hold (:class:`surfhap.render.hold.TouchHold`)
calls it inside its compiled loop, the force loop through :meth:`TouchPredictor.update`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from surfhap.errors import ConfigError

__all__ = ["TouchPredictor", "predict"]

# the state array of a predictor: parameters, then the filter state
_LATENCY, _ALPHA, _K_PRED, _MAX_GAP, _MAX_K, _TAU, _VALPHA = range(7)  # k_pred, velocity_alpha: NaN = None
_STARTED, _T, _MX, _MY, _X, _Y, _SPEED, _VX, _VY = range(7, 16)


@numba.njit(cache=True, nogil=True)
def predict(p, t, x, y):
    """One touch sample (t s, x, y m) into the predictor state ``p`` ((16,) float, see
    :class:`TouchPredictor`): eq. 6, eq. 7 and the speed low-pass."""
    if not (math.isfinite(t) and math.isfinite(x) and math.isfinite(y)):
        return  # sources validate; this keeps the state finite whatever reaches it
    if p[_STARTED] == 0.0 or not (0.0 < t - p[_T] <= p[_MAX_GAP]):
        if p[_STARTED] != 0.0 and t - p[_T] <= 0.0 and t > p[_T] - p[_MAX_GAP]:
            p[_MX] = x  # duplicate / out-of-order time stamp: keep the state, take the position
            p[_MY] = y
            return
        p[_STARTED] = 1.0
        p[_T], p[_MX], p[_MY], p[_X], p[_Y] = t, x, y, x, y
        p[_SPEED] = p[_VX] = p[_VY] = 0.0
        return
    dt = t - p[_T]
    k = p[_K_PRED]  # eq. 6's gain: fixed, or derived from the latency (see the module docstring)
    if k != k:
        k = 0.0
        if p[_LATENCY] != 0.0:
            k = min(p[_LATENCY] / dt + (1.0 - p[_ALPHA]) / p[_ALPHA], p[_MAX_K])
    # eq. 6: linear prediction from the last two measured positions
    px = x + k * (x - p[_MX])
    py = y + k * (y - p[_MY])
    # eq. 7 with its missing '+' restored: exponential smoothing on the previous output
    a = p[_ALPHA]
    nx = a * px + (1.0 - a) * p[_X]
    ny = a * py + (1.0 - a) * p[_Y]
    rvx = (nx - p[_X]) / dt
    rvy = (ny - p[_Y]) / dt
    g = p[_VALPHA]
    if g != g:
        g = dt / (p[_TAU] + dt)
        p[_SPEED] += g * (math.hypot(rvx, rvy) - p[_SPEED])
    p[_VX] += g * (rvx - p[_VX])
    p[_VY] += g * (rvy - p[_VY])
    if p[_VALPHA] == p[_VALPHA]:
        p[_SPEED] = math.hypot(p[_VX], p[_VY])
    p[_T], p[_MX], p[_MY], p[_X], p[_Y] = t, x, y, nx, ny


class TouchPredictor:
    """``update(t, x, y) -> None`` per touch sample, then read ``x``, ``y``, ``speed``, ``vx``,
    ``vy``; ``state`` is the (16,) float array :func:`predict` works on.

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
            raise ConfigError("must be within 0-0.2 s", field="latency")
        if not (math.isfinite(alpha) and 0.0 < alpha <= 1.0):
            raise ConfigError("must be in (0, 1]", field="alpha")
        if k_pred is not None and not (math.isfinite(k_pred) and 0.0 <= k_pred <= 100.0):
            raise ConfigError("must be within 0-100", field="k_pred")
        if not (math.isfinite(cutoff) and cutoff > 0):
            raise ConfigError("must be > 0 Hz", field="cutoff")
        if velocity_alpha is not None and not (math.isfinite(velocity_alpha) and 0.0 < velocity_alpha <= 1.0):
            raise ConfigError("must be in (0, 1]", field="velocity_alpha")
        self.state = np.zeros(16)
        self.state[:_STARTED] = (latency, alpha, math.nan if k_pred is None else k_pred, max_gap, max_k,
                                 1.0 / (2.0 * math.pi * cutoff), math.nan if velocity_alpha is None else velocity_alpha)

    def reset(self) -> None:
        self.state[_STARTED:] = 0.0

    def update(self, t: float, x: float, y: float) -> None:
        predict(self.state, t, x, y)

    started = property(lambda self: self.state[_STARTED] != 0.0)
    x = property(lambda self: float(self.state[_X]), doc="m, corrected position (eq. 7 output)")
    y = property(lambda self: float(self.state[_Y]))
    speed = property(lambda self: float(self.state[_SPEED]), doc="m/s")
    vx = property(lambda self: float(self.state[_VX]), doc="m/s, smoothed velocity")
    vy = property(lambda self: float(self.state[_VY]))
