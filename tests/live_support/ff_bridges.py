"""Loopback reference bridges of the OSC force-feedback bridge contract, written with python-osc
(its server parses the force messages, its builder encodes the positions: independent of
surfhap's own encoder in surfhap.live.ff_bridge_wire).

``ReferenceBridge(watchdog=True)`` follows the contract: it accepts forces carrying a
sequence number above the last one, clamps each axis to ``limit`` device units (NaN -> 0),
echoes the newest token, numbers its positions and sends one every ms from the socket it
receives forces on, with the force it applies: zero once 20 ms have passed without a force.
``watchdog=False`` is the same bridge holding its last force forever (the bug of issue 17 #7).
"""

from __future__ import annotations

import math
import threading
import time

from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_message_builder import OscMessageBuilder
from pythonosc.osc_server import BlockingOSCUDPServer


class ReferenceBridge:
    def __init__(self, host_listen: tuple[str, int], watchdog: bool = True, limit: float = 36.0,
                 position=(0.0, 0.0, 0.0), rate: float = 1000.0):
        self.host_listen = host_listen
        self.watchdog = watchdog
        self.limit = limit
        self.position = position
        self.period = 1.0 / rate
        self.token = 0
        self.seq_in = -1
        self.seq_out = 0
        self.applied = (0.0, 0.0, 0.0)
        self.t_force = -math.inf
        self.forces = 0
        self.commands = []  # (fx, fy, fz) as received, device units
        self.lock = threading.Lock()
        disp = Dispatcher()
        disp.map("/surfhap/ff/force", self._on_force)
        self.server = BlockingOSCUDPServer(("127.0.0.1", 0), disp)
        self.port = self.server.server_address[1]
        self._run = True
        self._threads = [threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.05},
                                          daemon=True),
                         threading.Thread(target=self._send_positions, daemon=True)]

    def _clamp(self, v) -> float:
        v = float(v)
        return 0.0 if not math.isfinite(v) else max(-self.limit, min(self.limit, v))

    def _on_force(self, _address, token, seq, fx, fy, fz):
        with self.lock:
            if seq <= self.seq_in:
                return
            self.seq_in, self.token = seq, token
            self.applied = (self._clamp(fx), self._clamp(fy), self._clamp(fz))
            self.t_force = time.monotonic()
            self.forces += 1
            self.commands.append((fx, fy, fz))

    def _send_positions(self):
        next_t = time.monotonic()
        while self._run:
            with self.lock:
                if self.watchdog and time.monotonic() - self.t_force > 0.020:
                    self.applied = (0.0, 0.0, 0.0)
                applied, token, seq = self.applied, self.token, self.seq_out
                self.seq_out += 1
            if token:
                b = OscMessageBuilder("/surfhap/ff/position")
                b.add_arg(token, "i")
                b.add_arg(seq, "i")
                for v in (*self.position, *applied):
                    b.add_arg(float(v), "f")
                try:  # from the socket the forces arrive on: the host checks the sender
                    self.server.socket.sendto(b.build().dgram, self.host_listen)
                except OSError:
                    pass
            next_t += self.period
            time.sleep(max(0.0, next_t - time.monotonic()))

    def __enter__(self):
        for t in self._threads:
            t.start()
        return self

    def __exit__(self, *exc):
        self._run = False
        self.server.shutdown()
        for t in self._threads:
            t.join(5)
        self.server.server_close()
