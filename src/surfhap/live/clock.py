"""The engine clock: one monotonic time base (s) for touch arrival stamps and blocks, and
the one law for a stamp handed in by a caller (:func:`arrival_stamp`)."""

from __future__ import annotations

import math
import time

__all__ = ["now", "sleep_until", "arrival_stamp", "STALE"]

now = time.perf_counter

# the arrival stamp of a sample whose caller's stamp could not be trusted: older than any
# watchdog timeout, so it can never keep an output alive
STALE = -math.inf


def arrival_stamp(t_caller: float | None, t_now: float) -> float:
    """The arrival stamp of a sample handed over at ``t_now`` (the receiver's own clock).

    Without a caller's stamp it is ``t_now``. A caller's stamp (e.g. the web process's
    arrival time, on the same clock) may only make the sample *older*: a finite stamp at or
    before ``t_now`` is kept; a stamp from the future, NaN or ±inf is not trusted and gives
    :data:`STALE` (the sample can never refresh a watchdog)."""
    if t_caller is None:
        return t_now
    t = float(t_caller)
    if t <= t_now and t > STALE:  # False for NaN, +inf (> t_now) and -inf
        return t
    return STALE


def sleep_until(deadline: float, spin: float = 0.0001) -> float:
    """Sleep until ``deadline`` on :func:`now` (coarse sleep, then a short spin); returns now."""
    while True:
        t = now()
        remaining = deadline - t
        if remaining <= 0:
            return t
        if remaining > spin:
            time.sleep(remaining - spin)
