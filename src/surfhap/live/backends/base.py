"""The base of the output backends (the typed ``--output`` specs and the factory are in
:mod:`surfhap.live.backends.output`).

A backend is a :class:`surfhap.runtime.protocols.Sink` that owns the clock: ``start(engine)``
returns at once and calls ``engine.render(frames, now)`` once per block, sending the volts
somewhere; ``stop(timeout)`` asks the engine for its ramp to zero, waits for it (bounded), then
stops calling and releases the device; ``drive_rate`` is the rate it needs (``None`` = the engine's).

A backend that fails is never left holding its last sample silently: an exception in its
output thread or callback, or no block for ``stall_timeout`` seconds (:class:`StallWatch`),
calls ``engine.fail(reason)``. The engine then renders 0 V for every later block, the
reason shows in ``engine.status()["failure"]`` (and on the page), and the CLI exits with
code 3. The paced thread emits one block of 0 V after an exception and ends.
"""

from __future__ import annotations

import logging
import threading
import time

import numpy as np

from surfhap.errors import ConfigError
from surfhap.runtime.clock import Clock, WallClock, now
from surfhap.runtime.loop import run

__all__ = ["PacedBackend", "StallWatch", "STALL_TIMEOUT", "ramp_down"]

# s without a rendered block before a running backend counts as stalled. A choice: long
# enough that a loaded machine's scheduling hiccups (tens of ms) never trip it, short
# enough that a hung output is reported (and the engine halted) within a second.
STALL_TIMEOUT = 1.0

log = logging.getLogger("surfhap.live")


class StallWatch:
    """Thread that reports a backend stall: no new block (``engine.counters['blocks']``)
    for ``timeout`` seconds while the backend runs -> ``engine.fail(...)`` (the engine
    renders 0 V from then on) and ``on_stall()`` of the backend, once."""

    def __init__(self, engine, name: str, timeout: float = STALL_TIMEOUT, on_stall=None):
        if not (timeout > 0 and timeout < 3600):
            raise ConfigError("must be within 0-3600 s", field="stall_timeout")
        self.engine, self.name, self.timeout, self.on_stall = engine, name, float(timeout), on_stall
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=f"surfhap-{name}-watch", daemon=True)

    def start(self) -> "StallWatch":
        self._thread.start()
        return self

    def _loop(self) -> None:
        eng = self.engine
        poll = min(0.05, self.timeout / 4)
        last, t_last = eng.counters["blocks"], now()
        while not self._stop.wait(poll):
            b = eng.counters["blocks"]
            t = now()
            if b != last:
                last, t_last = b, t
            elif t - t_last > self.timeout:
                eng.fail(f"{self.name} output stalled: no block for {1e3 * (t - t_last):.0f} ms")
                log.error("%s output stalled: the engine is halted (0 V)", self.name)
                if self.on_stall is not None:
                    try:
                        self.on_stall()
                    except Exception:  # noqa: BLE001 - best effort on a hung device
                        log.exception("could not abort the stalled %s output", self.name)
                return

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(1.0)


def ramp_down(engine, timeout: float) -> None:
    """Ask ``engine`` for its stop ramp and wait until it has run (or the engine halted),
    at most ``timeout`` s: what every backend's ``stop`` does before releasing its output."""
    engine.request_stop()
    end = time.monotonic() + timeout
    while not engine.stopped and not engine.halted and time.monotonic() < end:
        time.sleep(0.002)


class PacedBackend:
    """Calls the engine from its own thread through :func:`surfhap.runtime.loop.run`, one block
    per block period, buffered by ``buffer`` s like a sound card (a later block is an underrun
    and the schedule re-anchors; ``now`` is the actual render time, so the engine's latency
    figures exclude the buffer). Subclasses override :meth:`emit` (each block of volts, same
    thread); an output with its own device clock sets ``paced_by_device``."""

    name = "paced"
    drive_rate: int | None = None
    buffer: float = 0.005
    paced_by_device = False  # True: the device's buffer paces the blocks (no simulated clock)

    def __init__(self, stall_timeout: float = STALL_TIMEOUT):
        self._thread: threading.Thread | None = None
        self._run = False
        self.engine = None
        self.stall_timeout = float(stall_timeout)
        self._watch: StallWatch | None = None
        self.error: str | None = None
        self.clock: Clock = WallClock()  # what paces the blocks (a SimClock runs them as fast as possible)

    def open(self, engine) -> None:
        """Bind to ``engine`` and prepare the output (no thread; what :meth:`start` and a
        simulated run do first)."""
        self.engine = engine

    def start(self, engine) -> None:
        if self._thread is not None:
            raise RuntimeError("backend already started")
        self.open(engine)
        self._run = True
        self._thread = threading.Thread(target=self._loop, name=f"surfhap-{self.name}", daemon=True)
        self._thread.start()
        self._watch = StallWatch(engine, self.name, self.stall_timeout, on_stall=self.abort).start()

    def _loop(self) -> None:
        eng = self.engine
        try:
            run(None, eng, self.clock, self, keep_running=lambda: self._run, buffer=self.buffer)
        except Exception as exc:  # noqa: BLE001 - reported, never silent
            self.error = f"{self.name} output failed: {type(exc).__name__}: {exc}"
            eng.fail(self.error)
            log.error("%s; the engine is halted (0 V)", self.error)
            try:
                self.emit(np.zeros(eng.block_frames))  # best effort: leave the output at 0 V
            except Exception:  # noqa: BLE001
                pass

    def emit(self, volts) -> None:  # pragma: no cover - overridden
        pass

    def live(self) -> bool:
        """The output is running (its thread, or a device stream of a subclass)."""
        return self._thread is not None and self._thread.is_alive()

    def stop(self, timeout: float = 1.0) -> None:
        """Ramp a running output to zero (:func:`ramp_down`, then :meth:`drained`; the stall
        watch still reports a hung output meanwhile), stop the thread and :meth:`close` the output."""
        eng = self.engine
        if eng is not None and self.live():
            if not eng.halted:
                ramp_down(eng, timeout)
            self.drained(timeout)
        if self._watch is not None:
            self._watch.stop()
            self._watch = None
        self._run = False
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        self.close()

    def drained(self, timeout: float) -> None:
        """Wait (at most ``timeout`` s) until the device has output what was emitted (a
        device with its own buffer)."""

    def close(self) -> None:
        pass

    def abort(self) -> None:
        """Called once by the stall watch (the engine is already halted): release a hung device."""

    def info(self) -> dict:
        return {"name": self.name}
