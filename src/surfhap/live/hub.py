"""Shared state of the page app: its clients, counters and the newest trace frames."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass

from surfhap.live.protocol import encode
from surfhap.live.sources import RateLimiter, RejectLog

__all__ = ["Client", "Hub"]


@dataclass
class Client:
    """One WebSocket client: its rate limiter, page size (CSS px) and counters."""

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


class Hub:
    """Clients, counters and the newest frames (event-loop thread only).

    :meth:`publish` stores a frame and wakes every client's sender; a sender that is still
    busy with an older frame simply sends the newest one next."""

    KEEP = 8  # recent frames kept for a client that fell behind

    def __init__(self):
        self.clients: dict[int, Client] = {}
        self.next_id = 1000
        self.rejects = RejectLog()
        self.refused = 0
        self.frames: list[str] = []  # recent frames (encoded JSON objects), newest last (bounded)
        self.frame_no = 0
        self.engine_status: dict = {}
        self.status_json = "{}"  # the served status (/api/status)
        self.status_member = '{"status":{}}'  # the same as the member of a trace message
        self.status_no = 0
        self.guard = None  # the HTTP connection guard, when served by uvicorn_config
        self._event: asyncio.Event | None = None

    def publish(self, frame: dict, engine_status: dict | None = None) -> None:
        """Store ``frame`` (encoded once here for every client) and, when given, a new
        engine status, and wake the senders.
        The served status (``/api/status``, ``status`` in trace messages) is the engine's
        with the server's counters under ``"server"``, refreshed at least every 10 frames."""
        self.frames.append(encode(frame))
        if len(self.frames) > self.KEEP:
            del self.frames[0]
        self.frame_no += 1
        if engine_status is not None:
            self.engine_status = engine_status
        if engine_status is not None or self.frame_no % 10 == 1:
            srv = {"clients": len(self.clients), "rejected": self.rejects.count, "refused": self.refused}
            if self.guard is not None:
                srv["connections"] = self.guard.counters()
            status = {**self.engine_status, "server": srv}
            self.status_json = encode(status)
            self.status_member = encode({"status": status})
            self.status_no += 1
        ev, self._event = self._event, asyncio.Event()
        if ev is not None:
            ev.set()

    async def wait_frame(self, after: int, timeout: float) -> None:
        """Return when a frame newer than number ``after`` is there, or after ``timeout`` s."""
        if self.frame_no != after:
            return
        if self._event is None:
            self._event = asyncio.Event()
        try:
            await asyncio.wait_for(self._event.wait(), timeout)
        except asyncio.TimeoutError:
            pass
