"""Haply Inverse3 as a force-feedback device (:class:`surfhap.live.ff_devices.FFDevice`) through
the Inverse Service's simulation channel: JSON over a local WebSocket (service 3.x, port 10001).

Protocol (Haply's docs for service 3.5: https://docs.haply.co/inverseSDK/service/api/simulation,
.../service/realtime/websocket-protocol, .../service/realtime/control-commands): on connect the
service sends an inventory (``inverse3[i]``: ``device_id``, ``state.cursor_position`` {x, y, z} m),
then exactly one state update per message it receives (the client sets the cadence). Each tick's
:meth:`HaplyDevice.write` sends ``{"inverse3": [{"device_id", "commands": {"set_cursor_force":
{"vector": {x, y, z}}}}]}`` (N; per tick: commands that stop leave the device idle), the first
one also naming the session (``session.configure.profile.name``).

Frame: the service's default basis ``XYZ`` (.../service/commons/basis) is +X right, +Y away from
the user, +Z up; surfhap's device frame (:mod:`surfhap.ff.params`) is x right, y down the screen
(towards the user), z up. With the tablet flat on the end effector, top edge away from the user:
``p = M (P - P0)``, ``F_service = gain M F``, ``M = diag(1, -1, 1)``, ``P0`` the inventory's cursor
(X0). Metres and newtons on both sides: gain 1. ``cursor_velocity`` is unused (the safety stage
differentiates positions itself).

No thread of its own: the haptic thread does the non-blocking I/O (websockets' sans-I/O protocol
on a TCP socket), so a stall of surfhap's own process is not taken for a silent device (the first
read after it finds the answers that came meanwhile).

Fail safe: no new position for ``device_timeout`` -> the safety stage ramps to zero (the one
watchdog, :mod:`surfhap.ff.engine`); a command unanswered for ``silence`` s (issue 19: 20 ms;
``OPEN_TIMEOUT`` until the first answer) or a closed connection -> :meth:`HaplyDevice.read` raises
:class:`DeviceSilent`: the loop stops through the safety stage, the command exits 3. A malformed
message (not JSON, no state of this device, a missing or non-finite coordinate) is counted
(``malformed``) and ignored: one bad frame does not end a session, and as it never refreshes the
position, a stream of them is silence.
"""

from __future__ import annotations

import json
import logging
import math
import socket

from surfhap.live.sources import RejectLog, finite_in_range
from surfhap.runtime.clock import now

__all__ = ["HaplyDevice", "DeviceSilent", "SILENCE"]

SILENCE = 0.020  # s: "sensor or device silent for 20 ms -> zero output (ramped)" (issue 19, Targets)
OPEN_TIMEOUT = 5.0  # s, CHOICE: handshake and initial inventory of a local service; beyond, it is not answering
PROFILE = "surfhap"  # the session's profile name (shown by Haply Hub)

log = logging.getLogger("surfhap.live")


class DeviceSilent(OSError):
    """The service answered no command for ``silence`` s, or closed the connection."""


def _cursor(entry: dict) -> tuple[float, float, float]:
    """``state.cursor_position`` (m) of one ``inverse3`` entry; ValueError/KeyError/TypeError if malformed."""
    p = entry["state"]["cursor_position"]
    xyz = tuple(finite_in_range(p[k], -math.inf, math.inf) for k in "xyz")
    if None in xyz:
        raise ValueError(f"cursor position {p!r} is not three finite numbers")
    return xyz


