"""Settings of the live block engine (:class:`surfhap.live.engine.LiveEngine`), checked on
construction."""

from __future__ import annotations

import math
from dataclasses import dataclass

from surfhap.errors import ConfigError

__all__ = ["EngineConfig"]


@dataclass(frozen=True)
class EngineConfig:
    """Settings of the live engine (SI units).

    block_seconds : s, nominal block period (1 ms default); the backend's block size.
    touch_latency : s, touch latency compensated by prediction (0 = off; 004 Sec. 4.2).
    smoothing     : alpha of the exponential smoothing (004 eq. 7); 1 = off.
    k_pred        : fixed prediction gain (004 eq. 6); None = derived from touch_latency.
    speed_cutoff  : Hz, low-pass of the speed estimate.
    takeover      : s, a touch source may take over the finger when the current one has
                    been silent this long (one finger at a time drives the display).
    stop_ramp     : s, length of the ramp to zero on stop.
    simulate_display : run the simulated electroadhesion display to trace friction.
    touch_capacity, trace_capacity, latency_capacity : ring sizes (powers of two).
    max_block_frames : largest block a backend may ask for.
    """

    block_seconds: float = 0.001
    touch_latency: float = 0.0
    smoothing: float = 1.0
    k_pred: float | None = None
    speed_cutoff: float = 20.0
    takeover: float = 0.05
    stop_ramp: float = 0.010
    simulate_display: bool = True
    touch_capacity: int = 1024
    trace_capacity: int = 8192
    latency_capacity: int = 4096
    max_block_frames: int = 8192

    def __post_init__(self):
        if not (math.isfinite(self.block_seconds) and 0.0002 <= self.block_seconds <= 0.1):
            raise ConfigError("must be within 0.2-100 ms", field="block_seconds")
        if not (math.isfinite(self.touch_latency) and 0.0 <= self.touch_latency <= 0.2):
            raise ConfigError("must be within 0-200 ms", field="touch_latency")
        if not (math.isfinite(self.smoothing) and 0.0 < self.smoothing <= 1.0):
            raise ConfigError("must be in (0, 1]", field="smoothing")
        if not (math.isfinite(self.stop_ramp) and 0.0 < self.stop_ramp <= 1.0):
            raise ConfigError("must be within 0-1 s", field="stop_ramp")
        for name in ("touch_capacity", "trace_capacity", "latency_capacity"):
            v = getattr(self, name)
            if v < 2 or v & (v - 1):
                raise ConfigError("must be a power of two", field=name)
