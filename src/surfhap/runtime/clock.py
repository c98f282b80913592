"""The clocks of the runtime: one time base (s) for touch arrival stamps and blocks, the one
law for a stamp handed in by a caller (:func:`arrival_stamp`), and the three :class:`Clock`
implementations :func:`surfhap.runtime.loop.run` is driven by.

* :class:`WallClock` - monotonic time (:func:`now`); blocks are paced to it.
* :class:`SimClock` - simulated: as fast as possible; ``wait_until`` jumps to the deadline,
  so touch samples replayed at their stamps arrive exactly at their stamps.
* :class:`AudioClock` - stamps from the sound card: a block is stamped with the moment its
  first sample reaches the DAC (:meth:`AudioClock.dac_time`); PortAudio paces the blocks.
"""

from __future__ import annotations

import math
import time
from typing import Protocol, runtime_checkable

__all__ = ["now", "sleep_until", "arrival_stamp", "STALE", "Clock", "WallClock", "SimClock", "AudioClock"]

now = time.perf_counter

# the arrival stamp of a sample whose caller's stamp could not be trusted: older than any
# watchdog timeout, so it can never keep an output alive
STALE = -math.inf


def arrival_stamp(t_caller: float | None, t_now: float) -> float:
    """The arrival stamp of a sample handed over at ``t_now`` (the receiver's own clock).

    Without a caller's stamp it is ``t_now``. A caller's stamp (e.g. the web process's
    arrival time, on the same clock) may only make the sample *older*: a finite stamp at or
    before ``t_now`` is kept; a stamp from the future, NaN or ±inf is not trusted and gives
    :data:`STALE` (the sample can never refresh a watchdog)."""
    if t_caller is None:
        return t_now
    t = float(t_caller)
    if t <= t_now and t > STALE:  # False for NaN, +inf (> t_now) and -inf
        return t
    return STALE


def sleep_until(deadline: float, spin: float = 0.0001) -> float:
    """Sleep until ``deadline`` on :func:`now` (coarse sleep, then a short spin); returns now."""
    while True:
        t = now()
        remaining = deadline - t
        if remaining <= 0:
            return t
        if remaining > spin:
            time.sleep(remaining - spin)


@runtime_checkable
class Clock(Protocol):
    """``now()`` the current time (s); ``wait_until(deadline)`` returns once the clock has
    reached ``deadline`` and gives the time then; ``simulated`` True when time only moves by
    ``wait_until`` (nothing real is paced)."""

    simulated: bool

    def now(self) -> float: ...

    def wait_until(self, deadline: float) -> float: ...


class WallClock:
    """Monotonic wall time (:func:`now`); ``wait_until`` sleeps."""

    simulated = False

    def now(self) -> float:
        return now()

    def wait_until(self, deadline: float) -> float:
        return sleep_until(deadline)


class SimClock:
    """Simulated time, from ``start`` s: ``wait_until`` jumps to the deadline at once."""

    simulated = True

    def __init__(self, start: float = 0.0):
        self.t = float(start)

    def now(self) -> float:
        return self.t

    def wait_until(self, deadline: float) -> float:
        if deadline > self.t:
            self.t = float(deadline)
        return self.t


class AudioClock(WallClock):
    """Wall time whose block stamps come from the sound card (PortAudio paces the blocks)."""

    @staticmethod
    def dac_time(t_now: float, time_info, nominal_latency: float) -> float:
        """Clock time (s) at which the block of a PortAudio callback reaches the DAC:
        ``t_now`` (in the callback) plus the callback's ``outputBufferDacTime - currentTime``;
        ``nominal_latency`` when the host API gives no usable times (both zero, not finite,
        or a latency outside 0-1 s)."""
        dac = float(time_info.outputBufferDacTime)
        cur = float(time_info.currentTime)
        lat = dac - cur
        if (dac == 0.0 and cur == 0.0) or not 0.0 <= lat <= 1.0:  # False for NaN: nominal
            lat = nominal_latency
        return t_now + lat
