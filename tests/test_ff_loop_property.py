"""Whole-process safety of the force-feedback loop (issue 17): hypothesis drives
:class:`surfhap.live.ff_loop.FFLoop` through its public entry points (``push_touch``,
``request_stop``, ``tick_once`` on a simulated clock, no threads) with the simulated device
behind an adversarial backend:

* touches: any x, y, load (NaN, +-inf, +-1e308, huge), arrival stamps in the future, infinite,
  NaN or backwards, source event stamps anything;
* device positions: fresh, frozen (no new position), stamps in the future / inf / NaN /
  backwards, values NaN / +-inf / +-1e308 / far outside the workspace, and a read that raises;
* an effect that raises; stalls (the clock jumps up to 0.3 s between ticks); stop.

Every force the loop writes is audited against the documented limits, independently of the
safety stage's counters:

* finite and ``|F_i| <= f_max_i``; every change (from 0 N at start) ``<= slew / rate``;
* watchdog: once no valid new device position has arrived for ``device_timeout`` (the test's
  own, lenient bookkeeping of stamps), the output is exactly 0 N within ``f_max / slew`` of ticks;
* touch watchdog: no touch accepted by ``push_touch`` for ``touch_timeout`` -> Idle (mask 0);
* an exception anywhere -> ``loop.error`` set (the command exits 3), the loop still ends
  through the ramp: the last force is 0 N, within the safety stage's stop duration.

``SURFHAP_FF_SAFETY_EXAMPLES`` sets the number of sequences (default: 1/5 of
``SURFHAP_SAFETY_EXAMPLES``, so 2 000 in ``make test``; derandomized unless
``SURFHAP_SAFETY_SOAK`` is set).
"""

from __future__ import annotations

import math
import os

import numpy as np
from hypothesis import HealthCheck, event as tally, given, settings, strategies as st

from surfhap.ff import FALCON, DeviceParams, Effect, FFEngine, RectsField, Roughness, Shape, Sliding, Stiffness
from surfhap.live.ff_devices import SimDeviceBackend
from surfhap.live.ff_loop import FFLoop
from surfhap.runtime.clock import SimClock
from surfhap.render.kinematics import TouchPredictor
from surfhap.sim.ff_device import SimDevice

RATE = 1000.0
EPS = 1e-9
EXAMPLES = int(os.environ.get("SURFHAP_FF_SAFETY_EXAMPLES",
                              max(1, int(os.environ.get("SURFHAP_SAFETY_EXAMPLES", "10000")) // 5)))
SOAK = os.environ.get("SURFHAP_SAFETY_SOAK", "") not in ("", "0")


class Boom(Effect):
    """An effect that raises once the clock passes ``at`` (s) while the screen is touched."""

    name = "boom"

    def __init__(self, at: float):
        self.at = at
        super().__init__()

    def terms(self, s):
        if s.t >= self.at:
            raise RuntimeError("boom")
        return None


class Adversary:
    """The simulated device behind a backend that returns what the sequence dictates, and the
    test's own (lenient) record of the freshest valid position stamp."""

    name = "adversary"

    def __init__(self, device: DeviceParams):
        self.inner = SimDeviceBackend(SimDevice(rate=RATE, gain=device.gain), device.gain)
        self.kind = "fresh"
        self.value = 0.0
        self.frozen = (0.0, 0.0, 0.0, -math.inf)
        self.valid = -math.inf  # freshest stamp a lenient reader could accept, caller clock
        self.valid_at = -math.inf  # min(stamp, delivery time) of that sample
        self.writes: list[np.ndarray] = []

    def start(self) -> None:
        self.inner.start()

    def stop(self) -> None:
        pass

    def press(self, load: float) -> None:
        self.inner.press(load)

    def info(self) -> dict:
        return {"name": self.name}

    def read(self, t: float):
        px, py, pz, _ = self.inner.read(t)
        k = self.kind
        if k == "raise":
            raise OSError("device link lost")
        if k == "frozen":
            r = self.frozen
        elif k == "stamp":  # a bad stamp: future, inf, NaN or backwards
            r = (px, py, pz, self.value if self.value == self.value and abs(self.value) < 1e9 else self.value)
            if self.value == 0.5:
                r = (px, py, pz, t - 5.0)
            elif self.value == 0.25:
                r = (px, py, pz, t + 1.0)
        elif k == "value":
            r = (self.value, py, pz, t)
        else:
            r = (px, py, pz, t)
        s = r[3]
        if s == s and abs(s) != math.inf and s <= t + 1.0 / RATE and s > self.valid:
            self.valid, self.valid_at = s, min(s, t)
        self.frozen = r
        return r

    def write(self, force, t: float) -> None:
        self.writes.append(np.array(force, dtype=float))
        self.inner.write(force, t)


anything = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, math.nan]))
bad_stamp = st.sampled_from([3.0, math.inf, math.nan, -5.0, -1e308, -math.inf])  # arrival offsets (t - offset)
good_touch = st.tuples(st.floats(0.0, 0.2), st.floats(0.0, 0.14), st.floats(0.1, 3.0),
                       st.one_of(st.none(), st.floats(0.0, 0.03)), st.just(math.nan))
