"""Hold the page's HTTP server against half-open connections (slowloris).

uvicorn's HTTP/1.1 protocol (h11) waits for a request's headers for as long as the client
likes, and accepts connections until the process runs out of file handles; after that
every ``accept`` fails and the page is unreachable. :func:`uvicorn_config` builds the
server's configuration with a guarded protocol (:class:`ConnectionGuard`):

* **header deadline** - a connection that is waiting for a request (just opened, or
  kept alive after a response) must deliver complete request headers within
  ``header_timeout`` s, or it is closed; the deadline is absolute, so trickling one byte
  at a time does not extend it;
* **connection cap** - at most ``max_connections`` open connections (HTTP and
  WebSocket), lowered when the process's file-handle limit is small (see
  :func:`connection_cap`). A new connection beyond the cap closes the connection that has
  been *waiting for a request* the longest (a half-open one, or an idle keep-alive); a
  request being served and an open WebSocket are never closed for it. Only when nothing
  is waiting is the new connection itself closed;
* header size (``h11_max_incomplete_event_size``), keep-alive timeout, accept backlog and
  uvicorn's ``limit_concurrency`` are set from :class:`~surfhap.live.config.ServerConfig`.

Every closed connection is counted (``evicted``, ``timed_out``, ``refused``) and logged
through the ``surfhap.live.http`` logger. :func:`uvicorn_config` puts a
:class:`~surfhap.live.logfilter.RateLimitFilter` on that logger and on uvicorn's own
(``uvicorn.error``: one warning per malformed request) - on the loggers, not on handlers, so
the lines a client can provoke stay one per kind per second in every process that runs a
server (``serve``'s web process, ``study run``, a notebook), whatever logging it configured.
"""

from __future__ import annotations

import logging
from collections import OrderedDict

__all__ = ["ConnectionGuard", "connection_cap", "guarded_protocol", "uvicorn_config", "throttle_server_logs",
           "FD_RESERVE", "THROTTLED_LOGGERS"]

log = logging.getLogger("surfhap.live.http")
THROTTLED_LOGGERS = ("uvicorn.error", "surfhap.live.http")  # what clients can make a server log

# File handles kept free for everything else the web process opens (its listening and
# datagram sockets, the event loop's selector and self-pipe, the pipe to the engine
# process, imported modules' files): a Python process with the server running holds about
# 20; 64 leaves a margin of three.
FD_RESERVE = 64


def connection_cap(max_connections: int, backlog: int, fd_limit: int | None = None) -> int:
    """The number of open connections allowed: ``max_connections``, but never so many
    that the connections, the accept bursts in flight and :data:`FD_RESERVE` exceed the
    soft limit on open files (``fd_limit``; read from RLIMIT_NOFILE when None). At least 8.

    asyncio accepts up to ``backlog`` sockets per wake-up of the listening socket before
    any of them reaches the protocol; the protocol sees them one loop iteration later and
    a socket it closes is released one iteration after that, so up to three bursts of file
    handles are in flight on top of the capped connections."""
    if fd_limit is None:
        try:
            import resource

            soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
            fd_limit = None if soft == resource.RLIM_INFINITY else int(soft)
        except (ImportError, OSError, ValueError):  # not on POSIX
            fd_limit = None
    if fd_limit is None:
        return int(max_connections)
    return max(8, min(int(max_connections), fd_limit - 3 * int(backlog) - FD_RESERVE))


class ConnectionGuard:
    """State shared by all connections of one server: the cap, the deadline, the
    connections waiting for a request (oldest first) and the counters."""

    def __init__(self, max_connections: int, header_timeout: float):
        self.max_connections = int(max_connections)
        self.header_timeout = float(header_timeout)
        self.waiting: OrderedDict = OrderedDict()  # protocol -> None, longest waiting first
        self.closing: set = set()  # closed by us, connection_lost not seen yet
        self.evicted = 0
        self.timed_out = 0
        self.refused = 0

    def counters(self) -> dict:
        return {"max": self.max_connections, "evicted": self.evicted, "timed_out": self.timed_out,
                "refused": self.refused}


def _peer(proto) -> str:
    c = getattr(proto, "client", None)
    return f"{c[0]}:{c[1]}" if c else "?"


