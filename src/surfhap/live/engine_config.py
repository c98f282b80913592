"""Settings of the live block engine (:class:`surfhap.live.engine.LiveEngine`), checked on
construction."""

from __future__ import annotations

from typing import Annotated

from pydantic import AfterValidator

from surfhap.checked import checked_dataclass, within
from surfhap.live.queues import power_of_two

__all__ = ["EngineConfig"]

_Ring = Annotated[int, AfterValidator(power_of_two)]  # a ring size


@checked_dataclass
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

    block_seconds: within(0.0002, 0.1, "must be within 0.2-100 ms") = 0.001
    touch_latency: within(0.0, 0.2, "must be within 0-200 ms") = 0.0
    smoothing: within(0.0, 1.0, "must be in (0, 1]", open_low=True) = 1.0
    k_pred: float | None = None
    speed_cutoff: float = 20.0
    takeover: float = 0.05
    stop_ramp: within(0.0, 1.0, "must be within 0-1 s", open_low=True) = 0.010
    simulate_display: bool = True
    touch_capacity: _Ring = 1024
    trace_capacity: _Ring = 8192
    latency_capacity: _Ring = 4096
    max_block_frames: int = 8192
