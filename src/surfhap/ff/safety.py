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

Clock and stamps: the stage keeps its own clock, advanced by the caller's tick interval but by
at least one period and at most ``MAX_STEP`` per tick (a stopped, backwards, non-finite or
runaway caller clock cannot stop it). A position's stamp ``t_pos`` has been through the arrival
law upstream (:func:`surfhap.runtime.clock.arrival_stamp`); here it only orders samples and can
only age them (never younger than this tick). A non-finite stamp or one older than the last is
stale (counted): the output ramps towards zero. The arithmetic runs compiled
(:mod:`surfhap.ff.tick_kernel`); this class holds its state arrays.

The newtons are converted into device units (``gain``) by the backend, after this stage.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from surfhap.ff import tick_kernel as kernel
from surfhap.ff.params import DeviceParams
from surfhap.ff.tick_kernel import MAX_STEP

__all__ = ["ForceSafety", "ForceSafetyCounters", "MAX_STEP"]


# tick counts since the last reset, one per kernel counter (kernel.COUNTERS names them once)
ForceSafetyCounters = namedtuple("ForceSafetyCounters", kernel.COUNTERS)


class ForceSafety:
    """``process(force, t, t_pos, px, py, pz, stop=False) -> (3,) N``.

    force        : (3,) requested force, N.
    t            : s, now (the caller's clock).
    t_pos        : s, the arrival stamp of the device position (caller clock; orders samples only).
    px, py, pz   : m, that position relative to X0.
    stop         : lower the tablet and ramp to zero, and stay there.

    The engine calls :meth:`observe` before its control law (to use the accepted position ``p``
    and the velocity ``v``, views of the state) and the compiled law + :meth:`limit` after;
    :meth:`process` does both.
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
        self.params = kernel.safety_params(device, self.rate, velocity_cutoff)
        self.state = kernel.new_state()
        self.counts = np.zeros(len(kernel.COUNTERS), dtype=np.int64)
        self.out = np.zeros(3)
        self.p = self.state[0:3]  # last accepted position, m
        self.v = self.state[3:6]  # its velocity (one-pole low-pass of differences), m/s

    def reset(self) -> None:
        self.state[:] = kernel.new_state()
        self.counts[:] = 0
        self.out[:] = 0.0

    @property
    def n_ticks(self) -> int:
        return int(self.counts[0])

    @property
    def now(self) -> float:
        """s, the stage's own clock."""
        return float(self.state[kernel._NOW])

    @property
    def counters(self) -> ForceSafetyCounters:
        return ForceSafetyCounters(*self.counts.tolist())

    @property
    def stop_duration(self) -> float:
        """s, longest stop from any output: the landing plus a full-scale ramp."""
        return self.device.land_time + 2.0 * max(self.f_max) / self.device.slew + 10.0 * self.period

    def process(self, force, t: float, t_pos: float, px: float, py: float, pz: float, stop: bool = False) -> np.ndarray:
        """Safe force (3,) N (a view of ``self.out``) for the requested ``force`` (3,)."""
        self.observe(t, t_pos, px, py, pz)
        return self.limit(force[0], force[1], force[2], stop)

    def observe(self, t: float, t_pos: float, px: float, py: float, pz: float) -> bool:
        """Advance the clock one tick and take the device position if it is plausible;
        True when it was accepted (``p``, ``v`` updated)."""
        return kernel.observe(self.state, self.params, self.counts, float(t), float(t_pos), float(px), float(py),
                              float(pz))

    def limit(self, f0: float, f1: float, f2: float, stop: bool = False) -> np.ndarray:
        """The safe force for the requested one, given this tick's :meth:`observe`."""
        kernel.limit(self.state, self.params, self.counts, float(f0), float(f1), float(f2), bool(stop), self.out)
        return self.out

    def law_limit(self, law, terms, stop: bool) -> np.ndarray:
        """The control law ``law`` (:class:`surfhap.ff.control.ControlLaw`) of its merged
        ``terms`` at the accepted position, then :meth:`limit`: one compiled call."""
        kx, ky, kz, h, hv, fx, fy, fz = terms
        kernel.force(self.state, self.params, self.counts, law.ref, law.params, kx, ky, kz, h, hv, fx, fy, fz,
                     bool(stop), self.out)
        return self.out
