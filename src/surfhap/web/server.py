"""Serve the web app with uvicorn: its configuration, :class:`ServerThread` (tests, notebooks,
``study run``, ``serve --no-web-process``) and the connection gate against half-open
connections (slowloris).

Header size, keep-alive, backlog and ``limit_concurrency`` are uvicorn's own options, and
WebSocket compression is off (per-message deflate cost more CPU than anything else per
pointer event) and the event loop is uvloop where installed (``loop="auto"``). What uvicorn lacks: a deadline for a request head (its keep-alive timer stops
at the first byte) and a connection cap that closes the idlest. :class:`ConnectionGate` is an
``asyncio.Protocol`` around uvicorn's h11 protocol (composition through uvicorn's ``http``
option, nothing subclassed): a connection waiting for a request (new, or kept alive after a
response, as the request guard reports) must complete its headers within ``header_timeout``
s (absolute: trickling does not extend it); beyond ``max_connections`` (lowered under a small
file limit, :func:`connection_cap`) a new connection closes the one that has waited longest,
never a request being served or a WebSocket, else itself. What clients can make a server log
is throttled on the loggers: one line per kind per second.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import threading
import time
from collections import OrderedDict

from surfhap.live.config import ServerConfig

__all__ = ["ConnectionGate", "connection_cap", "uvicorn_config", "ServerThread", "FD_RESERVE", "THROTTLED_LOGGERS",
           "listen", "page_url"]

log = logging.getLogger("surfhap.web.http")
THROTTLED_LOGGERS = ("uvicorn.error", "surfhap.web.http")  # what clients can make a server log
# file handles kept free for the rest of the web process (listening socket, selector, pipes,
# module files): a serving process holds about 20; 64 leaves a margin of three
FD_RESERVE = 64


def connection_cap(max_connections: int, backlog: int, fd_limit: int | None = None) -> int:
    """``max_connections``, but never so many that the connections, three accept bursts of
    ``backlog`` and :data:`FD_RESERVE` exceed the soft limit on open files (``fd_limit``;
    RLIMIT_NOFILE when None). At least 8."""
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


def _key(addr) -> tuple | None:
    return (str(addr[0]), int(addr[1])) if addr else None


class _Gated(asyncio.Protocol):
    """One connection: the gate's bookkeeping around uvicorn's protocol ``inner``."""

    def __init__(self, gate: "ConnectionGate", inner: asyncio.Protocol):
        self.gate, self.inner = gate, inner
        self.transport = self.peer = self.deadline = None
        self.tail = b""  # the last bytes of a request head being received
        self.admitted = False

    def connection_made(self, transport) -> None:
        self.transport = transport
        self.peer = _key(transport.get_extra_info("peername"))
        self.admitted = self.gate.admit(self)
        if self.admitted:
            self.inner.connection_made(transport)
            self.gate.wait(self)

    def data_received(self, data: bytes) -> None:
        if not self.admitted:
            return
        if self.deadline is not None:  # waiting for a request head
            head = self.tail + data
            if b"\r\n\r\n" in head or b"\n\n" in head:
                self.gate.busy(self)
            else:
                self.tail = head[-3:]
        self.inner.data_received(data)

    def eof_received(self):
        return self.inner.eof_received() if self.admitted else None

    def connection_lost(self, exc) -> None:
        self.gate.forget(self)
        if self.admitted:
            self.inner.connection_lost(exc)

    def pause_writing(self) -> None:
        self.inner.pause_writing()

    def resume_writing(self) -> None:
        self.inner.resume_writing()

    def close(self) -> None:
        self.gate.forget(self)
        self.transport.close()


class ConnectionGate:
    """The cap, the header deadline, the connections waiting for a request (oldest first)
    and the counters of one server (see module doc)."""

    def __init__(self, max_connections: int, header_timeout: float):
        self.max_connections = int(max_connections)
        self.header_timeout = float(header_timeout)
        self.open: dict[_Gated, None] = {}
        self.waiting: OrderedDict[_Gated, None] = OrderedDict()
        self.by_peer: dict[tuple, _Gated] = {}
        self.evicted = self.timed_out = self.refused = 0

    def counters(self) -> dict:
        return {"max": self.max_connections, "evicted": self.evicted, "timed_out": self.timed_out,
                "refused": self.refused}

    def admit(self, conn: _Gated) -> bool:
        # a WebSocket's transport leaves the gate's protocol: drop the closed ones here
        for c in [c for c in self.open if c.transport.is_closing()]:
            self.forget(c)
        if len(self.open) >= self.max_connections:
            victim = next(iter(self.waiting), None)
            if victim is None:
                self.refused += 1
                log.warning("connection cap of %d reached and none is idle: refused %s", self.max_connections,
                            conn.peer)
                conn.transport.close()
                return False
            self.evicted += 1
            log.warning("connection cap of %d reached: closed %s, idle longest", self.max_connections, victim.peer)
            victim.close()
        self.open[conn] = None
        if conn.peer is not None:
            self.by_peer[conn.peer] = conn
        return True

    def wait(self, conn: _Gated) -> None:
        """``conn`` waits for a request head: evictable, with a deadline."""
        self._cancel(conn)
        self.waiting[conn] = None
        conn.tail = b""
        conn.deadline = asyncio.get_running_loop().call_later(self.header_timeout, self._expired, conn)

    def busy(self, conn: _Gated) -> None:
        """A request head is complete: served (or upgraded to a WebSocket) from now on."""
        self._cancel(conn)
        self.waiting.pop(conn, None)

    def response_done(self, client) -> None:
        """The app sent the last byte of a response to ``client`` (host, port)."""
        conn = self.by_peer.get(_key(client))
        if conn is not None and conn in self.open and not conn.transport.is_closing():
            self.wait(conn)

    def forget(self, conn: _Gated) -> None:
        self._cancel(conn)
        self.waiting.pop(conn, None)
        self.open.pop(conn, None)
        if self.by_peer.get(conn.peer) is conn:
            del self.by_peer[conn.peer]

    def _expired(self, conn: _Gated) -> None:
        conn.deadline = None
        if conn in self.waiting:
            self.timed_out += 1
            log.info("closed %s: no complete request within %g s", conn.peer, self.header_timeout)
            conn.close()

    @staticmethod
    def _cancel(conn: _Gated) -> None:
        if conn.deadline is not None:
            conn.deadline.cancel()
            conn.deadline = None


def uvicorn_config(app, cfg: ServerConfig):
    """``(uvicorn.Config, ConnectionGate)`` for ``app`` with the limits of ``cfg``; uvicorn's
    logging configuration is not installed (its records reach the root logger's handlers),
    and a :class:`~surfhap.live.logfilter.RateLimitFilter` sits on each of
    :data:`THROTTLED_LOGGERS`. The gate is handed to the app's request guard and hub for the
    connection state and ``/api/status``."""
    import uvicorn
    from uvicorn.protocols.http.h11_impl import H11Protocol

    from surfhap.live.logfilter import RateLimitFilter

    for name in THROTTLED_LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RateLimitFilter) for f in logger.filters):
            logger.addFilter(RateLimitFilter())
    cap = connection_cap(cfg.max_connections, cfg.backlog)
    gate = ConnectionGate(cap, cfg.header_timeout)
    for part in (getattr(app.state, "guard", None), getattr(app.state, "hub", None)):
        if part is not None:
            part.gate = gate
    config = uvicorn.Config(
        app, loop="auto", http=lambda **kw: _Gated(gate, H11Protocol(**kw)), ws="websockets-sansio",
        ws_per_message_deflate=False,
        log_level="warning", log_config=None, lifespan="on", ws_max_size=cfg.max_message_bytes,
        ws_ping_interval=None, timeout_keep_alive=cfg.keep_alive_timeout,
        h11_max_incomplete_event_size=cfg.max_header_bytes, backlog=cfg.backlog,
        limit_concurrency=2 * cap,  # the gate bounds connections; a 503 only if it were far exceeded
    )
    return config, gate


def listen(host: str, port: int, backlog: int = 64) -> socket.socket:
    """A listening TCP socket (port 0: any free port): connections queue in the kernel until
    the server accepts them."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(backlog)
    except OSError:
        sock.close()
        raise
    return sock


def page_url(host: str, port: int) -> str:
    """The page's address for a server bound to ``host`` (a wildcard bind: loopback)."""
    h = "127.0.0.1" if host in ("0.0.0.0", "") else ("::1" if host == "::" else host)
    return f"http://[{h}]:{port}" if ":" in h else f"http://{h}:{port}"


class ServerThread:
    """Run uvicorn for ``app`` in a background thread, bound to ``host``/``port`` (port 0: any
    free port, see :attr:`port`) with the limits of ``config`` (default: ServerConfig())."""

    def __init__(self, app, host: str = "127.0.0.1", port: int = 0, config: ServerConfig | None = None):
        import uvicorn

        cfg = config or ServerConfig(host=host, port=port)
        self._sock = listen(host, port, cfg.backlog)
        self.host, self.port = host, self._sock.getsockname()[1]
        self.app = app
        uconfig, self.gate = uvicorn_config(app, cfg)
        self.server = uvicorn.Server(uconfig)
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self._sock]},
                                        name="surfhap-http", daemon=True)

    @property
    def url(self) -> str:
        return page_url(self.host, self.port)

    def start(self, timeout: float = 120.0) -> "ServerThread":
        """Start serving; raises RuntimeError when uvicorn's thread ends before it is up, or it
        is not up within ``timeout`` s (a guard against a hang: start-up takes seconds on a
        loaded machine)."""
        self._thread.start()
        end = time.monotonic() + timeout
        while not self.server.started and self._thread.is_alive() and time.monotonic() < end:
            time.sleep(0.02)
        if not self.server.started:
            raise RuntimeError("the web server did not start")
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        self._thread.join(5.0)
        self._sock.close()
