"""Load generator for the touch page: many WebSocket clients streaming pointer events.

Used by ``benchmarks/bench_web.py`` (50 clients x 120 Hz x 60 s) and by the tests (a
shorter run). Each client sends ``move`` events at ``rate`` Hz for ``seconds`` (bounded
loops), reads its trace frames and measures the *ack lag*: the time from sending event
``seq`` to receiving the first frame that acknowledges it. ``bad_clients`` extra clients
misbehave (flood garbage and never read) to show they do not stall the others.

Measurement tooling, not part of the package (it needs only numpy and websockets). Run as a
script to keep the clients in their own process::

    python benchmarks/loadtest.py ws://127.0.0.1:PORT/ws N RATE SECONDS [BAD]

prints one JSON object.
"""

from __future__ import annotations

import asyncio
import base64
import gc
import json
import math
import os
import re
import sys
import time

import numpy as np
from websockets.frames import apply_mask  # the C speedup the server uses too

__all__ = ["run_clients"]

_ACK = re.compile(rb'"ack":\s*(-?\d+)')
_REJ = re.compile(rb'"rejected":\s*(\d+)')


def _frame(opcode: int, payload: bytes, mask: bytes) -> bytes:
    """One client -> server WebSocket frame (RFC 6455: FIN, masked with ``mask``)."""
    n = len(payload)
    size = bytes([0x80 | n]) if n < 126 else (bytes([0xFE]) + n.to_bytes(2, "big") if n < 65536
                                              else bytes([0xFF]) + n.to_bytes(8, "big"))
    return bytes([0x80 | opcode]) + size + mask + apply_mask(payload, mask)


class _Client(asyncio.Protocol):
    """One page client as a bare WebSocket client on an asyncio protocol (the handshake,
    masked text frames out, the server's unmasked frames in): a browser does this in native
    code, and the generator shares the machine with the server, so it costs one
    ``transport.write`` per event and no task. It sends ``move`` events when the shared ticker
    says so, reads its trace frames and records the ack lag of every event."""

    def __init__(self, k: int, n: int, host: str, path: str, origin: str):
        self.k, self.n = k, n
        self.sent_at = [math.nan] * n  # a list: cheaper per event than numpy scalars
        self.lags: list[float] = []
        self.gaps: list[float] = []
        self.last_ack = -1
        self.rejected = 0
        self.mask = os.urandom(4)
        key = base64.b64encode(os.urandom(16)).decode()
        self.request = (f"GET {path} HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                        f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\nOrigin: {origin}\r\n\r\n").encode()
        self.buf = bytearray()
        self.upgraded = False
        self.t_prev = None
        self.transport = None
        loop = asyncio.get_running_loop()
        self.opened, self.done = loop.create_future(), loop.create_future()

    def connection_made(self, transport) -> None:
        self.transport = transport
        transport.write(self.request)

    def connection_lost(self, exc) -> None:
        if not self.opened.done():
            self.opened.set_exception(ConnectionError("the server refused the WebSocket"))
        if not self.done.done():
            self.done.set_result(None)

    def send(self, text: str) -> None:
        self.transport.write(_frame(0x1, text.encode(), self.mask))

    def data_received(self, data: bytes) -> None:
        buf = self.buf
        buf += data
        if not self.upgraded:
            end = buf.find(b"\r\n\r\n")
            if end < 0:
                return
            if not buf.startswith(b"HTTP/1.1 101"):
                self.transport.close()
                return
            del buf[:end + 4]
            self.upgraded = True
            self.opened.set_result(None)
        t = time.perf_counter()
        while len(buf) >= 2:
            n, off = buf[1] & 0x7F, 2
            if n >= 126:
                off = 4 if n == 126 else 10
                if len(buf) < off:
                    return
                n = int.from_bytes(buf[2:off], "big")
            if len(buf) < off + n:
                return
            opcode, payload = buf[0] & 0x0F, bytes(buf[off:off + n])
            del buf[:off + n]
            if opcode == 0x8:  # close
                self.transport.close()
            elif opcode == 0x1:
                self.frame(t, payload)

    def frame(self, t: float, raw: bytes) -> None:
        if self.t_prev is not None:
            self.gaps.append(t - self.t_prev)
        self.t_prev = t
        # only the acknowledgement is needed: read it without parsing the whole frame
        mo = _ACK.search(raw, 0, 200)
        if mo is None:
            return
        a = int(mo.group(1))
        mr = _REJ.search(raw, 0, 300)
        self.rejected = int(mr.group(1)) if mr else self.rejected
        if a > self.last_ack:
            self.lags.extend(t - ts for ts in self.sent_at[self.last_ack + 1:min(a, self.n - 1) + 1] if ts == ts)
            self.last_ack = a
        if self.last_ack >= self.n - 1 and not self.done.done():
            self.done.set_result(None)

    def close(self) -> None:
        if not self.transport.is_closing():
            self.transport.write(_frame(0x8, (1000).to_bytes(2, "big"), self.mask))
            self.transport.close()

    def result(self) -> dict:
        lag = np.array(self.lags) if self.lags else np.array([np.inf])
        return {"sent": self.n, "acked": self.last_ack + 1, "lag_p50": float(np.percentile(lag, 50)),
                "lag_p99": float(np.percentile(lag, 99)), "lag_max": float(lag.max()),
                "max_frame_gap": float(max(self.gaps)) if self.gaps else float("inf"), "rejected": self.rejected}


