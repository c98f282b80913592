"""Settings of the web app's server (:mod:`surfhap.web`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ServerConfig"]


@dataclass(frozen=True)
class ServerConfig:
    """Settings of the touch page server: where it binds, who may reach it and its limits.

    Times in s, rates in messages/s, sizes in bytes."""

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
    # HTTP connection limits (surfhap.web.server). The page loads with a handful of
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
