"""The touch page: a FastAPI app that serves the page and streams pointer events over a
WebSocket into the live engine, and the live trace back.

Security (see docs/live.md):

* binds 127.0.0.1 unless told otherwise; the ``Host`` header must name a loopback name,
  the bound address or one of ``allowed_hosts`` (``*.example.org`` patterns allowed), which
  defeats DNS rebinding - also when bound to a wildcard address;
* a WebSocket is refused (close code 1008, one log line) unless its ``Origin`` is the page's
  own origin (``http://`` + ``Host``) or listed in ``allowed_origins``; a client that sends no
  ``Origin`` (not a browser) is allowed only with ``allow_missing_origin``;
* every message is size-checked (``max_message_bytes``, also enforced by uvicorn),
  rate-limited per client (token bucket), parsed as JSON (never evaluated) and
  range-checked (a number too large for a float, 10**400, is bad input like NaN);
  rejected messages are logged (rate-limited) and counted, and a client that keeps
  misbehaving is disconnected;
* each client has its own receive loop and its own sender with a send timeout; the engine
  is fed through the non-blocking touch ring, so no client can stall the engine or another
  client; ``max_clients`` bounds the WebSocket clients;
* the HTTP server closes connections that do not send their request headers in time and
  caps open connections (:mod:`surfhap.live.httpguard`).

Page -> server messages (JSON text, one per pointer event)::

    {"type": "hello", "w": css_px, "h": css_px}
    {"type": "move", "seq": n, "t": ms, "x": 0..1, "y": 0..1, "p": 0..1}
    {"type": "up", "seq": n, "t": ms}

Server -> page: ``{"type": "trace", ...}`` at ``trace_hz`` with the trace rows since the last
frame, the newest acknowledged ``seq`` and its page time stamp (so the page can show the
round trip) and, every few frames, the engine's counters and latency.
"""


import asyncio
import json
import logging
import threading
from contextlib import asynccontextmanager
from dataclasses import dataclass
from importlib import resources

import numpy as np

from surfhap.live.sources import RateLimiter, RejectLog, TouchSpace, finite_in_range

__all__ = ["ServerConfig", "LiveSession", "create_app", "ServerThread", "material_preview", "build_session", "FrameBuilder"]

log = logging.getLogger("surfhap.live")

CSS_PX_M = 0.0254 / 96.0  # one CSS pixel in metres (CSS reference pixel: 1/96 inch)
STATIC_FILES = {"app.js": "text/javascript; charset=utf-8", "style.css": "text/css; charset=utf-8",
                "index.html": "text/html; charset=utf-8"}
WILDCARD_HOSTS = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")


@dataclass(frozen=True)
class ServerConfig:
    """Settings of the touch page server."""

    host: str = "127.0.0.1"
    port: int = 8765
    allowed_origins: tuple[str, ...] = ()
    allowed_hosts: tuple[str, ...] = ()
    allow_missing_origin: bool = True
    max_message_bytes: int = 1024
    max_rate: float = 500.0  # messages/s per client (pointer events are <= 240 Hz)
    burst: float = 240.0  # two seconds of 120 Hz events (a client catching up after a stall)
    max_clients: int = 64
    max_rejects: int = 200  # rejected messages before a client is disconnected
    trace_hz: float = 30.0
    send_timeout: float = 1.0
    trace_points: int = 64
    # HTTP connection limits (surfhap.live.httpguard). The page loads with a handful of
    # requests and one WebSocket per client; 256 connections is four per WebSocket client
    # slot (max_clients); fewer when the process may not open that many files.
    max_connections: int = 256
    # a request's headers must be complete this long after the connection starts waiting
    # (nginx's client_header_timeout is 60 s for the open internet; a page on a lab network
    # sends its headers in one packet, 10 s leaves room for a congested Wi-Fi)
    header_timeout: float = 10.0
    keep_alive_timeout: float = 5.0  # idle keep-alive connections (uvicorn's default)
    max_header_bytes: int = 8192  # request line + headers (nginx's large header buffer size)
    backlog: int = 64  # pending connections; asyncio also accepts at most this many per wake-up