class HaplyDevice:
    """An Inverse3 through the Inverse Service at ``ws://host:port`` (see the module docstring).

    gain    : service newtons per newton (1: the service takes newtons).
    silence : s, longest wait for the answer to a command before :meth:`read` raises.
    """

    name = "haply"

    def __init__(self, host: str, port: int, gain: float = 1.0, silence: float = SILENCE):
        self.host, self.port = host, int(port)
        self.uri = f"ws://{f'[{host}]' if ':' in host else host}:{self.port}"
        self.gain = float(gain)
        self.silence = float(silence)
        self.device_id = None
        self._p0 = (0.0, 0.0, 0.0)
        self._pos = (0.0, 0.0, 0.0, -math.inf)
        self._asked = None  # now() of the oldest unanswered command
        self._sock = self._proto = None
        self._out = bytearray()  # bytes the socket did not take yet
        self.closed = ""
        self.sent = self.received = self.errors = 0
        self._malformed = RejectLog(log, every=1000, template="ff haply device %s: ignored a malformed message (%s; %d "
                                    "so far)")

    malformed = property(lambda self: self._malformed.count, doc="malformed messages ignored")

    def start(self) -> None:
        from websockets.client import ClientProtocol
        from websockets.uri import parse_uri

        self._out.clear()
        self.closed, self._asked = "", None
        self.sent = self.received = self.errors = self._malformed.count = 0
        try:
            self._sock = socket.create_connection((self.host, self.port), timeout=OPEN_TIMEOUT)
        except OSError as exc:
            raise OSError(f"no Haply Inverse Service at {self.uri} ({exc})") from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # one small frame per tick: no delay
        self._proto = ClientProtocol(parse_uri(self.uri))
        self._proto.send_request(self._proto.connect())
        first = []
        try:  # blocking, with the open timeout: the handshake, then the initial inventory
            self._sock.sendall(b"".join(self._proto.data_to_send()))
            while not first and not self.closed:
                first = self._receive(self._sock.recv(1 << 16))
            entry = json.loads(first[0])["inverse3"][0]
            self.device_id, self._p0 = entry["device_id"], _cursor(entry)
        except (OSError, ValueError, KeyError, TypeError, IndexError, RecursionError) as exc:
            self._sock.close()
            self._sock = None
            raise OSError(f"the Haply Inverse Service at {self.uri} reported no Inverse3 "
                          f"({self.closed or repr(exc)})") from None
        self._sock.setblocking(False)
        self._pos = (0.0, 0.0, 0.0, now())
        log.info("ff haply device %s at %s", self.device_id, self.uri)

    def stop(self) -> None:
        """Send what is pending (the loop's final zero force) and a close frame, and wait for the
        service to close (closing first, with its answers unread, would reset the connection and
        could drop the last commands at the service)."""
        if self._sock is None:
            return
        try:
            if not self.closed:
                self._proto.send_close()
                self._out += b"".join(self._proto.data_to_send())
                self._sock.settimeout(OPEN_TIMEOUT)
                self._sock.sendall(self._out)
                while self._sock.recv(1 << 16):
                    pass
        except Exception:  # noqa: BLE001 - the service is gone: nothing more to tell it
            log.debug("ff haply device: could not flush on stop", exc_info=True)
        self._sock.close()
        self._sock = None

    def press(self, load: float) -> None:
        pass  # the real finger presses on the real screen

    def read(self, t: float):
        """Take every answer that has arrived; the newest position (m, surfhap frame) and its arrival."""
        while not self.closed:
            try:
                data = self._sock.recv(1 << 16)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:
                self.closed = f"connection lost: {exc}"
                break
            for raw in self._receive(data):
                self.accept(raw)
        self._flush()
        a = self._asked
        wait = self.silence if self.received else OPEN_TIMEOUT  # the first answer: still opening the session
        if self.closed or (a is not None and now() - a > wait):
            raise DeviceSilent(f"no state from the Haply Inverse Service at {self.uri} for "
                               f"{wait * 1e3:g} ms" + (f" ({self.closed})" if self.closed else "")
                               + (f", {self.malformed} malformed messages" if self.malformed else ""))
        return self._pos

    def write(self, force, t: float) -> None:
        """Send ``gain M force`` as this tick's ``set_cursor_force`` (the first one names the session)."""
        if self.closed:
            self.errors += 1
            return
        g = self.gain
        msg = {"inverse3": [{"device_id": self.device_id, "commands": {"set_cursor_force": {"vector": {
            "x": float(force[0]) * g, "y": -float(force[1]) * g, "z": float(force[2]) * g}}}}]}
        if self.sent == 0:
            msg["session"] = {"configure": {"profile": {"name": PROFILE}}}
        self._proto.send_text(json.dumps(msg).encode())
        self._out += b"".join(self._proto.data_to_send())
        self.sent += 1
        if self._asked is None:
            self._asked = now()
        self._flush()

    # ------------------------------------------------------------- I/O
    def _flush(self) -> None:
        if self._out and not self.closed:
            try:
                del self._out[:self._sock.send(self._out)]
            except (BlockingIOError, InterruptedError):
                pass  # the socket is full: the rest goes with the next call
            except OSError as exc:
                self.errors += 1
                self.closed = f"connection lost: {exc}"

    def _receive(self, data: bytes) -> list[bytes]:
        """Feed ``data`` (b"": the peer closed) to the protocol; the text messages it completed."""
        from websockets.frames import Frame, Opcode

        p = self._proto
        if data:
            p.receive_data(data)
        else:
            p.receive_eof()
        texts = []
        for ev in p.events_received():
            if not isinstance(ev, Frame):  # the handshake's response
                if p.handshake_exc is not None:
                    raise OSError(f"WebSocket handshake refused: {p.handshake_exc}")
            elif ev.opcode is Opcode.CLOSE:
                self.closed = "the service closed the connection"
            elif ev.opcode in (Opcode.TEXT, Opcode.BINARY, Opcode.CONT):
                texts.append(ev.data if ev.opcode is Opcode.TEXT and ev.fin else b"")  # a fragment: malformed
        if not data:
            self.closed = "the service closed the connection"
        self._out += b"".join(p.data_to_send())  # pongs, the close reply
        return texts

    def accept(self, raw) -> bool:
        """Take one message of the service; True when it carried this device's cursor position."""
        try:
            entry = next(e for e in json.loads(raw)["inverse3"] if e["device_id"] == self.device_id)
            x, y, z = _cursor(entry)
        except (ValueError, KeyError, TypeError, StopIteration, RecursionError) as exc:
            self._malformed.reject(self.uri, repr(exc)[:120])
            return False
        p0 = self._p0
        self._pos = (x - p0[0], -(y - p0[1]), z - p0[2], now())
        self._asked = None
        self.received += 1
        return True

    def info(self) -> dict:
        return {"name": self.name, "target": self.uri, "device_id": self.device_id, "gain": self.gain,
                "silence_ms": self.silence * 1e3, "sent": self.sent, "received": self.received,
                "malformed": self.malformed, "errors": self.errors}
