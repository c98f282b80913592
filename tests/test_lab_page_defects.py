"""The study page in Debian's Chromium (Playwright) at a 1024 x 600 tablet and a 1920 x 1080
screen (issue 18 item 7): the scene page fits without scrolling (Next visible and clickable),
a look-only trial shows nothing to play, and no answer can be given before every stimulus was
played (touched on the pad; a real sample: clicked). Then paper 004's protocol on the page
and the force-feedback loop: each stimulus 3.5 s from the first touch, the screen black until
the finger is lifted, the next stimulus after it. Screenshots go to the test's tmp dir."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import pytest

from surfhap.lab.designs import build_study, template
from surfhap.lab.session import SessionRunner

sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
from browser_support import chromium_page, poll  # noqa: E402
from test_lab_page import PATIENCE_MS, _need_browser, opaque, study_server  # noqa: E402

VIEWPORTS = [(1024, 600), (1920, 1080)]


def _study(tmp_path: Path, name: str, **params) -> Path:
    d = template(name, seed=2, participants=2)
    if params:
        d = d.model_validate({**d.model_dump(), "params": params})
    folder = tmp_path / name
    (folder / "logs").mkdir(parents=True)
    (folder / "study.json").write_text(json.dumps(build_study(d).model_dump(mode="json")))
    return folder


def _stroke(page, hold_ms: int = 0, release: bool = True) -> None:
    """A finger (the mouse) down on the pad, slid across it, held ``hold_ms``, lifted."""
    box = page.locator("#pad").bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + 20, y)
    page.mouse.down()
    for i in range(10):
        page.mouse.move(box["x"] + 20 + i / 9 * (box["width"] - 40), y)
    if hold_ms:
        page.wait_for_timeout(hold_ms)
    if release:
        page.mouse.up()


def _reachable(page, selector: str, width: int, height: int) -> dict:
    """``selector``'s box, asserted inside the viewport with nothing over its centre and the
    page not scrollable (clickable where it is, without scrolling)."""
    box = page.locator(selector).bounding_box()
    assert box is not None, f"{selector} is not laid out"
    assert box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= width and box["y"] + box["height"] <= height, \
        (selector, box, (width, height))
    assert page.evaluate("document.scrollingElement.scrollHeight <= window.innerHeight")
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    assert page.evaluate(f"document.elementFromPoint({cx}, {cy}) === document.querySelector({selector!r})")
    return {"x": cx, "y": cy}


def _picture_loaded(page) -> None:
    """Wait until the pad's picture can be drawn (loaded once more by the test), then a frame."""
    assert page.evaluate("""async () => {
        const url = getComputedStyle(document.getElementById("pad")).backgroundImage.slice(5, -2);
        const img = new Image(); img.src = url; await img.decode(); return true; }""")
    page.wait_for_timeout(300)


def _wait(cond, timeout_s: float = PATIENCE_MS / 1000) -> None:
    end = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.01)


def _disabled(page, selector: str) -> list[bool]:
    return page.eval_on_selector_all(selector, "els => els.map(e => e.disabled)")


@pytest.mark.parametrize("width,height", VIEWPORTS)
def test_scene_trials_fit_and_wait_for_a_touch(tmp_path, width, height):
    _need_browser()
    study = _study(tmp_path, "kim-scenes")
    # P01 (group G1) starts with the touched scenes (V+H), P02 with the look-only ones (V)
    for pid, task in (("P01", "V+H"), ("P02", "V")):
        runner = SessionRunner(study, pid, mode="page")
        trial = runner.current()
        assert trial.condition["task"] == task
        server = study_server(runner)
        try:
            with chromium_page(server.url + "/", width, height, PATIENCE_MS) as page:
                poll(page, f"window.study.trialId === {trial.id!r}", PATIENCE_MS)
                _picture_loaded(page)
                page.screenshot(path=str(tmp_path / f"{pid}-{task}-{width}x{height}.png"))
                toggles = "#toggles button"
                if task == "V":  # look only: nothing to play, the answers are open at once
                    assert not page.locator("button.stim").is_visible()
                    assert not page.locator("#stimuli-caption").is_visible()
                    assert not any(_disabled(page, toggles))
                else:  # nothing can be answered before the scene was touched
                    assert page.locator("button.stim").is_visible()
                    assert all(_disabled(page, toggles)) and all(_disabled(page, "#submit"))
                    page.click("button.stim")
                    assert all(_disabled(page, toggles))  # selected but not touched yet
                    _stroke(page)
                    poll(page, "window.study.answerable === true", PATIENCE_MS)
                    assert not any(_disabled(page, toggles))
                for pos in trial.toggles:
                    page.click(f"#toggles button[data-pos='{pos}']")
                centre = _reachable(page, "#submit", width, height)
                page.screenshot(path=str(tmp_path / f"{pid}-{task}-{width}x{height}-answered.png"))
                poll(page, "!document.querySelector('#submit').disabled", PATIENCE_MS)
                page.mouse.click(centre["x"], centre["y"])  # where it is: no scrolling
                poll(page, "window.study.answered === 1", PATIENCE_MS)
        finally:
            server.stop()
            runner.close()
        assert runner.n_done == 1


