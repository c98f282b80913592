"""The study page end to end in Debian's Chromium (Playwright): a short study is answered by
clicking, with a rest screen between blocks and a stimulus played live on the simulated
display; the log must hold every trial once with the clicked answers and response times."""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

import pytest

from live_support.studies import identification_study
from surfhap.lab.triallog import read_log

sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
from browser_support import CHROMIUM, chromium_page, poll  # noqa: E402

PATIENCE_MS = 60_000  # bound of the waits on the page (generous: a loaded 2-core machine)
IN_CI = os.environ.get("CI", "").lower() == "true"


def study_server(runner, player=None, markers=None):
    """The study page of ``runner`` served on 127.0.0.1 (any free port), as 'study run' serves it."""
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    return ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner, player, markers))).start()


def play(page) -> None:
    """Select each stimulus of the trial shown and touch the pad (the answers open after it)."""
    for b in page.locator("button.stim").all():
        b.click()
        box = page.locator("#pad").bounding_box()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)


def opaque(trial, choice_id: str) -> str:
    """The id the page shows for a choice: its position from 1 (blinding, surfhap.lab.blinding)."""
    return str([c.id for c in trial.choices].index(choice_id) + 1)


def _need(what: str, ok: bool):
    if not ok:
        if IN_CI:
            pytest.fail(f"CI needs {what}")
        pytest.skip(f"{what} not available")


def _need_browser():
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        _need("the Python package playwright", False)
    _need(f"Chromium at {CHROMIUM} (Debian package chromium)", Path(CHROMIUM).exists() or shutil.which("chromium"))


def test_short_study_answered_in_chromium(tmp_path):
    _need_browser()
    from surfhap.lab.stimuli import StimulusPlayer
    from surfhap.lab.session import SessionRunner
    from surfhap.live.session import build_session

    study = identification_study(tmp_path, name="page test")
    runner = SessionRunner(study, "P01", mode="page")
    plan = runner.plan.trials
    session = build_session("cork")
    player = StimulusPlayer(session, gain=1.0, v_max=runner.v_max)
    player.mute()
    session.start()
    server = study_server(runner, player=player)
    eng = session.engine
    clicked = []
    try:
        with chromium_page(server.url + "/", 900, 800, PATIENCE_MS) as page:
            for k, trial in enumerate(plan):
                if k == len(plan) // 2:  # block change: the rest screen, then continue
                    page.wait_for_selector("#rest:not([hidden])", timeout=PATIENCE_MS)
                    page.click("#continue")
                poll(page, f"window.study.trialId === {trial.id!r}", PATIENCE_MS)
                assert page.inner_text("#prompt") == trial.prompt
                if k == 0:  # play the stimulus and stroke the pad: the engine gets touches and drives
                    poll(page, "window.study.wsOpen === true", PATIENCE_MS)
                    touches = eng.counters["touches"]
                    page.click("button.stim")
                    box = page.locator("#pad").bounding_box()
                    y = box["y"] + box["height"] / 2
                    page.mouse.move(box["x"] + 30, y)
                    page.mouse.down()
                    for i in range(40):
                        page.mouse.move(box["x"] + 30 + i / 39 * (box["width"] - 60), y)
                        page.wait_for_timeout(10)
                    page.mouse.up()
                    page.wait_for_timeout(200)
                    assert eng.counters["touches"] > touches
                    rows, _ = eng.trace_since(0)
                    assert rows[:, 5].max() > 1.0  # volts were driven for the selected stimulus
                    assert rows[:, 5].max() <= runner.v_max + 1e-9
                else:
                    play(page)
                answer = trial.correct if k % 2 == 0 else [c.id for c in trial.choices if c.id != trial.correct][0]
                page.wait_for_timeout(150)  # a measurable response time
                page.click(f"#choices button[data-choice='{opaque(trial, answer)}']")
                clicked.append((trial.id, answer))
            page.wait_for_selector("#done:not([hidden])", timeout=PATIENCE_MS)
            assert page.evaluate("window.study.answered") == len(plan)
    finally:
        server.stop()
        session.stop()
        runner.close()
    log = read_log(study / "logs" / "P01.jsonl")
    assert [(t["trial_id"], t["answer"]) for t in log.trials] == clicked
    assert all(t["rt_s"] is not None and t["rt_s"] > 0.1 for t in log.trials)
    assert [t["is_correct"] for t in log.trials] == [k % 2 == 0 for k in range(len(plan))]
    assert log.trials[0]["stimuli_touched"] and log.trials[0]["stimuli_touched"][0][0] == 0
    assert [e["event"] for e in log.events] == ["rest", "rest-end", "end"]


