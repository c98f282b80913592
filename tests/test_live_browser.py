"""The touch page in a real browser: Debian's Chromium driven by Playwright drags over the
page; the server must receive the pointer stream, the drive must change and the trace
must be drawn. A screenshot is kept in test-artifacts/ (gitignored)."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import playwright.sync_api  # noqa: F401  (the dev extra: a broken install fails, it does not skip)

sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
from browser_support import CHROMIUM, chromium_page, poll, start_ff_buttons_page  # noqa: E402

IN_CI = os.environ.get("CI", "").lower() == "true"
ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"
PATIENCE_MS = 120_000  # bound of every wait on the page (generous: a loaded 2-core machine)


def _need(what: str, ok: bool):
    if not ok:
        if IN_CI:
            pytest.fail(f"CI needs {what}")
        pytest.skip(f"{what} not available")


def test_drag_on_page_drives_engine_and_draws_trace():
    _need(f"Chromium at {CHROMIUM} (Debian package chromium)", Path(CHROMIUM).exists() or shutil.which("chromium"))
    from surfhap.web import create_app
    from surfhap.live.config import ServerConfig
    from surfhap.web.server import ServerThread
    from surfhap.live.session import build_session

    session = build_session("denim")
    session.start()
    srv = ServerThread(create_app(ServerConfig(port=0), touch=session), port=0).start()
    eng = session.engine
    try:
        with chromium_page(srv.url + "/", 900, 700, PATIENCE_MS) as page:
            _poll(page, "window.surfhap && window.surfhap.open")
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
            _poll(page, "(window.surfhap.keepAlive || 0) >= 5")
            for _ in range(1200):  # bounded (60 s): 100 trace rows rendered under the resting finger
                if eng.trace_count > n_rest + 150:
                    break
                page.wait_for_timeout(50)
            rest, _ = eng.trace_since(n_rest + 100)
            page.mouse.up()
            _poll(page, "window.surfhap.traceFrames > 10 && window.surfhap.tracePointsDrawn > 100")
            _poll(page, "window.surfhap.acked >= window.surfhap.sent - 5")
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


def _poll(page, expr: str) -> None:
    """Wait (bounded by PATIENCE_MS) until the JS expression is true (live_support/browser_support.py)."""
    poll(page, expr, PATIENCE_MS)


def test_page_sends_one_move_per_animation_frame():
    """Pointer events faster than the display (a pen, a 240 Hz digitiser): 50 moves dispatched
    in one task are one message, the newest position, sent on the next animation frame."""
    _need(f"Chromium at {CHROMIUM} (Debian package chromium)", Path(CHROMIUM).exists() or shutil.which("chromium"))
    from surfhap.web import create_app
    from surfhap.live.config import ServerConfig
    from surfhap.web.server import ServerThread
    from surfhap.live.session import build_session

    session = build_session("cork")
    session.start()
    srv = ServerThread(create_app(ServerConfig(port=0), touch=session), port=0).start()
    try:
        with chromium_page(srv.url + "/", 900, 700, PATIENCE_MS) as page:
            _poll(page, "window.surfhap && window.surfhap.open")
            in_task = page.evaluate("""() => {
                const s = document.getElementById('surface'), r = s.getBoundingClientRect(), st = window.surfhap;
                const sent0 = st.sent;
                for (let i = 0; i < 50; i++)
                    s.dispatchEvent(new PointerEvent('pointermove', {buttons: 1, clientX: r.left + 10 + i,
                                                                     clientY: r.top + r.height / 2, pressure: 0.5}));
                return st.sent - sent0; }""")
            _poll(page, "window.surfhap.sent >= 1 && window.surfhap.acked >= 0")
            stats = page.evaluate("() => Object.assign({}, window.surfhap)")
            page.evaluate("() => document.getElementById('surface').dispatchEvent(new PointerEvent('pointerup'))")
    finally:
        srv.stop()
        session.stop()
    assert in_task == 0, "moves sent within the events' task, not on the animation frame"
    assert stats["coalesced"] == 49

def test_ff_page_panel_shows_device_position_force_and_button_press():
    """`ff run SCENE --touch web`: the page's force-feedback panel (values read from the DOM)
    shows the force of the loop and a device position that moves under the dragging finger,
    and the GUI button pressed under it."""
    _need(f"Chromium at {CHROMIUM} (Debian package chromium)", Path(CHROMIUM).exists() or shutil.which("chromium"))
    import json

    from surfhap.ff import FALCON

    sc, loop, srv = start_ff_buttons_page()
    w, h = sc.size
    easy = sc.buttons[0]
    weight = FALCON.moving_mass * 9.81  # N
    samples = []

    def panel(page):
        return page.evaluate("""() => ({pos: document.getElementById('ff-pos').dataset.m,
            flat: document.getElementById('ff-flat').dataset.n, fz: document.getElementById('ff-fz').dataset.n,
            posText: document.getElementById('ff-pos').textContent, fzText: document.getElementById('ff-fz').textContent,
            effects: document.getElementById('ff-effects').textContent,
            button: document.getElementById('ff-button').dataset.index,
            buttonText: (document.querySelector('#ff-button .btn.pressed') || {textContent: '–'}).textContent,
            hidden: document.getElementById('ffpanel').hidden})""")

    try:
        with chromium_page(srv.url + "/", 900, 800, PATIENCE_MS) as page:
            _poll(page, "window.surfhap && window.surfhap.open && window.surfhap.ff && window.surfhap.ff.frames > 5")
            # untouched, once the start-up transient has settled: the weight compensation alone
            _poll(page, f"Math.abs(Number(document.getElementById('ff-fz').dataset.n) - {weight}) < 0.2")
            idle = panel(page)
            box = page.locator("#surface").bounding_box()
            y = box["y"] + box["height"] * (easy.y0 + easy.y1) / 2 / h
            x_easy = box["x"] + box["width"] * (easy.x0 + easy.x1) / 2 / w
            page.mouse.move(box["x"] + 0.02 * box["width"], y)
            page.mouse.down()
            for i in range(60):  # drag along the row of buttons and back
                f = i / 59
                x = box["x"] + box["width"] * (0.02 + 0.9 * (1 - abs(2 * f - 1)))
                page.mouse.move(x, y)
                page.wait_for_timeout(25)
                samples.append(panel(page))
            page.mouse.up()  # lift, then push on the easy button (a landing touch arms it)
            page.mouse.move(x_easy, y)
            page.mouse.down()
            _poll(page, "document.getElementById('ff-button').dataset.index === '0'")
            pressed = panel(page)
            _poll(page, "JSON.parse(document.getElementById('ff-pos').dataset.m)[2] < -3e-3")
            settled = panel(page)
            ARTIFACTS.mkdir(exist_ok=True)
            page.screenshot(path=str(ARTIFACTS / "ff_page.png"))
            page.mouse.up()
            _poll(page, "document.getElementById('ff-button').dataset.index === '-1'")
            released = panel(page)
    finally:
        srv.stop()
        loop.stop()
    assert loop.error is None and not idle["hidden"]
    pos = np.array([json.loads(s["pos"]) for s in samples])
    fz = np.array([float(s["fz"]) for s in samples])
    assert pos.shape == (60, 3)
    assert abs(float(idle["fz"]) - weight) < 0.2  # untouched: the weight compensation alone, N
    assert np.ptp(pos[:, 2]) > 0.5e-3, "the device position did not move under the finger"
    assert np.min(pos[:, 2]) < -1e-3 and fz.max() > weight + 0.3, "no push on the screen shown"
    # metres, and inside the simulated device's end stops. Not the 40 mm workspace: when the
    # 1 kHz loop is starved (two test suites and Chromium on 2 cores), the simulated device
    # runs on under the last force for up to 50 ms and may pass the software wall for a moment.
    # The wall itself is tests/test_ff_safety.py's.
    assert np.all(np.abs(pos) <= np.array(loop.backend.device.stops) + 1e-9)
    assert "mm" in pressed["posText"] and pressed["fzText"].endswith(" N")
    assert pressed["effects"] == "stiffness" and pressed["buttonText"] == "easy"
    # shown pressed: the screen is below the release depth (the press itself, past the click depth,
    # is tests/test_ff_buttons.py's; the first frame the page shows pressed may come a few ticks
    # after it, once a starved loop let the screen spring back a little, still pressed)
    assert json.loads(pressed["pos"])[2] < -easy.release_depth_m + 1e-4
    # 0.5 N on the 100 N/m button: about -5 mm, still pressed
    assert json.loads(settled["pos"])[2] < -3e-3 and settled["buttonText"] == "easy"
    assert released["buttonText"] == "–"