@dataclass
class _Client:
    id: int
    peer: str
    limiter: RateLimiter
    width_px: float = 800.0
    height_px: float = 600.0
    last_seq: int = -1
    last_t: float = 0.0
    received: int = 0
    rejected: int = 0
    slow: int = 0
    down: bool = False


def material_preview(material, width: int = 256, height: int = 64, seed: int = 0) -> dict:
    """A small grey image of a material for the page: its texture synthesized along x at
    0.1 m/s (rows are successive strokes), or flat for a friction-only material."""
    data = np.full((height, width), 0.5)
    tex = getattr(material, "texture", None)
    if tex is not None:
        try:
            syn = tex.synthesizer(seed=seed)
            n = width * height
            s = syn.process(np.full(n, 0.1), np.full(n, 0.5)).reshape(height, width)
            s = (s - s.mean()) / (s.std() + 1e-12)
            data = 0.5 + 0.15 * np.clip(s, -3, 3)
        except Exception:  # noqa: BLE001 - a preview is cosmetic
            log.debug("no texture preview", exc_info=True)
    return {"w": width, "h": height, "data": np.round(255 * np.clip(data, 0, 1)).astype(int).ravel().tolist()}


class LiveSession:
    """An engine with its backend and touch sources, plus what the page shows."""

    def __init__(self, engine, backend, *, title: str = "", preview: dict | None = None,
                 space: TouchSpace | None = None, sources: list | None = None, positions: str = "physical"):
        """``positions``: "physical" maps page positions to metres through CSS pixels (a
        material: the finger speed is real); "surface" maps the page onto the whole touch
        surface (a mesh: the shaded preview and the felt shape line up)."""
        self.engine = engine
        self.positions = positions
        self.backend = backend
        self.title = title
        self.preview = preview or {"w": 1, "h": 1, "data": [128]}
        self.space = space or TouchSpace()
        self.sources = list(sources or [])
        self.started = False

    def start(self) -> None:
        # The engine thread competes for the GIL with the web server: a short switch
        # interval (process-wide; restored on stop) bounds how long it can wait.
        import sys

        self._switch = sys.getswitchinterval()
        sys.setswitchinterval(min(self._switch, 0.0002))
        self.engine.warm_up()
        self.backend.start(self.engine)
        for s in self.sources:
            s.start()
        self.started = True

    def stop(self) -> None:
        # the backend first: its stop ramp runs on the live signal (a source's final lift
        # would cut it short), then the sources
        if self.started:
            import sys

            self.backend.stop()
            sys.setswitchinterval(self._switch)
        for s in self.sources:
            s.stop()
        self.started = False


