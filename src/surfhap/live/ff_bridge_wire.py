"""The OSC force-feedback bridge contract on the wire: the two messages, encoded and decoded once.

A bridge (e.g. a CHAI3D program driving a Falcon) and ``surfhap ff run --device osc://...``
exchange two fixed-format OSC messages over UDP (docs/forcefeedback.md, "Bridge contract"):

==============================================  =============================================
host -> bridge, every haptic tick (1 kHz)        ``/surfhap/ff/force ,iifff token seq fx fy fz``
bridge -> host, >= 500 Hz (1 kHz recommended)    ``/surfhap/ff/position ,iiffffff token seq
                                                 x y z ax ay az``
==============================================  =============================================

* ``token`` (int32 > 0): the session token, chosen at random by the host for each run and
  sent in every force message; the bridge echoes the token of the newest force it accepted.
* ``seq`` (int32 >= 0): each side numbers its own messages, strictly increasing; the
  receiver drops a message whose number is not above the last one it accepted.
* forces in device units (gain x N), positions in m relative to X0, both in the device frame
  (x along the display's width, y along its height, z normal to it towards the user);
  ``ax ay az`` is the force the device is applying now (device units, after the bridge's
  clamp and watchdog): zero within 20 ms of the last force message.

Both messages are decoded by exact layout (address, type tags, size): anything else is not
the contract. :class:`PositionReceiver` is the one acceptance of a position datagram, used by
:class:`surfhap.live.ff_devices.OscDeviceBackend` (which adds the sequence rule) and
:mod:`surfhap.live.ff_bridge_check` (which checks the sequence itself).
"""

from __future__ import annotations

import math
import socket
import struct

__all__ = ["FORCE_ADDRESS", "POSITION_ADDRESS", "BRIDGE_WATCHDOG_S", "MIN_POSITION_RATE_HZ", "MAX_POSITION_M",
           "SEQ_LIMIT", "PositionReceiver", "encode_force", "encode_position", "decode_position", "new_token"]

FORCE_ADDRESS = "/surfhap/ff/force"
POSITION_ADDRESS = "/surfhap/ff/position"
BRIDGE_WATCHDOG_S = 0.020  # the bridge applies zero force within 20 ms of the last force message
MIN_POSITION_RATE_HZ = 500.0  # the host ramps to zero after 10 ms without a position (FALCON.device_timeout)
MAX_POSITION_M = 1.0  # larger positions are garbage (not metres)
SEQ_LIMIT = 2**31  # sequence numbers are int32 >= 0; a session does not wrap (24 days at 1 kHz)


def _osc_string(text: str) -> bytes:
    b = text.encode("ascii") + b"\0"
    return b + b"\0" * (-len(b) % 4)


_FORCE_PREFIX = _osc_string(FORCE_ADDRESS) + _osc_string(",iifff")
_POSITION_PREFIX = _osc_string(POSITION_ADDRESS) + _osc_string(",iiffffff")
_FORCE = struct.Struct(">iifff")
_POSITION = struct.Struct(">iiffffff")
POSITION_SIZE = len(_POSITION_PREFIX) + _POSITION.size


def new_token() -> int:
    """A random session token, 1 .. 2**31 - 1."""
    import secrets

    return secrets.randbelow(2**31 - 1) + 1


def encode_force(token: int, seq: int, fx: float, fy: float, fz: float) -> bytes:
    return _FORCE_PREFIX + _FORCE.pack(token, seq % SEQ_LIMIT, fx, fy, fz)


def encode_position(token: int, seq: int, x: float, y: float, z: float, ax: float, ay: float, az: float) -> bytes:
    return _POSITION_PREFIX + _POSITION.pack(token, seq % SEQ_LIMIT, x, y, z, ax, ay, az)


def decode_position(data: bytes):
    """``(token, seq, x, y, z, ax, ay, az)`` or None when ``data`` is not a position message of
    the contract or holds a non-finite value, a negative sequence number or a position
    beyond :data:`MAX_POSITION_M`."""
    if len(data) != POSITION_SIZE or not data.startswith(_POSITION_PREFIX):
        return None
    v = _POSITION.unpack_from(data, len(_POSITION_PREFIX))
    if v[1] < 0 or not all(math.isfinite(a) for a in v[2:]) or not all(abs(a) <= MAX_POSITION_M for a in v[2:5]):
        return None
    return v


class PositionReceiver:
    """A UDP socket bound on ``listen`` taking ``/surfhap/ff/position`` from the bridge at
    ``host:port`` for the session ``token``.

    :meth:`accept` returns the decoded message, or None for a datagram from another address
    (``dropped_sender``), one not in the contract's layout or range (``rejected``) or with
    another session's token (``dropped_token``); ``last_drop`` says why the last one was dropped.
    """

    def __init__(self, host: str, port: int, listen: tuple[str, int], token: int):
        self.host, self.port, self.listen, self.token = host, int(port), listen, int(token)
        self.sock: socket.socket | None = None
        self.bridge: set[tuple[str, int]] = set()
        self.dropped_sender = self.rejected = self.dropped_token = 0
        self.last_drop = ""

    def open(self, timeout: float | None) -> int:
        """Resolve the bridge's address (once: positions from anywhere else are not the bridge's)
        and bind the socket (``timeout`` s per receive, 0 = non-blocking); returns the bound port."""
        family = socket.AF_INET6 if ":" in self.listen[0] else socket.AF_INET
        self.bridge = {(a[4][0], a[4][1]) for a in socket.getaddrinfo(self.host, self.port, family,
                                                                        socket.SOCK_DGRAM)}
        self.sock = socket.socket(family, socket.SOCK_DGRAM)
        self.sock.bind(self.listen)
        self.sock.settimeout(timeout)
        return self.sock.getsockname()[1]

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()

    def accept(self, data: bytes, addr: tuple):
        """``(token, seq, x, y, z, ax, ay, az)`` of a position of the contract from the bridge, or None."""
        if (addr[0], addr[1]) not in self.bridge:
            self.dropped_sender += 1
            self.last_drop = f"not the bridge ({self.host}:{self.port})"
            return None
        msg = decode_position(data)
        if msg is None:
            self.rejected += 1
            self.last_drop = "not /surfhap/ff/position ,iiffffff with finite values in range"
            return None
        if msg[0] != self.token:
            self.dropped_token += 1
            self.last_drop = "wrong session token"
            return None
        return msg
