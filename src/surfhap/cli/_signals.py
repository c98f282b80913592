"""One process guard for every long-running command: SIGINT (Ctrl-C) and SIGTERM (a service
manager, ``kill PID``, a scheduler ending a job) give the same orderly stop.

Within ``with StopSignals() as guard:`` both signals are caught in the main thread; the
first one

* records itself (``guard.stopped``, ``guard.name``) and sets an event the command's main
  loop waits on (``guard.wait(period)`` instead of ``time.sleep``);
* calls ``on_stop`` (e.g. the force-feedback loop's ``request_stop``), never raising;
* interrupts (``KeyboardInterrupt`` in the main thread) only a call made through
  ``guard.call(fn, ...)``, the blocking stretches that cannot poll (a batch waiting on its
  workers, a fit); ``call`` then returns None. Cleanup code (the ramp to zero, flushing a
  recording, writing an index) runs outside such a call, so a signal never cuts it short.

Later signals are ignored while the command shuts down. Both handlers are installed whatever
the inherited disposition (a shell starts a background command with SIGINT ignored) and the
previous ones are restored on exit. Outside the main thread (an embedding app, a test
runner's worker) the guard is inert: ``stopped`` stays False.

After printing its status, the command calls ``guard.finish(message)``: when a signal
stopped it, one line ``error: interrupted: message`` on stderr and exit code 130
(:data:`EXIT_INTERRUPTED`).
"""

from __future__ import annotations

import signal
import threading
from typing import Callable, TypeVar

import typer

from surfhap.cli._common import error_line

__all__ = ["StopSignals", "EXIT_INTERRUPTED", "STOP_SIGNALS"]

EXIT_INTERRUPTED = 130
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
T = TypeVar("T")


class StopSignals:
    """Context manager turning SIGINT/SIGTERM into one orderly stop (see the module doc)."""

    def __init__(self, on_stop: Callable[[], None] | None = None):
        self.on_stop = on_stop
        self.signum: int | None = None
        self._event = threading.Event()
        self._previous: dict[int, object] = {}
        self._raise = 0  # depth of call() stretches

    # ------------------------------------------------------------------ state
    @property
    def stopped(self) -> bool:
        return self.signum is not None

    @property
    def name(self) -> str | None:
        return None if self.signum is None else signal.Signals(self.signum).name

    def __call__(self) -> bool:
        """``stop()`` for code that polls between blocks (True once a signal arrived)."""
        return self.stopped

    def wait(self, timeout: float) -> bool:
        """Sleep up to ``timeout`` s, waking at once on a stop signal; returns ``stopped``."""
        self._event.wait(timeout)
        return self.stopped

    # ---------------------------------------------------------------- handler
    def _handle(self, signum, frame) -> None:
        if self.signum is not None:
            return  # shutting down already: later signals are ignored
        self.signum = signum
        self._event.set()
        if self.on_stop is not None:
            try:
                self.on_stop()
            except Exception:  # noqa: BLE001 - the stop continues through the main loop
                pass
        if self._raise:
            raise KeyboardInterrupt

    def __enter__(self) -> "StopSignals":
        if threading.current_thread() is threading.main_thread():
            self._previous = {sig: signal.signal(sig, self._handle) for sig in STOP_SIGNALS}
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}
        return False

    def call(self, fn: Callable[..., T], *args, **kwargs) -> T | None:
        """``fn(*args, **kwargs)``, interrupted by a stop signal: its result, or None when a
        signal ended it (or had arrived before)."""
        if self.stopped:
            return None
        self._raise += 1
        try:
            return fn(*args, **kwargs)
        except KeyboardInterrupt:
            if not self.stopped:  # not ours (the guard is inert outside the main thread)
                raise
            return None
        finally:
            self._raise -= 1

    # ------------------------------------------------------------------- exit
    def finish(self, message: str) -> None:
        """After the command printed its status: exit 130 with one line when a signal stopped it."""
        if self.stopped:
            error_line(f"interrupted: {message} ({self.name})")
            raise typer.Exit(EXIT_INTERRUPTED)
