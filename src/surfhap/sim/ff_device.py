"""A simulated 3-DoF impedance device carrying a tablet, and a simulated finger on it.

:class:`SimDevice` is a mass-spring-damper per axis, integrated by semi-implicit (symplectic)
Euler at the haptic rate: ``v += a dt`` then ``p += v dt``. Its input is the force command
in *device units*, divided by ``gain`` into newtons, as a Falcon through CHAI3D needs
(004 Sec. 4.3: the device produces 1/4.5 of the requested force). Numbers:

* mass: the tablet, 0.389 kg (004 Sec. 4.1) plus ``extra_mass`` (adapter; not given);
* gravity acts on z (the screen is horizontal, z up, 004 Sec. 3.1);
* damping 0.5 N s/m, spring 0 N/m per axis. CHOICE: the paper gives no device dynamics; a
  Falcon has no centring spring and light motor friction;
* end stops at 1.25 x the Falcon workspace (CHAI3D workspace radius 0.04 m): a hard stop
  that zeroes the velocity into it (mechanical limit, beyond the safety stage's walls).

:class:`SimFinger` moves along a :class:`~surfhap.models.trajectory.Trajectory` in the world
(position-driven in x, y; the person's arm is far stiffer than the screen's lateral
holding), presses with the trajectory's load on the screen, drags it with Coulomb friction
``mu load`` (CHOICE: mu = 0 by default, so effects are judged without help from friction),
and reports touches as the tablet would: screen coordinates (finger world position minus the
screen's displacement from X0) sampled at ``touch_rate``
(60 Hz, 004 Sec. 4.2) and delivered ``latency`` s late (default 40 ms, "a few dozens
of ms", 004 Sec. 4.2).
"""

from __future__ import annotations

import math

import numpy as np

from surfhap.ff.params import GRAVITY, TABLET_MASS

__all__ = ["SimDevice", "SimFinger"]


class SimDevice:
    """``step(command (3,), external (3,) N)`` advances one tick; read ``p`` and ``v`` (3,) m, m/s."""

    def __init__(self, rate: float = 1000.0, extra_mass: float = 0.0, damping=(0.5, 0.5, 0.5),
                 spring=(0.0, 0.0, 0.0), gain: float = 1.0, stops=(0.05, 0.05, 0.05), gravity: bool = True):
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self.mass = TABLET_MASS + float(extra_mass)
        if not self.mass > 0:
            raise ValueError("mass must be > 0")
        self.b = np.asarray(damping, dtype=float)
        self.k = np.asarray(spring, dtype=float)
        self.gain = float(gain)
        self.stops = np.asarray(stops, dtype=float)
        self.g = GRAVITY if gravity else 0.0
        self.p = np.zeros(3)
        self.v = np.zeros(3)
        self.applied = np.zeros(3)  # N, last force the actuators produced

    def reset(self, p=None) -> None:
        self.p[:] = 0.0 if p is None else p
        self.v[:] = 0.0
        self.applied[:] = 0.0

    def step(self, command, external) -> None:
        dt, m = self.dt, self.mass
        for i in range(3):
            fa = float(command[i]) / self.gain
            self.applied[i] = fa
            f = fa + float(external[i]) - self.b[i] * self.v[i] - self.k[i] * self.p[i]
            if i == 2:
                f -= m * self.g
            v = self.v[i] + f / m * dt
            p = self.p[i] + v * dt
            lim = self.stops[i]
            if p > lim:
                p, v = lim, min(v, 0.0)
            elif p < -lim:
                p, v = -lim, max(v, 0.0)
            self.v[i] = v
            self.p[i] = p


class SimFinger:
    """A finger following ``trajectory`` (world / content coordinates, m) with its load (N).

    ``force_on_screen(t, v_screen)`` -> (3,) N it applies to the screen at time t;
    ``touches(t_to)`` returns the touch reports due by ``t_to`` and not yet returned, as
    ``(t_report, x_screen, y_screen, load, t_event)``; call ``record_screen(t, p)`` each tick
    so the reports see where the screen was at sampling time.
    """

    def __init__(self, trajectory, touch_rate: float = 60.0, latency: float = 0.040, mu: float = 0.0,
                 friction_speed: float = 0.005, pixel: float = 0.0):
        self.tr = trajectory
        self.touch_rate = float(touch_rate)
        self.latency = float(latency)
        self.mu = float(mu)
        self.friction_speed = float(friction_speed)  # m/s, smoothing of sign(v) in Coulomb friction
        self.pixel = float(pixel)  # m, quantisation of reported positions (0 = none)
        t = trajectory.t
        self.t0, self.t1 = float(t[0]), float(t[-1])
        dt = np.gradient(t)
        self._vx = np.gradient(trajectory.x) / dt
        self._vy = np.gradient(trajectory.y) / dt
        self._hist_t: list[float] = []
        self._hist_p: list[tuple[float, float]] = []
        self._next_sample = self.t0
        self._k = 0  # reports already delivered

    def position(self, t: float) -> tuple[float, float]:
        tr = self.tr
        return float(np.interp(t, tr.t, tr.x)), float(np.interp(t, tr.t, tr.y))

    def velocity(self, t: float) -> tuple[float, float]:
        return float(np.interp(t, self.tr.t, self._vx)), float(np.interp(t, self.tr.t, self._vy))

    def load(self, t: float) -> float:
        if t < self.t0 or t > self.t1:
            return 0.0
        return float(np.interp(t, self.tr.t, self.tr.load))

    def force_on_screen(self, t: float, v_screen) -> np.ndarray:
        f = np.zeros(3)
        ld = self.load(t)
        if ld <= 0.0:
            return f
        f[2] = -ld
        if self.mu > 0.0:
            fvx, fvy = self.velocity(t)
            rx, ry = fvx - float(v_screen[0]), fvy - float(v_screen[1])
            r = math.hypot(rx, ry)
            if r > 0.0:
                g = self.mu * ld * math.tanh(r / self.friction_speed) / r
                f[0], f[1] = g * rx, g * ry
        return f

    def record_screen(self, t: float, p) -> None:
        """Remember the screen position at tick time t (for the sampling of touch reports)."""
        while t >= self._next_sample - 1e-12 and self._next_sample <= self.t1 + 1.0 / self.touch_rate:
            ts = self._next_sample
            self._hist_t.append(ts)
            self._hist_p.append((float(p[0]), float(p[1])))
            self._next_sample = ts + 1.0 / self.touch_rate

    def touches(self, t_to: float):
        """Reports whose delivery time ``t_sample + latency`` is <= t_to, not yet returned."""
        out = []
        ht, hp = self._hist_t, self._hist_p
        while self._k < len(ht) and ht[self._k] + self.latency <= t_to:
            ts = ht[self._k]
            sx, sy = hp[self._k]
            self._k += 1
            ld = self.load(ts)
            fx, fy = self.position(ts)
            x, y = fx - sx, fy - sy
            if self.pixel > 0:
                x = round(x / self.pixel) * self.pixel
                y = round(y / self.pixel) * self.pixel
            out.append((ts + self.latency, x, y, ld, ts))
        return out
