"""The force safety stage: the last processor before any device backend.

Per tick it turns the control law's force (N, device frame) into the force sent to the
device, and for *any* input sequence (property-tested with hypothesis, also through the
whole loop in ``tests/test_ff_loop_property.py``) guarantees:

* ``|F_i| <= f_max_i`` on each axis;
* ``|F_i[n] - F_i[n-1]| <= slew / rate`` on each axis (no jumps, including at effect
  switches, touch / lift, faults, exceptions and stop: every change, towards zero too, is a ramp);
* a non-finite force, a non-finite device position or one beyond ``position_bound``, or a
  position implying a speed above ``max_speed`` -> the output ramps to zero (fault / rejected);
* no fresh device position for ``device_timeout`` (10 ms) -> the output ramps to zero (a full
  scale force reaches zero within ``f_max / slew`` more);
* ``stop`` -> lateral axes ramp to zero; the weight compensation is lowered to zero over
  ``land_time`` while ``land_damping`` brakes the descent (the tablet is put down, not dropped);
* workspace: towards a wall the screen speed is held to ``sqrt(2 a d)`` (the brake, d the
  distance to the wall less ``brake_margin``); beyond the box ``|X_t,i| <= workspace_i`` a
  component pushing further out is dropped and a damped wall spring pushes back in.

Clock and stamps. The stage keeps its own clock: it advances by the caller's tick interval,
but by at least one period per tick and at most ``MAX_STEP`` (a stopped, backwards, non-finite
or runaway caller clock cannot stop it). A position's stamp ``t_pos`` (caller clock) only
orders samples and can only make a sample *older*: a new stamp is taken as arriving on this
tick, aged by ``t - t_pos`` when that is positive. A stamp in the future (beyond one period,
a thread race), non-finite or older than the last one is *stale* (counted): that tick the
output ramps towards zero. So no stamp can extend the watchdog.

The newtons are converted into device units (``gain``) by the backend, after this stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from surfhap.ff.params import DeviceParams

__all__ = ["ForceSafety", "ForceSafetyCounters", "MAX_STEP"]

MAX_STEP = 1.0  # s, largest clock advance per tick (a stall beyond this is past every timeout anyway)
_EPS = 1e-9  # s, rounding of the watchdog comparison


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
    stale: int = 0
    rejected: int = 0
    braked: int = 0


class ForceSafety:
    """``process(force, t, t_pos, px, py, pz, stop=False) -> (3,) N``.

    force        : (3,) requested force, N.
    t            : s, now (the caller's clock).
    t_pos        : s, the caller's time stamp of the device position (orders samples only).
    px, py, pz   : m, that position relative to X0.
    stop         : lower the tablet and ramp to zero, and stay there.

    The engine calls :meth:`observe` before its control law (to use the accepted position and
    the velocity ``v``) and :meth:`limit` after; :meth:`process` does both.
    """

    def __init__(self, device: DeviceParams, rate: float = 1000.0, velocity_cutoff: float = 100.0):
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError("rate must be > 0 Hz")
        if not (math.isfinite(velocity_cutoff) and velocity_cutoff > 0):
            raise ValueError("velocity_cutoff must be > 0 Hz")
        self.device = device
        self.rate = float(rate)
        self.period = 1.0 / self.rate
        self.f_max = tuple(device.f_max)
        self.ws = tuple(device.workspace)
        self.bound = device.position_bound
        self.step = device.slew / self.rate  # N per tick
        self.wall_k = device.wall_k
        self.timeout = device.device_timeout
        self._tau = 1.0 / (2.0 * math.pi * velocity_cutoff)
        self._gravity = (0.0, 0.0, device.weight)  # N the weight compensation provides per axis
        self.out = np.zeros(3)
        self._prev = [0.0, 0.0, 0.0]
        self.p = [0.0, 0.0, 0.0]  # last accepted position, m
        self.v = [0.0, 0.0, 0.0]  # its velocity (one-pole low-pass of differences), m/s
        self.reset()

    def reset(self) -> None:
        self._prev[0] = self._prev[1] = self._prev[2] = 0.0
        self.out[:] = 0.0
        self.p[0] = self.p[1] = self.p[2] = 0.0
        self.v[0] = self.v[1] = self.v[2] = 0.0
        self.now = 0.0  # s, own clock
        self._raw = math.nan  # last finite caller time
        self._stamp = -math.inf  # newest accepted position stamp (caller clock)
        self._pos_at = -math.inf  # its arrival on the own clock
        self._p_at = -math.inf  # own-clock time of the last accepted position
        self._zero = True  # this tick's position does not allow a force
        self._stop_at = math.inf
        self.n_ticks = self.n_clamped = self.n_slew = self.n_faults = self.n_lost = self.n_ws = self.n_stop = 0
        self.n_stale = self.n_rejected = self.n_brake = 0

    @property
    def counters(self) -> ForceSafetyCounters:
        return ForceSafetyCounters(self.n_ticks, self.n_clamped, self.n_slew, self.n_faults, self.n_lost, self.n_ws,
                                   self.n_stop, self.n_stale, self.n_rejected, self.n_brake)

    @property
    def stop_duration(self) -> float:
        """s, longest stop from any output: the landing plus a full-scale ramp."""
        return self.device.land_time + 2.0 * max(self.f_max) / self.device.slew + 10.0 * self.period

    def process(self, force, t: float, t_pos: float, px: float, py: float, pz: float, stop: bool = False) -> np.ndarray:
        """Safe force (3,) N (a view of ``self.out``) for the requested ``force`` (3,)."""
        return self.process_xyz(float(force[0]), float(force[1]), float(force[2]), t, t_pos, px, py, pz, stop)

    def process_xyz(self, f0: float, f1: float, f2: float, t: float, t_pos: float, px: float, py: float, pz: float,
                    stop: bool = False) -> np.ndarray:
        """:meth:`process` with the force as three floats."""
        self.observe(t, t_pos, px, py, pz)
        return self.limit(f0, f1, f2, stop)

    # ------------------------------------------------------------ inputs
    def _advance(self, t: float) -> float:
        raw = self._raw
        dt = t - raw if (t == t and abs(t) != math.inf and raw == raw) else self.period
        if not dt >= self.period:  # stopped, backwards or first tick
            dt = self.period
        elif dt > MAX_STEP:
            dt = MAX_STEP
        if t == t and abs(t) != math.inf:
            self._raw = t
        else:
            self.n_faults += 1
        self.now += dt
        return self.now

    def observe(self, t: float, t_pos: float, px: float, py: float, pz: float) -> bool:
        """Advance the clock one tick and take the device position if it is plausible;
        True when it was accepted (``p``, ``v`` updated)."""
        self.n_ticks += 1
        c = self._advance(t)
        self._zero = True
        if not (t_pos == t_pos and abs(t_pos) != math.inf and t == t and t_pos <= t + self.period
                and t_pos >= self._stamp):
            self.n_stale += 1
            return False
        b = self.bound
        if not (abs(px) <= b[0] and abs(py) <= b[1] and abs(pz) <= b[2]):  # also NaN
            self.n_faults += 1
            return False
        p, v = self.p, self.v
        h = c - self._p_at
        if h <= self.timeout:
            d = max(abs(px - p[0]), abs(py - p[1]), abs(pz - p[2]))
            if d > self.device.max_speed * h:
                self.n_rejected += 1
                return False
            g = h / (self._tau + h)
            v[0] += g * ((px - p[0]) / h - v[0])
            v[1] += g * ((py - p[1]) / h - v[1])
            v[2] += g * ((pz - p[2]) / h - v[2])
        else:  # first position, or after a gap: no difference to take
            v[0] = v[1] = v[2] = 0.0
        p[0], p[1], p[2] = px, py, pz
        self._p_at = c
        if t_pos > self._stamp:
            self._stamp = t_pos
            age = t - t_pos
            self._pos_at = c - (age if age > 0.0 else 0.0)
        if c - self._pos_at <= self.timeout + _EPS:
            self._zero = False
        else:
            self.n_lost += 1
        return True

    # ------------------------------------------------------------ output
    def limit(self, f0: float, f1: float, f2: float, stop: bool = False) -> np.ndarray:
        """The safe force for the requested one, given this tick's :meth:`observe`."""
        zero = self._zero
        if not (math.isfinite(f0) and math.isfinite(f1) and math.isfinite(f2)):
            self.n_faults += 1
            zero = True
        if stop:
            self.n_stop += 1
            if self._stop_at == math.inf:
                self._stop_at = self.now
        if zero:
            f0 = f1 = f2 = 0.0
        elif stop:
            f0 = f1 = 0.0
            left = 1.0 - (self.now - self._stop_at) / self.device.land_time if self.device.land_time > 0 else 0.0
            f2 = self._gravity[2] * left - self.device.land_damping * self.v[2] if left > 0.0 else 0.0
        else:
            f0 = self._wall(0, f0)
            f1 = self._wall(1, f1)
            f2 = self._wall(2, f2)
        prev = self._prev
        out = self.out
        step = self.step
        clamped = slewed = False
        for i, f in ((0, f0), (1, f1), (2, f2)):  # clamp to +-f_max, then limit the change
            m = self.f_max[i]
            if f > m:
                f = m; clamped = True
            elif f < -m:
                f = -m; clamped = True
            p = prev[i]
            if f > p + step:
                f = p + step; slewed = True
            elif f < p - step:
                f = p - step; slewed = True
            prev[i] = f
            out[i] = f
        if clamped:
            self.n_clamped += 1
        if slewed:
            self.n_slew += 1
        return out

    def _wall(self, i: int, f: float) -> float:
        """Brake towards the wall of axis i, and the damped wall beyond it."""
        p, v, w = self.p[i], self.v[i], self.ws[i]
        if p > w:
            self.n_ws += 1
            return min(f, 0.0) - self.wall_k * (p - w) - self.device.wall_damping * v
        if p < -w:
            self.n_ws += 1
            return max(f, 0.0) + self.wall_k * (-w - p) - self.device.wall_damping * v
        s = 1.0 if v > 0.0 else -1.0
        dev = self.device
        a = dev.brake_decel
        # the output turns at the slew rate: project the motion over the time the net force needs
        # to go from its present value (along the motion) to braking at m a
        f_net = s * (self._prev[i] - self._gravity[i])
        m = dev.moving_mass if dev.moving_mass > 0.0 else 1.0
        turn = (f_net + m * a) / dev.slew if f_net + m * a > 0.0 else 0.0
        dv = (f_net * turn - 0.5 * dev.slew * turn * turn) / m
        d = w - s * p - dev.brake_margin - (s * v * turn + 0.5 * dv * turn)  # distance left once braking
        v_lim = math.sqrt(2.0 * a * d) if d > 0.0 else 0.0
        excess = s * v + (dv if dv > 0.0 else 0.0) - v_lim
        if excess > 0.0:
            # along the motion at most: brake B x excess (the weight compensation counted on z)
            cap = s * self._gravity[i] - dev.brake_gain * excess
            if s * f > cap:
                self.n_brake += 1
                return s * cap
        return f
