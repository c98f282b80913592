"""Touch sources of the live engine and the checks every incoming message passes.

Each source is a :class:`surfhap.runtime.protocols.Source` (``start()``, ``stop()``) pushing
into a :class:`surfhap.runtime.protocols.TouchSink` (the engine's ``push_touch``); the
replay of a trajectory file (on a simulated or a wall clock) is
:class:`surfhap.runtime.sources.TrajectorySource`.

* :class:`OscTouchSource` - OSC over UDP (python-osc parsing, our own bounded handler);
* the web page's WebSocket stream lives in :mod:`surfhap.web.touch` and uses the same
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
import socket
import threading
from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from surfhap.checked import checked_dataclass
from surfhap.runtime.clock import now
from surfhap.live.udpguard import UdpListener

__all__ = ["TouchSpace", "RateLimiter", "RejectLog", "OscTouchSource", "OSC_ADDRESSES",
           "finite_in_range"]

log = logging.getLogger("surfhap.live")

OSC_ADDRESSES = ("/surfhap/touch", "/surfhap/touch/norm", "/surfhap/lift")
MAX_DATAGRAM = 512


@checked_dataclass
class TouchSpace:
    """The touch surface: size in metres and the load at full pressure.

    width, height : m, 0.01-2 (default: a 10.1" tablet, 0.217 x 0.136 m).
    max_load      : N at pointer pressure 1, 0.05-20 (pointer devices without pressure report 0.5).
    default_load  : N used when a source gives no load, 0-20.
    """

    width: Annotated[float, Field(ge=0.01, le=2.0)] = 0.217
    height: Annotated[float, Field(ge=0.01, le=2.0)] = 0.136
    max_load: Annotated[float, Field(ge=0.05, le=20.0)] = 1.0
    default_load: Annotated[float, Field(ge=0.0, le=20.0)] = 0.5


class RateLimiter:
    """Token bucket: ``rate`` messages/s sustained, ``burst`` at once."""

    def __init__(self, rate: float, burst: float, t: float | None = None):
        """``t``: the current time on the caller's clock (default :func:`now`)."""
        self.rate = float(rate)
        self.burst = float(burst)
        self.tokens = float(burst)
        self.t = now() if t is None else t

    def allow(self, t: float | None = None) -> bool:
        t = now() if t is None else t
        self.tokens = min(self.burst, self.tokens + max(0.0, t - self.t) * self.rate)
        self.t = max(self.t, t)
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False

    def hold(self, until: float) -> None:
        """No tokens accrue before ``until`` (a sender in the penalty box comes out with an
        empty bucket, not a fresh burst)."""
        self.t = max(self.t, until)


class RejectLog:
    """Counts rejected messages and logs the first ``first`` and then every ``every``-th, as
    ``template % (peer, reason, count so far)`` (the one rate law of every "dropped" log line)."""

    def __init__(self, logger: logging.Logger = log, first: int = 5, every: int = 100,
                 template: str = "rejected message from %s: %s (%d rejected so far)"):
        self.logger, self.first, self.every, self.template = logger, first, every, template
        self.count = 0

    def reject(self, peer: str, reason: str) -> None:
        self.count += 1
        c = self.count
        if c <= self.first or c % self.every == 0:
            self.logger.warning(self.template, peer, reason, c)


def finite_in_range(v, lo: float, hi: float) -> float | None:
    """``v`` as a float when it is a real number (int or float, not bool) within
    [lo, hi]; None for anything else: other types, NaN, infinities, and integers too
    large for a float (``10**400``: ``float()`` would raise OverflowError)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    try:
        v = float(v)
    except OverflowError:
        return None
    if not (math.isfinite(v) and lo <= v <= hi):
        return None
    return v


@dataclass(slots=True)
class _Sender:
    """One entry of the OSC sender table."""

    source: int
    limiter: RateLimiter
    last_seen: float
    proven: bool = False


class OscTouchSource:
    """Listen for OSC touch messages on UDP ``host:port`` (127.0.0.1 unless told otherwise).

    Each sender (IP, port) is its own touch source id. ``port=0`` picks a free port
    (see ``.port`` after ``start``).

    The sender table holds at most ``max_senders`` entries, each with its own token
    bucket (``rate`` messages/s, ``burst``). It cannot be locked by junk:

    * a datagram from an unknown sender needs a token of the *admission* bucket
      (``admit_rate`` new senders/s, ``admit_burst`` at once), so a flood from ever-new
      source ports costs at most that many table changes per second;
    * an entry that has not yet sent one valid message ("unproven") is the first to go
      when the table is full (the one seen longest ago); a sender that has sent a valid
      message keeps its entry while it is active;
    * any entry idle for ``sender_idle`` s expires (a sender that comes back later is
      admitted again, under a new source id).

    So after any burst of junk a new sender is admitted within ``1 / admit_rate`` s; only
    while a flood of new addresses lasts are new senders delayed (established ones are
    not). A sender that exceeds its bucket is put in a penalty box for ``penalty_hold`` s
    (:class:`surfhap.live.udpguard.UdpListener`: the kernel drops its datagrams), so a flood
    from one sender cannot fill the socket's queue and crowd out the other senders' touches;
    it leaves the box with an empty bucket (a flood that goes on is boxed again at once).
    ``clock`` (s, monotonic) is injectable for tests.
    """

    def __init__(self, engine, host: str = "127.0.0.1", port: int = 9000, space: TouchSpace | None = None,
                 rate: float = 2000.0, burst: float = 200.0, max_senders: int = 64, source_base: int = 1 << 32,
                 admit_rate: float = 20.0, admit_burst: float = 16.0, sender_idle: float = 10.0, clock=now,
                 penalty_hold: float = 1.0):
        """``source_base``: first source id of OSC senders, far above the page's client
        ids (which count up from 1000), so the two never collide.

        ``admit_rate``/``admit_burst``: a lab has a few OSC senders that start at about the
        same time; 16 at once and 20 more per second is far above that and still bounds a
        flood. ``sender_idle``: an OSC sender streams at >= 25 Hz while touching, so 10 s of
        silence means it has stopped (the watchdog silenced it after 50 ms). ``penalty_hold``:
        s a sender that exceeded its bucket spends in the kernel-level penalty box
        (:class:`surfhap.live.udpguard.UdpListener`)."""
        from pythonosc.osc_message import OscMessage  # noqa: F401  (fail early if missing)

        self.engine, self.host, self.port, self.space = engine, host, int(port), space or TouchSpace()
        self.rate, self.burst, self.max_senders, self.source_base = rate, burst, int(max_senders), int(source_base)
        self.sender_idle, self.penalty_hold, self.clock = float(sender_idle), float(penalty_hold), clock
        self.admission = RateLimiter(admit_rate, admit_burst, t=clock())
        self.rejects = RejectLog()
        self.accepted = self.expired = self.evicted = self._next_source = 0
        self._senders: dict[tuple, _Sender] = {}
        self._listener: UdpListener | None = None
        self._run, self._thread = False, None

    def start(self) -> None:
        self._listener = UdpListener(self.host, self.port, hold=self.penalty_hold)
        self._listener.sock.settimeout(0.1)
        self.port = self._listener.port
        self._run = True
        self._thread = threading.Thread(target=self._serve, name="surfhap-osc-in", daemon=True)
        self._thread.start()
        log.info("OSC touch input on udp://%s:%d (%s)", self.host, self.port, ", ".join(OSC_ADDRESSES))

    def _serve(self) -> None:
        """Receive loop: one plain ``recvfrom`` per datagram, so that a flood from one sender
        costs a socket read and a token-bucket check per datagram (not a server round,
        handler object and parse), and the socket is drained faster than a flood fills it:
        the other senders' datagrams are not lost in the kernel's queue."""
        sock, datagram, limit, release, clock = (self._listener.sock, self._datagram, MAX_DATAGRAM + 1,
                                                 self._listener.release_due, self.clock)
        while self._run:
            release(clock())
            try:
                data, addr = sock.recvfrom(limit)
            except (socket.timeout, InterruptedError):
                continue
            except OSError:
                if self._run:
                    continue
                return
            try:
                datagram(data, addr)
            except Exception as exc:  # noqa: BLE001 - a datagram must never end the listener
                self.rejects.reject(f"osc {addr}", f"bad datagram ({type(exc).__name__})")

    def stop(self) -> None:
        self._run = False
        if self._thread is not None:
            self._thread.join(2.0)
            self._thread = None
        if self._listener is not None:
            self._listener.close()
            self._listener = None

    def _datagram(self, data: bytes, addr: tuple) -> None:
        from pythonosc.osc_message import OscMessage

        t = self.clock()
        peer = f"osc {addr[0]}:{addr[1]}"
        entry = self._senders.get(addr) or self._admit(addr, peer, t)
        if entry is None:
            return
        entry.last_seen = t
        if not entry.limiter.allow(t):  # a flood's path: one look-up and one bucket per datagram
            self.rejects.reject(peer, "rate limit exceeded")
            # and from now on the kernel drops its datagrams for a while; out of the box, its bucket
            # is still empty, so a flood that goes on is boxed again at its first datagram (not
            # after another burst, which could fill the socket's queue while it is read)
            if self._listener is not None and self._listener.penalise(addr, t):
                entry.limiter.hold(t + self.penalty_hold)
            return
        if len(data) > MAX_DATAGRAM:
            self.rejects.reject(peer, f"datagram of {len(data)} bytes (limit {MAX_DATAGRAM})")
        elif data.startswith(b"#bundle"):
            self.rejects.reject(peer, "OSC bundles are not accepted; send single messages")
        else:
            try:
                msg = OscMessage(data)
                address, args = msg.address, msg.params
            except Exception as exc:  # noqa: BLE001 - any parse failure is a bad message
                self.rejects.reject(peer, f"malformed OSC ({type(exc).__name__})")
                return
            if self._message(entry.source, peer, address, args):
                entry.proven = True

    def _admit(self, addr: tuple, peer: str, t: float) -> _Sender | None:
        """A table entry for a new sender, or None (rejected and counted)."""
        if not self.admission.allow(t):
            self.rejects.reject(peer, "too many new OSC senders at once")
            return None
        table = self._senders
        if len(table) >= self.max_senders:
            for a in [a for a, e in table.items() if t - e.last_seen > self.sender_idle]:
                del table[a]
                self.expired += 1
        if len(table) >= self.max_senders:
            unproven = [(e.last_seen, a) for a, e in table.items() if not e.proven]
            if not unproven:
                self.rejects.reject(peer, f"{len(table)} OSC senders active")
                return None
            del table[min(unproven)[1]]
            self.evicted += 1
        entry = _Sender(self.source_base + self._next_source, RateLimiter(self.rate, self.burst, t=t), t)
        self._next_source += 1
        table[addr] = entry
        return entry

    @property
    def senders(self) -> int:
        """Entries in the sender table."""
        return len(self._senders)

    def _message(self, src: int, peer: str, address: str, args: list) -> bool:
        """Check one parsed message and feed the engine; True when it was accepted."""
        sp = self.space
        if address == "/surfhap/touch":  # (lo, hi, scale) per argument, the load's default
            form, spec, load = "x y [load]", ((-0.01, sp.width + 0.01, 1.0), (-0.01, sp.height + 0.01, 1.0),
                                              (0.0, 20.0, 1.0)), sp.default_load
        elif address == "/surfhap/touch/norm":
            form, spec, load = "u v [pressure]", ((0.0, 1.0, sp.width), (0.0, 1.0, sp.height),
                                                  (0.0, 1.0, sp.max_load)), 0.5 * sp.max_load
        elif address == "/surfhap/lift":
            form, spec, load = "no arguments", (), 0.0
        else:
            self.rejects.reject(peer, f"unknown address {address[:64]!r} (known: {', '.join(OSC_ADDRESSES)})")
            return False
        if len(args) not in ((0,) if not spec else (2, 3)):
            self.rejects.reject(peer, f"{address} takes {form}, got {len(args)} arguments")
            return False
        vals = [finite_in_range(v, lo, hi) for v, (lo, hi, _) in zip(args, spec)]
        if None in vals:
            self.rejects.reject(peer, f"{address}: argument not a number or out of range: {args!r}"[:200])
            return False
        x, y, load = [v * k for v, (_, _, k) in zip(vals, spec)] + [load] * (3 - len(vals)) if spec else (0.0,) * 3
        self.engine.push_touch(src, x, y, load, t_arrival=now())
        self.accepted += 1
        return True
