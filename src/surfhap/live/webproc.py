"""Run the touch page server in its own process, apart from the real-time engine.

In one Python process the web server and the engine's callback share the GIL: a burst of
pointer messages from many clients then delays the audio callback (underruns). With
:class:`WebProcess` the engine process keeps only two light threads next to the
callback:

* :class:`TouchBridge` receives validated touch samples from the web process as fixed-size
  datagrams on 127.0.0.1 (64 bytes: a per-run random 16-byte token, source id, source time,
  arrival time on the shared monotonic clock, x, y, load) and pushes them into the touch
  ring; anything else is dropped and counted;
* :class:`TracePublisher` sends the trace frames and the engine status back at
  ``trace_hz`` as datagrams (``S`` + status JSON, ``F`` + frame JSON, both objects).

In the web process the app reaches the engine through :class:`RemoteLink`, the
:class:`~surfhap.live.link.EngineLink` over this boundary.

The web process does everything else (HTTP, WebSocket, origin/host checks, validation,
rate limits, the connection guard of :mod:`surfhap.live.httpguard`, rate-limited logging)
exactly as the in-process server; ``time.perf_counter`` is CLOCK_MONOTONIC
on Linux, the same clock in both processes, so arrival stamps stay comparable.
"""

from __future__ import annotations

import json
import logging
import math
import multiprocessing as mp
import os
import socket
import struct
import threading

from surfhap.runtime.clock import now

__all__ = ["TouchBridge", "TracePublisher", "WebProcess", "RemoteLink", "describe"]

log = logging.getLogger("surfhap.live")

_TOUCH = struct.Struct("<16sqddddd")  # token, source, t_event, t_arrival, x, y, load


class TouchBridge:
    """Engine side: receive touch datagrams on 127.0.0.1 and push them to the engine."""

    def __init__(self, engine):
        self.engine = engine
        self.token = os.urandom(16)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.received = 0
        self.dropped = 0
        self._run = False
        self._thread = None

    def start(self) -> None:
        self._run = True
        self._thread = threading.Thread(target=self._loop, name="surfhap-touch-bridge", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        size = _TOUCH.size
        push = self.engine.push_touch
        while self._run:
            try:
                data = self.sock.recv(256)
            except socket.timeout:
                continue
            except OSError:
                return
            if len(data) != size:
                self.dropped += 1
                continue
            token, src, t_ev, t_arr, x, y, load = _TOUCH.unpack(data)
            if token != self.token:
                self.dropped += 1
                continue
            # the web process's arrival stamp: the receiver (LiveEngine or FFLoop push_touch)
            # applies clock.arrival_stamp to it, so it can only make the sample older, and a
            # stale stamp stays stale (datagrams queued while this process was stopped)
            push(src, x, y, load, t_event=t_ev, t_arrival=t_arr)
            self.received += 1

    def stop(self) -> None:
        self._run = False
        if self._thread is not None:
            self._thread.join(1.0)
        self.sock.close()


class RemoteLink:
    """Web side :class:`~surfhap.live.link.EngineLink` to an engine in another process:
    ``push_touch`` sends a datagram to its :class:`TouchBridge`, ``stream`` publishes the
    frames and status its :class:`TracePublisher` sends to ``trace_sock``.

    ``about``: what :meth:`WebProcess.start` tells the web process (:func:`describe`)."""

    def __init__(self, about: dict, bridge_port: int, token: bytes, trace_sock=None):
        from surfhap.live.sources import TouchSpace

        self._info = about["info"]
        self.space = TouchSpace(*about["space"])
        self.positions = about.get("positions", "physical")
        self._addr = ("127.0.0.1", bridge_port)
        self._token = token
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setblocking(False)
        self._trace_sock = trace_sock
        self.dropped = 0  # touch datagrams the socket refused (buffer full)
        self.bad_datagrams = 0  # trace datagrams that were not a JSON object

    def info(self) -> dict:
        return dict(self._info)

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan) -> bool:
        try:
            self._sock.sendto(_TOUCH.pack(self._token, int(source), t_event, now(), x, y, load), self._addr)
            return True
        except OSError:  # buffer full: drop, never wait
            self.dropped += 1
            return False

    async def stream(self, publish) -> None:
        import asyncio

        link = self

        class Datagrams(asyncio.DatagramProtocol):
            pending_status = None

            def datagram_received(self, data, addr):
                try:
                    body = json.loads(data[1:])
                except ValueError:
                    body = None
                if not isinstance(body, dict):
                    link.bad_datagrams += 1
                elif data[:1] == b"S":
                    self.pending_status = body
                elif data[:1] == b"F":
                    publish(body, self.pending_status)
                    self.pending_status = None

        transport, _ = await asyncio.get_running_loop().create_datagram_endpoint(Datagrams, sock=self._trace_sock)
        try:
            await asyncio.Event().wait()  # until cancelled
        finally:
            transport.close()