async def _clients(url: str, origin: str, n_clients: int, rate: float, seconds: float) -> list[dict]:
    """``n_clients`` clients, each sending ``move`` events at ``rate`` Hz for ``seconds``: one
    ticker sends every client's event of a tick (one timer wake-up per tick for all clients,
    so the generator itself stays light); the clients read their frames as they arrive."""
    from urllib.parse import urlsplit

    u = urlsplit(url)
    loop = asyncio.get_running_loop()
    n = int(rate * seconds)
    clients = []
    for k in range(n_clients):
        _, c = await loop.create_connection(lambda k=k: _Client(k, n, u.netloc, u.path, origin), u.hostname, u.port)
        await asyncio.wait_for(c.opened, 20.0)
        c.send(json.dumps({"type": "hello", "w": 1000, "h": 700}))
        clients.append(c)
    gc.freeze()  # the cyclic collector never scans the setup again (no pause of the ticker)
    t0 = time.perf_counter()
    for i in range(n):
        # always yield, also when behind schedule: the clients read their frames meanwhile,
        # else the generator's own backlog would count as the server's ack lag
        await asyncio.sleep(max(0.0, t0 + i / rate - time.perf_counter()))
        for c in clients:
            ph = (i / rate) * 0.5 + c.k * 0.013
            x = 0.1 + 0.8 * abs((ph % 2.0) - 1.0)
            c.sent_at[i] = ts = time.perf_counter()
            c.send(f'{{"type":"move","seq":{i},"t":{(ts - t0) * 1e3:.3f},"x":{x:.6f},'
                   f'"y":{0.2 + 0.6 * (c.k % 10) / 10:.3f},"p":0.5}}')
    for c in clients:
        c.send(json.dumps({"type": "up", "seq": n, "t": (time.perf_counter() - t0) * 1e3}))
    await asyncio.wait([c.done for c in clients], timeout=5.0)
    for c in clients:
        c.close()
    return [c.result() for c in clients]


async def _bad_client(url: str, origin: str, seconds: float) -> dict:
    import websockets

    sent = 0
    closed = False
    try:
        async with websockets.connect(url, origin=origin, max_queue=1, close_timeout=0.5) as ws:
            end = time.perf_counter() + seconds
            while time.perf_counter() < end:
                for msg in ("{not json", '{"type":"move","seq":1,"t":0,"x":1e9,"y":0}', "[]"):
                    await ws.send(msg)
                    sent += 1
                await asyncio.sleep(0.001)
    except Exception:  # noqa: BLE001 - being disconnected is the expected outcome
        closed = True
    return {"bad_sent": sent, "disconnected": closed}


async def _run(url: str, n: int, rate: float, seconds: float, bad: int) -> dict:
    origin = url.replace("ws://", "http://").rsplit("/ws", 1)[0]
    res = await asyncio.gather(_clients(url, origin, n, rate, seconds),
                               *[_bad_client(url, origin, seconds) for _ in range(bad)])
    return {"clients": res[0], "bad": list(res[1:])}


def run_clients(url: str, n: int = 50, rate: float = 120.0, seconds: float = 60.0, bad: int = 0) -> dict:
    """Run the clients (this process) and return per-client results and a summary."""
    try:  # the event loop in C where installed (the server's too): the generator shares the machine
        import uvloop

        factory = uvloop.new_event_loop
    except ImportError:
        factory = None
    with asyncio.Runner(loop_factory=factory) as runner:
        out = runner.run(_run(url, n, rate, seconds, bad))
    cl = out["clients"]
    out["summary"] = {
        "clients": n, "all_acked": all(c["acked"] >= c["sent"] for c in cl),
        "lag_p99_max": max(c["lag_p99"] for c in cl), "lag_max": max(c["lag_max"] for c in cl),
        "max_frame_gap": max(c["max_frame_gap"] for c in cl), "rejected": sum(c["rejected"] for c in cl),
        "sent": sum(c["sent"] for c in cl),
    }
    return out


if __name__ == "__main__":
    a = sys.argv[1:]
    sys.stdout.write(json.dumps(run_clients(a[0], int(a[1]), float(a[2]), float(a[3]), int(a[4]) if len(a) > 4 else 0)) + "\n")