class FrameBuilder:
    """Engine side of the trace stream: the rows written since the last call, binned to
    at most ``points`` points, as a JSON fragment; and the engine status as JSON."""

    def __init__(self, engine, backend, points: int = 64):
        self.engine, self.backend, self.points = engine, backend, int(points)
        self._idx = 0

    def frame(self) -> str:
        eng = self.engine
        rows, self._idx = eng.trace_since(self._idx, limit=eng.trace.shape[0] // 2)
        k = self.points
        if rows.shape[0] > k:  # bin to k points, keep each bin's peak voltage
            edges = np.linspace(0, rows.shape[0], k + 1).astype(int)
            keep = rows[edges[1:] - 1].copy()
            keep[:, 5] = np.maximum.reduceat(rows[:, 5], edges[:-1])
            rows = keep
        r = np.nan_to_num(rows, nan=0.0)
        return ('"t":' + json.dumps(np.round(r[:, 0], 4).tolist()) + ',"v":' + json.dumps(np.round(r[:, 5], 2).tolist())
                + ',"f":' + json.dumps(np.round(r[:, 7], 4).tolist()) + ',"target":' + json.dumps(np.round(r[:, 6], 4).tolist())
                + ',"speed":' + json.dumps(np.round(r[:, 3], 4).tolist()))

    def status(self) -> str:
        st = self.engine.status()
        st["output"] = _safe_info(self.backend)
        return json.dumps(st, default=_json_default)


class _Hub:
    """Shared state of the app: clients, counters, the newest trace frame.

    ``publish`` (event-loop thread) stores a frame and wakes every client's sender; a
    sender that is still busy with an older frame simply sends the newest one next."""

    def __init__(self, cfg: ServerConfig):
        self.cfg = cfg
        self.clients: dict[int, _Client] = {}
        self.next_id = 1000
        self.rejects = RejectLog()
        self.refused = 0
        self.frames: list[str] = []  # recent frames, newest last (bounded)
        self.frame_no = 0
        self.engine_status = "{}"
        self.status_json = "{}"
        self.status_no = 0
        self.guard = None  # the HTTP connection guard, when served by uvicorn_config
        self._event: asyncio.Event | None = None

    def publish(self, frame: str, engine_status: str | None = None) -> None:
        self.frames.append(frame)
        if len(self.frames) > 8:
            del self.frames[0]
        self.frame_no += 1
        if engine_status is not None:
            self.engine_status = engine_status
        if engine_status is not None or self.frame_no % 10 == 1:
            srv = {"clients": len(self.clients), "rejected": self.rejects.count, "refused": self.refused}
            if self.guard is not None:
                srv["connections"] = self.guard.counters()
            server = json.dumps(srv)
            es = self.engine_status
            self.status_json = (es[:-1] + ("," if len(es) > 2 else "") + '"server":' + server + "}") if es.endswith("}") else es
            self.status_no += 1
        ev, self._event = self._event, asyncio.Event()
        if ev is not None:
            ev.set()

    async def wait_frame(self, after: int, timeout: float) -> None:
        if self.frame_no != after:
            return
        if self._event is None:
            self._event = asyncio.Event()
        try:
            await asyncio.wait_for(self._event.wait(), timeout)
        except asyncio.TimeoutError:
            pass


def _safe_info(backend) -> dict:
    try:
        return backend.info()
    except Exception:  # noqa: BLE001
        return {"name": getattr(backend, "name", "?")}


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    return str(o)


_num = finite_in_range


def host_allow_list(bind_host: str, allowed_hosts=()) -> tuple[str, ...]:
    """The names a ``Host`` header may carry: the loopback names, the bound address
    (unless it is a wildcard) and ``allowed_hosts`` (exact names or ``*.domain`` patterns).
    A wildcard bind does not widen the list: that is what keeps DNS rebinding out."""
    names = [*LOOPBACK_NAMES, *(h.strip().lower().rstrip(".") for h in allowed_hosts)]
    if bind_host not in WILDCARD_HOSTS:
        names.append(bind_host.lower())
    return tuple(dict.fromkeys(n for n in names if n))


def host_allowed(host: str, allowed: tuple[str, ...]) -> bool:
    """True when ``host`` (lower case, port removed) matches the allow-list."""
    host = host.rstrip(".")
    for name in allowed:
        if name.startswith("*."):
            if host.endswith(name[1:]) and len(host) > len(name) - 1:
                return True
        elif host == name:
            return True
    return False


def _host_only(host_header: str) -> str:
    h = host_header.strip().lower()
    if h.startswith("["):
        return h[1 : h.find("]")] if "]" in h else h
    return h.rsplit(":", 1)[0] if h.count(":") == 1 else h


def create_app(session, cfg: ServerConfig | None = None, *, frames: str = "local", trace_sock=None):
    """The ASGI app (FastAPI) for ``session``.

    ``frames="local"``: the engine runs in this process and a ticker builds the trace
    frames. ``frames="remote"``: the engine runs in another process that sends frames as
    datagrams to ``trace_sock`` (see :mod:`surfhap.live.webproc`).
    """
    from fastapi import FastAPI, WebSocket
    from fastapi.responses import JSONResponse, Response
    from starlette.websockets import WebSocketDisconnect

    cfg = cfg or ServerConfig()
    hub = _Hub(cfg)
    surface_positions = getattr(session, "positions", "physical") == "surface"
    allowed_hosts = host_allow_list(cfg.host, cfg.allowed_hosts)
    allowed_origins = {o.rstrip("/").lower() for o in cfg.allowed_origins}

    def host_ok(host_header: str | None) -> bool:
        return bool(host_header) and host_allowed(_host_only(host_header), allowed_hosts)

    def origin_ok(origin: str | None, host_header: str | None) -> bool:
        if origin is None:
            return cfg.allow_missing_origin
        o = origin.rstrip("/").lower()
        if o in allowed_origins:
            return True
        return bool(host_header) and o == "http://" + host_header.strip().lower()

    async def ticker():
        builder = FrameBuilder(session.engine, session.backend, cfg.trace_points)
        period = 1.0 / cfg.trace_hz
        n = 0
        while True:
            try:
                hub.publish(builder.frame(), builder.status() if n % 5 == 0 else None)
            except Exception:  # noqa: BLE001 - monitoring must not die
                log.exception("trace tick failed")
            n += 1
            await asyncio.sleep(period)

    class _Datagrams(asyncio.DatagramProtocol):
        pending_status = None

        def datagram_received(self, data, addr):
            kind, body = data[:1], data[1:].decode("utf-8", "replace")
            if kind == b"S":
                self.pending_status = body
            elif kind == b"F":
                hub.publish(body, self.pending_status)
                self.pending_status = None

    @asynccontextmanager
    async def lifespan(_app):
        loop = asyncio.get_running_loop()
        if frames == "remote":
            transport, _ = await loop.create_datagram_endpoint(_Datagrams, sock=trace_sock)
            try:
                yield
            finally:
                transport.close()
            return
        task = loop.create_task(ticker())
        try:
            yield
        finally:
            task.cancel()

    app = FastAPI(title="surfhap live", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.hub = hub

    @app.middleware("http")
    async def check_host(request, call_next):
        if not host_ok(request.headers.get("host")):
            hub.refused += 1
            log.warning("refused HTTP request for host %r", request.headers.get("host"))
            return Response("host not allowed", status_code=400)
        return await call_next(request)

    def _static(name: str) -> bytes:
        return resources.files("surfhap.live").joinpath("static", name).read_bytes()

    @app.get("/")
    async def index():
        return Response(_static("index.html"), media_type=STATIC_FILES["index.html"],
                        headers={"Cache-Control": "no-store", "Content-Security-Policy":
                                 "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:"})

    @app.get("/static/{name}")
    async def static(name: str):
        if name not in STATIC_FILES or name == "index.html":
            return Response("not found", status_code=404)
        return Response(_static(name), media_type=STATIC_FILES[name], headers={"Cache-Control": "no-store"})

    @app.get("/api/info")
    async def info():
        eng = session.engine
        return JSONResponse({"title": session.title, "preview": session.preview, "drive_rate": eng.drive_rate,
                             "model_rate": eng.model_rate, "block_period": eng.block_period, "v_max": eng.v_max,
                             "surface_m": [session.space.width, session.space.height],
                             "output": _safe_info(session.backend)})

    @app.get("/api/status")
    async def status():
        return Response(hub.status_json, media_type="application/json")

    def handle(client: _Client, text) -> None:
        """Validate one message and feed the engine; raises nothing: a message that makes
        the validation itself fail is one more rejected message."""
        try:
            validate(client, text)
        except Exception as exc:  # noqa: BLE001 - a hostile message must not end the connection
            reject(client, f"malformed message ({type(exc).__name__})")

    def validate(client: _Client, text) -> None:
        if not isinstance(text, str):
            return reject(client, "binary frames are not accepted")
        if len(text) > cfg.max_message_bytes:
            return reject(client, f"message of {len(text)} bytes (limit {cfg.max_message_bytes})")
        if not client.limiter.allow():
            return reject(client, "rate limit exceeded")
        try:
            msg = json.loads(text)
        except (ValueError, RecursionError):
            return reject(client, "not JSON")
        if not isinstance(msg, dict):
            return reject(client, "not a JSON object")
        kind = msg.get("type")
        if kind == "move":
            seq = msg.get("seq")
            t = _num(msg.get("t"), 0.0, 1e12)
            x = _num(msg.get("x"), -0.05, 1.05)
            y = _num(msg.get("y"), -0.05, 1.05)
            p = _num(msg.get("p", 0.5), 0.0, 1.0)
            if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**53 or None in (t, x, y, p):
                return reject(client, "move needs seq (int), t (ms), x, y in 0-1, p in 0-1")
            sp = session.space
            load = (p if p > 0 else 0.5) * sp.max_load
            if surface_positions:
                xm = min(max(x, 0.0), 1.0) * sp.width
                ym = min(max(y, 0.0), 1.0) * sp.height
            else:
                xm = min(max(x, 0.0), 1.0) * client.width_px * CSS_PX_M
                ym = min(max(y, 0.0), 1.0) * client.height_px * CSS_PX_M
            session.engine.push_touch(client.id, xm, ym, load, t_event=t * 1e-3)
            client.down = True
        elif kind == "up":
            seq = msg.get("seq")
            t = _num(msg.get("t"), 0.0, 1e12)
            if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**53 or t is None:
                return reject(client, "up needs seq (int) and t (ms)")
            session.engine.push_touch(client.id, 0.0, 0.0, 0.0, t_event=t * 1e-3)
            client.down = False
        elif kind == "hello":
            w = _num(msg.get("w"), 10.0, 20000.0)
            h = _num(msg.get("h"), 10.0, 20000.0)
            if w is None or h is None:
                return reject(client, "hello needs w and h in CSS pixels (10-20000)")
            client.width_px, client.height_px = w, h
            return None
        else:
            return reject(client, f"unknown message type {str(kind)[:32]!r}")
        client.last_seq = seq
        client.last_t = t
        client.received += 1
        return None

    def reject(client: _Client, reason: str) -> None:
        client.rejected += 1
        hub.rejects.reject(client.peer, reason)

    async def sender(ws: WebSocket, client: _Client) -> None:
        sent_frame = hub.frame_no
        sent_status = -1
        while True:
            await hub.wait_frame(sent_frame, 1.0)
            if hub.frame_no == sent_frame:
                continue
            # the frames this client has not seen yet (all of them unless it fell behind)
            new = min(hub.frame_no - sent_frame, len(hub.frames))
            sent_frame = hub.frame_no
            for frame in hub.frames[len(hub.frames) - new:]:
                parts = ['{"type":"trace","ack":', str(client.last_seq), ',"ack_t":', repr(float(client.last_t)),
                         ',"received":', str(client.received), ',"rejected":', str(client.rejected), ',', frame]
                if hub.status_no != sent_status:
                    sent_status = hub.status_no
                    parts += [',"status":', hub.status_json]
                parts.append("}")
                try:
                    await asyncio.wait_for(ws.send_text("".join(parts)), cfg.send_timeout)
                    client.slow = 0
                except (WebSocketDisconnect, RuntimeError, OSError):
                    return  # the client went away; its receive loop cleans up
                except asyncio.TimeoutError:
                    client.slow += 1
                    if client.slow >= 5:
                        log.warning("closing %s: not reading its trace", client.peer)
                        await ws.close(code=1008)
                        return
                    break

    @app.websocket("/ws")
    async def ws_endpoint(ws: WebSocket):
        peer = f"ws {ws.client.host}:{ws.client.port}" if ws.client else "ws ?"
        origin = ws.headers.get("origin")
        host = ws.headers.get("host")
        if not host_ok(host) or not origin_ok(origin, host):
            hub.refused += 1
            log.warning("refused WebSocket from %s: origin %r, host %r not allowed", peer, origin, host)
            await ws.close(code=1008)
            return
        if len(hub.clients) >= cfg.max_clients:
            hub.refused += 1
            log.warning("refused WebSocket from %s: %d clients already", peer, len(hub.clients))
            await ws.close(code=1013)
            return
        await ws.accept()
        client = _Client(hub.next_id, peer, RateLimiter(cfg.max_rate, cfg.burst))
        hub.next_id += 1
        hub.clients[client.id] = client
        task = asyncio.get_running_loop().create_task(sender(ws, client))
        log.info("page client %d connected from %s", client.id, peer)
        try:
            while True:
                msg = await ws.receive()
                if msg["type"] == "websocket.disconnect":
                    break
                handle(client, msg.get("text") if msg.get("text") is not None else msg.get("bytes"))
                if client.rejected > cfg.max_rejects:
                    log.warning("closing %s: %d rejected messages", peer, client.rejected)
                    await ws.close(code=1008)
                    break
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            task.cancel()
            if client.down:
                session.engine.push_touch(client.id, 0.0, 0.0, 0.0)
            hub.clients.pop(client.id, None)
            log.info("page client %d left (%d messages, %d rejected)", client.id, client.received, client.rejected)

    return app


class ServerThread:
    """Run uvicorn for ``app`` in a background thread (tests, benchmarks, notebooks)."""

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0, max_message_bytes: int = 1024,
                 config: ServerConfig | None = None):
        """``config``: the limits to serve with (connection cap, timeouts, message size);
        by default a :class:`ServerConfig` with ``max_message_bytes``. ``host``/``port``
        are where to bind."""
        import socket

        import uvicorn

        self._sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.bind((host, port))
        self.host, self.port = host, self._sock.getsockname()[1]
        self.app = app
        from surfhap.live.httpguard import uvicorn_config

        cfg = config or ServerConfig(host=host, port=port, max_message_bytes=max_message_bytes)
        uconfig, self.guard = uvicorn_config(app, cfg)
        self.server = uvicorn.Server(uconfig)
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self._sock]},
                                        name="surfhap-http", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def start(self, timeout: float = 10.0) -> "ServerThread":
        import time

        self._thread.start()
        end = time.monotonic() + timeout
        while not self.server.started and time.monotonic() < end:
            time.sleep(0.02)
        if not self.server.started:
            raise RuntimeError("the web server did not start")
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        self._thread.join(5.0)
        self._sock.close()


