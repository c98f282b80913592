"""The touch page server over real loopback sockets: WebSocket stream -> engine -> trace,
origin and host checks, hostile messages, several clients at once."""

from __future__ import annotations

import asyncio
import http.client
import json
import logging
import time

import pytest

pytest.importorskip("fastapi")
websockets = pytest.importorskip("websockets")

from surfhap.live.server import ServerConfig, ServerThread, build_session, create_app  # noqa: E402


@pytest.fixture
def served():
    session = build_session("cork", "sim")
    session.start()
    srv = ServerThread(create_app(session, ServerConfig(port=0, max_rate=400.0, burst=50.0, max_rejects=30)),
                       port=0).start()
    yield session, srv
    srv.stop()
    session.stop()


def ws_url(srv):
    return f"ws://127.0.0.1:{srv.port}/ws"


async def stream(srv, n=120, rate=120.0, x0=0.2, origin=None):
    origin = origin or f"http://127.0.0.1:{srv.port}"
    async with websockets.connect(ws_url(srv), origin=origin) as ws:
        await ws.send(json.dumps({"type": "hello", "w": 800, "h": 600}))
        t0 = time.perf_counter()
        for i in range(n):
            t = (time.perf_counter() - t0) * 1e3
            await ws.send(json.dumps({"type": "move", "seq": i, "t": t, "x": x0 + 0.5 * i / n, "y": 0.5, "p": 0.5}))
            await asyncio.sleep(1.0 / rate)
        last = None
        for _ in range(40):
            m = json.loads(await asyncio.wait_for(ws.recv(), 2.0))
            last = m
            if m["ack"] == n - 1:
                break
        await ws.send(json.dumps({"type": "up", "seq": n, "t": (time.perf_counter() - t0) * 1e3}))
        return last


def test_page_and_static_files_are_served(served):
    _, srv = served
    c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=5)
    for path, kind in (("/", "text/html"), ("/static/app.js", "javascript"), ("/static/style.css", "text/css"),
                       ("/api/info", "json")):
        c.request("GET", path)
        r = c.getresponse()
        body = r.read()
        assert r.status == 200 and kind in r.getheader("content-type"), path
    assert json.loads(body)["drive_rate"] == 20000
    c.request("GET", "/static/../../etc/passwd")
    r = c.getresponse()
    r.read()
    assert r.status == 404


def test_pointer_stream_changes_the_drive(served):
    session, srv = served
    m = asyncio.run(stream(srv))
    assert m["ack"] == 119 and m["received"] == 120 and m["rejected"] == 0
    eng = session.engine
    assert eng.counters["touches"] >= 120
    rows, _ = eng.trace_since(0)
    assert rows[:, 5].max() > 50.0  # volts reached the output
    assert eng.latency_stats()["p99"] < 0.05


def test_unknown_origin_and_host_are_refused(served, caplog):
    _, srv = served
    caplog.set_level(logging.WARNING, logger="surfhap.live")

    async def evil():
        async with websockets.connect(ws_url(srv), origin="http://evil.example"):
            pass

    with pytest.raises(websockets.exceptions.InvalidStatus):
        asyncio.run(evil())
    assert any("refused WebSocket" in r.getMessage() for r in caplog.records)
    c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=5)
    c.request("GET", "/", headers={"Host": f"rebind.example:{srv.port}"})
    r = c.getresponse()
    r.read()
    assert r.status == 400


