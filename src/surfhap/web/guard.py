"""The request guard of the web app (:func:`surfhap.web.app.create_app`), a pure ASGI
middleware (:meth:`RequestGuard.install`). Every request and WebSocket handshake passes:

* **Host** must name a loopback name, the bound address or an allowed name
  (:func:`host_allow_list`, ``*.domain`` patterns; a wildcard bind widens nothing; with
  ``ip_literals`` any IP literal too): no DNS rebinding. Refused: 400, WebSocket close 1008;
* **Origin** (CSRF): a state-changing request (not GET/HEAD/OPTIONS) and every WebSocket must
  come from the page's own origin (``http://`` + ``Host``) or an allowed one
  (:class:`OriginRule`); no ``Origin`` (not a browser) only with ``allow_missing_origin`` and
  no cross-site ``Sec-Fetch-Site``. Refused: 403, before the body is read;
* **body cap**: the guard reads the body, at most ``max_body_bytes``; a larger declared
  ``Content-Length`` or chunked body is refused (413, ``Connection: close``);
* **errors**: an exception answers 500 with one log line (type, message, where), never a
  traceback; FastAPI's validation error of a pydantic body (:mod:`surfhap.web.messages`) is a
  422 with a one-line reason (:meth:`RequestGuard.invalid`);
* **connection state**: a finished response tells the server's
  :class:`~surfhap.web.server.ConnectionGate` that the connection waits again.

Everything refused or rejected is counted (:attr:`RequestGuard.counts`) and logged through one
:class:`~surfhap.live.sources.RejectLog` (the first few lines, then every 100th).
"""

from __future__ import annotations

import ipaddress
import json
import logging
import traceback
from typing import Callable

from surfhap.live.sources import RejectLog

__all__ = ["RequestGuard", "OriginRule", "host_allow_list", "MAX_BODY_BYTES", "SAFE_METHODS", "WILDCARD_HOSTS",
           "LOOPBACK_NAMES"]

log = logging.getLogger("surfhap.live")

MAX_BODY_BYTES = 16 * 1024  # the pages' requests are JSON objects of well under 1 KiB
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
_CROSS = ("cross-site", "same-site")  # Sec-Fetch-Site values of another site's page
_REFUSALS = ("host", "origin", "body")  # counted as refused; "invalid" bodies and "error"s reached the app


WILDCARD_HOSTS = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")  # as a Host header names them (IPv6 in brackets)


def _as_host(name: str) -> str:
    name = name.strip().lower().rstrip(".")
    return f"[{name}]" if ":" in name and not name.startswith("[") else name


def host_allow_list(bind_host: str, allowed_hosts=()) -> tuple[str, ...]:
    """The names a ``Host`` header may carry (lower case, IPv6 literals in brackets): the
    loopback names, the bound address (unless it is a wildcard) and ``allowed_hosts``
    (exact names or ``*.domain`` patterns)."""
    names = [*LOOPBACK_NAMES, *(_as_host(h) for h in allowed_hosts)]
    if bind_host not in WILDCARD_HOSTS:
        names.append(_as_host(bind_host))
    return tuple(dict.fromkeys(n for n in names if n))


class OriginRule:
    """The ``Origin`` check of WebSockets and state-changing requests (see module doc)."""

    def __init__(self, allowed_origins=(), allow_missing: bool = True):
        self.allowed = {o.rstrip("/").lower() for o in allowed_origins}
        self.allow_missing = bool(allow_missing)

    def __call__(self, origin: str | None, host_header: str | None) -> bool:
        if origin is None:
            return self.allow_missing
        o = origin.rstrip("/").lower()
        if o in self.allowed:
            return True
        return bool(host_header) and o == "http://" + host_header.strip().lower()


def _header(scope, name: bytes) -> str | None:
    for k, v in scope.get("headers", ()):
        if k == name:
            return v.decode("latin-1")
    return None


