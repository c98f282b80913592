"""Bounded, non-blocking hand-over between producer threads and the real-time callback.

:class:`TouchRing` carries touch samples; :class:`CommandQueue` carries control commands.
Both are allocated up front and never grow. Producers (web server, OSC listener, replay
thread) serialise among themselves with a lock; the consumer (the audio callback) never
takes that lock: it reads the write counter, copies the rows written so far and advances
its own read counter. Under CPython's GIL an ``int`` store is atomic and the data rows are
written before the counter that publishes them, so the consumer never sees a half-written
row. When the ring is full the *newest* sample is refused and counted (the consumer only
needs the freshest state, but refusing keeps the ring single-writer-per-slot safe).
"""

from __future__ import annotations

import threading
from collections import deque

import numpy as np

__all__ = ["TouchRing", "CommandQueue", "TOUCH_FIELDS", "ring_rows_since", "ring_stats"]

def ring_rows_since(ring: np.ndarray, count: int, index: int, limit: int | None = None) -> tuple[np.ndarray, int]:
    """Rows of a power-of-two ring ``ring`` ((cap, c) float) written since ``index``, oldest
    first, when ``count`` rows were written in all: ((n, c) float copy, ``count``). At most
    the ring's length less one (the slot being written may be torn) and at most ``limit``
    of the newest rows."""
    cap = ring.shape[0]
    start = max(index, count - cap + 1)
    if limit is not None:
        start = max(start, count - limit)
    if start >= count:
        return np.zeros((0, ring.shape[1])), count
    return ring[np.arange(start, count) & (cap - 1)].copy(), count


# one row per touch sample
TOUCH_FIELDS = ("source", "t_event", "t_arrival", "x", "y", "load")


def ring_stats(ring: np.ndarray, count: int) -> dict:
    """p50, p99, max and last of the ``min(count, len(ring))`` values written into a ring of
    power-of-two length after ``count`` writes (None each when empty), and ``n`` = count."""
    n = min(count, ring.shape[0])
    if n == 0:
        return {"n": 0, "p50": None, "p99": None, "max": None, "last": None}
    vals = ring[:n] if count <= ring.shape[0] else ring.copy()
    last = float(ring[(count - 1) & (ring.shape[0] - 1)])
    return {"n": int(count), "p50": float(np.percentile(vals, 50)), "p99": float(np.percentile(vals, 99)),
            "max": float(vals.max()), "last": last}


def power_of_two(n: int) -> int:
    """``n`` when it is a power of two >= 2 (a ring size), else ValueError."""
    if n < 2 or n & (n - 1):
        raise ValueError("must be a power of two")
    return n


class TouchRing:
    """Single-consumer ring of touch samples (float64 rows, see ``TOUCH_FIELDS``).

    source    : integer id of the touch source (web client, OSC sender, replay), as float.
    t_event   : s, the source's own time stamp (its clock; only differences are used), NaN if none.
    t_arrival : s, engine-clock time at which the sample reached surfhap.
    x, y      : m on the display surface.
    load      : N (0 = finger lifted).
    """

    def __init__(self, capacity: int = 1024):
        self.capacity = power_of_two(int(capacity))
        self._mask = self.capacity - 1
        self.rows = np.zeros((self.capacity, len(TOUCH_FIELDS)))
        self._write = 0  # published rows (monotonic)
        self._read = 0  # consumed rows (monotonic, consumer only)
        self._lock = threading.Lock()
        self.dropped = 0

    def push(self, source: int, t_event: float, t_arrival: float, x: float, y: float, load: float) -> bool:
        """Producer side: append one sample; False (and counted) when the ring is full."""
        with self._lock:
            w = self._write
            if w - self._read >= self.capacity:
                self.dropped += 1
                return False
            self.rows[w & self._mask] = (source, t_event, t_arrival, x, y, load)
            self._write = w + 1  # publish after the row is complete
            return True

    def pop_into(self, out: np.ndarray) -> int:
        """Consumer side: copy up to ``len(out)`` pending rows into ``out``; returns the count.

        Never blocks and never allocates.
        """
        r = self._read
        n = self._write - r
        if n <= 0:
            return 0
        if n > out.shape[0]:
            n = out.shape[0]
        for i in range(n):
            out[i] = self.rows[(r + i) & self._mask]
        self._read = r + n
        return n

    read = property(lambda self: self._read, doc="rows consumed (monotonic)")
    write = property(lambda self: self._write, doc="rows published (monotonic)")

    def consume(self, k: int) -> None:
        """Consumer side: mark the ``k`` rows after ``read`` (copied from ``rows``) as taken."""
        self._read += k

    def clear(self) -> None:
        with self._lock:
            self._read = self._write


class CommandQueue:
    """Bounded queue of typed commands (:mod:`surfhap.runtime.commands`); ``put`` refuses
    (returns False) when full.

    ``get_nowait`` returns None when empty; both never block. ``deque.append`` and
    ``popleft`` are atomic under the GIL.
    """

    def __init__(self, capacity: int = 64):
        self.capacity = int(capacity)
        self._q: deque = deque()
        self.pending = self._q  # read-only for the consumer: true while a command waits
        self._lock = threading.Lock()
        self.dropped = 0

    def put(self, command) -> bool:
        with self._lock:
            if len(self._q) >= self.capacity:
                self.dropped += 1
                return False
            self._q.append(command)
            return True

    def get_nowait(self):
        """The oldest command, or None when the queue is empty (the usual case, without raising)."""
        if not self._q:
            return None
        try:
            return self._q.popleft()
        except IndexError:  # emptied by another consumer between the test and the pop
            return None