def guarded_protocol(guard: ConnectionGuard) -> type:
    """An h11 protocol class (uvicorn's ``H11Protocol``) bound to ``guard``."""
    from uvicorn.protocols.http.h11_impl import H11Protocol

    # the guard hooks into these (uvicorn's h11 protocol, stable since 0.2x); fail loudly
    # at start rather than serve unguarded if a future uvicorn renames them
    missing = [m for m in ("connection_made", "connection_lost", "handle_events", "handle_websocket_upgrade",
                           "on_response_complete") if not hasattr(H11Protocol, m)]
    if missing:
        raise RuntimeError(f"this uvicorn's H11Protocol lacks {', '.join(missing)}; the connection guard needs them")

    class GuardedH11Protocol(H11Protocol):
        _deadline = None

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            g = guard
            if len(self.connections) - len(g.closing) > g.max_connections:
                victim = next((p for p in g.waiting if p is not self), None)
                if victim is None:
                    g.refused += 1
                    log.warning("connection cap of %d reached and none is idle: refused %s", g.max_connections,
                                _peer(self))
                    self._guard_close()
                    return
                g.evicted += 1
                log.warning("connection cap of %d reached: closed %s, idle longest", g.max_connections, _peer(victim))
                victim._guard_close()
            self._guard_wait()

        def _guard_wait(self) -> None:
            """Now waiting for a request: evictable, and with a header deadline."""
            guard.waiting[self] = None
            guard.waiting.move_to_end(self)
            self._guard_cancel()
            self._deadline = self.loop.call_later(guard.header_timeout, self._guard_expired)

        def _guard_cancel(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _guard_expired(self) -> None:
            self._deadline = None
            if self.transport.is_closing() or self.transport.get_protocol() is not self:
                return
            if self.cycle is not None and not self.cycle.response_complete:
                return  # a request is being served
            guard.timed_out += 1
            log.info("closed %s: no complete request within %g s", _peer(self), guard.header_timeout)
            self._guard_close()

        def _guard_close(self) -> None:
            guard.waiting.pop(self, None)
            guard.closing.add(self)
            self._guard_cancel()
            self.transport.close()

        def handle_events(self) -> None:
            super().handle_events()
            if self.cycle is not None and not self.cycle.response_complete:
                guard.waiting.pop(self, None)  # headers complete: being served

        def handle_websocket_upgrade(self, event) -> None:
            guard.waiting.pop(self, None)
            self._guard_cancel()
            super().handle_websocket_upgrade(event)

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._guard_wait()

        def connection_lost(self, exc) -> None:
            super().connection_lost(exc)
            guard.waiting.pop(self, None)
            guard.closing.discard(self)
            self._guard_cancel()

    return GuardedH11Protocol


def throttle_server_logs() -> None:
    """Put one :class:`~surfhap.live.logfilter.RateLimitFilter` on each of
    :data:`THROTTLED_LOGGERS` (once per process)."""
    from surfhap.live.logfilter import RateLimitFilter

    for name in THROTTLED_LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RateLimitFilter) for f in logger.filters):
            logger.addFilter(RateLimitFilter())


def uvicorn_config(app, cfg):
    """A ``uvicorn.Config`` for ``app`` with the limits of ``cfg``
    (:class:`~surfhap.live.config.ServerConfig`) and a guarded h11 protocol.

    uvicorn's own logging configuration is not installed (``log_config=None``): its records
    propagate to the root logger's handlers, where :func:`surfhap.live.logfilter.install_rate_limit`
    rate-limits them. Returns ``(config, guard)``; the guard is also given to the app's hub
    (when it has one) so ``/api/status`` reports its counters."""
    import uvicorn

    throttle_server_logs()
    cap = connection_cap(cfg.max_connections, cfg.backlog)
    guard = ConnectionGuard(cap, cfg.header_timeout)
    hub = getattr(getattr(app, "state", None), "hub", None)
    if hub is not None:
        hub.guard = guard
    config = uvicorn.Config(
        app, http=guarded_protocol(guard), log_level="warning", log_config=None, lifespan="on",
        ws_max_size=cfg.max_message_bytes, ws_ping_interval=None,
        timeout_keep_alive=cfg.keep_alive_timeout, h11_max_incomplete_event_size=cfg.max_header_bytes,
        backlog=cfg.backlog,
        # the guard's cap is what bounds connections (and so tasks: one per request or
        # WebSocket); this second net answers 503 only if it were ever far exceeded
        limit_concurrency=2 * cap,
    )
    return config, guard