bad_touch = st.tuples(st.one_of(st.floats(-0.02, 0.22), anything), st.one_of(st.floats(-0.02, 0.16), anything),
                      st.one_of(st.just(0.0), st.floats(0.0, 3.0), anything), st.one_of(st.none(), bad_stamp),
                      anything)  # x, y, load, t_arrival offset, t_event
touch = st.one_of(good_touch, good_touch, good_touch, bad_touch)
fresh = st.just(("fresh", 0.0))
position = st.one_of(fresh, fresh, fresh, fresh, fresh, fresh, fresh, fresh, st.just(("frozen", 0.0)),
                     st.tuples(st.just("stamp"), st.sampled_from([math.inf, -math.inf, math.nan, 0.5, 0.25])),
                     st.tuples(st.just("value"), st.one_of(st.sampled_from([math.nan, math.inf, 1e308, -1e308, 0.5,
                                                                            0.039, -0.05]), st.floats(-0.2, 0.2))),
                     st.just(("raise", 0.0)))
event = st.tuples(st.one_of(st.none(), touch), position,
                  st.integers(1, 40),  # ticks this lasts
                  st.sampled_from([1] * 12 + [2, 5, 30, 300]))  # periods per tick (stall)
devices = st.one_of(st.just(FALCON), st.builds(DeviceParams, f_max=st.tuples(*[st.floats(0.5, 10)] * 3),
                                               slew=st.floats(20, 5000)))


def effects(boom_at: float):
    k = RectsField([(0.0, 0.0, 0.07, 0.07, 200.0)])
    a = RectsField([(0.07, 0.0, 0.14, 0.07, 1.0), (0.14, 0.07, 0.2, 0.14, -1.0)])
    d = RectsField([(0.0, 0.07, 0.1, 0.14, 2e-4)])
    h = RectsField([(0.1, 0.0, 0.2, 0.07, 0.02)])
    return [Stiffness(k), Shape(h), Roughness(d, 1e-3), Sliding(a, mass=0.389), Boom(boom_at)]


@settings(max_examples=EXAMPLES, deadline=None, derandomize=not SOAK, database=None, print_blob=True,
          suppress_health_check=list(HealthCheck))
@given(events=st.lists(event, min_size=1, max_size=25), device=devices,
       stop_at=st.one_of(st.none(), st.integers(0, 400)), boom_at=st.one_of(st.just(math.inf), st.floats(0.0, 0.3)))
def test_ff_loop_holds_every_limit_for_any_input(events, device, stop_at, boom_at):
    clock = SimClock()
    eng = FFEngine(effects(boom_at), device, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45),
                   rate=RATE, touch_latency=0.04)
    be = Adversary(device)
    loop = FFLoop(eng, be, clock=clock)
    eng.reset()
    be.start()
    period = 1.0 / RATE
    step = device.slew / RATE
    ramp_ticks = math.ceil(max(device.f_max) / step) + 2
    f_max = np.asarray(device.f_max)
    last_touch = -math.inf
    lost_ticks = 0
    failed_at = None
    k = 0
    go = True
    prev = np.zeros(3)
    stop_ticks = 0  # ticks since the stop (request or failure)
    for tch, (kind, value), n, stall in events:
        be.kind, be.value = kind, value
        for _ in range(n):
            clock.t += stall * period
            t = clock.t
            if tch is not None:
                x, y, load, off, te = tch
                ok = loop.push_touch(0, x, y, load, t_event=te, t_arrival=None if off is None else t - off)
                if ok:
                    last_touch = t
            if stop_at is not None and k == stop_at:
                loop.request_stop()
            go = loop.tick_once(t)
            f = be.writes[-1]
            k += 1
            if loop.error is not None or stop_at is not None and k > stop_at:
                stop_ticks += 1
            # limits and slew, from 0 N at start
            assert np.all(np.isfinite(f)) and np.all(np.abs(f) <= f_max + EPS), f
            assert np.all(np.abs(f - prev) <= step + EPS), (f, prev)
            prev = f
            # device watchdog: ticks since the freshest valid position got older than the timeout
            lost_ticks = lost_ticks + 1 if t - be.valid_at > device.device_timeout else 0
            if lost_ticks > ramp_ticks:
                assert np.all(f == 0.0), (f, lost_ticks)
            # touch watchdog
            if loop.error is None and t - last_touch > device.touch_timeout + period:
                assert eng.mask == 0 and not eng.state.touched
            if loop.error is not None and failed_at is None:
                failed_at = t
            if not go:
                break
        if not go:
            break
    if stop_ticks:
        # run on until the loop ends: through the ramp, at 0 N, within the stop duration (in ticks:
        # a stalled loop still ramps)
        be.kind = "fresh"
        while go:
            clock.t += period
            go = loop.tick_once(clock.t)
            stop_ticks += 1
            f = be.writes[-1]
            assert np.all(np.abs(f) <= f_max + EPS) and np.all(np.abs(f - prev) <= step + EPS)
            prev = f
            assert stop_ticks <= eng.stop_duration * RATE
        assert np.all(be.writes[-1] == 0.0)
    if failed_at is not None:
        assert loop.error is not None  # the command turns this into exit code 3
    tally(f"error: {type(loop.error).__name__}, stopped: {stop_ticks > 0}, max |F|: {np.abs(be.writes).max():.0f} N")