def test_choices_wait_for_every_stimulus(tmp_path):
    """A 3AFC trial: the answers open only once each of the three stimuli was touched."""
    _need_browser()
    study = _study(tmp_path, "otake2021-3afc")
    runner = SessionRunner(study, "P01", mode="page")
    trial = runner.current()
    server = study_server(runner)
    try:
        with chromium_page(server.url + "/", 1024, 600, PATIENCE_MS) as page:
            poll(page, f"window.study.trialId === {trial.id!r}", PATIENCE_MS)
            choices = "#choices button"
            assert len(_disabled(page, choices)) == 3 and all(_disabled(page, choices))
            _stroke(page)  # touching the pad with no stimulus selected plays nothing
            for i in range(3):
                assert all(_disabled(page, choices)), f"open after {i} of 3 stimuli"
                page.click(f"button.stim[data-index='{i}']")
                _stroke(page)
            poll(page, "window.study.answerable === true", PATIENCE_MS)
            assert not any(_disabled(page, choices))
            _reachable(page, f"#choices button[data-choice='{opaque(trial, trial.correct)}']", 1024, 600)
            page.screenshot(path=str(tmp_path / "3afc-1024x600.png"))
            page.click(f"#choices button[data-choice='{opaque(trial, trial.correct)}']")
            poll(page, "window.study.answered === 1", PATIENCE_MS)
    finally:
        server.stop()
        runner.close()


def test_004_timed_stimuli_black_until_release_on_the_ff_loop(tmp_path):
    """004 Sec. 5.2 on the page with the force-feedback loop running (wall clock, simulated
    device): stimulus 1 plays from the first touch for 3.5 s, then the screen is black until
    the finger is lifted; then stimulus 2; only then the question."""
    _need_browser()
    from surfhap.lab.stimuli import FFStimulusPlayer, FFStudySession

    study = _study(tmp_path, "kinestouch-sliding", repetitions=1)
    runner = SessionRunner(study, "P01", mode="page")
    trial = runner.current()
    assert trial.practice and runner.limit_s == 3.5
    player = FFStimulusPlayer(FFStudySession(), limit_s=runner.limit_s)
    player.mute()
    player.session.start()
    server = study_server(runner, player=player)
    eng = player.session.engine
    try:
        with chromium_page(server.url + "/", 1024, 600, PATIENCE_MS) as page:
            poll(page, f"window.study.trialId === {trial.id!r} && window.study.wsOpen === true", PATIENCE_MS)
            choices = "#choices button"
            for i, stim in enumerate(trial.stimuli):
                poll(page, f"window.study.selected === {i}", PATIENCE_MS)  # played in order, by itself
                assert all(_disabled(page, choices))
                assert _disabled(page, "button.stim") == [True, True]  # no skipping ahead
                effects = {e.name for e in player.session.effects[stim.render["effect"]]}
                seen = set()
                _stroke(page, release=False)
                box = page.locator("#pad").bounding_box()
                for k in range(PATIENCE_MS // 50):  # keep stroking until the screen turns black
                    if page.evaluate("window.study.blank"):
                        break
                    page.mouse.move(box["x"] + box["width"] * (0.5 + 0.15 * math.sin(0.3 * k)), box["y"] + box["height"] / 2)
                    seen |= {e.name for b, e in enumerate(eng.effects) if eng.mask >> b & 1}
                    page.wait_for_timeout(50)
                assert page.locator("#blank").is_visible()
                page.screenshot(path=str(tmp_path / f"004-blank-{i}.png"))
                _wait(lambda: eng.effects == [] and eng.mask == 0)  # the stimulus is over at the device too
                assert seen == effects, (stim.render, seen)  # its effect played under the finger
                assert page.locator("#blank").is_visible()  # black while the finger stays down
                page.mouse.up()
                poll(page, "window.study.blank === false", PATIENCE_MS)
            poll(page, "window.study.answerable === true", PATIENCE_MS)
            page.click("#choices button[data-choice='1']")
            poll(page, "window.study.answered === 1", PATIENCE_MS)
    finally:
        server.stop()
        player.session.stop()
        runner.close()
    st = player.session.loop.stats()
    assert st["error"] is None and st["touches_received"] > 0
    rec = runner.log.path.read_text().splitlines()
    assert json.loads(rec[-1])["practice"] is True
