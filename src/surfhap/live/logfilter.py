"""Rate-limit repeated log lines: at most one record per kind per period.

A hostile client can make a server log the same complaint many thousand times a second
(a flood of half-open connections once filled 439 MB of log with ``socket.accept()``
tracebacks). :class:`RateLimitFilter` lets the first record of each *kind* through, drops
the repeats for ``period`` seconds and counts them; the next record of that kind that is
let through carries the count (``[1234 similar lines suppressed]``).

A kind is the logger name, the level, the unformatted message template and the type of
the attached exception, so ``"rejected message from %s: %s"`` is one kind whatever peer
and reason fill it in. Attach the filter to *handlers* (a logger's own filters do not see
records propagated from child loggers): :func:`install_rate_limit`.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict

__all__ = ["RateLimitFilter", "install_rate_limit", "configure_logging"]


class RateLimitFilter(logging.Filter):
    """Let through one record per kind per ``period`` s; count and report the rest.

    period    : s between two records of one kind (1 s: one line per kind per second).
    clock     : monotonic time source in s (injectable for tests).
    max_kinds : kinds remembered (least recently seen forgotten first), so a stream of
                ever-new message templates cannot grow memory without bound.
    """

    def __init__(self, period: float = 1.0, clock=time.monotonic, max_kinds: int = 512):
        super().__init__()
        self.period = float(period)
        self.clock = clock
        self.max_kinds = int(max_kinds)
        self.suppressed_total = 0
        self._kinds: OrderedDict[tuple, list] = OrderedDict()  # kind -> [last let through, suppressed since]
        self._lock = threading.Lock()

    @staticmethod
    def kind(record: logging.LogRecord) -> tuple:
        exc = record.exc_info[0].__name__ if record.exc_info and record.exc_info[0] else None
        msg = record.msg if isinstance(record.msg, str) else type(record.msg).__name__
        return (record.name, record.levelno, msg, exc)

    def filter(self, record: logging.LogRecord) -> bool:
        key = self.kind(record)
        t = self.clock()
        with self._lock:
            state = self._kinds.get(key)
            if state is not None and t - state[0] < self.period:
                state[1] += 1
                self.suppressed_total += 1
                self._kinds.move_to_end(key)
                return False
            suppressed = state[1] if state is not None else 0
            self._kinds[key] = [t, 0]
            self._kinds.move_to_end(key)
            while len(self._kinds) > self.max_kinds:
                self._kinds.popitem(last=False)
        if suppressed:
            # fold the arguments in, so the added text cannot disturb %-formatting
            record.msg = f"{record.getMessage()} [{suppressed} similar lines suppressed]"
            record.args = None
        return True


def install_rate_limit(logger: logging.Logger | None = None, period: float = 1.0) -> RateLimitFilter:
    """Attach one :class:`RateLimitFilter` to every handler of ``logger`` (default: the
    root logger); a handler that already has one keeps it. Returns the filter."""
    logger = logger if logger is not None else logging.getLogger()
    filt = RateLimitFilter(period)
    for h in logger.handlers:
        if not any(isinstance(f, RateLimitFilter) for f in h.filters):
            h.addFilter(filt)
    return filt


def configure_logging(verbose: bool = False) -> None:
    """Logging of a long-running command: when the caller has not configured logging (no
    root handler, as in an embedding app or a test), one stderr handler at WARNING (INFO
    when ``verbose``) with :func:`install_rate_limit` on it, so whatever a client provokes
    gives at most one line per kind per second."""
    root = logging.getLogger()
    if not root.handlers:
        logging.basicConfig(level=logging.INFO if verbose else logging.WARNING,
                            format="%(asctime)s %(levelname)s %(name)s: %(message)s")
        install_rate_limit(root)
