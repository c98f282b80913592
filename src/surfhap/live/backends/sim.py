"""``sim``: the simulated display, paced in real time (the default output).

The engine runs the simulated electroadhesion display itself (``simulate_display``), so the
trace shows the friction a finger would feel; this backend only provides the clock and
keeps the last block for inspection.
"""

from __future__ import annotations

from surfhap.live.backends.base import PacedBackend

__all__ = ["SimBackend"]


class SimBackend(PacedBackend):
    name = "sim"
    blocks = 0  # blocks emitted

    def emit(self, volts) -> None:
        self.blocks += 1

    def info(self) -> dict:
        return {"name": self.name, "blocks": self.blocks}