def _host_name(host_header: str) -> str:
    """The name in a ``Host`` header, without the port, lower case (IPv6 in brackets)."""
    h = host_header.strip().lower()
    if h.startswith("["):
        return h.split("]", 1)[0] + "]"
    return h.rsplit(":", 1)[0] if h.count(":") == 1 else h


def _is_ip_literal(name: str) -> bool:
    try:
        ipaddress.ip_address(name.strip("[]"))
        return True
    except ValueError:
        return False


def _short(text: str | None, n: int = 80) -> str:
    """``text`` quoted on one line (repr escapes line breaks), at most ``n`` characters of it."""
    return repr(text if text is None else text[:n])


class RequestGuard:
    """The rules and counters of one web app (see module doc).

    allowed_hosts : names a ``Host`` header may carry (:func:`host_allow_list`).
    origins       : the ``Origin`` rule for state-changing requests and WebSockets.
    max_body_bytes: the request body cap.
    ip_literals   : also accept any IP address literal as ``Host`` (a wildcard bind).
    on_refused    : called once per refused request or handshake (e.g. a status counter).
    logger        : where the throttled refusal lines go."""

    def __init__(self, allowed_hosts: tuple[str, ...], origins: OriginRule | None = None,
                 max_body_bytes: int = MAX_BODY_BYTES, ip_literals: bool = False,
                 on_refused: Callable[[], None] | None = None, logger: logging.Logger = log):
        names = tuple(h.lower() for h in allowed_hosts)
        self.exact = frozenset(n for n in names if not n.startswith("*."))
        self.suffixes = tuple(n[1:] for n in names if n.startswith("*."))  # "*.a.b" -> ".a.b"
        self.origins = origins or OriginRule()
        self.max_body_bytes = int(max_body_bytes)
        self.ip_literals = bool(ip_literals)
        self.on_refused = on_refused
        self.rejects = RejectLog(logger)
        self.counts = {"host": 0, "origin": 0, "body": 0, "invalid": 0, "error": 0}
        self.gate = None  # the server's ConnectionGate, told when a response is complete

    def install(self, app) -> "RequestGuard":
        """Add this guard to the FastAPI ``app`` (as its outermost user middleware: inside it
        only the app's exception handlers and routes), answer FastAPI's validation errors with
        a short 422 and keep the guard as ``app.state.guard``."""
        from fastapi.exceptions import RequestValidationError
        from fastapi.responses import JSONResponse

        from surfhap.web.messages import reason

        async def invalid_body(request, exc: RequestValidationError):
            return JSONResponse(self.invalid(request.scope, reason(exc.errors())), status_code=422)

        app.add_exception_handler(RequestValidationError, invalid_body)
        app.add_middleware(_GuardMiddleware, guard=self)
        app.state.guard = self
        return self

    # ------------------------------------------------------------------ rules

    def host_ok(self, host_header: str | None) -> bool:
        if not host_header:
            return False
        name = _host_name(host_header)
        if name in self.exact or any(name.endswith(s) for s in self.suffixes):
            return True
        return self.ip_literals and _is_ip_literal(name)

    def origin_ok(self, scope) -> bool:
        origin = _header(scope, b"origin")
        if origin is None and (_header(scope, b"sec-fetch-site") or "").lower() in _CROSS:
            return False
        return self.origins(origin, _header(scope, b"host"))

    # ------------------------------------------------------------------ counting and logging

    def _count(self, kind: str, peer: str, reason: str) -> None:
        self.counts[kind] += 1
        if kind in _REFUSALS and self.on_refused is not None:
            self.on_refused()
        self.rejects.reject(peer, reason)

    def invalid(self, scope, reason: str) -> dict:
        """Count and log (throttled) an invalid request body; returns the 422 body."""
        self._count("invalid", _peer(scope), f"{scope.get('method', '')} {_short(scope.get('path'))}: {reason}")
        return {"error": reason}

    @property
    def refused(self) -> int:
        """Requests and handshakes refused before reaching the app (host, origin, body)."""
        return sum(self.counts[k] for k in _REFUSALS)


