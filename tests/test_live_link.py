"""The two engine links of the page app: in-process (LocalLink) and over the process boundary
(ProcessLink -> EngineEnd over multiprocessing pipes, and the trace back), here with both
ends in this process on real pipes."""

from __future__ import annotations

import asyncio
import json
import multiprocessing as mp
import select
import time

import numpy as np

from surfhap.live.session import build_session
from surfhap.web.link import EngineLink, LocalLink, as_link
from surfhap.web import process
from surfhap.web.process import FLUSH_S, EngineEnd, ProcessLink, describe

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
        for k in range(10):  # one sample per flush window: each one is sent
            assert link.push_touch(1001, 0.01 + 0.001 * k, 0.02, 0.5, t_event=1.25 + k)
            await asyncio.sleep(2 * FLUSH_S)  # its timer runs after the flush's
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
    assert gone == [1] and link.coalesced == 0 and end.dropped == 0


def test_samples_of_one_turn_are_coalesced_to_the_newest_per_client():
    """A web process that falls behind reads many samples of each client in one turn of its
    loop: only the newest position per client goes to the engine (with the count it stands
    for), so no queue grows with the backlog."""
    session = build_session("cork")
    touch_in, touch_out, trace_in, _ = _pipes()
    link = ProcessLink(describe(session), touch_out, trace_in)

    async def burst():
        for k in range(500):
            for src in (7, 8):
                assert link.push_touch(src, 0.001 * k, 0.01 * src, 0.5, t_event=float(k))
        await asyncio.sleep(2 * FLUSH_S)  # the window ends: one flush

    asyncio.run(burst())
    rows = np.frombuffer(touch_in.recv_bytes(), dtype=np.float64).reshape(-1, 7)
    assert not touch_in.poll(0) and rows.shape == (2, 7)
    assert rows[:, 0].tolist() == [7.0, 8.0] and np.all(rows[:, 1] == 499.0)  # the newest of each
    assert np.allclose(rows[:, 3], 0.499) and np.allclose(rows[:, 4], [0.07, 0.08])
    assert rows[:, 6].tolist() == [500.0, 500.0] and link.coalesced == 998


def test_touches_of_one_flush_window_reach_the_engine_in_one_message(monkeypatch):
    """Many clients' samples, read in separate turns of the event loop, go to the engine in one
    pipe message per flush window (one write and one wake-up of the engine's reader for all
    of them), each client's newest with the count it stands for."""
    monkeypatch.setattr(process, "FLUSH_S", 0.5)  # a window no loaded machine misses here
    session = build_session("cork")
    touch_in, touch_out, trace_in, _ = _pipes()
    link = ProcessLink(describe(session), touch_out, trace_in)

    async def turns():
        for k in range(4):
            for src in range(10):  # ten clients, one sample each per turn
                assert link.push_touch(src, 0.001 * k, 0.01, 0.5, t_event=float(k))
                await asyncio.sleep(0)
        deadline = time.monotonic() + PATIENCE
        while link.pending and time.monotonic() < deadline:
            await asyncio.sleep(0.01)

    asyncio.run(turns())
    rows = np.frombuffer(touch_in.recv_bytes(), dtype=np.float64).reshape(-1, 7)
    assert not touch_in.poll(0) and rows[:, 0].tolist() == list(range(10))
    assert np.all(rows[:, 1] == 3.0) and np.all(rows[:, 6] == 4.0) and link.coalesced == 30


def test_a_stalled_engine_side_keeps_the_newest_touch_and_never_blocks():
    session = build_session("cork")
    touch_in, touch_out, trace_in, _ = _pipes()  # nobody reads the touches
    link = ProcessLink(describe(session), touch_out, trace_in)

    async def flood() -> int:
        # at least 100 000 samples and on until the pipe is full (a blocking send would hang
        # here): how far a fixed count gets depends on how often the loop's flush timer fires
        k = 0
        while k < 100_000 or select.select([], [touch_out], [], 0)[1]:
            assert k < 10_000_000, "the pipe never filled"
            assert link.push_touch(k % 3, 0.01, 0.02, 0.5, t_event=float(k))
            k += 1
            await asyncio.sleep(0)  # every turn of the loop flushes what the pipe takes
        for src in range(3):  # each client's newest, with the engine side stalled
            assert link.push_touch(src, 0.01, 0.02, 0.5, t_event=float(k))
            k += 1
        await asyncio.sleep(2 * FLUSH_S)  # a flush is due: the pipe takes nothing
        return k

    total = asyncio.run(flood())
    assert sorted(link.pending) == [0, 1, 2]  # bounded by the clients, not by the backlog
    assert [link.pending[src][1] for src in range(3)] == [float(total - 3 + src) for src in range(3)]  # the newest kept
    got = []  # and what reached the pipe is whole messages, in order per client
    while touch_in.poll(0):
        got.append(np.frombuffer(touch_in.recv_bytes(), dtype=np.float64).reshape(-1, 7))
    rows = np.concatenate(got)
    for src in range(3):
        assert np.all(np.diff(rows[rows[:, 0] == src, 1]) > 0)
    assert rows[:, 6].sum() + sum(r[6] for r in link.pending.values()) == total
