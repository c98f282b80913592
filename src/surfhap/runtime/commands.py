"""Typed commands for a running engine (:meth:`surfhap.live.engine.LiveEngine.send`).

One small frozen dataclass per command, checked on construction; the engine raises for
anything else, so a misspelt command is an error, never silently ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from surfhap.errors import ConfigError

__all__ = ["Stop", "SetGain", "SwapRenderer", "Command"]


@dataclass(frozen=True)
class Stop:
    """Ramp the output to zero over the engine's ``stop_ramp``, then silence."""


@dataclass(frozen=True)
class SetGain:
    """Output gain in [0, 1], applied inside the output safety pass (so a step is rise-limited)."""

    gain: float

    def __post_init__(self):
        g = self.gain
        if isinstance(g, bool) or not isinstance(g, (int, float)) or not (math.isfinite(g) and 0.0 <= g <= 1.0):
            raise ConfigError(f"must be a number within 0-1, got {g!r}", field="gain")


@dataclass(frozen=True)
class SwapRenderer:
    """Switch to another renderer (same drive rate; build it outside the real-time callback)."""

    renderer: object


Command = Stop | SetGain | SwapRenderer
