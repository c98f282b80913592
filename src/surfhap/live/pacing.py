"""Deadline pacing of a real-time thread, and real-time scheduling where the OS grants it.

:class:`Pacer` is the one schedule of a thread that must act once per ``period`` on the engine
clock (the force-feedback haptic thread; a paced output backend can use it too): absolute
deadlines (no drift), a coarse sleep to ``spin`` seconds before the deadline and a busy wait
for the rest (``time.sleep`` alone overshoots by the OS timer slack, ~0.1 ms, and by far more
on a loaded machine), and a late start handled once: a wait that ends more than ``slack``
after its deadline counts the periods it skipped and re-anchors the schedule on the same
phase instead of bursting to catch up.

:func:`enter_realtime` raises the *calling thread* to ``SCHED_FIFO`` (Linux; needs root or
CAP_SYS_NICE / an ``rtprio`` limit), which lets it pre-empt every ordinary process, a
CPU-bound neighbour included. Where that is refused it falls back to the highest ``nice``
the OS allows for the thread, else to normal scheduling, and logs the fallback once per
process (a loop at normal priority beside a CPU-bound process misses deadlines).
"""

from __future__ import annotations

import logging
import os
import threading

from surfhap.runtime.clock import now, sleep_until

__all__ = ["Pacer", "enter_realtime", "SPIN", "FIFO_PRIORITY"]

log = logging.getLogger("surfhap.live")

SPIN = 0.0003  # s, busy wait before a deadline: above a woken thread's usual latency (~0.05-0.2 ms)
FIFO_PRIORITY = 20  # SCHED_FIFO priority (1-99): above every ordinary process, below kernel threads (50)
_fallback_logged = threading.Event()


class Pacer:
    """Deadlines every ``period`` s from ``start()``; :meth:`wait` sleeps to the next one.

    slack : s, lateness beyond which the skipped periods are counted and the schedule
            re-anchored (default one period).
    spin  : s, busy wait before each deadline (see the module docstring).
    """

    def __init__(self, period: float, slack: float | None = None, spin: float = SPIN):
        self.period = float(period)
        self.slack = self.period if slack is None else float(slack)
        self.spin = float(spin)
        self.deadline = now() + self.period

    def start(self) -> None:
        """The first deadline one period from now."""
        self.deadline = now() + self.period

    def wait(self) -> tuple[float, float, int]:
        """Sleep until the next deadline: ``(t, late, skipped)`` with ``t`` the wake-up time,
        ``late = t - deadline`` (s) and ``skipped`` the periods missed (0 unless ``late`` >
        ``slack``; then the schedule keeps its phase from the next deadline after ``t``)."""
        d = self.deadline
        t = sleep_until(d, self.spin)
        late = t - d
        skipped = 0
        if late > self.slack:
            skipped = int(late / self.period)
            d += skipped * self.period
        self.deadline = d + self.period
        return t, late, skipped


def enter_realtime(priority: int = FIFO_PRIORITY) -> str:
    """Raise the calling thread's scheduling class: ``"fifo"`` (SCHED_FIFO at ``priority``),
    ``"nice"`` (the lowest nice value granted) or ``"normal"``; the fallback is logged once."""
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
