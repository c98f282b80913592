"""The request guard of the web app (:func:`surfhap.web.app.create_app`), an ASGI middleware
added with ``app.add_middleware`` (:meth:`RequestGuard.install`). Every request and WebSocket
handshake passes:

* **Host** must name a loopback name, the bound address or an allowed name
  (:func:`host_allow_list`, ``*.domain`` patterns; a wildcard bind widens nothing; with
  ``ip_literals`` any IP literal too): no DNS rebinding. Refused: 400, WebSocket close 1008;
* **Origin** (CSRF): a state-changing request (not GET/HEAD/OPTIONS) and every WebSocket must
  come from the page's own origin (``http://`` + ``Host``) or an allowed one; no ``Origin``
  (not a browser) only with ``allow_missing_origin`` and no cross-site ``Sec-Fetch-Site``.
  Refused: 403, before the body is read;
* **body cap**: the guard reads the body, at most ``max_body_bytes``; a larger declared
  ``Content-Length`` or chunked body is refused (413, ``Connection: close``);
* **errors**: an exception answers 500 with one log line (type, message, where), never a
  traceback; FastAPI's validation error of a pydantic body (:mod:`surfhap.web.messages`) is a
  422 with a one-line reason (:meth:`RequestGuard.install`);
* **connection state**: a finished response tells the server's
  :class:`~surfhap.web.server.ConnectionGate` that the connection waits again.

Everything refused or rejected is counted (:attr:`RequestGuard.counts`) and logged through one
:class:`~surfhap.live.sources.RejectLog` (the first few lines, then every 100th).
"""

from __future__ import annotations

import ipaddress
import logging
import traceback
from typing import Callable

from surfhap.live.sources import RejectLog

__all__ = ["RequestGuard", "host_allow_list", "MAX_BODY_BYTES", "SAFE_METHODS", "WILDCARD_HOSTS", "LOOPBACK_NAMES"]

log = logging.getLogger("surfhap.live")

MAX_BODY_BYTES = 16 * 1024  # the pages' requests are JSON objects of well under 1 KiB
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
WILDCARD_HOSTS = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")  # as a Host header names them (IPv6 in brackets)
_REFUSALS = ("host", "origin", "body")  # counted as refused; "invalid" bodies and "error"s reached the app


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


def _short(text: str | None, n: int = 80) -> str:
    """``text`` quoted on one line (repr escapes line breaks), at most ``n`` characters of it."""
    return repr(text if text is None else text[:n])


def _peer(scope) -> str:
    c = scope.get("client")
    return f"{c[0]}:{c[1]}" if c else "?"


class RequestGuard:
    """The rules and counters of one web app (see module doc).

    allowed_hosts : names a ``Host`` header may carry (:func:`host_allow_list`).
    allowed_origins, allow_missing_origin: the ``Origin`` rule.
    max_body_bytes: the request body cap.
    ip_literals   : also accept any IP address literal as ``Host`` (a wildcard bind).
    on_refused    : called once per refused request or handshake (e.g. a status counter).
    logger        : where the throttled refusal lines go."""

    def __init__(self, allowed_hosts: tuple[str, ...], allowed_origins=(), allow_missing_origin: bool = True,
                 max_body_bytes: int = MAX_BODY_BYTES, ip_literals: bool = False,
                 on_refused: Callable[[], None] | None = None, logger: logging.Logger = log):
        names = tuple(h.lower() for h in allowed_hosts)
        self.exact = frozenset(n for n in names if not n.startswith("*."))
        self.suffixes = tuple(n[1:] for n in names if n.startswith("*."))  # "*.a.b" -> ".a.b"
        self.origins = frozenset(o.rstrip("/").lower() for o in allowed_origins)
        self.allow_missing_origin = bool(allow_missing_origin)
        self.max_body_bytes = int(max_body_bytes)
        self.ip_literals = bool(ip_literals)
        self.on_refused = on_refused
        self.rejects = RejectLog(logger)
        self.counts = {"host": 0, "origin": 0, "body": 0, "invalid": 0, "error": 0}
        self.gate = None  # the server's ConnectionGate, told when a response is complete

    @classmethod
    def for_page(cls, cfg, **kw) -> "RequestGuard":
        """The guard of a page served as ``cfg`` (:class:`~surfhap.live.config.ServerConfig`)
        says: its bind address, ``allowed_hosts``, ``allowed_origins`` and
        ``allow_missing_origin``; ``kw`` as the constructor's."""
        return cls(host_allow_list(cfg.host, cfg.allowed_hosts), cfg.allowed_origins, cfg.allow_missing_origin, **kw)

    def install(self, app) -> "RequestGuard":
        """Add this guard to the FastAPI ``app`` (its outermost user middleware: inside it
        only the app's exception handlers and routes), answer FastAPI's validation errors with
        a short 422 and keep the guard as ``app.state.guard``."""
        from fastapi.exceptions import RequestValidationError
        from fastapi.responses import JSONResponse

        from surfhap.web.messages import reason

        async def invalid_body(request, exc: RequestValidationError):  # counted and logged (throttled)
            why, scope = reason(exc.errors()), request.scope
            self.count("invalid", _peer(scope), f"{scope.get('method', '')} {_short(scope.get('path'))}: {why}")
            return JSONResponse({"error": why}, status_code=422)

        app.add_exception_handler(RequestValidationError, invalid_body)
        app.add_middleware(_GuardMiddleware, guard=self)
        app.state.guard = self
        return self

    def host_ok(self, host_header: str | None) -> bool:
        if not host_header:
            return False
        h = host_header.strip().lower()  # the name without the port (IPv6 in brackets)
        name = h.split("]", 1)[0] + "]" if h.startswith("[") else (h.rsplit(":", 1)[0] if h.count(":") == 1 else h)
        if name in self.exact or any(name.endswith(s) for s in self.suffixes):
            return True
        try:
            return self.ip_literals and bool(ipaddress.ip_address(name.strip("[]")))
        except ValueError:
            return False

    def origin_ok(self, headers) -> bool:
        """The ``Origin`` rule for a request's ``headers`` (Starlette's ``Headers``)."""
        origin = headers.get("origin")
        if origin is None:
            cross = headers.get("sec-fetch-site", "").lower() in ("cross-site", "same-site")
            return self.allow_missing_origin and not cross
        o, host = origin.rstrip("/").lower(), headers.get("host")
        return o in self.origins or (bool(host) and o == "http://" + host.strip().lower())

    def count(self, kind: str, peer: str, reason: str) -> None:
        """Count one ``kind`` of refusal or rejection and log it (throttled)."""
        self.counts[kind] += 1
        if kind in _REFUSALS and self.on_refused is not None:
            self.on_refused()
        self.rejects.reject(peer, reason)

    @property
    def refused(self) -> int:
        """Requests and handshakes refused before reaching the app (host, origin, body)."""
        return sum(self.counts[k] for k in _REFUSALS)


