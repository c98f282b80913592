"""Haply Inverse3 as a force-feedback device (:class:`surfhap.live.ff_devices.FFDevice`): the
Haply Inverse Service's simulation channel, JSON over a local WebSocket (service 3.x, port 10001).

Protocol, as documented by Haply for the Inverse Service 3.5 ("Simulation Channel",
https://docs.haply.co/inverseSDK/service/api/simulation; "WebSocket Protocol",
https://docs.haply.co/inverseSDK/service/realtime/websocket-protocol; "Control Commands",
https://docs.haply.co/inverseSDK/service/realtime/control-commands):

* on connect the service sends an initial inventory, ``{"inverse3": [{"device_id", "config",
  "state": {"cursor_position": {x, y, z} (m), "cursor_velocity", ...}, "status"}, ...], ...}``;
* then exactly one state update (``{"inverse3": [{"device_id", "state", "status"}]}``) per message
  it receives: the cadence is the client's. Each haptic tick's :meth:`HaplyDevice.write` sends one
  ``{"inverse3": [{"device_id": ID, "commands": {"set_cursor_force": {"vector": {x, y, z}}}}]}``
  (N, per tick: a device whose commands stop returns to idle); the first one also names the
  session (``{"session": {"configure": {"profile": {"name": "surfhap"}}}}``).

Frame: the service's default basis (``XYZ``, https://docs.haply.co/inverseSDK/service/commons/basis)
is right-handed, +X right, +Y forward (away from the user), +Z up; surfhap's device frame
(:mod:`surfhap.ff.params`) is x right, y down the screen (towards the user), z up, relative to X0.
With the tablet flat on the end effector, its top edge away from the user: ``p = M (P - P0)`` and
``F_service = gain M F`` with ``M = diag(1, -1, 1)``; ``P0`` is the cursor position of the initial
inventory (start with the end effector at the workspace centre). The service speaks metres and
newtons, as surfhap does: gain 1. Its ``cursor_velocity`` is not used (the safety stage
differentiates the positions itself: one law).

Threads: the haptic thread only stores and reads tuples; a receiver thread parses the states, a
sender thread sends the newest force (a late sender sends the latest, never a backlog).

Fail safe: positions older than ``device_timeout`` -> the safety stage ramps the force to zero
(the one watchdog, :mod:`surfhap.ff.engine`); a command unanswered for ``silence`` s (issue 19:
20 ms; ``OPEN_TIMEOUT`` until the service has answered once) or a closed connection ->
:meth:`HaplyDevice.read` raises :class:`DeviceSilent`, so the loop stops through the safety stage and the command exits 3. A malformed message (not JSON, no
state of this device, a missing, non-numeric or non-finite coordinate) is counted
(``malformed``) and ignored: one bad frame does not end a session, and since it never refreshes
the position, a stream of them is silence and ends the run as such.
"""

from __future__ import annotations

import json
import logging
import math
import threading
from contextlib import ExitStack

from surfhap.errors import ConfigError
from surfhap.live.netaddr import parse_host_port
from surfhap.runtime.clock import now

__all__ = ["HaplyDevice", "DeviceSilent", "parse_haply_url", "SILENCE"]

SILENCE = 0.020  # s: "sensor or device silent for 20 ms -> zero output (ramped)" (issue 19, Targets)
OPEN_TIMEOUT = 5.0  # s, CHOICE: handshake and initial inventory of a local service; beyond, it is not answering
PROFILE = "surfhap"  # the session's profile name (shown by Haply Hub)

log = logging.getLogger("surfhap.live")


class DeviceSilent(OSError):
    """The service answered no command for ``silence`` s, or closed the connection."""


def parse_haply_url(text: str, option: str) -> tuple[str, int]:
    """``haply://HOST:PORT`` -> (host, port), checked without a DNS lookup; ConfigError naming ``option``."""
    s = (text or "").strip()
    if not s.startswith("haply://"):
        raise ConfigError(f"expected haply://HOST:PORT, got {text!r}", source=option)
    return parse_host_port(s[len("haply://"):], option)


