"""Touch sources of the live engine and the checks every incoming message passes.

* :class:`OscTouchSource` - OSC over UDP (python-osc parsing, our own bounded handler);
* :class:`ReplaySource` - a trajectory file (CSV: time, x, y, load) replayed in real time;
* the web page's WebSocket stream lives in :mod:`surfhap.live.server` and uses the same
  :class:`RateLimiter`, :class:`RejectLog` and :class:`TouchSpace`.

OSC address patterns (arguments are floats or ints; anything else is rejected):

=========================  =========================================================
``/surfhap/touch x y``      finger at (x, y) metres on the display, default load
``/surfhap/touch x y load`` same with the normal load in newtons (0 = lifted)
``/surfhap/touch/norm u v [pressure]``  position as fractions 0-1 of the surface size,
                            pressure 0-1 (scaled by ``TouchSpace.max_load``)
``/surfhap/lift``           finger lifted
=========================  =========================================================

Every message is checked for size, rate (token bucket per sender) and ranges; a rejected
message gives one log line (rate-limited per sender) and is counted, and never reaches
the engine. Nothing received is ever evaluated.
"""

from __future__ import annotations

import logging
import math
import socketserver
import threading
from dataclasses import dataclass

from surfhap.errors import ConfigError
from surfhap.live.clock import now, sleep_until

__all__ = ["TouchSpace", "RateLimiter", "RejectLog", "OscTouchSource", "ReplaySource", "OSC_ADDRESSES"]

log = logging.getLogger("surfhap.live")

OSC_ADDRESSES = ("/surfhap/touch", "/surfhap/touch/norm", "/surfhap/lift")
MAX_DATAGRAM = 512


@dataclass(frozen=True)
class TouchSpace:
    """The touch surface: size in metres and the load at full pressure.

    width, height : m (default: a 10.1" tablet, 0.217 x 0.136 m).
    max_load      : N at pointer pressure 1 (pointer devices without pressure report 0.5).
    default_load  : N used when a source gives no load.
    """

    width: float = 0.217
    height: float = 0.136
    max_load: float = 1.0
    default_load: float = 0.5

    def __post_init__(self):
        for name, lo, hi in (("width", 0.01, 2.0), ("height", 0.01, 2.0), ("max_load", 0.05, 20.0),
                             ("default_load", 0.0, 20.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise ConfigError(f"must be within {lo}-{hi}", field=name)


class RateLimiter:
    """Token bucket: ``rate`` messages/s sustained, ``burst`` at once."""

    def __init__(self, rate: float, burst: float):
        self.rate = float(rate)
        self.burst = float(burst)
        self.tokens = float(burst)
        self.t = now()

    def allow(self, t: float | None = None) -> bool:
        t = now() if t is None else t
        self.tokens = min(self.burst, self.tokens + (t - self.t) * self.rate)
        self.t = t
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False


class RejectLog:
    """Counts rejected messages per peer and logs the first few and then every 100th."""

    def __init__(self, logger: logging.Logger = log, first: int = 5, every: int = 100):
        self.logger, self.first, self.every = logger, first, every
        self.count = 0

    def reject(self, peer: str, reason: str) -> None:
        self.count += 1
        c = self.count
        if c <= self.first or c % self.every == 0:
            self.logger.warning("rejected message from %s: %s (%d rejected so far)", peer, reason, c)


def _finite(v, lo: float, hi: float) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    v = float(v)
    if not (math.isfinite(v) and lo <= v <= hi):
        return None
    return v


class OscTouchSource:
    """Listen for OSC touch messages on UDP ``host:port`` (127.0.0.1 unless told otherwise).

    Each sender (IP, port) is its own touch source id. ``port=0`` picks a free port
    (see ``.port`` after ``start``).
    """

    def __init__(self, engine, host: str = "127.0.0.1", port: int = 9000, space: TouchSpace | None = None,
                 rate: float = 2000.0, burst: float = 200.0, max_senders: int = 64, source_base: int = 2000):
        from pythonosc.osc_message import OscMessage  # noqa: F401  (fail early if missing)

        self.engine = engine
        self.host, self.port = host, int(port)
        self.space = space or TouchSpace()
        self.rate, self.burst = rate, burst
        self.max_senders = max_senders
        self.source_base = source_base
        self.rejects = RejectLog()
        self.accepted = 0
        self._senders: dict[tuple, tuple[int, RateLimiter]] = {}
        self._server = None
        self._thread = None

    def start(self) -> None:
        source = self

        class Handler(socketserver.BaseRequestHandler):
            def handle(self):
                source._datagram(self.request[0], self.client_address)

        self._server = socketserver.UDPServer((self.host, self.port), Handler)
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.1},
                                        name="surfhap-osc-in", daemon=True)
        self._thread.start()
        log.info("OSC touch input on udp://%s:%d (%s)", self.host, self.port, ", ".join(OSC_ADDRESSES))

    def stop(self) -> None:
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None

    def _datagram(self, data: bytes, addr: tuple) -> None:
        from pythonosc.osc_message import OscMessage, ParseError

        peer = f"osc {addr[0]}:{addr[1]}"
        if len(data) > MAX_DATAGRAM:
            self.rejects.reject(peer, f"datagram of {len(data)} bytes (limit {MAX_DATAGRAM})")
            return
        entry = self._senders.get(addr)
        if entry is None:
            if len(self._senders) >= self.max_senders:
                self.rejects.reject(peer, "too many OSC senders")
                return
            entry = (self.source_base + len(self._senders), RateLimiter(self.rate, self.burst))
            self._senders[addr] = entry
        src, limiter = entry
        if not limiter.allow():
            self.rejects.reject(peer, "rate limit exceeded")
            return
        if data.startswith(b"#bundle"):
            self.rejects.reject(peer, "OSC bundles are not accepted; send single messages")
            return
        try:
            msg = OscMessage(data)
            address, args = msg.address, msg.params
        except (ParseError, Exception) as exc:  # noqa: BLE001 - any parse failure is a bad message
            self.rejects.reject(peer, f"malformed OSC ({type(exc).__name__})")
            return
        self._message(src, peer, address, args)

    def _message(self, src: int, peer: str, address: str, args: list) -> None:
        sp = self.space
        t_arr = now()
        if address == "/surfhap/lift":
            if args:
                self.rejects.reject(peer, "/surfhap/lift takes no arguments")
                return
            self.engine.push_touch(src, 0.0, 0.0, 0.0, t_arrival=t_arr)
            self.accepted += 1
            return
        if address == "/surfhap/touch":
            if len(args) not in (2, 3):
                self.rejects.reject(peer, f"{address} needs x y [load], got {len(args)} arguments")
                return
            x = _finite(args[0], -0.01, sp.width + 0.01)
            y = _finite(args[1], -0.01, sp.height + 0.01)
            load = sp.default_load if len(args) == 2 else _finite(args[2], 0.0, 20.0)
        elif address == "/surfhap/touch/norm":
            if len(args) not in (2, 3):
                self.rejects.reject(peer, f"{address} needs u v [pressure], got {len(args)} arguments")
                return
            u = _finite(args[0], 0.0, 1.0)
            v = _finite(args[1], 0.0, 1.0)
            p = 0.5 if len(args) == 2 else _finite(args[2], 0.0, 1.0)
            x = None if u is None else u * sp.width
            y = None if v is None else v * sp.height
            load = None if p is None else p * sp.max_load
        else:
            self.rejects.reject(peer, f"unknown address {address[:64]!r} (known: {', '.join(OSC_ADDRESSES)})")
            return
        if x is None or y is None or load is None:
            self.rejects.reject(peer, f"{address}: argument not a number or out of range: {args!r}"[:200])
            return
        self.engine.push_touch(src, x, y, load, t_arrival=t_arr)
        self.accepted += 1


