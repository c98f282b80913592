"""The force-feedback engine: touch kinematics -> effects (control law) -> safety stage, one tick
per call; with built-in effects the whole tick is one compiled call (:func:`surfhap.ff.tick_kernel.tick`,
the effects' laws in :mod:`surfhap.ff.effect_kernel`), this class holds their state arrays and
packs the effects when they are set.

Driven tick by tick by a clock that is not its business (:class:`surfhap.live.ff_loop.FFLoop`
on the runtime's wall or simulated clock): ``touch(t, x, y, load)`` per touch sample (screen
coordinates in m as the tablet reports them, load N, 0 = lifted, ``t`` its arrival in s);
``tick(t, px, py, pz, t_pos)`` once per haptic tick with the freshest device position (m,
relative to X0) and its stamp; it returns the safe force (3,) N in the device frame.

Control law: eq. 8 (004 Sec. 4.3), ``F = (m g + delta sin(phi)) e_z + alpha f_dot - nu f_dot ^ e_z
+ K (X0 + h e_z - X_t)``, the active effects merged (:meth:`FFEngine.merge`: per axis the most
compliant stiffness, offsets h and feed-forward forces summed), plus a damping ``-D v``,
``D = damping sqrt(K / K_max)`` on held axes (K_max on the tablet rings at 8 Hz without it), the
weight compensation always on, the reference height inside the workspace and bumpless switching
(the reference approaches ``X0 + h e_z`` at <= ``ref_speed`` per axis, follows the screen on a
free axis; the grating's offset is added after that limit). Not touched: Idle (eq. 5).

Safety stage, last before any backend, for *any* input (property-tested here and through the
loop, ``tests/test_ff_safety.py``, ``tests/test_ff_loop_property.py``): ``|F_i| <= f_max_i``;
``|F_i[n] - F_i[n-1]| <= slew / rate`` (every change, towards zero too, is a ramp); a non-finite
force or position, one beyond ``position_bound`` or implying a speed above ``max_speed`` -> ramp
to zero (fault / rejected); no fresh position for ``device_timeout`` -> ramp to zero; ``stop`` ->
lateral axes ramp to zero, the weight compensation is lowered over ``land_time`` while
``land_damping`` brakes the descent (the tablet is put down, not dropped); towards a wall the
screen speed is held to ``sqrt(2 a d)`` and beyond the box ``|X_t,i| <= workspace_i`` an outward
component is dropped and a damped wall spring pushes back. It keeps its own clock, advanced by
the caller's interval but by at least one period and at most ``MAX_STEP`` per tick; a
position's stamp (through :func:`surfhap.runtime.clock.arrival_stamp` upstream) only orders and
ages samples: non-finite or older than the last is stale. ``gain`` (N -> device units) is the backend's.

Screen -> world: the content is drawn shifted by ``-X_t`` so it stays still in the world; the
finger's world position is ``f_screen + X_t,xy`` with ``X_t`` taken when the touch was *sampled*
(``touch_latency`` before it arrived; 0.5 s of positions kept): a late touch mixed with the
current screen position feeds the screen's motion back (Sliding unstable for nu latency / m >
pi / 2). Prediction (``predictor``, a :class:`surfhap.render.kinematics.TouchPredictor`) runs on
the world stream, extrapolated between samples for at most ``max_extrapolate``.

Watchdogs, on the safety stage's own clock: no touch for ``touch_timeout`` -> Idle; no
device position for ``device_timeout`` -> zero force. A touch stamp older than the previous
one, non-finite or in the future is stale (rejected, or the finger counts as lifted); positions
beyond ``TOUCH_BOUND``, loads beyond ``MAX_LOAD`` and jumps faster than ``MAX_SPEED`` are
rejected (``touch_rejected``); the finger's acceleration is bounded by ``MAX_ACCELERATION``
(the finger bounds of :mod:`surfhap.models.finger`).

Failure: an exception in an effect is kept in ``error`` and turns the tick into a stop; the
safety stage still runs on every tick and ramps the force down. With a scene's GUI buttons,
``button`` is the pressed one each tick (-1 = none; :mod:`surfhap.ff.buttons`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from surfhap.ff import effect_kernel as ek, tick_kernel as kernel
from surfhap.ff.buttons import ButtonPresses
from surfhap.ff.effects import Effect, TickState
from surfhap.ff.params import DeviceParams
from surfhap.models.finger import MAX_ACCELERATION, MAX_LOAD, MAX_SPEED

__all__ = ["FFEngine", "FFCounters", "TOUCH_BOUND"]

TOUCH_BOUND = 1.0  # m, no tablet is larger: touch coordinates beyond are garbage (rejected)

# the safety stage's tick counts since the last reset, one per kernel counter
FFCounters = namedtuple("FFCounters", kernel.COUNTERS)


class FFEngine:
    """Kinematics + control law + safety for one scene on one device at ``rate`` Hz.

    effects         : list of :class:`surfhap.ff.effects.Effect`.
    device          : :class:`DeviceParams`.
    predictor       : touch prediction filter (see module docstring).
    rate            : Hz, haptic tick rate (004: 1 kHz).
    touch_latency   : s, age of a touch sample when it arrives (004: "a few dozens of ms";
                      the predictor should compensate the same latency).
    velocity_cutoff : Hz, one-pole low-pass of the device velocity (finite differences of
                      positions, in the safety stage). CHOICE: 100 Hz, well above the 8 Hz
                      K_max resonance.
    accel_cutoff    : Hz, one-pole low-pass of the finger acceleration (differences of the
                      predicted velocity per touch sample). CHOICE: 5 Hz, ten times the
                      0.5 Hz strokes of the paper's study (Sec. 5.2).
    max_extrapolate : s, longest extrapolation of the touch position between samples.
    buttons         : GUI buttons (:class:`surfhap.ff.buttons.Button`) whose press events
                      the engine tracks each tick (``button``, ``button_presses``).
    """

    def __init__(self, effects: list[Effect], device: DeviceParams, predictor, rate: float = 1000.0,
                 touch_latency: float = 0.0, velocity_cutoff: float = 100.0, accel_cutoff: float = 5.0,
                 max_extrapolate: float = 0.05, buttons=()):
        if not (math.isfinite(touch_latency) and 0.0 <= touch_latency <= 0.4):
            raise ValueError("touch_latency must be within 0-0.4 s")
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError("rate must be > 0 Hz")
        if not (math.isfinite(velocity_cutoff) and velocity_cutoff > 0):
            raise ValueError("velocity_cutoff must be > 0 Hz")
        self.touch_latency = float(touch_latency)
        self.device = device
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        # safety stage: state S, parameters P, counters N, output (3,) N; control law: reference R
        # (rx, ry, rz, fresh), parameters L (k_max, damping, weight, h_lim, ref_step); tick state T,
        # screen history H: views of the buffers Z, PL (tick_kernel layouts)
        self.max_extrapolate = float(max_extrapolate)
        L = np.array([device.k_max, device.damping, device.weight, device.workspace[2], device.ref_speed / rate])
        self.Z, self.PL = kernel.buffers(kernel.safety_params(device, self.rate, velocity_cutoff), L)
        views = kernel.views.py_func(self.Z, self.PL, np.zeros((0, ek.E_COLS + ek.X_COLS)))
        self.S, self.R, self.out, self.T, self.H, self.P, self.L = views[:7]
        self.N = np.zeros(len(kernel.COUNTERS), dtype=np.int64)
        self.effects = list(effects)  # packed by reset()
        self.predictor = predictor
        self._atau = 1.0 / (2.0 * math.pi * accel_cutoff)
        self.button_presses = ButtonPresses(buttons)  # reset() resets it and ``button``
        self._pending = self._switched = None
        self.reset()

    @staticmethod
    def _pack(effects: list[Effect]) -> tuple:
        """The effects of a scene packed for the compiled tick: ``(effects, EX, F, python)``, the
        built-in ones' rows (state reset) and data, ``python`` the ``(index, effect)`` evaluated in
        Python (code EXTERNAL: their terms go through ``X`` each tick)."""
        if len(effects) > 30:
            raise ValueError("at most 30 effects per scene")
        EX, data, size, python = np.zeros((len(effects), ek.E_COLS + ek.X_COLS)), [np.zeros(1)], 1, []
        for i, e in enumerate(effects):
            packed = e.packed()
            if packed is None:  # a zero row: code EXTERNAL
                python.append((i, e))
                continue
            EX[i, :ek.E_COLS] = packed[0]
            EX[i, ek._STATE] = 0.0  # reset
            if packed[1] is not None:
                EX[i, ek._FIELD] = size
                data.append(packed[1])
                size += packed[1].size
        return list(effects), EX, np.concatenate(data), python

    def _set_effects(self, packed: tuple) -> None:
        """Use packed effects (bit i of ``mask`` = effect i active); the reference restarts at the
        screen on the next tick (bumpless)."""
        self.effects, self.EX, self.F, self._python = packed
        self.E, self.X = self.EX[:, :ek.E_COLS], self.EX[:, ek.E_COLS:]
        for _, e in self._python:
            e.reset()
        self.T[kernel._MASK] = 0.0  # no effect active on the last tick (idle)
        self.R[:] = (0.0, 0.0, 0.0, 1.0)

    def reset(self) -> None:
        self._set_effects(self._pack(self.effects))
        self.button_presses.reset()
        self.button = -1
        self.S[:] = kernel.new_state()
        self.N[:] = 0
        self.out[:] = 0.0
        self.predictor.reset()
        self.T[:] = kernel.new_tick_state(self.dt, self.device.touch_timeout, self.max_extrapolate)
        self._pvx = self._pvy = 0.0
        self._pt = math.nan
        self.stopping = False
        self.error = None  # the first exception of an effect / the control law
        self.touch_rejected = 0

    mask = property(lambda self: int(self.T[kernel._MASK]), doc="bit mask of the effects active on the last tick")
    touch_stale = property(lambda self: int(self.T[kernel._STALE_T]), doc="touch samples found stale at a tick")

    @property
    def state(self) -> TickState:
        """A copy of the last tick's state (what an effect read)."""
        return TickState.of(self.T)

    def switch(self, effects: list[Effect], buttons=()) -> None:
        """Another scene's effects from the next tick, without resetting the safety stage: the
        weight compensation and the output stay up (bumpless, from the screen's position).
        Any thread may call it (e.g. a study's next stimulus while the loop runs): the switch is
        one tuple store (the effects packed here), taken by the haptic thread at the start of its next tick."""
        self._pending = (self._pack(effects), ButtonPresses(buttons))

    # ----------------------------------------------------------------- safety stage
    @property
    def counters(self) -> FFCounters:
        return FFCounters(*self.N.tolist())

    @property
    def stop_duration(self) -> float:
        """s, longest stop from any output: the landing plus a full-scale ramp."""
        return self.device.land_time + 2.0 * max(self.device.f_max) / self.device.slew + 10.0 * self.dt

    def observe(self, t: float, t_pos: float, px: float, py: float, pz: float) -> bool:
        """Advance the safety stage's clock one tick and take the device position (m, stamp
        ``t_pos`` s) if plausible; True when accepted (``S[0:6]``: position m, velocity m/s)."""
        return kernel.observe(self.S, self.P, self.N, float(t), float(t_pos), float(px), float(py), float(pz))

    def limit(self, f0: float, f1: float, f2: float, stop: bool = False) -> np.ndarray:
        """The safe force (3,) N (a view of ``out``) for the requested one, after this tick's
        :meth:`observe`: the safety stage alone (no control law)."""
        kernel.limit(self.S, self.P, self.N, float(f0), float(f1), float(f2), bool(stop), self.out)
        return self.out

    # ----------------------------------------------------------------- inputs
    def touch(self, t: float, x: float, y: float, load: float, t_event: float = math.nan) -> None:
        """One touch sample: screen position (m), load (N; <= 0 = lifted), arrival time ``t``
        (s, engine clock; orders samples) and optionally the source's own time stamp ``t_event``
        (s, its own clock; used by the prediction filter when finite)."""
        T, pr = self.T, self.predictor
        if not (t == t and abs(t) != math.inf and t >= T[kernel._STAMP_T] and abs(x) <= TOUCH_BOUND
                and abs(y) <= TOUCH_BOUND and abs(load) <= MAX_LOAD):  # also NaN
            self.touch_rejected += 1
            return
        T[kernel._STAMP_T] = t
        T[kernel._NEW] = 1.0
        if T[kernel._QRESET] != 0.0 or load <= 0.0:  # a tick found the last touch stale / lifted
            pr.reset()
            T[kernel._QRESET] = T[kernel._QON] = 0.0
        if load <= 0.0:
            T[kernel._FINGER] = T[ek._FAX] = T[ek._FAY] = 0.0
            self._pt = math.nan
            return
        T[kernel._FINGER] = 1.0
        T[ek._LOAD] = load
        sx, sy = self._screen_at(t - self.touch_latency)
        te = t_event if (t_event == t_event and abs(t_event) < 1e12) else t
        pr.update(te, x + sx, y + sy)
        if not pr.vx * pr.vx + pr.vy * pr.vy <= MAX_SPEED * MAX_SPEED:  # a jump: restart the filter here
            self.touch_rejected += 1
            pr.reset()
            pr.update(te, x + sx, y + sy)
            self._pt = math.nan
        vx, vy = pr.vx, pr.vy
        h = te - self._pt
        if 0.0 < h <= 0.1:
            g = h / (self._atau + h)
            fax = T[ek._FAX] + g * ((vx - self._pvx) / h - T[ek._FAX])
            fay = T[ek._FAY] + g * ((vy - self._pvy) / h - T[ek._FAY])
            a = math.hypot(fax, fay)
            if a > MAX_ACCELERATION:
                fax *= MAX_ACCELERATION / a
                fay *= MAX_ACCELERATION / a
        else:
            fax = fay = 0.0
        T[ek._FAX], T[ek._FAY] = fax, fay
        self._pt, self._pvx, self._pvy = te, vx, vy
        T[kernel._T_PRED] = t
        T[kernel._QX:kernel._QON + 1] = pr.x, pr.y, vx, vy, float(pr.started)

    def _screen_at(self, ts: float) -> tuple[float, float]:
        """Screen x, y (m) recorded at the tick nearest to time ts (clamped to the history)."""
        T, n = self.T, self.H.shape[1]
        k = int(T[kernel._HK])
        if k == 0:
            return 0.0, 0.0
        back = (float(T[kernel._T_LAST]) - ts) * self.rate
        back = int(round(back)) if 0.0 < back < n else (0 if not back > 0.0 else n)
        back = min(back, min(k, n) - 1)
        j = (k - 1 - back) % n
        return float(self.H[0, j]), float(self.H[1, j])

    def stop(self) -> None:
        """Lower the tablet and ramp the force to zero (safety stage), and keep it there."""
        self.stopping = True

    # ----------------------------------------------------------------- tick
    def tick(self, t: float, px: float, py: float, pz: float, t_pos: float) -> np.ndarray:
        """Safe force (3,) N for this tick; see the module docstring. With compiled effects only,
        one compiled call (:func:`surfhap.ff.tick_kernel.tick`)."""
        if self._pending is not self._switched:  # never cleared: a switch sent meanwhile is taken next tick
            self._switched = self._pending
            self._set_effects(self._switched[0])
            self.button_presses, self.button = self._switched[1], -1
        T, pos = self.T, (float(t), float(t_pos), float(px), float(py), float(pz))
        if self.error is None:
            try:
                if self._python:  # the kinematics, the Python effects' terms, then the rest
                    kernel.kinematics(self.S, self.P, self.N, T, self.H, *pos)
                    self._python_terms(TickState.of(T))
                    kernel.finish(self.S, self.P, self.N, self.R, self.L, T, self.E, self.F, self.X, self.stopping,
                                  self.out)
                else:
                    kernel.tick(self.Z, self.PL, self.N, self.EX, self.F, *pos, self.stopping)
                if self.button_presses.buttons:
                    self.button = self.button_presses.update(T[ek._TOUCHED] != 0.0, T[ek._FX], T[ek._FY], T[ek._PZ])
                return self.out
            except Exception as exc:  # noqa: BLE001 - kept for the caller; the safety stage ramps down
                self.error = exc  # (raised after this tick's observe: the effects come after it)
                self.stopping = True
        else:
            kernel.kinematics(self.S, self.P, self.N, T, self.H, *pos)
        return self.limit(0.0, 0.0, 0.0, self.stopping)

    def _python_terms(self, s: TickState) -> None:
        """The Python effects' terms at ``s`` into ``X`` (called only on a touched tick, as merged)."""
        X = self.X
        for i, e in self._python:
            r = e.terms(s) if s.touched else None
            X[i, 0] = r is not None
            if r is not None:
                X[i, 1:8] = r
                X[i, 8] = e.vibration

    def merge(self, s: TickState) -> tuple[float, float, float, float, float, float, float, float]:
        """The active effects' terms merged at ``s`` (sets ``mask``, advances the effects' state):
        ``(kx, ky, kz, h, hv, fx, fy, fz)`` (:func:`surfhap.ff.effect_kernel.merge`)."""
        self.T[:len(TickState.__slots__)] = s.array()
        self._python_terms(s)
        mask, *terms = ek.merge(self.E, self.F, self.X, self.T, self.L[0])
        self.T[kernel._MASK] = mask
        return tuple(terms)
