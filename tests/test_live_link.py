"""The two engine links of the page app: in-process (LocalLink) and over the process boundary
(ProcessLink -> EngineEnd over multiprocessing pipes, and the trace back), here with both
ends in this process on real pipes."""

from __future__ import annotations

import asyncio
import json
import multiprocessing as mp
import time

import numpy as np

from surfhap.live.session import build_session
from surfhap.web.link import EngineLink, LocalLink, as_link
from surfhap.web.process import EngineEnd, ProcessLink, describe

PATIENCE = 30.0


def _pipes():
    touch_in, touch_out = mp.Pipe(duplex=False)
    trace_in, trace_out = mp.Pipe(duplex=False)
    return touch_in, touch_out, trace_in, trace_out


def test_both_links_satisfy_the_interface_and_describe_the_same_page():
    session = build_session("cork")
    local = as_link(session, type("Cfg", (), {"trace_points": 16, "trace_hz": 30.0})())
    assert isinstance(local, LocalLink) and isinstance(local, EngineLink)
    assert not isinstance(session, EngineLink)
    _, touch_out, trace_in, _ = _pipes()
    remote = ProcessLink(describe(session), touch_out, trace_in)
    assert isinstance(remote, EngineLink) and as_link(remote, None) is remote
    assert json.loads(json.dumps(remote.info())) == json.loads(json.dumps(local.info()))
    assert remote.space == session.space and remote.positions == local.positions == "physical"


def test_touches_reach_the_engine_and_frames_come_back():
    session = build_session("cork")
    touch_in, touch_out, trace_in, trace_out = _pipes()
    end = EngineEnd(session, touch_in, trace_out, hz=50.0, points=16).start()
    gone = []
    link = ProcessLink(describe(session), touch_out, trace_in, on_engine_gone=lambda: gone.append(1))
    got = []

    async def scenario():
        task = asyncio.get_running_loop().create_task(link.stream(lambda f, s: got.append((f, s))))
        for k in range(10):
            assert link.push_touch(1001, 0.01 + 0.001 * k, 0.02, 0.5, t_event=1.25 + k)
        deadline = time.monotonic() + PATIENCE
        while (len(got) < 6 or end.received < 10) and time.monotonic() < deadline:
            await asyncio.sleep(0.02)
        end.stop()  # the engine side goes away: the web side is told
        while not gone and time.monotonic() < deadline:
            await asyncio.sleep(0.02)
        task.cancel()

    asyncio.run(scenario())
    buf = np.zeros((64, 6))
    n = session.engine.touches.pop_into(buf)
    # source, t_event, t_arrival, x, y, load: in order, as pushed
    assert n == 10 and np.all(buf[:n, 0] == 1001) and np.allclose(buf[:n, 1], 1.25 + np.arange(10))
    assert np.allclose(buf[:n, 3], 0.01 + 0.001 * np.arange(10)) and np.all(buf[:n, 5] == 0.5)
    assert len(got) >= 6 and set(got[0][0]) >= {"t", "v", "f", "target", "speed"}
    assert got[0][1] is not None and got[1][1] is None  # the status with every 5th frame
    assert gone == [1] and link.dropped == 0 and end.dropped == 0


def test_a_stalled_engine_side_drops_the_oldest_touches_and_never_blocks():
    session = build_session("cork")
    touch_in, touch_out, trace_in, _ = _pipes()  # nobody reads the touches
    link = ProcessLink(describe(session), touch_out, trace_in, max_pending=100)

    async def flood():  # far more than the pipe and the queue hold (a blocking send hangs here)
        for k in range(100_000):
            assert link.push_touch(1, 0.01, 0.02, 0.5, t_event=float(k))
            if k % 50 == 0:
                await asyncio.sleep(0)  # the loop turns: the link flushes what the pipe takes

    asyncio.run(flood())
    assert link.dropped > 0 and len(link.pending) == 100
    assert link.pending[-1][1] == 99_999.0  # the newest sample is kept, the oldest went
    got = []  # and what reached the pipe is whole messages, in order
    while touch_in.poll(0):
        got.append(np.frombuffer(touch_in.recv_bytes(), dtype=np.float64).reshape(-1, 6))
    t_events = np.concatenate(got)[:, 1]
    assert t_events[0] == 0.0 and np.all(np.diff(t_events) == 1.0) and t_events.size + 100 + link.dropped == 100_000
