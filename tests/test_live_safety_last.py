"""The safety stage is the last processor before the backend (issue 8, items 1-3).

Regression tests for the live engine: whatever touches the signal after a renderer's own
safety stage (lift silencing of queued drive, gain, stop ramp, renderer switch) cannot make
the emitted stream rise faster than ``rise_rate / drive_rate`` or exceed ``v_max``; and a
touch sample that is stale when it reaches the engine stays stale.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from surfhap.exchange.materials import load_material
from surfhap.runtime.clock import now as clock_now
from surfhap.live.audit import audit_drive
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.runtime.commands import SetGain, SwapRenderer

LOAD = 2.0  # N: a firm press drives cork to the 250 V limit


def engine(rate, block, material="cork", **cfg):
    chain = TextureChain(load_material(material), ChainConfig(drive_rate=rate))
    return LiveEngine(chain, EngineConfig(block_seconds=block, **cfg))


class Run:
    """Manual clock: one touch per block (arrival = block start), every block audited."""

    def __init__(self, e):
        self.e, self.t, self.out = e, 0.0, []

    def blocks(self, n, touch=True, x=0.02):
        e = self.e
        for _ in range(n):
            if touch:
                e.push_touch(1, x + 0.05 * self.t, 0.03, LOAD, t_arrival=self.t)
            self.out.append(e.render(e.block_frames, self.t).copy())
            self.t += e.block_period

    def audit(self):
        d = np.concatenate(self.out)
        return audit_drive(d, self.e.drive_rate, self.e.renderer.safety.limits), d


@pytest.mark.parametrize("rate,block", [(44100, 0.001), (20000, 0.00025), (48000, 0.0005)])
def test_lift_and_retouch_in_one_block_keep_the_rise_limit(rate, block):
    for phase in range(6):  # lift at different points of the model/drive sample grid
        r = Run(engine(rate, block))
        r.blocks(200 + phase)
        # a strong drive before the lift (cork carries a texture, so it is not pinned at 250 V):
        # above the per-sample rise limit, so a 0 -> V jump on re-touch would be caught
        assert np.abs(r.out[-1]).max() > 1.2 * r.e.renderer.safety.limits.rise_rate / rate
        # the finger lifts and lands again before the next block
        r.e.push_touch(1, 0.0, 0.0, 0.0, t_arrival=r.t)
        r.blocks(20)
        a, _ = r.audit()
        assert a["violations"] == 0, (rate, block, phase, a)


@pytest.mark.parametrize("rate,block", [(44100, 0.001), (20000, 0.00025)])
def test_gain_zero_to_one_keeps_the_rise_limit(rate, block):
    r = Run(engine(rate, block))
    r.e.send(SetGain(0.0))
    r.blocks(100)
    assert not np.any(np.concatenate(r.out))
    r.e.send(SetGain(1.0))
    r.blocks(20)
    a, d = r.audit()
    assert a["violations"] == 0, a
    assert np.abs(d).max() == pytest.approx(250.0)  # the gain is applied, by a ramp


def test_renderer_switch_back_and_forth_keeps_the_rise_limit():
    e = engine(44100, 0.001)
    a_chain = e.renderer
    b_chain = TextureChain(load_material("cork"), ChainConfig(drive_rate=44100, alpha=1.0))  # a faint renderer
    r = Run(e)
    r.blocks(100)
    e.send(SwapRenderer(b_chain))
    r.blocks(30)
    e.send(SwapRenderer(a_chain))  # its own safety stage still remembers 250 V
    r.blocks(30)
    a, _ = r.audit()
    assert a["violations"] == 0, a


def test_stop_ramp_is_applied_inside_the_last_pass():
    e = engine(20000, 0.001, stop_ramp=0.004)
    r = Run(e)
    r.blocks(100)
    e.request_stop()
    n0 = sum(o.size for o in r.out)
    r.blocks(10)
    a, d = r.audit()
    assert a["violations"] == 0 and e.stopped
    tail = np.abs(d[n0:])
    ramp = np.maximum(1.0 - np.arange(tail.size) / (0.004 * 20000), 0.0)
    assert np.all(tail <= 250.0 * ramp + 1e-9)  # under a linear ramp from v_max to 0 in 4 ms
    assert tail[0] > 0.0


def test_touches_queued_during_an_engine_stall_stay_stale():
    # the engine thread stops for 2.7 s while the finger keeps sending; on resume the queued
    # samples carry their true (old) arrival stamps: zero output until a fresh one arrives
    e = engine(20000, 0.001)
    r = Run(e)
    r.blocks(100)
    t_stall = r.t
    for k in range(50):
        t = t_stall + 0.01 * k
        e.push_touch(1, 0.03 + 0.001 * k, 0.03, LOAD, t_arrival=t)
    r.t = t_stall + 2.7  # resume
    n0 = sum(o.size for o in r.out)
    r.blocks(10, touch=False)
    assert not np.any(np.concatenate(r.out)[n0:])
    r.blocks(20)  # fresh touches again
    a, d = r.audit()
    assert a["violations"] == 0 and np.abs(d[-20:]).max() > 0


def _send_touch(conn, t_arrival, load=LOAD):
    # one message of the web process's link: source, t_event, t_arrival, x, y, load, samples
    conn.send_bytes(np.array([[7, np.nan, t_arrival, 0.05, 0.03, load, 1]]).tobytes())


def test_process_link_keeps_stale_arrival_stamps():
    # web process -> engine process: samples stamped by the web process 2.7 s ago (the
    # engine process was stopped meanwhile) must not be re-stamped as fresh
    import multiprocessing as mp

    from surfhap.live.backends.sim import SimBackend
    from surfhap.web.process import EngineEnd

    e = engine(20000, 0.001)
    session = type("Session", (), {"engine": e, "backend": SimBackend()})()
    touch_in, touch_out = mp.Pipe(duplex=False)
    trace_in, trace_out = mp.Pipe(duplex=False)
    end = EngineEnd(session, touch_in, trace_out, hz=1.0).start()
    try:
        t0 = clock_now()
        for k in range(20):
            _send_touch(touch_out, t0 - 2.7 + 0.01 * k)
        deadline = time.monotonic() + 30.0
        while end.received < 20 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert end.received == 20
        buf = np.zeros((64, 6))
        n = e.touches.pop_into(buf)
        assert n == 20 and np.all(buf[:n, 2] < t0 - 2.5)  # stamps kept
        # replayed into the engine: the watchdog holds the output at zero
        for i in range(n):
            e.push_touch(int(buf[i, 0]), buf[i, 3], buf[i, 4], buf[i, 5], t_arrival=buf[i, 2])
        t = clock_now()
        out = np.concatenate([e.render(e.block_frames, t + k * e.block_period).copy() for k in range(30)])
        assert not np.any(out)
        # a sample from the future is not trusted: stale (it can never refresh the watchdog)
        _send_touch(touch_out, clock_now() + 100.0)
        deadline = time.monotonic() + 30.0
        while end.received < 21 and time.monotonic() < deadline:
            time.sleep(0.01)
        n = e.touches.pop_into(buf)
        assert n == 1 and buf[0, 2] == -np.inf
    finally:
        touch_out.close()
        end.stop()
        trace_in.close()
