"""The clocks of the runtime: one time base (s) for touch arrival stamps and blocks, the one
law for a stamp handed in by a caller (:func:`arrival_stamp`), and the three :class:`Clock`
implementations :func:`surfhap.runtime.loop.run` is driven by.

* :class:`WallClock` - monotonic time (:func:`now`); blocks (and force-feedback ticks, blocks of
  one frame) are paced to it: the one pacer, a sleep to ``spin`` s before each deadline and a
  busy wait for the rest (``time.sleep`` alone overshoots by the OS timer slack, ~0.1 ms, and
  by far more on a loaded machine); it keeps each wait's lateness for the statistics.
* :class:`SimClock` - simulated: as fast as possible; ``wait_until`` jumps to the deadline,
  so touch samples replayed at their stamps arrive exactly at their stamps.
* :class:`AudioClock` - stamps from the sound card: a block is stamped with the moment its
  first sample reaches the DAC (:meth:`AudioClock.dac_time`); PortAudio paces the blocks.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["now", "sleep_until", "arrival_stamp", "STALE", "Clock", "WallClock", "SimClock", "AudioClock",
           "enter_realtime", "SPIN", "FIFO_PRIORITY"]

log = logging.getLogger("surfhap.live")

SPIN = 0.0003  # s, busy wait before a 1 kHz deadline: above a woken thread's usual latency (~0.05-0.2 ms)
FIFO_PRIORITY = 20  # SCHED_FIFO priority (1-99): above every ordinary process, below kernel threads (50)
_fallback_logged = threading.Event()

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
    """Monotonic wall time (:func:`now`); ``wait_until`` sleeps to ``spin`` s before the
    deadline and spins the rest. ``late`` keeps the lateness (s, wake-up minus deadline) of
    the last ``history`` waits (a ring; ``waits`` counts them all)."""

    simulated = False

    def __init__(self, spin: float = 0.0001, history: int = 0):
        self.spin = float(spin)
        self.late = np.zeros(int(history))
        self.waits = 0

    def now(self) -> float:
        return now()

    def wait_until(self, deadline: float) -> float:
        t = sleep_until(deadline, self.spin)
        if self.late.size:
            self.late[self.waits % self.late.size] = t - deadline
        self.waits += 1
        return t

    def lateness(self) -> np.ndarray:
        """s, the lateness of the waits kept (oldest first not guaranteed)."""
        return self.late[:min(self.waits, self.late.size)]


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


def enter_realtime(priority: int = FIFO_PRIORITY) -> str:
    """Raise the *calling thread* to ``SCHED_FIFO`` (Linux; root or CAP_SYS_NICE / an
    ``rtprio`` limit), which pre-empts every ordinary process, a CPU-bound neighbour included:
    ``"fifo"``; else the lowest nice value granted for the thread (``"nice"``) or ``"normal"``.
    The fallback is logged once per process (a loop at normal priority beside a CPU-bound
    process misses deadlines)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))  # 0 = this thread (Linux)
        return "fifo"
    except (AttributeError, OSError) as exc:
        why = f"SCHED_FIFO refused ({exc})"
    mode = "normal"
    try:
        tid = threading.get_native_id()
        for nice in (-20, -10, -5, -1):
            try:
                os.setpriority(os.PRIO_PROCESS, tid, nice)  # a thread id: this thread only
                mode = "nice"
                break
            except OSError:
                continue
    except (AttributeError, OSError):
        pass
    if not _fallback_logged.is_set():
        _fallback_logged.set()
        log.warning("real-time scheduling not granted: %s; the haptic thread runs at %s priority and may "
                    "miss deadlines beside a CPU-bound process (run as root, or grant CAP_SYS_NICE / an "
                    "rtprio limit)", why, "raised nice" if mode == "nice" else "normal")
    return mode
