"""The touch page router: the page, its static files, ``/api/info``, ``/api/status`` and the
``/ws`` stream of pointer events into the engine with the live trace back (also the
force-feedback page, :mod:`surfhap.web.ff`). :func:`pointer_messages` (size, per-client token
bucket, pydantic validation, rejections counted and logged, disconnect after ``max_rejects``)
also checks the study page's pad. Each client has its own receive loop and its own sender; a
client whose trace send stays blocked (it does not read) for 5 x ``send_timeout`` is closed,
and the engine is fed through a non-blocking link (:mod:`surfhap.web.link`,
:mod:`surfhap.web.process`), so no client stalls the engine or another client. docs/live.md.
"""

# no "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time
import asyncio
import contextlib
import logging
from dataclasses import dataclass, field
from importlib import resources
from typing import Callable, Optional, Union

from pydantic import ValidationError

from surfhap.live.config import ServerConfig
from surfhap.live.sources import RateLimiter, RejectLog
from surfhap.runtime.clock import now
from surfhap.web.messages import Move, Up, encode, page_to_surface, parse_message, reason, trace_message

__all__ = ["Client", "Hub", "pointer_messages", "touch_router", "PAGE_CSP"]

log = logging.getLogger("surfhap.web")

PAGE_CSP = "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:"
# how far a page's clock may run ahead of the server's for its rate limit (s): the backlog of a
# server that fell this far behind is still read as the page sent it, not as a flood
CATCH_UP_S = 10.0
SLOW_SENDS = 5  # a trace send blocked for this many send_timeouts closes the client
# receiving a queued message does not yield to the event loop: a client whose backlog (one read
# of the socket, thousands of messages) is handled in one go held the loop for seconds, with
# no trace frame (no acknowledgement) for anyone, so a client's loop yields every few messages
FAIR_TURN = 8


@dataclass
class Client:
    """One WebSocket client: its rate limiter (on :meth:`clock`), page size (CSS px),
    counters, and while a trace send is under way, since when (``sending``, s)."""

    id: int
    peer: str
    limiter: RateLimiter  # started at t=0 on the client's clock
    width_px: float = 800.0
    height_px: float = 600.0
    last_seq: int = -1
    last_t: float = 0.0
    received: int = 0
    rejected: int = 0
    down: bool = False
    server0: float = field(default_factory=now)  # the server's clock at connect (s)
    page0: Optional[float] = None  # the page's clock (s) at connect, from its first stamp
    elapsed: float = 0.0  # the client's clock (s since connect)
    sending: Optional[float] = None
    close: Optional[Callable[[], None]] = None  # stops its sender and closes it (1008)

    def clock(self, t_page: Optional[float]) -> float:
        """The client's time for its rate limit (s since connect): its page's stamps
        (``t_page``, s), never more than :data:`CATCH_UP_S` ahead of the server's clock, never
        backwards; the server's clock for a message without a stamp. A backlog that a starved
        server reads late keeps the rate at which the page sent it; a page that stamps faster
        than time passes gains at most ``CATCH_UP_S`` of allowance, once."""
        since = now() - self.server0
        if t_page is None:
            t = since
        else:  # comparisons, not min/max: this runs for every pointer event
            if self.page0 is None:
                self.page0 = t_page - since
            t = t_page - self.page0
            if t > since + CATCH_UP_S:
                t = since + CATCH_UP_S
        if t > self.elapsed:
            self.elapsed = t
        return self.elapsed


async def pointer_messages(ws, cfg: ServerConfig, client: Client, rejects: RejectLog,
                           handle: Callable[[Union[Move, Up]], None]) -> None:
    """``handle`` each validated move and up (:mod:`surfhap.web.messages`) of the WebSocket ``ws``
    until it closes (a callback, not an async generator: cheaper per message); a hello sets
    ``client``'s page size. A binary,
    oversized, invalid or too frequent message (``client.limiter`` on :meth:`Client.clock`) is
    counted on ``client`` and logged (throttled) through ``rejects``; after ``cfg.max_rejects``
    the socket is closed. Every :data:`FAIR_TURN` messages the loop yields to the event loop."""
    from starlette.websockets import WebSocketDisconnect

    receive, allow, clock, max_bytes = ws.receive, client.limiter.allow, client.clock, cfg.max_message_bytes
    n = 0
    while True:
        n += 1
        if n == FAIR_TURN:
            n = 0
            await asyncio.sleep(0)
        try:  # a closed socket ends the loop; an error in ``handle`` propagates
            msg = await receive()
        except (WebSocketDisconnect, RuntimeError):
            return
        text = msg.get("text")
        if text is None:
            if msg["type"] == "websocket.disconnect":
                return
            why = "binary frames are not accepted"
        elif len(text) > max_bytes:
            why = f"message of {len(text)} bytes (limit {max_bytes})"
        else:
            try:
                message = parse_message(text)
            except ValidationError as exc:
                message, why = None, reason(exc.errors(include_url=False, include_input=False))
            if message is not None:
                hello = message.type == "hello"
                if allow(clock(None if hello else message.t * 1e-3)):
                    if hello:
                        client.width_px, client.height_px = message.w, message.h
                    else:
                        handle(message)
                    continue
                why = "rate limit exceeded"
        client.rejected += 1
        rejects.reject(client.peer, why)
        if client.rejected > cfg.max_rejects:
            log.warning("closing %s: %d rejected messages", client.peer, client.rejected)
            with contextlib.suppress(RuntimeError):
                await ws.close(code=1008)
            return


