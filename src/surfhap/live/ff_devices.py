"""Device backends of the force-feedback loop: the small protocol and its two implementations
(``haply``, a Haply Inverse3, is :class:`surfhap.live.ff_haply.HaplyDevice`).

Protocol :class:`FFDevice` (called from the haptic thread only, once per tick, never blocking):

* ``start()`` / ``stop()``; ``info()`` a small dict for the statistics;
* ``press(load)``: the finger's load (N) as the touch source reported it (the simulated
  device presses it on the screen; a real device feels the real finger and ignores it);
* ``read(t) -> (px, py, pz, t_pos)``: freshest screen position (m, device frame relative to
  X0, see :mod:`surfhap.ff.params`) and the engine-clock time it was measured;
* ``write(force, t)``: the safe force (3,) N; the backend converts it into device units
  with its ``gain`` (Falcon through CHAI3D: 4.5, 004 Sec. 4.3).
"""

from __future__ import annotations

import logging
import math
import socket
import threading
from typing import Protocol

import numpy as np

from surfhap.runtime.clock import now
from surfhap.live.sources import RejectLog
from surfhap.live.ff_bridge_wire import PositionReceiver, encode_force, new_token

__all__ = ["FFDevice", "SimDeviceBackend", "OscDeviceBackend"]


class FFDevice(Protocol):
    """A device backend of the force-feedback loop (see the module docstring)."""

    name: str

    def start(self) -> None: ...

    def stop(self) -> None: ...

    def read(self, t: float) -> tuple[float, float, float, float]: ...

    def write(self, force, t: float) -> None: ...

    def press(self, load: float) -> None: ...

    def info(self) -> dict: ...

log = logging.getLogger("surfhap.live")


class SimDeviceBackend:
    """The simulated device (:class:`surfhap.sim.ff_device.SimDevice`), stepped on every write by
    as many of its own ticks as wall-clock periods have passed (missed haptic ticks do not slow
    its physics down); ``finger_load`` (N) is pressed onto the screen while touched, or with
    ``finger`` (:class:`surfhap.sim.ff_device.SimFinger`, ``ff simulate``) its ``force_on_screen``."""

    name = "sim"

    def __init__(self, device, gain: float, finger=None):
        self.device = device
        self.gain = float(gain)
        self.finger = finger
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

    def press(self, load: float) -> None:
        self.finger_load = load

    def read(self, t: float):
        p = self.device.p
        return float(p[0]), float(p[1]), float(p[2]), t

    def write(self, force, t: float) -> None:
        g = self.gain
        self._cmd[0], self._cmd[1], self._cmd[2] = force[0] * g, force[1] * g, force[2] * g
        self._ext[2] = -self.finger_load
        dev = self.device
        ext = self._ext if self.finger is None else self.finger.force_on_screen(t, dev.v)
        n = 1 if self._t is None else int(round((t - self._t) * dev.rate))
        n = 1 if n < 1 else (50 if n > 50 else n)
        for _ in range(n):
            dev.step(self._cmd, ext)
        self._t = t if self._t is None else self._t + n * dev.dt
        if abs(t - self._t) > 0.05:  # a long stall: re-anchor instead of catching up
            self._t = t
        self.writes += 1

    def info(self) -> dict:
        return {"name": self.name, "gain": self.gain, "writes": self.writes, "position_m": self.device.p.tolist()}


class OscDeviceBackend:
    """Force commands to a device bridge (e.g. a CHAI3D program) at ``host:port`` over OSC;
    positions from the bridge on ``listen`` (UDP), under the bridge contract
    (:mod:`surfhap.live.ff_bridge_wire`, docs/forcefeedback.md). A position is used only from
    the bridge's own address with this session's token (:class:`~surfhap.live.ff_bridge_wire.PositionReceiver`,
    shared with ``ff bridge-check``) and a sequence number above the last one accepted; anything
    else is dropped and counted (``dropped_sender``, ``dropped_token``, ``dropped_sequence``, ``rejected``).

    listen : (host, port) to receive positions on; port 0 picks a free one (see ``.listen_port``).
    token  : the session token (default: a random one per backend).
    """

    name = "osc"

    def __init__(self, host: str, port: int, gain: float, listen: tuple[str, int] = ("127.0.0.1", 0),
                 token: int | None = None):
        self.host, self.port = host, int(port)
        self.gain = float(gain)
        self.listen = listen
        self.listen_port = None
        self.token = new_token() if token is None else int(token)
        self.receiver = PositionReceiver(host, port, listen, self.token)
        self._seq_out = 0
        self._seq_in = -1
        self._pos = (0.0, 0.0, 0.0, -math.inf)
        self._sock_out = None
        self._thread = None
        self._run = False
        self.sent = self.received = self.errors = self.dropped_sequence = 0
        self._drops = RejectLog(log, every=1000, template="ff osc device: dropped a position from %s: %s (%d dropped "
                                "so far)")

    # the receiver's drop counters, under the names of info()
    dropped_sender = property(lambda self: self.receiver.dropped_sender)
    dropped_token = property(lambda self: self.receiver.dropped_token)
    rejected = property(lambda self: self.receiver.rejected)

    def start(self) -> None:
        self.listen_port = self.receiver.open(0.1)
        self._sock_out = socket.socket(socket.AF_INET6 if ":" in self.host else socket.AF_INET, socket.SOCK_DGRAM)
        self._sock_out.setblocking(False)
        self._run = True
        self._thread = threading.Thread(target=self._receive, name="surfhap-ff-osc-in", daemon=True)
        self._thread.start()
        log.info("ff osc device: forces to %s:%d, positions on udp://%s:%d", self.host, self.port, self.listen[0],
                 self.listen_port)

    def stop(self) -> None:
        self._run = False
        if self._thread is not None:
            self._thread.join(1.0)
        self.receiver.close()
        if self._sock_out is not None:
            self._sock_out.close()

    def press(self, load: float) -> None:
        pass  # the real finger presses on the real screen

    def _receive(self) -> None:
        sock = self.receiver.sock
        while self._run:
            try:
                data, addr = sock.recvfrom(1024)
            except (socket.timeout, OSError):
                continue
            self.accept(data, addr)

    def accept(self, data: bytes, addr: tuple) -> bool:
        """Check one datagram from ``addr`` against the contract; True when its position was taken."""
        msg = self.receiver.accept(data, addr)
        if msg is None:
            self._drops.reject(addr[:2], self.receiver.last_drop)
            return False
        seq, x, y, z = msg[1:5]
        if seq <= self._seq_in:
            self.dropped_sequence += 1
            self._drops.reject(addr[:2], f"sequence number {seq} not above {self._seq_in}")
            return False
        self._seq_in = seq
        self._pos = (x, y, z, now())  # one tuple store: atomic
        self.received += 1
        return True

    def read(self, t: float):
        return self._pos

    def write(self, force, t: float) -> None:
        g = self.gain
        payload = encode_force(self.token, self._seq_out, force[0] * g, force[1] * g, force[2] * g)
        self._seq_out += 1
        try:
            self._sock_out.sendto(payload, (self.host, self.port))
            self.sent += 1
        except OSError:
            self.errors += 1

    def info(self) -> dict:
        return {"name": self.name, "target": f"{self.host}:{self.port}", "listen_port": self.listen_port,
                "gain": self.gain, "sent": self.sent, "received": self.received, "rejected": self.rejected,
                "dropped_sender": self.dropped_sender, "dropped_token": self.dropped_token,
                "dropped_sequence": self.dropped_sequence, "errors": self.errors}
