"""The two engine links of the page app: in-process (LocalLink) and over the web process
boundary (RemoteLink -> TouchBridge, TracePublisher -> RemoteLink), on real loopback sockets."""

from __future__ import annotations

import asyncio
import json
import socket
import time

from surfhap.live.link import EngineLink, LocalLink, as_link
from surfhap.live.session import build_session
from surfhap.live.webproc import RemoteLink, TouchBridge, describe


class _Engine:
    """Records what the bridge pushes (the engine's push_touch signature)."""

    def __init__(self):
        self.pushed = []

    def push_touch(self, source, x, y, load, t_event=float("nan"), t_arrival=None):
        self.pushed.append((source, x, y, load, t_event))
        return True


def test_both_links_satisfy_the_interface_and_describe_the_same_page():
    session = build_session("cork", "sim")
    local = as_link(session, type("Cfg", (), {"trace_points": 16, "trace_hz": 30.0})())
    assert isinstance(local, LocalLink) and isinstance(local, EngineLink)
    assert not isinstance(session, EngineLink)
    remote = RemoteLink(describe(session), 9, b"0" * 16)
    assert isinstance(remote, EngineLink) and as_link(remote, None) is remote
    assert json.loads(json.dumps(remote.info())) == json.loads(json.dumps(local.info()))
    assert remote.space == session.space and remote.positions == local.positions == "physical"


def test_remote_link_pushes_through_the_bridge_and_streams_published_frames():
    eng = _Engine()
    bridge = TouchBridge(eng)
    bridge.start()
    session = build_session("cork", "sim")
    trace_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    trace_sock.bind(("127.0.0.1", 0))
    link = RemoteLink(describe(session), bridge.port, bridge.token, trace_sock)
    frame = {"t": [0.5], "v": [12.0], "f": [0.1], "target": [0.1], "speed": [0.02]}
    got = []

    async def scenario():
        task = asyncio.get_running_loop().create_task(link.stream(lambda f, s: got.append((f, s))))
        await asyncio.sleep(0.2)
        out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        addr = trace_sock.getsockname()
        for data in (b"S" + json.dumps({"counters": {"blocks": 7}}).encode(), b"F" + json.dumps(frame).encode(),
                     b"Fnot json", b"F[1, 2]", b"S{", b"F" + json.dumps(frame).encode()):
            out.sendto(data, addr)
        end = time.monotonic() + 20
        while len(got) < 2 and time.monotonic() < end:
            await asyncio.sleep(0.02)
        out.close()
        task.cancel()

    try:
        assert link.push_touch(1001, 0.01, 0.02, 0.5, t_event=1.25)
        asyncio.run(scenario())
        end = time.monotonic() + 20
        while not eng.pushed and time.monotonic() < end:
            time.sleep(0.02)
    finally:
        bridge.stop()
        trace_sock.close()
    assert eng.pushed == [(1001, 0.01, 0.02, 0.5, 1.25)]
    assert got == [(frame, {"counters": {"blocks": 7}}), (frame, None)]  # the status goes with the next frame
    assert link.bad_datagrams == 3