def _refusal(status: int, error: str):
    """A JSON error that closes the connection (the request's body may be left unread)."""
    from starlette.responses import JSONResponse

    return JSONResponse({"error": error}, status, headers={"connection": "close"})


class _GuardMiddleware:
    """The ASGI middleware of a :class:`RequestGuard` (see module doc)."""

    def __init__(self, app, guard: RequestGuard):
        self.app, self.guard = app, guard

    async def __call__(self, scope, receive, send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        from starlette.datastructures import Headers

        headers = Headers(scope=scope)
        g, peer, host = self.guard, _peer(scope), headers.get("host")
        what = "WebSocket" if kind == "websocket" else f"{scope.get('method', '')} {_short(scope.get('path'))}"
        refusal = None
        if not g.host_ok(host):
            g.count("host", peer, f"refused {what} for host {_short(host)}")
            refusal = (400, "host not allowed")
        elif (kind == "websocket" or scope.get("method") not in SAFE_METHODS) and not g.origin_ok(headers):
            g.count("origin", peer, f"refused {what}: origin {_short(headers.get('origin'))} not allowed "
                                    f"for host {_short(host)}")
            refusal = (403, "origin not allowed")
        if refusal is not None:
            if kind == "websocket":
                return await send({"type": "websocket.close", "code": 1008})
            return await _refusal(*refusal)(scope, receive, send)
        if kind == "websocket":  # its messages go straight through (nothing to track: the hot path)
            return await self._call(scope, receive, send, peer, what)
        body = await self._read_body(scope, receive, send, headers.get("content-length", "0"), peer, what)
        if body is None:
            return None
        pending = [{"type": "http.request", "body": body, "more_body": False}]

        async def replay():  # the body whole, then the real receive (for the client's disconnect)
            return pending.pop() if pending else await receive()

        started = False

        async def tracked_send(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)
            if g.gate is not None and message["type"] == "http.response.body" and not message.get("more_body"):
                g.gate.response_done(scope.get("client"))

        if not await self._call(scope, replay, tracked_send, peer, what) and not started:
            await _refusal(500, "internal error")(scope, receive, send)

    async def _call(self, scope, receive, send, peer: str, what: str) -> bool:
        """Run the app; False after an exception (one log line, never a traceback)."""
        try:
            await self.app(scope, receive, send)
            return True
        except Exception as exc:  # noqa: BLE001 - one line per failure, never a traceback per request
            where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
            at = f" at {where.filename.rsplit('/', 1)[-1]}:{where.lineno}" if where else ""
            self.guard.count("error", peer, f"{what} failed: {type(exc).__name__}: {_short(str(exc), 120)}{at}")
            return False

    async def _read_body(self, scope, receive, send, declared: str, peer: str, what: str) -> bytes | None:
        """The whole body (``declared``: its Content-Length), at most the cap; None after
        refusing it (413) or a disconnect."""
        g, cap = self.guard, self.guard.max_body_bytes
        declared = declared.strip()
        chunks = bytearray()
        while declared.isdigit() and len(declared) <= 15 and int(declared) <= cap:
            message = await receive()
            if message["type"] != "http.request":
                return None  # the client went away
            data = message.get("body", b"")
            if len(chunks) + len(data) > cap:  # checked before keeping it: never more than the cap
                break
            chunks += data
            if not message.get("more_body", False):
                return bytes(chunks)
        g.count("body", peer, f"refused {what}: body over {cap} bytes (declared {_short(declared, 20)})")
        await _refusal(413, f"request body over {cap} bytes")(scope, receive, send)
        return None