def _num(v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{v!r} is not a finite number")
    return float(v)


def _cursor(entry: dict) -> tuple[float, float, float]:
    """``state.cursor_position`` (m) of one ``inverse3`` entry; ValueError/KeyError/TypeError if malformed."""
    p = entry["state"]["cursor_position"]
    return _num(p["x"]), _num(p["y"]), _num(p["z"])


class HaplyDevice:
    """An Inverse3 through the Inverse Service at ``ws://host:port`` (see the module docstring).

    gain    : service newtons per newton (1: the service takes newtons).
    silence : s, longest wait for the answer to a command before :meth:`read` raises.
    """

    name = "haply"

    def __init__(self, host: str, port: int, gain: float = 1.0, silence: float = SILENCE):
        self.uri = f"ws://{f'[{host}]' if ':' in host else host}:{int(port)}"
        self.gain = float(gain)
        self.silence = float(silence)
        self.device_id = None
        self._p0 = (0.0, 0.0, 0.0)
        self._pos = (0.0, 0.0, 0.0, -math.inf)
        self._cmd = (0, 0.0, 0.0, 0.0)  # (write number, fx, fy, fz) in the service's frame: one tuple store
        self._asked = None  # now() of the oldest unanswered command
        self._wake = threading.Event()
        self._ws = self._stack = None
        self._threads: list[threading.Thread] = []
        self._run = False
        self.closed = ""
        self.sent = self.received = self.malformed = self.errors = 0

    def start(self) -> None:
        from websockets.exceptions import WebSocketException
        from websockets.sync.client import connect

        self._stack = ExitStack()  # the connection as a context (the form websockets >= 17.1 asks for)
        try:
            ws = self._stack.enter_context(connect(self.uri, open_timeout=OPEN_TIMEOUT, compression=None))
        except (OSError, WebSocketException) as exc:
            raise OSError(f"no Haply Inverse Service at {self.uri} ({exc})") from None
        try:
            entry = json.loads(ws.recv(timeout=OPEN_TIMEOUT))["inverse3"][0]
            self.device_id, self._p0 = entry["device_id"], _cursor(entry)
        except (OSError, WebSocketException, ValueError, KeyError, TypeError, IndexError, RecursionError) as exc:
            self._stack.close()
            raise OSError(f"the Haply Inverse Service at {self.uri} reported no Inverse3 ({exc!r})") from None
        self._pos = (0.0, 0.0, 0.0, now())
        self._ws, self._run, self._asked, self.closed = ws, True, None, ""
        self._threads = [threading.Thread(target=f, name=f"surfhap-ff-haply-{n}", daemon=True)
                         for f, n in ((self._send, "out"), (self._receive, "in"))]
        for th in self._threads:
            th.start()
        log.info("ff haply device %s at %s", self.device_id, self.uri)

    def stop(self) -> None:
        """Send the last force written (the loop's final zero), then close."""
        self._run = False
        self._wake.set()
        if self._threads:
            self._threads[0].join(1.0)
        if self._ws is not None:
            self._stack.close()
        for th in self._threads[1:]:
            th.join(1.0)

    def press(self, load: float) -> None:
        pass  # the real finger presses on the real screen

    def read(self, t: float):
        a = self._asked
        wait = self.silence if self.received else OPEN_TIMEOUT  # the first answer: still opening the session
        if self.closed or (a is not None and now() - a > wait):
            raise DeviceSilent(f"no state from the Haply Inverse Service at {self.uri} for "
                               f"{wait * 1e3:g} ms" + (f" ({self.closed})" if self.closed else "")
                               + (f", {self.malformed} malformed messages" if self.malformed else ""))
        return self._pos

    def write(self, force, t: float) -> None:
        g = self.gain
        self._cmd = (self._cmd[0] + 1, float(force[0]) * g, -float(force[1]) * g, float(force[2]) * g)
        if self._asked is None:
            self._asked = now()
        self._wake.set()

    # ------------------------------------------------------------- I/O threads
    def _send(self) -> None:
        last = 0
        while True:
            self._wake.wait()
            self._wake.clear()
            n, fx, fy, fz = self._cmd
            if n != last:
                last = n
                msg = {"inverse3": [{"device_id": self.device_id,
                                     "commands": {"set_cursor_force": {"vector": {"x": fx, "y": fy, "z": fz}}}}]}
                if self.sent == 0:
                    msg["session"] = {"configure": {"profile": {"name": PROFILE}}}
                try:
                    self._ws.send(json.dumps(msg))
                    self.sent += 1
                except Exception:  # noqa: BLE001 - closed: read() reports it, the loop ramps down
                    self.errors += 1
            if not self._run:
                return

    def _receive(self) -> None:
        try:
            for raw in self._ws:
                self.accept(raw)
        except Exception as exc:  # noqa: BLE001 - any end of the connection is reported by read()
            log.debug("ff haply device: connection ended", exc_info=exc)
        if self._run:
            self.closed = "the service closed the connection"

    def accept(self, raw) -> bool:
        """Take one message of the service; True when it carried this device's cursor position."""
        try:
            entry = next(e for e in json.loads(raw)["inverse3"] if e["device_id"] == self.device_id)
            x, y, z = _cursor(entry)
        except (ValueError, KeyError, TypeError, StopIteration, RecursionError) as exc:
            self.malformed += 1
            if self.malformed <= 5 or self.malformed % 1000 == 0:
                log.warning("ff haply device: ignored a malformed message (%s; %d so far)", repr(exc)[:120],
                            self.malformed)
            return False
        p0 = self._p0
        self._pos = (x - p0[0], -(y - p0[1]), z - p0[2], now())  # one tuple store: atomic
        self._asked = None
        self.received += 1
        return True

    def info(self) -> dict:
        return {"name": self.name, "target": self.uri, "device_id": self.device_id, "gain": self.gain,
                "silence_ms": self.silence * 1e3, "sent": self.sent, "received": self.received,
                "malformed": self.malformed, "errors": self.errors}
