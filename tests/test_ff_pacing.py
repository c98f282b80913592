"""The one pacing (runtime/loop.py run() on a clock, issue 20): the force-feedback tick is a block
of one frame; a late wake-up counts the periods it skipped and keeps the phase. No wall-clock
bounds: a scripted clock stands in for a machine that wakes the thread late."""

from __future__ import annotations

import logging
import threading

import numpy as np
import pytest

from surfhap.runtime import clock as rclock
from surfhap.runtime.clock import WallClock
from surfhap.runtime.loop import run


class LateClock:
    """A wall (not simulated) clock that wakes ``delays[k]`` s after the k-th deadline."""

    simulated = False

    def __init__(self, delays, hook=None):
        self.delays, self.deadlines, self.t, self.hook = list(delays), [], 0.0, hook

    def now(self) -> float:
        return self.t

    def wait_until(self, deadline: float) -> float:
        self.deadlines.append(deadline)
        k = len(self.deadlines) - 1
        self.t = max(self.t, deadline + (self.delays[k] if k < len(self.delays) else 0.0))
        if self.hook is not None:
            self.hook(k)
        return self.t


class Ticks:
    drive_rate, block_frames = 1000, 1

    def __init__(self):
        self.counters, self.t = {"underruns": 0}, []

    def render(self, frames, now=None):
        self.t.append(now)
        return np.zeros(3)

    def emit(self, force):
        pass


def test_a_late_tick_counts_the_skipped_periods_and_keeps_the_phase():
    period = 1e-3
    delays = [0.0, 0.0, 3.5 * period, 0.0, 0.0, 0.7 * period, 0.0]
    clock, eng = LateClock(delays), Ticks()
    assert run(None, eng, clock, eng, total_frames=len(delays), buffer=0.0) == len(delays)
    assert eng.counters["underruns"] == 3  # 3.5 periods late: three whole periods without a tick
    d = np.array(clock.deadlines) / period
    np.testing.assert_allclose(d, np.round(d), atol=1e-9)  # every deadline on the original phase
    assert d[3] == pytest.approx(d[2] + 4)  # the next deadline after the late wake-up, not a burst
    assert np.all(np.diff(d) >= 1 - 1e-9)
    np.testing.assert_allclose(eng.t, np.array(clock.deadlines) + delays)  # the tick runs at its wake-up


def test_the_wall_clock_keeps_each_wait_s_lateness():
    c = WallClock(spin=0.0, history=4)
    t0 = c.now()
    for _ in range(6):
        assert c.wait_until(t0 - 1.0) >= t0  # a deadline 1 s ago: no sleep, at least 1 s late
    assert c.waits == 6 and c.lateness().size == 4 and np.all(c.lateness() >= 1.0)


def test_the_haptic_loop_is_run_on_its_clock():
    """``ff run``'s haptic thread is the runtime's run() on the loop's clock: a stall on that
    clock is counted as missed ticks, and the stop ramps to zero before the loop ends."""
    from surfhap.ff import FALCON, FFEngine, Stiffness
    from surfhap.live.ff_devices import SimDeviceBackend
    from surfhap.live.ff_loop import FFLoop
    from surfhap.render.kinematics import TouchPredictor
    from surfhap.sim.ff_device import SimDevice

    eng = FFEngine([Stiffness(300.0)], FALCON, TouchPredictor(), rate=1000.0)
    be = SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain)
    loop = None
    clock = LateClock([0.0] * 50 + [5.2e-3], hook=lambda k: k == 300 and loop.request_stop())
    loop = FFLoop(eng, be, clock=clock, realtime=False)
    eng.reset()
    be.start()
    loop._run()  # the haptic thread's body, here on the test's thread
    st = loop.stats()
    assert st["missed"] == 5 and st["error"] is None and loop.done.is_set()
    assert st["ticks"] == len(clock.deadlines) > 300 and np.all(eng.out == 0.0)


def _in_thread(fn):
    out = []
    th = threading.Thread(target=lambda: out.append(fn()))  # never change the test runner's own thread
    th.start()
    th.join(10)
    return out[0]


def test_refused_realtime_falls_back_and_logs_once(monkeypatch, caplog):
    def refuse(*a):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(rclock.os, "sched_setscheduler", refuse)
    monkeypatch.setattr(rclock.os, "setpriority", refuse)
    monkeypatch.setattr(rclock, "_fallback_logged", threading.Event())
    with caplog.at_level(logging.WARNING, logger="surfhap.live"):
        modes = [_in_thread(rclock.enter_realtime) for _ in range(3)]
    assert modes == ["normal"] * 3
    warnings = [r for r in caplog.records if "real-time scheduling not granted" in r.getMessage()]
    assert len(warnings) == 1 and "SCHED_FIFO refused" in warnings[0].getMessage()


def test_granted_mode_is_reported():
    assert _in_thread(rclock.enter_realtime) in ("fifo", "nice", "normal")