def describe(session) -> dict:
    """What the web process needs to know about ``session`` (picklable): the page info,
    the touch surface and how page positions map onto it."""
    from surfhap.live.session import page_info

    s = session.space
    return {"info": page_info(session), "positions": getattr(session, "positions", "physical"),
            "space": (s.width, s.height, s.max_load, s.default_load)}


class TracePublisher:
    """Engine side: send trace frames and status to the web process at ``hz``."""

    def __init__(self, session, port: int, hz: float = 30.0, points: int = 64):
        from surfhap.live.frames import FrameBuilder

        self.builder = FrameBuilder(session.engine, session.backend, points)
        self.addr = ("127.0.0.1", port)
        self.hz = float(hz)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._stop = threading.Event()
        self._thread = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="surfhap-trace-pub", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        n = 0
        while not self._stop.wait(1.0 / self.hz):
            try:
                if n % 5 == 0:
                    self.sock.sendto(b"S" + _dumps(self.builder.status()), self.addr)
                self.sock.sendto(b"F" + _dumps(self.builder.frame()), self.addr)
            except OSError:
                pass
            except Exception:  # noqa: BLE001 - monitoring must not die
                log.exception("trace publisher failed")
            n += 1

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(1.0)
        self.sock.close()


def _dumps(obj: dict) -> bytes:
    from surfhap.live.protocol import encode

    return encode(obj).encode()


def _web_main(cfg, about: dict, bridge_port: int, token: bytes, conn, log_level: int) -> None:
    """Entry point of the web process."""
    logging.basicConfig(level=log_level, format="%(asctime)s %(levelname)s %(name)s[web]: %(message)s")
    import uvicorn

    from surfhap.live.httpguard import uvicorn_config
    from surfhap.live.logfilter import install_rate_limit
    from surfhap.live.app import create_app

    install_rate_limit()  # one line per kind per second, whatever a client provokes

    try:
        trace_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        trace_sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        trace_sock.bind(("127.0.0.1", 0))
        fam = socket.AF_INET6 if ":" in cfg.host else socket.AF_INET
        http_sock = socket.socket(fam, socket.SOCK_STREAM)
        http_sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        http_sock.bind((cfg.host, cfg.port))
    except OSError as exc:
        conn.send(("error", f"cannot listen on {cfg.host}:{cfg.port} ({exc.strerror or exc})"))
        return
    parent = os.getppid()

    def watch_parent():  # never outlive the engine process, even if it is killed
        import time

        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(0)

    threading.Thread(target=watch_parent, name="surfhap-parent-watch", daemon=True).start()
    app = create_app(RemoteLink(about, bridge_port, token, trace_sock), cfg)
    server = uvicorn.Server(uvicorn_config(app, cfg)[0])
    conn.send(("ok", trace_sock.getsockname()[1], http_sock.getsockname()[1]))
    server.run(sockets=[http_sock])


class WebProcess:
    """Start the page server for ``session`` in a separate (spawned) process."""

    def __init__(self, session, cfg):
        self.session = session
        self.cfg = cfg
        self.bridge = None
        self.publisher = None
        self.proc = None
        self.port = None

    @property
    def url(self) -> str:
        h = self.cfg.host
        return f"http://[{h}]:{self.port}" if ":" in h else f"http://{h}:{self.port}"

    def start(self, timeout: float = 30.0) -> "WebProcess":
        from surfhap.errors import ConfigError

        s = self.session
        about = describe(s)
        self.bridge = TouchBridge(s.engine)
        self.bridge.start()
        ctx = mp.get_context("spawn")
        parent, child = ctx.Pipe()
        self.proc = ctx.Process(target=_web_main, name="surfhap-web", daemon=True,
                                args=(self.cfg, about, self.bridge.port, self.bridge.token, child,
                                      logging.getLogger("surfhap").getEffectiveLevel()))
        self.proc.start()
        if not parent.poll(timeout):
            self.stop()
            raise RuntimeError("the web process did not start")
        msg = parent.recv()
        if msg[0] != "ok":
            self.stop()
            raise ConfigError(msg[1], source="--port")
        self.port = msg[2]
        self.publisher = TracePublisher(s, msg[1], self.cfg.trace_hz, self.cfg.trace_points)
        self.publisher.start()
        # wait until it answers HTTP (bounded)
        import time
        import urllib.request

        host = "127.0.0.1" if self.cfg.host in ("0.0.0.0", "::", "") else self.cfg.host
        host = f"[{host}]" if ":" in host else host
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                urllib.request.urlopen(f"http://{host}:{self.port}/api/status", timeout=1).read()
                break
            except OSError:
                time.sleep(0.05)
        return self

    def stop(self) -> None:
        if self.publisher is not None:
            self.publisher.stop()
        if self.proc is not None:
            self.proc.terminate()
            self.proc.join(5.0)
            if self.proc.is_alive():
                self.proc.kill()
                self.proc.join(2.0)
        if self.bridge is not None:
            self.bridge.stop()
