"""The haptic thread's pacing and scheduling (live/pacing.py, issue 20). No wall-clock
bounds: only what holds however late the machine wakes the thread."""

from __future__ import annotations

import logging
import threading

import pytest

from surfhap.live import pacing
from surfhap.runtime.clock import now


def test_a_late_wait_counts_the_skipped_periods_and_keeps_the_phase():
    period = 1e-3
    p = pacing.Pacer(period, spin=0.0)
    d0 = now() - 3.5 * period  # the thread woke 3.5 periods after this deadline
    p.deadline = d0
    t, late, skipped = p.wait()
    assert late >= 3.5 * period and t - d0 == pytest.approx(late)
    assert skipped == int(late / period) >= 3  # every whole period past the deadline is a missed tick
    k = (p.deadline - d0) / period
    assert k == pytest.approx(round(k)) and p.deadline > t  # same phase, next deadline ahead of t
    _, late2, skipped2 = p.wait()  # on schedule again: waits for its deadline
    assert late2 >= 0.0 and skipped2 == (int(late2 / period) if late2 > period else 0)


def _in_thread(fn):
    out = []
    th = threading.Thread(target=lambda: out.append(fn()))  # never change the test runner's own thread
    th.start()
    th.join(10)
    return out[0]


def test_refused_realtime_falls_back_and_logs_once(monkeypatch, caplog):
    def refuse(*a):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(pacing.os, "sched_setscheduler", refuse)
    monkeypatch.setattr(pacing.os, "setpriority", refuse)
    monkeypatch.setattr(pacing, "_fallback_logged", threading.Event())
    with caplog.at_level(logging.WARNING, logger="surfhap.live"):
        modes = [_in_thread(pacing.enter_realtime) for _ in range(3)]
    assert modes == ["normal"] * 3
    warnings = [r for r in caplog.records if "real-time scheduling not granted" in r.getMessage()]
    assert len(warnings) == 1 and "SCHED_FIFO refused" in warnings[0].getMessage()


def test_granted_mode_is_reported():
    assert _in_thread(pacing.enter_realtime) in ("fifo", "nice", "normal")
