"""The touch page: a FastAPI app that serves the page and streams pointer events over a
WebSocket into the live engine, and the live trace back.

Security (see docs/live.md):

* binds 127.0.0.1 unless told otherwise; every request passes the one request guard of
  :mod:`surfhap.live.webguard` (shared with the study page): the ``Host`` header must name a
  loopback name, the bound address or one of ``allowed_hosts`` (:mod:`surfhap.live.hosts`),
  which defeats DNS rebinding - also when bound to a wildcard address; a WebSocket or a
  state-changing request is refused (close code 1008 / 403, a throttled log line) unless its
  ``Origin`` is the page's own origin (``http://`` + ``Host``) or listed in
  ``allowed_origins``; a client that sends no ``Origin`` (not a browser) is allowed only with
  ``allow_missing_origin``; request bodies are capped while they are read;
* every message is size-checked (``max_message_bytes``, also enforced by uvicorn),
  rate-limited per client (token bucket) and validated by the pydantic models of
  :mod:`surfhap.live.protocol` (JSON parsed, never evaluated; a number too large for a
  float, 10**400, is bad input like NaN); rejected messages are logged (rate-limited) and
  counted, and a client that keeps misbehaving is disconnected;
* each client has its own receive loop and its own sender with a send timeout; the engine
  is fed through the non-blocking touch ring (:mod:`surfhap.live.link`), so no client can
  stall the engine or another client; ``max_clients`` bounds the WebSocket clients;
* the HTTP server closes connections that do not send their request headers in time and
  caps open connections (:mod:`surfhap.live.httpguard`).

The messages are described in :mod:`surfhap.live.protocol`.
"""

# no "from __future__ import annotations": FastAPI reads the endpoints' annotations
# (WebSocket, imported inside create_app) at run time
import asyncio
import logging
from contextlib import asynccontextmanager
from importlib import resources

from surfhap.live.config import ServerConfig
from surfhap.live.hosts import OriginRule, host_allow_list
from surfhap.live.hub import Client, Hub
from surfhap.live.link import as_link
from surfhap.live.protocol import Hello, Move, page_to_surface, parse_message, trace_message
from surfhap.live.sources import RateLimiter
from surfhap.live.webguard import RequestGuard

__all__ = ["create_app"]

log = logging.getLogger("surfhap.live")

PAGE_CSP = "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:"


def _static_files():
    """StaticFiles for the page's assets (``surfhap.live/static``), never cached by the
    browser (a page updated with the package is reloaded whole)."""
    from starlette.staticfiles import StaticFiles

    class NoStoreStaticFiles(StaticFiles):
        def file_response(self, *args, **kwargs):
            response = super().file_response(*args, **kwargs)
            response.headers["Cache-Control"] = "no-store"
            return response

    return NoStoreStaticFiles(packages=[("surfhap.live", "static")])


def create_app(session, cfg: ServerConfig | None = None):
    """The ASGI app (FastAPI) for ``session``: an :class:`~surfhap.live.link.EngineLink`,
    or a :class:`~surfhap.live.session.LiveSession` (linked in-process,
    :class:`~surfhap.live.link.LocalLink`)."""
    from fastapi import FastAPI, WebSocket
    from fastapi.responses import FileResponse, JSONResponse, Response
    from starlette.websockets import WebSocketDisconnect

    cfg = cfg or ServerConfig()
    link = as_link(session, cfg)
    hub = Hub()
    surface_positions = link.positions == "surface"

    @asynccontextmanager
    async def lifespan(_app):
        task = asyncio.get_running_loop().create_task(link.stream(hub.publish))
        try:
            yield
        finally:
            task.cancel()

    def refused() -> None:
        hub.refused += 1

    app = FastAPI(title="surfhap live", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.hub = hub
    RequestGuard(host_allow_list(cfg.host, cfg.allowed_hosts), OriginRule(cfg.allowed_origins, cfg.allow_missing_origin),
                 on_refused=refused).install(app)
    app.mount("/static", _static_files(), name="static")
    index_html = resources.files("surfhap.live").joinpath("static", "index.html")

    @app.get("/")
    async def index():
        return FileResponse(str(index_html), media_type="text/html; charset=utf-8",
                            headers={"Cache-Control": "no-store", "Content-Security-Policy": PAGE_CSP})

    @app.get("/api/info")
    async def info():
        return JSONResponse(link.info())

    @app.get("/api/status")
    async def status():
        return Response(hub.status_json, media_type="application/json")

    def reject(client: Client, reason: str) -> None:
        client.rejected += 1
        hub.rejects.reject(client.peer, reason)

    def handle(client: Client, text) -> None:
        """Check one message and feed the engine; raises nothing (an invalid message is
        counted and logged through :meth:`reject`)."""
        if not isinstance(text, str):
            return reject(client, "binary frames are not accepted")
        if len(text) > cfg.max_message_bytes:
            return reject(client, f"message of {len(text)} bytes (limit {cfg.max_message_bytes})")
        if not client.limiter.allow():
            return reject(client, "rate limit exceeded")
        msg = parse_message(text)
        if isinstance(msg, str):
            return reject(client, msg)
        if isinstance(msg, Hello):
            client.width_px, client.height_px = msg.w, msg.h
            return None
        if isinstance(msg, Move):
            xm, ym, load = page_to_surface(msg, client.width_px, client.height_px, link.space, surface_positions)
            link.push_touch(client.id, xm, ym, load, t_event=msg.t * 1e-3)
            client.down = True
        else:  # Up
            link.push_touch(client.id, 0.0, 0.0, 0.0, t_event=msg.t * 1e-3)
            client.down = False
        client.last_seq = msg.seq
        client.last_t = msg.t
        client.received += 1
        return None

    async def sender(ws: WebSocket, client: Client) -> None:
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
                parts = [frame]
                if hub.status_no != sent_status:
                    sent_status = hub.status_no
                    parts.append(hub.status_member)
                text = trace_message(client.last_seq, client.last_t, client.received, client.rejected, *parts)
                try:
                    await asyncio.wait_for(ws.send_text(text), cfg.send_timeout)
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
        # host and origin: checked by the request guard before the handshake gets here
        if len(hub.clients) >= cfg.max_clients:
            hub.refused += 1
            log.warning("refused WebSocket from %s: %d clients already", peer, len(hub.clients))
            await ws.close(code=1013)
            return
        await ws.accept()
        client = Client(hub.next_id, peer, RateLimiter(cfg.max_rate, cfg.burst))
        hub.next_id += 1
        hub.clients[client.id] = client
        task = asyncio.get_running_loop().create_task(sender(ws, client))
        log.info("page client %d connected from %s", client.id, peer)
        try:
            while True:
                msg = await ws.receive()
                if msg["type"] == "websocket.disconnect":
                    break
                try:
                    handle(client, msg.get("text") if msg.get("text") is not None else msg.get("bytes"))
                except Exception as exc:  # noqa: BLE001 - a hostile message must not end the connection
                    reject(client, f"malformed message ({type(exc).__name__})")
                if client.rejected > cfg.max_rejects:
                    log.warning("closing %s: %d rejected messages", peer, client.rejected)
                    await ws.close(code=1008)
                    break
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            task.cancel()
            if client.down:
                link.push_touch(client.id, 0.0, 0.0, 0.0)
            hub.clients.pop(client.id, None)
            log.info("page client %d left (%d messages, %d rejected)", client.id, client.received, client.rejected)

    return app