class Hub:
    """Clients, counters and the newest frames (event-loop thread only). :meth:`publish`
    stores a frame and wakes every client's sender (one that is still busy with an older
    frame sends the newest next) and closes the clients whose send is blocked for longer than
    ``SLOW_SENDS * send_timeout``."""

    KEEP = 8  # recent frames kept for a client that fell behind

    def __init__(self, send_timeout: float = 1.0):
        self.send_timeout = float(send_timeout)
        self.clients: dict[int, Client] = {}
        self.next_id = 1000
        self.rejects = RejectLog(log)
        self.refused = 0
        self.frames: list[str] = []  # recent frames (encoded JSON objects), newest last (bounded)
        self.frame_no = 0
        self.engine_status: dict = {}
        self.status_json = "{}"  # the served status (/api/status), also "status" in trace messages
        self.status_no = 0
        self.gate = None  # the server's ConnectionGate (surfhap.web.server), for its counters
        self._event = asyncio.Event()

    def publish(self, frame: dict, engine_status: Optional[dict] = None) -> None:
        """Store ``frame`` (encoded once here for every client) and, when given, a new engine
        status, and wake the senders. The served status (``/api/status``, ``status`` in trace
        messages) is the engine's with the server's counters under ``"server"``, refreshed at
        least every 10 frames."""
        self.frames.append(encode(frame))
        if len(self.frames) > self.KEEP:
            del self.frames[0]
        self.frame_no += 1
        if engine_status is not None:
            self.engine_status = engine_status
        if engine_status is not None or self.frame_no % 10 == 1:
            srv = {"clients": len(self.clients), "rejected": self.rejects.count, "refused": self.refused}
            if self.gate is not None:
                srv["connections"] = self.gate.counters()
            self.status_json = encode({**self.engine_status, "server": srv})
            self.status_no += 1
        ev, self._event = self._event, asyncio.Event()
        ev.set()
        late = now() - SLOW_SENDS * self.send_timeout
        for c in [c for c in self.clients.values() if c.sending is not None and c.sending < late]:
            log.warning("closing %s: not reading its trace", c.peer)
            c.sending = None
            if c.close is not None:
                c.close()

    async def wait_frame(self, after: int) -> None:
        """Return when a frame newer than number ``after`` is there."""
        while self.frame_no == after:
            await self._event.wait()


def touch_router(link, hub: Hub, cfg: ServerConfig):
    """The routes of the touch page over ``link`` (an :class:`~surfhap.web.link.EngineLink`);
    ``hub`` holds its clients and frames (the app streams ``link``'s frames into it)."""
    from fastapi import APIRouter, WebSocket
    from fastapi.responses import FileResponse, JSONResponse, Response
    from starlette.websockets import WebSocketDisconnect

    router = APIRouter()
    surface_positions = link.positions == "surface"
    index_html = resources.files("surfhap.web").joinpath("static", "touch", "index.html")

    @router.get("/")
    async def index():
        return FileResponse(str(index_html), media_type="text/html; charset=utf-8",
                            headers={"Cache-Control": "no-store", "Content-Security-Policy": PAGE_CSP})

    @router.get("/api/info")
    async def info():
        return JSONResponse(link.info())

    @router.get("/api/status")
    async def status():
        return Response(hub.status_json, media_type="application/json")

    async def sender(ws: WebSocket, client: Client) -> None:
        sent_frame, sent_status = hub.frame_no, -1
        while True:
            await hub.wait_frame(sent_frame)
            # the frames this client has not seen yet (all of them unless it fell behind)
            new = min(hub.frame_no - sent_frame, len(hub.frames))
            sent_frame = hub.frame_no
            for frame in hub.frames[len(hub.frames) - new:]:
                parts = [frame]
                if hub.status_no != sent_status:
                    sent_status = hub.status_no
                    parts.append('{"status":' + hub.status_json + "}")
                client.sending = now()
                try:
                    await ws.send_text(trace_message(client.last_seq, client.last_t, client.received,
                                                     client.rejected, *parts))
                except (WebSocketDisconnect, RuntimeError, OSError):
                    return  # the client went away; its receive loop cleans up
                client.sending = None

    @router.websocket("/ws")
    async def ws_endpoint(ws: WebSocket):
        peer = f"ws {ws.client.host}:{ws.client.port}" if ws.client else "ws ?"
        # host and origin: checked by the request guard before the handshake gets here
        if len(hub.clients) >= cfg.max_clients:
            hub.refused += 1
            log.warning("refused WebSocket from %s: %d clients already", peer, len(hub.clients))
            await ws.close(code=1013)
            return
        await ws.accept()
        client = Client(hub.next_id, peer, RateLimiter(cfg.max_rate, cfg.burst, t=0.0))
        hub.next_id += 1
        hub.clients[client.id] = client
        loop = asyncio.get_running_loop()
        task = loop.create_task(sender(ws, client))
        client.close = lambda: (task.cancel(), loop.create_task(ws.close(code=1008)))
        log.info("page client %d connected from %s", client.id, peer)
        space, push = link.space, link.push_touch

        def handle(msg) -> None:
            if msg.type == "move":
                xm, ym, load = page_to_surface(msg, client.width_px, client.height_px, space, surface_positions)
                push(client.id, xm, ym, load, msg.t * 1e-3)
                client.down = True
            else:  # up
                push(client.id, 0.0, 0.0, 0.0, msg.t * 1e-3)
                client.down = False
            client.last_seq, client.last_t = msg.seq, msg.t
            client.received += 1

        try:
            await pointer_messages(ws, cfg, client, hub.rejects, handle)
        finally:
            task.cancel()
            if client.down:
                link.push_touch(client.id, 0.0, 0.0, 0.0)
            hub.clients.pop(client.id, None)
            log.info("page client %d left (%d messages, %d rejected)", client.id, client.received, client.rejected)

    return router
