"""Debian's Chromium driven by Playwright (sync API) for the browser tests.

:func:`chromium_page` opens one page on a URL and closes the browser afterwards. :func:`poll`
waits on the page. The pages' Content-Security-Policy (``default-src 'self'``) forbids ``eval``;
Playwright's ``page.wait_for_function(expression)`` evaluates a string expression with ``eval``
once its first check has failed, so on a loaded machine (first check too early) it raises a CSP
error instead of waiting. :func:`poll` evaluates a function through the DevTools protocol
instead, which the policy does not cover.
"""

from __future__ import annotations

import contextlib

CHROMIUM = "/usr/bin/chromium"  # the Debian package; never `playwright install`
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run"]


@contextlib.contextmanager
def chromium_page(url: str, width: int, height: int, timeout_ms: int):
    """A headless Chromium page of ``width`` x ``height`` CSS px, loaded from ``url``."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(url, timeout=timeout_ms)
            yield page
        finally:
            browser.close()


def poll(page, expr: str, timeout_ms: int, every_ms: int = 50) -> None:
    """Return when the JavaScript expression ``expr`` is truthy on ``page``; raise
    AssertionError naming it after ``timeout_ms``."""
    for _ in range(max(1, timeout_ms // every_ms)):
        if page.evaluate(f"() => !!({expr})"):
            return
        page.wait_for_timeout(every_ms)
    raise AssertionError(f"timed out after {timeout_ms} ms waiting for {expr}")



def start_ff_buttons_page():
    """The force-feedback page of the "buttons" scene on the simulated Falcon (as ``ff run buttons
    --touch web``), started: ``(scene, loop, server)``; stop the server, then the loop."""
    from surfhap.ff import FALCON, FFEngine
    from surfhap.ff.scene import load_scene
    from surfhap.live.config import ServerConfig
    from surfhap.live.ff_devices import SimDeviceBackend
    from surfhap.live.ff_loop import FFLoop
    from surfhap.render.kinematics import TouchPredictor
    from surfhap.sim.ff_device import SimDevice
    from surfhap.web import create_app
    from surfhap.web.ff import build_ff_session
    from surfhap.web.server import ServerThread

    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0, buttons=sc.buttons)
    loop = FFLoop(eng, SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain))
    session = build_ff_session(sc, loop, max(FALCON.f_max))
    loop.feedback = lambda t, px, py, pz, dx, dy, fx, fy, fz: session.engine.record(t, px, py, pz, fx, fy, fz)
    srv = ServerThread(create_app(ServerConfig(port=0), touch=session), port=0).start()
    loop.start()
    return sc, loop, srv