def test_future_and_infinite_position_stamps_do_not_switch_the_watchdog_off():
    """Issue 17 item 1: a position stamped t + 1 s (or inf) after a normal stream, then no
    positions: the output reaches 0 N within device_timeout + f_max / slew."""
    ramp = math.ceil(max(FALCON.f_max) / (FALCON.slew / RATE)) + 1
    for bad in (1.0, math.inf):
        saf = FFEngine([], FALCON, TouchPredictor(), rate=RATE)  # the safety stage fed 5 N up directly
        for k in range(100):
            saf.observe(k / RATE, k / RATE, 0.0, 0.0, 0.0)
            saf.limit(0.0, 0.0, 5.0)
        t0 = 100 / RATE
        saf.observe(t0, t0 + bad, 0.0, 0.0, 0.0)
        out = [saf.limit(0.0, 0.0, 5.0)[2]]
        for k in range(101, 600):  # the device goes silent: the caller repeats the last sample
            saf.observe(k / RATE, t0 + bad, 0.0, 0.0, 0.0)
            out.append(saf.limit(0.0, 0.0, 5.0)[2])
        lost = int(FALCON.device_timeout * RATE) + ramp
        assert out[lost] == 0.0 and max(out[lost:]) == 0.0, (bad, out[lost])
        assert saf.counters.stale > 0 or saf.counters.device_lost > 0


def test_frozen_caller_clock_does_not_stop_the_watchdog():
    """A caller whose clock stops (t and t_pos repeated) cannot hold a force: the stage's own
    clock advances one period per tick."""
    saf = FFEngine([], FALCON, TouchPredictor(), rate=RATE)
    out = [(saf.observe(1.0, 1.0, 0.0, 0.0, 0.0), saf.limit(0.0, 0.0, 5.0)[2])[1] for _ in range(600)]
    assert out[-1] == 0.0 and saf.counters.device_lost > 0


def test_huge_touch_cannot_crash_or_freeze_the_roughness_phase():
    """Issue 17 item 2: a touch at 1e308 made the grating phase overflow (math.floor(inf)) and a
    NaN speed froze it; now such touches are rejected where they enter, and the phase stays
    finite and keeps advancing for any speed."""
    eng = FFEngine([Roughness(1e-4, 1e-3)], FALCON, TouchPredictor(), rate=RATE)
    for k in range(50):
        t = k / RATE
        if k % 5 == 0:
            eng.touch(t, 0.1 if k < 25 else 1e308, 0.05, 1.0)
        f = eng.tick(t, 0.0, 0.0, 0.0, t)
        assert np.all(np.isfinite(f))
    assert eng.error is None and eng.touch_rejected > 0
    from surfhap.ff.effects import TickState

    r = Roughness(1e-4, 1e-3)
    s = TickState()
    s.touched = True
    for speed in (1e308, math.inf, math.nan, 0.2):
        s.speed = speed
        r.terms(s)
        assert 0.0 <= r.phase < 2 * math.pi
    before = r.phase
    r.terms(s)
    assert r.phase != before  # a NaN speed did not freeze it


def test_device_position_stamps_pass_the_one_arrival_law():
    """Issue 20: the loop hands a device position's stamp through runtime/clock.arrival_stamp, the
    law touches pass: a stamp after the hand-over (even within one period) or non-finite is
    stale and never refreshes the watchdog; one at or before it is taken."""
    from surfhap.runtime.clock import STALE, arrival_stamp

    period = 1.0 / RATE
    for offset in (-3 * period, 0.0, 0.5 * period, 0.99 * period, 2 * period, math.inf, math.nan):
        clock = SimClock()
        eng = FFEngine([Stiffness(300.0)], FALCON, TouchPredictor(), rate=RATE)
        be = Adversary(FALCON)
        loop = FFLoop(eng, be, clock=clock)
        eng.reset()
        be.start()
        be.kind = "stamp"
        for _ in range(20):
            clock.t += period
            be.value = clock.t + offset
            loop.tick_once(clock.t)
        stale = eng.counters.stale
        assert (stale == 20) == (arrival_stamp(clock.t + offset, clock.t) == STALE), (offset, stale)
        assert stale in (0, 20)