def test_a_late_poll_response_does_not_bring_back_an_answered_trial(tmp_path):
    """The page polls /api/state every second. A poll sent just before an answer can be answered
    after it (separate connections): its older state must not re-show the answered trial, which
    would also restart the response-time clock. The test holds one poll's response, answers,
    then releases the held (stale) response."""
    _need_browser()
    from surfhap.lab.session import SessionRunner

    study = identification_study(tmp_path, name="page test")
    runner = SessionRunner(study, "P01", mode="page")
    first, second = runner.plan.trials[0], runner.plan.trials[1]
    server = study_server(runner)
    held = []
    try:
        with chromium_page(server.url + "/", 900, 800, PATIENCE_MS) as page:
            poll(page, f"window.study.trialId === {first.id!r}", PATIENCE_MS)
            # hold the next poll: the server answers it now (the first trial), the page later
            def hold_first(route):
                if held:
                    route.continue_()
                else:
                    held.append((route, route.fetch()))

            page.route("**/api/state", hold_first)
            for _ in range(PATIENCE_MS // 50):
                if held:
                    break
                page.wait_for_timeout(50)
            assert held, "the page sent no poll"
            play(page)
            page.wait_for_timeout(150)
            page.click(f"#choices button[data-choice='{opaque(first, first.correct)}']")
            poll(page, f"window.study.trialId === {second.id!r}", PATIENCE_MS)
            route, stale = held[0]
            assert json.loads(stale.text())["trial"]["id"] == first.id
            route.fulfill(response=stale)
            poll(page, "window.study.staleDropped === 1", PATIENCE_MS)  # the page has handled it
            assert page.evaluate("window.study.trialId") == second.id
            assert page.inner_text("#prompt") == second.prompt
            play(page)
            page.wait_for_timeout(150)
            page.click(f"#choices button[data-choice='{opaque(second, second.correct)}']")
            poll(page, "window.study.answered === 2", PATIENCE_MS)
    finally:
        server.stop()
        runner.close()
    log = read_log(study / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == [first.id, second.id]
    assert all(t["rt_s"] is not None and t["rt_s"] >= 0.15 for t in log.trials)  # at least the waits above


def _in_child(fn, *args):
    """``fn(*args)`` in a spawned process; its return value, or its exception raised here.

    The LSL tests run there: liblsl starts threads of its own (the outlet's servers, an inlet's
    reconnection) whose ends its releases do not always wait for (an outlet destroyed under a
    connected inlet may give up joining them: "did not exit in time"), and a crash of theirs
    at exit must not be taken for, or hide, a fault of this suite's process."""
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply_async(fn, args).get(timeout=600)  # a guard against a hang, not a deadline


def _lsl_session(tmp_path) -> str | None:
    """The page's events through an outlet to an inlet; None, or why LSL cannot run here."""
    import pylsl
    import urllib.request

    from websockets.sync.client import connect

    from surfhap.lab.markers import open_markers
    from surfhap.lab.session import SessionRunner

    def post(url, body):
        req = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=30) as r:
            return json.loads(r.read())

    study = identification_study(tmp_path, name="page test")
    runner = SessionRunner(study, "P01", mode="page")
    markers = open_markers(True, "P01", "page test")
    server = study_server(runner, markers=markers)
    inlet = None
    try:
        streams = pylsl.resolve_byprop("name", "surfhap-P01", timeout=10)
        if not streams:  # LSL's own discovery (UDP multicast/broadcast) is blocked on this host
            return "LSL stream discovery does not work on this host"
        inlet = pylsl.StreamInlet(streams[0])
        inlet.open_stream(timeout=30)
        # an outlet sends only to consumers it has accepted: wait for this inlet, not a fixed time
        assert markers.outlet.wait_for_consumers(30), "the outlet never saw the inlet"
        got = []

        def pull(n):  # the next n markers (bounded wait)
            for _ in range(60):
                if len(got) >= n:
                    return
                sample, _ = inlet.pull_sample(timeout=1.0)
                if sample:
                    got.append(json.loads(sample[0]))

        t = runner.current()
        assert post(server.url + "/api/stimulus", {"trial_id": t.id, "index": 0})["ok"]
        with connect(server.url.replace("http", "ws") + "/ws", origin=server.url) as ws:
            ws.send(json.dumps({"type": "move", "seq": 0, "t": 1.0, "x": 0.5, "y": 0.5, "p": 0.5}))
            ws.send(json.dumps({"type": "up", "seq": 1, "t": 2.0}))
            pull(3)  # the touch reached the server before the answer is sent
        ans = opaque(t, t.correct)  # the marker carries the page's opaque id; the log maps it back
        assert post(server.url + "/api/answer", {"trial_id": t.id, "answer": ans, "rt_ms": 900})["accepted"]
        pull(5)
        assert [g["event"] for g in got] == ["stimulus_on", "touch_down", "touch_up", "stimulus_off", "answer"]
        assert got[-1]["trial"] == t.id and got[-1]["answer"] == ans and got[-1]["rt_s"] == 0.9
    finally:
        server.stop()
        del inlet  # the consumer leaves first: the outlet's end then has no transfer to wait for
        markers.close()
        runner.close()
    return None


def test_lsl_markers_of_stimulus_touch_and_answer(tmp_path):
    """With pylsl (the 'lsl' extra): the page's events arrive at an LSL inlet."""
    why = _in_child(_lsl_session, tmp_path)
    if why:
        pytest.skip(why)


def _push_after_close() -> object:
    from surfhap.lab.markers import open_markers

    markers = open_markers(True, "P02", "closing test")
    markers.push("touch_down")
    markers.close()
    markers.push("touch_up")
    return markers.outlet


def test_a_marker_after_close_is_dropped_not_an_error():
    """A page thread may report an event while the session closes its markers: the push after
    close is a no-op (before: an AttributeError on the closed outlet)."""
    assert _in_child(_push_after_close) is None


def test_cli_study_run_serves_the_page_until_done(tmp_path):
    """'surfhap study run' as a process: the page is answered over HTTP (as the browser does),
    with a live simulated output; the command ends by itself when the last trial is logged."""
    import re
    import subprocess
    import sys
    import threading
    import time
    import urllib.request

    study = identification_study(tmp_path, name="page test")
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())",
                             "study", "run", str(study), "-p", "P01", "--port", "0", "--output", "sim"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stderr.readline, "")), daemon=True)
    reader.start()
    try:
        url = None
        end = time.monotonic() + 120
        while url is None and time.monotonic() < end and proc.poll() is None:
            m = re.search(r"(http://127\.0\.0\.1:\d+)", "".join(lines))
            url = m.group(1) if m else None
            time.sleep(0.1)
        assert url, "".join(lines)

        def call(path, body=None):
            req = urllib.request.Request(url + path, data=None if body is None else json.dumps(body).encode(),
                                         headers={"Content-Type": "application/json"})
            with urllib.request.urlopen(req, timeout=30) as r:
                return json.loads(r.read())

        # the experimenter page's address, printed once with its token (which the log never holds)
        while "token=" not in "".join(lines) and time.monotonic() < end:
            time.sleep(0.05)
        (tok,) = re.findall(r"/experimenter\?token=([\w-]+)", "".join(lines))
        req = urllib.request.Request(url + "/experimenter/api/state", headers={"X-Experimenter-Token": tok})
        with urllib.request.urlopen(req, timeout=30) as r:
            assert json.loads(r.read())["participant"] == "P01"
        answered = 0
        while time.monotonic() < end:
            st = call("/api/state")
            if st["status"] == "done":
                break
            if st["status"] == "rest":
                call("/api/resume", {})
                continue
            t = st["trial"]
            assert call("/api/stimulus", {"trial_id": t["id"], "index": 0})["playing"] != "muted"
            st = call("/api/answer", {"trial_id": t["id"], "answer": t["choices"][0]["id"], "rt_ms": 500})
            answered += st["accepted"]
        assert answered == 4
        assert proc.wait(timeout=60) == 0
        assert tok not in (study / "logs" / "P01.jsonl").read_text()
        reader.join(60)
        assert "last answer" in "".join(lines) and "friction" not in "".join(lines)  # blinded: no condition
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    log = read_log(study / "logs" / "P01.jsonl")
    assert len(log.trials) == 4 and all(t["rt_s"] == 0.5 for t in log.trials)
    assert log.sessions[0]["config"]["mode"] == "page"
