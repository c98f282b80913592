"""Typed commands for a running engine (:meth:`surfhap.live.engine.LiveEngine.send`).

One small frozen dataclass per command, checked on construction (pydantic, a bad value is
one :class:`~surfhap.errors.ConfigError` naming the field); the engine raises for anything
else, so a misspelt command is an error, never silently ignored.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from surfhap.checked import checked_dataclass

__all__ = ["Stop", "SetGain", "SwapRenderer", "Command"]


@dataclass(frozen=True)
class Stop:
    """Ramp the output to zero over the engine's ``stop_ramp``, then silence."""


@checked_dataclass
class SetGain:
    """Output gain in [0, 1], applied inside the output safety pass (so a step is rise-limited)."""

    gain: Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False, strict=True)]


@dataclass(frozen=True)
class SwapRenderer:
    """Switch to another renderer (same drive rate; build it outside the real-time callback).
    The engine resets it when it takes it (its sample clock starts at 0): the sender never
    resets a renderer the engine may be running."""

    renderer: object


Command = Stop | SetGain | SwapRenderer
