"""Waiting on a page in the browser tests (Playwright, sync API).

The pages' Content-Security-Policy (``default-src 'self'``) forbids ``eval``. Playwright's
``page.wait_for_function(expression)`` evaluates a string expression with ``eval`` once its first
check has failed, so on a loaded machine (first check too early) it raises a CSP error instead
of waiting. :func:`poll` evaluates a function through the DevTools protocol instead, which the
policy does not cover.
"""

from __future__ import annotations


def poll(page, expr: str, timeout_ms: int, every_ms: int = 50) -> None:
    """Return when the JavaScript expression ``expr`` is truthy on ``page``; raise
    AssertionError naming it after ``timeout_ms``."""
    for _ in range(max(1, timeout_ms // every_ms)):
        if page.evaluate(f"() => !!({expr})"):
            return
        page.wait_for_timeout(every_ms)
    raise AssertionError(f"timed out after {timeout_ms} ms waiting for {expr}")