def test_hostile_messages_are_rejected_and_the_engine_keeps_running(served, caplog):
    session, srv = served
    caplog.set_level(logging.WARNING, logger="surfhap.live")
    eng = session.engine
    hostile = ["not json", "[1,2,3]", '{"type":"move"}', '{"type":"move","seq":1,"t":0,"x":NaN,"y":0.5}',
               '{"type":"move","seq":1,"t":0,"x":1e308,"y":0.5}', '{"type":"move","seq":-1,"t":0,"x":0.5,"y":0.5}',
               '{"type":"move","seq":true,"t":0,"x":0.5,"y":0.5}', '{"type":"__import__(\'os\')"}',
               '{"type":"hello","w":-5,"h":1e9}', '{"type":"move","seq":1,"t":0,"x":"0.5","y":0.5}',
               "{" * 5000]

    async def attack():
        async with websockets.connect(ws_url(srv), origin=f"http://127.0.0.1:{srv.port}", max_size=None) as ws:
            for h in hostile[:-1]:
                await ws.send(h)
            await ws.send(b"\x00\x01binary")
            m = None
            for _ in range(10):
                m = json.loads(await asyncio.wait_for(ws.recv(), 2.0))
                if m["rejected"] >= len(hostile) - 1:
                    break
            rejected = m["rejected"]
            await ws.send(hostile[-1])  # larger than the message limit: connection closed
            with pytest.raises(websockets.exceptions.ConnectionClosed):
                for _ in range(50):
                    await asyncio.wait_for(ws.recv(), 2.0)
            return rejected

    blocks0 = eng.counters["blocks"]
    rejected = asyncio.run(attack())
    assert rejected >= len(hostile) - 1
    assert any("rejected message" in r.getMessage() for r in caplog.records)
    # the engine kept running and a well-behaved client still works
    m = asyncio.run(stream(srv, n=40))
    assert m["ack"] == 39 and m["rejected"] == 0
    assert eng.counters["blocks"] > blocks0 and eng.counters["errors"] == 0


def test_flooding_client_is_rate_limited_and_disconnected(served):
    session, srv = served

    async def flood():
        async with websockets.connect(ws_url(srv), origin=f"http://127.0.0.1:{srv.port}") as ws:
            msg = json.dumps({"type": "move", "seq": 1, "t": 0.0, "x": 0.5, "y": 0.5, "p": 0.5})
            with pytest.raises(websockets.exceptions.ConnectionClosed):
                for _ in range(3000):
                    await ws.send(msg)
                for _ in range(100):
                    await asyncio.wait_for(ws.recv(), 2.0)

    asyncio.run(flood())
    assert session.engine.counters["touches"] < 3000


def test_fifty_clients_and_a_hostile_one_do_not_stall_each_other(tmp_path):
    """The benchmark's 50-client run, shortened: page server in its own process, clients in
    a third one, one of them flooding garbage and never reading its trace."""
    import subprocess
    import sys

    from surfhap.live.engine import audit_drive
    from surfhap.live.webproc import WebProcess

    session = build_session("cork", f"file:{tmp_path / 'drive.npz'}", backend_options={"max_seconds": 60})
    session.start()
    web = WebProcess(session, ServerConfig(port=0)).start()
    try:
        r = subprocess.run([sys.executable, "-m", "surfhap.live.loadtest", f"ws://127.0.0.1:{web.port}/ws",
                            "50", "120", "2", "1"], capture_output=True, text=True, timeout=60)
    finally:
        web.stop()
        session.stop()
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads(r.stdout)["summary"]
    assert res["all_acked"] and res["rejected"] == 0
    assert res["lag_p99_max"] < 0.5, res
    eng = session.engine
    assert eng.counters["errors"] == 0
    assert audit_drive(session.backend.recorded, eng.drive_rate, eng.renderer.safety.limits)["violations"] == 0


def test_page_server_in_its_own_process_feeds_the_engine():
    from surfhap.live.webproc import WebProcess

    session = build_session("cork", "sim")
    session.start()
    web = WebProcess(session, ServerConfig(port=0)).start()
    try:
        class _Srv:
            port = web.port

        m = asyncio.run(stream(_Srv, n=60))
        assert m["ack"] == 59 and m["received"] == 60 and m["rejected"] == 0

        async def hostile():
            async with websockets.connect(ws_url(_Srv), origin=f"http://127.0.0.1:{web.port}") as ws:
                await ws.send('{"type":"move","seq":1,"t":0,"x":9,"y":0}')
                for _ in range(20):
                    mm = json.loads(await asyncio.wait_for(ws.recv(), 2.0))
                    if mm["rejected"]:
                        return mm
        assert asyncio.run(hostile())["rejected"] == 1
        c = http.client.HTTPConnection("127.0.0.1", web.port, timeout=5)
        for _ in range(40):  # the status is refreshed a few times a second
            c.request("GET", "/api/status")
            st = json.loads(c.getresponse().read())
            if st["server"]["rejected"] >= 1:
                break
            time.sleep(0.05)
        assert st["counters"]["blocks"] > 0 and st["server"]["rejected"] >= 1
    finally:
        web.stop()
        session.stop()
    eng = session.engine
    assert web.bridge.received >= 60 and web.bridge.dropped == 0
    assert eng.counters["touches"] >= 60 and eng.trace_since(0)[0][:, 5].max() > 50.0
