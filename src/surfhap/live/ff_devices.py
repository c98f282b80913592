"""Device backends of the force-feedback loop: the small protocol and its two implementations.

Protocol (called from the haptic thread only, once per tick, never blocking):

* ``start()`` / ``stop()``;
* ``read(t) -> (px, py, pz, t_pos)``: freshest screen position (m, device frame relative to
  X0, see :mod:`surfhap.ff.params`) and the engine-clock time it was measured;
* ``write(force, t)``: the safe force (3,) N; the backend converts it into device units
  with its ``gain`` (Falcon through CHAI3D: 4.5, 004 Sec. 4.3).

``sim``: :class:`SimDeviceBackend`, a :class:`surfhap.sim.ff_device.SimDevice` stepped on
every write by as many of its own ticks as wall-clock periods have passed (so that missed
haptic ticks do not slow the simulated physics down; the finger's load, as reported by the
touch source, presses on it).

``osc``: :class:`OscDeviceBackend` talks to a device bridge (e.g. a CHAI3D program) over UDP:

=====================================  ==================================================
sent to the bridge, every tick          ``/surfhap/ff/force fx fy fz`` (float32, device
                                        units = gain x N, device frame)
received from the bridge                ``/surfhap/ff/position x y z`` (m, relative to X0)
=====================================  ==================================================

Received messages are size-, type- and range-checked; anything else is counted and dropped.
"""

from __future__ import annotations

import logging
import math
import socket
import struct
import threading

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.clock import now
from surfhap.live.netaddr import parse_osc_address

__all__ = ["SimDeviceBackend", "OscDeviceBackend", "parse_osc_url"]

log = logging.getLogger("surfhap.live")

MAX_POSITION = 1.0  # m, larger positions are rejected as garbage


def parse_osc_url(text: str, option: str, *, listen: bool = False) -> tuple[str, int]:
    """``osc://HOST:PORT`` -> (host, port), checked without a DNS lookup (port 0 only where
    the option ``listen``\ s); ConfigError naming ``option`` otherwise."""
    host, port, path = parse_osc_address(text, option, listen=listen)
    if path:
        raise ConfigError(f"expected osc://HOST:PORT, got {text!r}", source=option)
    return host, port


class SimDeviceBackend:
    """The simulated device; ``finger_load`` (N) is pressed onto the screen while touched."""

    name = "sim"

    def __init__(self, device, gain: float):
        self.device = device
        self.gain = float(gain)
        self.finger_load = 0.0
        self._cmd = np.zeros(3)
        self._ext = np.zeros(3)
        self.writes = 0
        self._t = None

    def start(self) -> None:
        self.device.reset()
        self._t = None

    def stop(self) -> None:
        pass

    def read(self, t: float):
        p = self.device.p
        return float(p[0]), float(p[1]), float(p[2]), t

    def write(self, force, t: float) -> None:
        g = self.gain
        self._cmd[0], self._cmd[1], self._cmd[2] = force[0] * g, force[1] * g, force[2] * g
        self._ext[2] = -self.finger_load
        dev = self.device
        n = 1 if self._t is None else int(round((t - self._t) * dev.rate))
        n = 1 if n < 1 else (50 if n > 50 else n)
        for _ in range(n):
            dev.step(self._cmd, self._ext)
        self._t = t if self._t is None else self._t + n * dev.dt
        if abs(t - self._t) > 0.05:  # a long stall: re-anchor instead of catching up
            self._t = t
        self.writes += 1

    def info(self) -> dict:
        return {"name": self.name, "gain": self.gain, "writes": self.writes, "position_m": self.device.p.tolist()}


class OscDeviceBackend:
    """Force commands to ``host:port`` over OSC; positions from the bridge on ``listen`` (UDP).

    listen : (host, port) to receive positions on; port 0 picks a free one (see ``.listen_port``).
    """

    name = "osc"

    def __init__(self, host: str, port: int, gain: float, listen: tuple[str, int] = ("127.0.0.1", 0)):
        from pythonosc.osc_message_builder import OscMessageBuilder  # noqa: F401  (fail early if missing)

        self.host, self.port = host, int(port)
        self.gain = float(gain)
        self.listen = listen
        self.listen_port = None
        self._pos = (0.0, 0.0, 0.0, -math.inf)
        self._sock_out = None
        self._sock_in = None
        self._thread = None
        self._run = False
        self.sent = self.received = self.rejected = self.errors = 0
        self._prefix = self._build_prefix()

    @staticmethod
    def _build_prefix() -> bytes:
        addr = b"/surfhap/ff/force"
        addr += b"\0" * (4 - len(addr) % 4)
        tags = b",fff"
        tags += b"\0" * (4 - len(tags) % 4)
        return addr + tags

    def start(self) -> None:
        self._sock_out = socket.socket(socket.AF_INET6 if ":" in self.host else socket.AF_INET, socket.SOCK_DGRAM)
        self._sock_out.setblocking(False)
        self._sock_in = socket.socket(socket.AF_INET6 if ":" in self.listen[0] else socket.AF_INET, socket.SOCK_DGRAM)
        self._sock_in.bind(self.listen)
        self._sock_in.settimeout(0.1)
        self.listen_port = self._sock_in.getsockname()[1]
        self._run = True
        self._thread = threading.Thread(target=self._receive, name="surfhap-ff-osc-in", daemon=True)
        self._thread.start()
        log.info("ff osc device: forces to %s:%d, positions on udp://%s:%d", self.host, self.port, self.listen[0],
                 self.listen_port)

    def stop(self) -> None:
        self._run = False
        if self._thread is not None:
            self._thread.join(1.0)
        for s in (self._sock_in, self._sock_out):
            if s is not None:
                s.close()

    def _receive(self) -> None:
        from pythonosc.osc_message import OscMessage

        while self._run:
            try:
                data, _ = self._sock_in.recvfrom(1024)
            except (socket.timeout, OSError):
                continue
            try:
                msg = OscMessage(data)
                addr, args = msg.address, msg.params
            except Exception:  # noqa: BLE001 - any parse failure is a bad message
                self.rejected += 1
                continue
            if addr != "/surfhap/ff/position" or len(args) != 3 or not all(
                    isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a)
                    and abs(a) <= MAX_POSITION for a in args):
                self.rejected += 1
                if self.rejected <= 5:
                    log.warning("ff osc device: rejected %s %r", addr[:64], args[:4] if isinstance(args, list) else args)
                continue
            self._pos = (float(args[0]), float(args[1]), float(args[2]), now())  # one tuple store: atomic
            self.received += 1

    def read(self, t: float):
        return self._pos

    def write(self, force, t: float) -> None:
        g = self.gain
        payload = self._prefix + struct.pack(">fff", force[0] * g, force[1] * g, force[2] * g)
        try:
            self._sock_out.sendto(payload, (self.host, self.port))
            self.sent += 1
        except OSError:
            self.errors += 1

    def info(self) -> dict:
        return {"name": self.name, "target": f"{self.host}:{self.port}", "listen_port": self.listen_port,
                "gain": self.gain, "sent": self.sent, "received": self.received, "rejected": self.rejected,
                "errors": self.errors}
