"""How the page app reaches the engine: the :class:`EngineLink` interface and its in-process
implementation :class:`LocalLink` (over the process boundary:
:class:`surfhap.web.process.ProcessLink`)."""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Callable, Protocol, runtime_checkable

from surfhap.live.session import FrameBuilder, page_info
from surfhap.live.sources import TouchSpace

__all__ = ["EngineLink", "LocalLink", "Publish", "as_link", "trace_ticks"]

log = logging.getLogger("surfhap.live")

Publish = Callable[[dict, "dict | None"], None]  # (frame, engine status or None)


@runtime_checkable
class EngineLink(Protocol):
    """The engine as the page app sees it. ``space``: the touch surface (m, N);
    ``positions``: "physical" (page positions through CSS pixels) or "surface" (the page
    spans the whole surface)."""

    space: TouchSpace
    positions: str

    def info(self) -> dict:
        """The page's ``/api/info`` (:func:`surfhap.live.session.page_info`)."""

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan) -> bool:
        """One touch sample: position (m), load (N, 0 = lifted), the source's time stamp
        (s). Never blocks; False when it was dropped."""

    async def stream(self, publish: Publish) -> None:
        """Call ``publish(frame, status)`` for every trace frame (:class:`surfhap.live.session.FrameBuilder`),
        with the engine status every few frames (else None), until cancelled."""


class LocalLink:
    """The engine in this process: touches go straight into its touch ring and a ticker
    builds a frame every ``1 / hz`` s (the engine status with every 5th)."""

    def __init__(self, session, points: int = 64, hz: float = 30.0):
        self.session, self.space, self.positions = session, session.space, session.positions
        self.push_touch = session.engine.push_touch
        self.points, self.hz = int(points), float(hz)

    def info(self) -> dict:
        return page_info(self.session)

    async def stream(self, publish: Publish) -> None:
        for frame, status in trace_ticks(self.session, self.points):
            publish(frame, status)
            await asyncio.sleep(1.0 / self.hz)


def trace_ticks(session, points: int):
    """Endless ``(frame, status or None)`` of ``session``'s engine: one frame per call, the
    engine status with every 5th; a failing tick gives ``({}, None)`` (and one log line)."""
    builder = FrameBuilder(session.engine, session.backend, points)
    n = 0
    while True:
        try:
            yield builder.frame(), builder.status() if n % 5 == 0 else None
        except Exception:  # noqa: BLE001 - monitoring must not die
            log.exception("trace tick failed")
            yield {}, None
        n += 1


def as_link(obj, cfg) -> EngineLink:
    """``obj`` when it is an :class:`EngineLink`, else a :class:`LocalLink` to the live
    session ``obj`` with the trace settings of ``cfg`` (:class:`~surfhap.live.config.ServerConfig`)."""
    return obj if isinstance(obj, EngineLink) else LocalLink(obj, cfg.trace_points, cfg.trace_hz)