def build_session(material: str = "cork", output: str = "sim", *, drive_rate: int | None = None,
                  engine_config=None, amp_gain: float = 250.0, space: TouchSpace | None = None,
                  osc_in: tuple[str, int] | None = None, replay=None, replay_loop: bool = False,
                  seed: int = 0, backend_options: dict | None = None, mesh=None, display=None) -> LiveSession:
    """Everything ``surfhap serve`` runs: material (or ``mesh`` file) -> renderer -> engine
    -> backend, plus optional OSC touch input ``(host, port)`` and a replayed trajectory."""
    from surfhap.exchange.materials import load_material
    from surfhap.live.backends import open_backend, parse_output
    from surfhap.live.engine import EngineConfig, LiveEngine
    from surfhap.live.sources import OscTouchSource, ReplaySource
    from surfhap.models.panel import SimulatedDisplay
    from surfhap.render.chain import ChainConfig, TextureChain

    kind, _ = parse_output(output)
    rate = int(drive_rate or (48000 if kind == "sound" else 20000))
    space = space or TouchSpace()
    cfg = engine_config or EngineConfig()
    if mesh is not None:
        from surfhap.live.shape_live import load_live_shape, shape_preview

        chain, title = load_live_shape(mesh, rate, (space.width, space.height), seed=seed)
        preview = shape_preview(chain.surface, (space.width, space.height))
        display_model = chain.config.display
    else:
        mat = load_material(material)
        chain = TextureChain(mat, ChainConfig(drive_rate=rate, seed=seed, **({} if display is None else {"display": display})))
        title, preview, display_model = f"{mat.name} ({chain.method})", material_preview(mat), chain.config.display
    display = SimulatedDisplay(display_model, chain.drive_rate, chain.model_rate) if cfg.simulate_display else None
    engine = LiveEngine(chain, cfg, display=display)
    backend = open_backend(output, amp_gain=amp_gain, **(backend_options or {}))
    sources = []
    if osc_in is not None:
        sources.append(OscTouchSource(engine, osc_in[0], osc_in[1], space=space))
    if replay is not None:
        sources.append(ReplaySource(engine, replay, loop=replay_loop))
    return LiveSession(engine, backend, title=title, preview=preview, space=space, sources=sources,
                       positions="surface" if mesh is not None else "physical")
