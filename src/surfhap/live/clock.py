"""The engine clock: one monotonic time base (s) for touch arrival stamps and blocks."""

from __future__ import annotations

import time

__all__ = ["now", "sleep_until"]

now = time.perf_counter


def sleep_until(deadline: float, spin: float = 0.0001) -> float:
    """Sleep until ``deadline`` on :func:`now` (coarse sleep, then a short spin); returns now."""
    while True:
        t = now()
        remaining = deadline - t
        if remaining <= 0:
            return t
        if remaining > spin:
            time.sleep(remaining - spin)

