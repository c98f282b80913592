"""The touch page in a real browser: Debian's Chromium driven by Playwright drags over the
page; the server must receive the pointer stream, the drive must change and the trace
must be drawn. A screenshot is kept in test-artifacts/ (gitignored)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from playwright.sync_api import sync_playwright

CHROMIUM = "/usr/bin/chromium"
IN_CI = os.environ.get("CI", "").lower() == "true"
ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"
PATIENCE_MS = 120_000  # bound of every wait on the page (generous: a loaded 2-core machine)
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run"]


def _need(what: str, ok: bool):
    if not ok:
        if IN_CI:
            pytest.fail(f"CI needs {what}")
        pytest.skip(f"{what} not available")


def test_drag_on_page_drives_engine_and_draws_trace():
    _need(f"Chromium at {CHROMIUM} (Debian package chromium)", Path(CHROMIUM).exists() or shutil.which("chromium"))
    from surfhap.live.app import create_app
    from surfhap.live.config import ServerConfig
    from surfhap.live.serverthread import ServerThread
    from surfhap.live.session import build_session

    session = build_session("denim", "sim")
    session.start()
    srv = ServerThread(create_app(session, ServerConfig(port=0)), port=0).start()
    eng = session.engine
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
            try:
                page = browser.new_page(viewport={"width": 900, "height": 700})
                page.goto(srv.url + "/", timeout=PATIENCE_MS)
                page.wait_for_function("window.surfhap && window.surfhap.open", timeout=PATIENCE_MS)
                box = page.locator("#surface").bounding_box()
                assert box and box["width"] > 100
                v_before = eng.trace_since(0)[0][:, 5].max() if eng.trace_count else 0.0
                touches_before = eng.counters["touches"]
                y = box["y"] + box["height"] / 2
                page.mouse.move(box["x"] + 50, y)
                page.mouse.down()
                for k in range(2):  # two strokes, ~0.8 s
                    for i in range(40):
                        f = i / 39 if k % 2 == 0 else 1 - i / 39
                        page.mouse.move(box["x"] + 50 + f * (box["width"] - 100), y + 10 * (k - 1))
                        page.wait_for_timeout(10)
                rows, _ = eng.trace_since(0)
                v_during = rows[:, 5].max()
                # a resting finger keeps the drive on (keep-alive), no watchdog fade
                n_rest = eng.trace_count
                page.wait_for_function("(window.surfhap.keepAlive || 0) >= 5", timeout=PATIENCE_MS)
                for _ in range(1200):  # bounded (60 s): 100 trace rows rendered under the resting finger
                    if eng.trace_count > n_rest + 150:
                        break
                    page.wait_for_timeout(50)
                rest, _ = eng.trace_since(n_rest + 100)
                page.mouse.up()
                page.wait_for_function("window.surfhap.traceFrames > 10 && window.surfhap.tracePointsDrawn > 100",
                                       timeout=PATIENCE_MS)
                page.wait_for_function("window.surfhap.acked >= window.surfhap.sent - 5", timeout=PATIENCE_MS)
                page.wait_for_timeout(300)
                stats = page.evaluate("() => Object.assign({}, window.surfhap)")
                lit = page.evaluate(
                    """() => { const c = document.getElementById('trace');
                               const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
                               let n = 0; for (let i = 0; i < d.length; i += 4) if (d[i] > 150 && d[i+1] > 120) n++;
                               return n; }""")
                ARTIFACTS.mkdir(exist_ok=True)
                page.screenshot(path=str(ARTIFACTS / "live_page.png"))
                latency_text = page.inner_text("#lat")
            finally:
                browser.close()
    finally:
        srv.stop()
        session.stop()
    received = eng.counters["touches"] - touches_before
    assert received >= 70, f"server received only {received} pointer samples"
    assert stats["sent"] >= 70 and stats["acked"] >= stats["sent"] - 5
    assert v_during > 50.0 and v_during > v_before, "the drive did not change"
    assert stats["maxV"] > 50.0
    # 100+ trace rows after the last move, the 50 ms watchdog would have silenced a finger that
    # sends nothing; keep-alive keeps (or brings) the drive on. (Not 'on in every row': a page
    # starved of CPU may send a keep-alive late, and then the watchdog rightly fades the drive.)
    assert stats.get("keepAlive", 0) >= 5 and rest.size and rest[:, 5].max() > 10.0, "the drive faded under a resting finger"
    assert lit > 50, "the trace canvas shows no drive curve"
    assert "ms" in latency_text
    assert (ARTIFACTS / "live_page.png").stat().st_size > 1000