def _peer(scope) -> str:
    c = scope.get("client")
    return f"{c[0]}:{c[1]}" if c else "?"


async def _respond(send, status: int, error: str, close: bool = False) -> None:
    body = json.dumps({"error": error}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if close:  # the request's body is left unread: the connection cannot carry another request
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class _GuardMiddleware:
    """The ASGI middleware of a :class:`RequestGuard` (see module doc)."""

    def __init__(self, app, guard: RequestGuard):
        self.app = app
        self.guard = guard

    async def __call__(self, scope, receive, send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        g = self.guard
        peer = _peer(scope)
        host = _header(scope, b"host")
        what = "WebSocket" if kind == "websocket" else f"{scope.get('method', '')} {_short(scope.get('path'))}"
        if not g.host_ok(host):
            g._count("host", peer, f"refused {what} for host {_short(host)}")
            return await self._refuse(kind, send, 400, "host not allowed")
        if (kind == "websocket" or scope.get("method") not in SAFE_METHODS) and not g.origin_ok(scope):
            g._count("origin", peer, f"refused {what}: origin {_short(_header(scope, b'origin'))} not allowed "
                                     f"for host {_short(host)}")
            return await self._refuse(kind, send, 403, "origin not allowed")
        if kind == "http":
            body = await self._read_body(scope, receive, send, peer, what)
            if body is None:
                return None
            receive = _replay(body, receive)
        started = False

        async def tracked_send(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)
            if g.gate is not None and message["type"] == "http.response.body" and not message.get("more_body"):
                g.gate.response_done(scope.get("client"))

        try:  # a WebSocket's messages go straight through (nothing to track: the hot path)
            await self.app(scope, receive, tracked_send if kind == "http" else send)
        except Exception as exc:  # noqa: BLE001 - one line per failure, never a traceback per request
            where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
            at = f" at {where.filename.rsplit('/', 1)[-1]}:{where.lineno}" if where else ""
            g._count("error", peer, f"{what} failed: {type(exc).__name__}: {_short(str(exc), 120)}{at}")
            if not started and kind == "http":
                await _respond(send, 500, "internal error", close=True)

    async def _refuse(self, kind: str, send, status: int, error: str) -> None:
        if kind == "websocket":
            await send({"type": "websocket.close", "code": 1008})
        else:
            await _respond(send, status, error, close=True)

    async def _read_body(self, scope, receive, send, peer: str, what: str) -> bytes | None:
        """The whole body, at most the cap; None after refusing it (413) or a disconnect."""
        g = self.guard
        cap = g.max_body_bytes
        declared = _header(scope, b"content-length")
        declared = None if declared is None else declared.strip()
        if declared is not None and (not declared.isdigit() or len(declared) > 15 or int(declared) > cap):
            g._count("body", peer, f"refused {what}: declared body of {_short(declared, 20)} bytes "
                                   f"(limit {cap})")
            await _respond(send, 413, f"request body over {cap} bytes", close=True)
            return None
        chunks = bytearray()
        while True:
            message = await receive()
            if message["type"] != "http.request":
                return None  # the client went away
            data = message.get("body", b"")
            if len(chunks) + len(data) > cap:  # checked before keeping it: never more than the cap
                g._count("body", peer, f"refused {what}: body over {cap} bytes")
                await _respond(send, 413, f"request body over {cap} bytes", close=True)
                return None
            chunks += data
            if not message.get("more_body", False):
                return bytes(chunks)


def _replay(body: bytes, receive):
    """A ``receive`` that first delivers ``body`` whole, then waits on the real one (for the
    client's disconnect)."""
    pending = [{"type": "http.request", "body": body, "more_body": False}]

    async def replay():
        if pending:
            return pending.pop()
        return await receive()

    return replay
