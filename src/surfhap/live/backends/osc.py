"""``osc``: send what the engine renders to an external renderer over OSC (UDP).

Address patterns sent (one message per block):

* mode ``intensity``: ``/surfhap/intensity f`` - the block's peak drive magnitude over the
  safety limit, in [0, 1] (for renderers that make their own waveform: a force-feedback
  loop, a vibrotactile actuator);
* mode ``drive``: ``/surfhap/drive b`` - the block's drive samples in volts as a blob of
  little-endian float32, plus ``/surfhap/intensity f``.

UDP sends never wait for the receiver; a send error is counted, not raised.
"""

from __future__ import annotations

import numpy as np

from surfhap.live.backends.base import PacedBackend

__all__ = ["OscBackend"]


class OscBackend(PacedBackend):
    name = "osc"

    def __init__(self, host: str, port: int, mode: str = "intensity"):
        super().__init__()
        from pythonosc.udp_client import SimpleUDPClient

        self.host, self.port, self.mode = host, int(port), mode
        self._client = SimpleUDPClient(host, self.port)
        self.sent = 0
        self.errors = 0
        self._f32 = None

    def open(self, engine) -> None:
        super().open(engine)
        self._f32 = np.zeros(engine.block_frames, dtype="<f4")

    def emit(self, volts) -> None:
        vmax = self.engine.v_max
        peak = float(np.abs(volts).max()) if volts.shape[0] else 0.0
        try:
            if self.mode == "drive":
                buf = self._f32[: volts.shape[0]]
                buf[:] = volts
                self._client.send_message("/surfhap/drive", buf.tobytes())
            self._client.send_message("/surfhap/intensity", min(1.0, peak / vmax))
            self.sent += 1
        except OSError:
            self.errors += 1

    def info(self) -> dict:
        return {"name": self.name, "target": f"{self.host}:{self.port}", "mode": self.mode, "sent": self.sent,
                "errors": self.errors}
