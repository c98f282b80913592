"""Rate-limited logging: one line per kind per second, with the count of what was dropped."""

from __future__ import annotations

import io
import logging

from surfhap.live.logfilter import RateLimitFilter, install_rate_limit


class FakeClock:
    def __init__(self, t: float = 100.0):
        self.t = t

    def __call__(self) -> float:
        return self.t


def make_logger(name: str, filt: logging.Filter) -> tuple[logging.Logger, io.StringIO]:
    buf = io.StringIO()
    handler = logging.StreamHandler(buf)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    handler.addFilter(filt)
    logger = logging.getLogger(name)
    logger.handlers[:] = [handler]
    logger.propagate = False
    logger.setLevel(logging.DEBUG)
    return logger, buf


def test_repeats_within_a_period_are_dropped_and_counted():
    clock = FakeClock()
    filt = RateLimitFilter(1.0, clock=clock)
    logger, buf = make_logger("test.logfilter.repeat", filt)
    for i in range(1000):  # 1000 records within one second, same template, different peers
        clock.t = 100.0 + i * 0.000999
        logger.warning("refused connection from %s:%d", "10.0.0.1", 40000 + i)
    lines = buf.getvalue().splitlines()
    assert lines == ["WARNING test.logfilter.repeat: refused connection from 10.0.0.1:40000"]
    assert filt.suppressed_total == 999
    clock.t = 101.0  # a second after the first: let through, carrying the count
    logger.warning("refused connection from %s:%d", "10.0.0.2", 1)
    lines = buf.getvalue().splitlines()
    assert lines[-1] == "WARNING test.logfilter.repeat: refused connection from 10.0.0.2:1 [999 similar lines suppressed]"
    clock.t = 102.5  # nothing was suppressed since: no count
    logger.warning("refused connection from %s:%d", "10.0.0.3", 2)
    assert buf.getvalue().splitlines()[-1].endswith("10.0.0.3:2")


def test_one_line_per_kind_per_second_over_a_long_flood():
    clock = FakeClock(0.0)
    filt = RateLimitFilter(1.0, clock=clock)
    logger, buf = make_logger("test.logfilter.flood", filt)
    n, seconds = 20000, 10.0
    for i in range(n):  # two kinds interleaved, 10 s of simulated time
        clock.t = seconds * i / n
        logger.warning("rejected message from %s: %s", f"peer{i}", "not JSON")
        logger.error("accept failed: %s", "EMFILE")
    lines = buf.getvalue().splitlines()
    per_kind = {k: [ln for ln in lines if k in ln] for k in ("rejected message", "accept failed")}
    for k, got in per_kind.items():
        assert len(got) == int(seconds), (k, len(got))  # one per simulated second
    # every record is either printed or counted in a printed line (the last second's count
    # is still pending)
    counted = sum(int(ln.rsplit("[", 1)[1].split()[0]) for ln in lines if "suppressed]" in ln)
    pending = sum(s[1] for s in filt._kinds.values())
    assert len(lines) + counted + pending == 2 * n


def test_kinds_are_told_apart_by_logger_level_template_and_exception():
    clock = FakeClock()
    filt = RateLimitFilter(1.0, clock=clock)
    logger, buf = make_logger("test.logfilter.kinds", filt)
    other, obuf = make_logger("test.logfilter.kinds2", filt)
    logger.warning("a %s", 1)
    logger.warning("a %s", 2)  # same kind: dropped
    logger.error("a %s", 3)  # other level
    logger.warning("b %s", 4)  # other template
    other.warning("a %s", 5)  # other logger
    for exc in (OSError("x"), ValueError("y"), OSError("z")):
        try:
            raise exc
        except Exception:
            logger.exception("failed")
    text = buf.getvalue()
    assert "a 1" in text and "a 2" not in text and "a 3" in text and "b 4" in text and "a 5" in obuf.getvalue()
    assert text.count("failed") == 2 and "OSError: x" in text and "ValueError: y" in text and "OSError: z" not in text


def test_memory_is_bounded_by_max_kinds():
    clock = FakeClock()
    filt = RateLimitFilter(1.0, clock=clock, max_kinds=32)
    logger, buf = make_logger("test.logfilter.bounded", filt)
    for i in range(5000):
        logger.warning(f"template {i} %s", i)  # ever-new templates
    assert len(filt._kinds) == 32
    assert len(buf.getvalue().splitlines()) == 5000  # each is a new kind: none dropped


def test_install_attaches_one_filter_to_each_handler():
    logger = logging.getLogger("test.logfilter.install")
    h1, h2 = logging.StreamHandler(io.StringIO()), logging.StreamHandler(io.StringIO())
    logger.handlers[:] = [h1, h2]
    try:
        f = install_rate_limit(logger)
        install_rate_limit(logger)  # idempotent
        assert h1.filters == [f] and h2.filters == [f]
    finally:
        logger.handlers[:] = []