class ReplaySource:
    """Replay a :class:`~surfhap.sim.trajectory.Trajectory` in real time from a thread.

    ``loop`` repeats it (bounded by ``max_seconds``); a lift is sent at the end.
    """

    def __init__(self, engine, trajectory, loop: bool = False, max_seconds: float = 3600.0, source: int = 1):
        self.engine = engine
        self.trajectory = trajectory
        self.loop = loop
        self.max_seconds = float(max_seconds)
        self.source = source
        self._run = False
        self._thread = None
        self.sent = 0
        self.done = threading.Event()

    def start(self) -> None:
        self._run = True
        self._thread = threading.Thread(target=self._play, name="surfhap-replay", daemon=True)
        self._thread.start()

    def _play(self) -> None:
        tr = self.trajectory
        t_rel = tr.t - tr.t[0]
        start = now()
        offset = 0.0
        period = float(t_rel[-1]) + (float(t_rel[-1] - t_rel[-2]) if t_rel.size > 1 else 0.0)
        try:
            while self._run:
                for i in range(t_rel.size):
                    if not self._run:
                        return
                    due = start + offset + float(t_rel[i])
                    if due - start > self.max_seconds:
                        return
                    sleep_until(due)
                    self.engine.push_touch(self.source, float(tr.x[i]), float(tr.y[i]), float(tr.load[i]),
                                           t_event=offset + float(t_rel[i]))
                    self.sent += 1
                if not self.loop:
                    return
                offset += period
        finally:
            self.engine.push_touch(self.source, 0.0, 0.0, 0.0)
            self.done.set()

    def stop(self) -> None:
        self._run = False
        if self._thread is not None:
            self._thread.join(2.0)
