"""The experimenter's page of ``study run`` (issue 18 item 3): token-guarded API (403 on a wrong
or missing token, the token nowhere in the participant's page or the log), pause (the
participant's page shows "paused" and the drive reaching the output falls to 0 V through the
engine's safety stage), resume, skip (logged, never analysed) and notes (timestamped log
events); and training with feedback (003 Sec. III-B)."""

from __future__ import annotations

import http.client
import json
import threading
from urllib.parse import quote

import numpy as np

from live_support.studies import identification_study
from surfhap.cli import main
from surfhap.lab.triallog import read_log

PATIENCE = 60.0  # s: bound of every wait (a loaded 2-core machine), never a measured duration


def call(port, method, path, body=None, token=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=PATIENCE)
    try:
        headers = {"Content-Type": "application/json"}
        if token is not None:
            headers["X-Experimenter-Token"] = token
        c.request(method, path, body=None if body is None else json.dumps(body), headers=headers)
        r = c.getresponse()
        data, kind = r.read(), r.getheader("content-type", "")
        return r.status, (json.loads(data) if kind.startswith("application/json") else
                          data.decode() if kind.startswith("text/") else data)
    finally:
        c.close()


def serve(runner, player=None):
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    page = StudyPage(runner, player)
    return page, ServerThread(create_app(ServerConfig(port=0), study=page)).start()


def test_the_token_guards_every_route_and_reaches_neither_page_nor_log(tmp_path):
    from surfhap.lab.session import SessionRunner

    study = identification_study(tmp_path)
    runner = SessionRunner(study, "P01", mode="page")
    page, server = serve(runner)
    tok, port = page.experimenter_token, server.port
    served = []
    try:
        assert len(tok) >= 32
        for bad in (None, "", tok[:-1], tok + "x", "é" * 8):
            q = "" if bad is None else f"?token={quote(bad)}"
            assert call(port, "GET", "/experimenter" + q)[0] == 403, bad
            for method, path, body in (("GET", "state", None), ("POST", "pause", None), ("POST", "resume", None),
                                       ("POST", "skip", {"trial_id": runner.current().id}),
                                       ("POST", "note", {"text": "x"})):
                assert call(port, method, f"/experimenter/api/{path}", body, token=bad)[0] == 403, (bad, path)
        assert runner.current().id == runner.plan.trials[0].id and not runner.paused  # nothing happened
        status, html = call(port, "GET", f"/experimenter?token={tok}")
        assert status == 200 and "experimenter.js" in html
        st = call(port, "GET", "/experimenter/api/state", token=tok)[1]
        assert (st["participant"], st["trial"], st["total"], st["paused"]) == ("P01", 1, 4, False)
        assert "condition" not in st  # blinded by default (session.blind_experimenter)
        call(port, "POST", "/experimenter/api/note", {"text": "a note"}, token=tok)
        # the participant's whole session
        for path in ("/", "/static/study.js", "/static/study.css"):
            served.append(call(port, "GET", path)[1])
        while (st := call(port, "GET", "/api/state")[1])["status"] != "done":
            served.append(json.dumps(st))
            if st["status"] == "rest":
                served.append(json.dumps(call(port, "POST", "/api/resume")[1]))
                continue
            served.append(json.dumps(call(port, "POST", "/api/stimulus", {"trial_id": st["trial"]["id"], "index": 0})[1]))
            served.append(json.dumps(call(port, "POST", "/api/answer", {"trial_id": st["trial"]["id"], "answer": "1"})[1]))
    finally:
        server.stop()
        runner.close()
    assert all(tok not in s for s in served)
    assert tok not in (study / "logs" / "P01.jsonl").read_text()


def test_a_design_not_blinded_to_the_experimenter_shows_the_condition(tmp_path):
    from surfhap.lab.session import SessionRunner

    design = {"format": "surfhap-study-design", "version": 1, "kind": "identification", "name": "open",
              "participants": 1, "params": {"materials": ["cork", "denim"], "repetitions": 1},
              "session": {"blind_experimenter": False}}
    (tmp_path / "d.json").write_text(json.dumps(design))
    assert main(["study", "new", str(tmp_path / "d.json"), "--out", str(tmp_path / "s")]) == 0
    runner = SessionRunner(tmp_path / "s", "P01")
    try:
        t = runner.current()
        assert runner.experimenter_state()["condition"] == {"block": t.block_label, **t.condition}
    finally:
        runner.close()


class RecordingSim:
    """The simulated output, keeping the largest |volts| of every block the engine emits (after
    the engine's output safety pass: what reaches the amplifier)."""

    def __new__(cls):
        from surfhap.live.backends.sim import SimBackend

        class _Rec(SimBackend):
            def __init__(self):
                super().__init__()
                self.peaks: list[float] = []

            def emit(self, volts) -> None:
                super().emit(volts)
                self.peaks.append(float(np.max(np.abs(volts))) if len(volts) else 0.0)

        return _Rec()


class Stroke:
    """A finger on the participant's pad: the page's WebSocket messages, a move every 5 ms
    back and forth across the pad until stopped (one connection for the whole session)."""

    def __init__(self, url: str):
        from websockets.sync.client import connect

        self.ws = connect(url.replace("http://", "ws://") + "/ws", open_timeout=PATIENCE).__enter__()
        self.ws.send(json.dumps({"type": "hello", "w": 800.0, "h": 500.0}))
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        k = 0
        while not self.stop.wait(0.005):
            x = 0.2 + 0.6 * abs((k % 200) / 100.0 - 1.0)
            self.ws.send(json.dumps({"type": "move", "seq": k, "t": 5.0 * k, "x": x, "y": 0.5, "p": 0.5}))
            k += 1

    def close(self):
        self.stop.set()
        self.thread.join(PATIENCE)
        self.ws.close()


def wait_for(cond, what: str):
    ev = threading.Event()
    for _ in range(int(PATIENCE / 0.01)):
        if cond():
            return
        ev.wait(0.01)
    raise AssertionError(f"timed out waiting for {what}")


def test_pause_mutes_the_output_resume_skip_and_notes_are_logged(tmp_path):
    from surfhap.lab.analyze_study import analyze_study
    from surfhap.lab.session import SessionRunner
    from surfhap.lab.stimuli import StimulusPlayer
    from surfhap.live.session import build_session

    study = identification_study(tmp_path, repetitions=2)
    runner = SessionRunner(study, "P01", mode="page")
    session = build_session("cork")
    session.backend = rec = RecordingSim()
    player = StimulusPlayer(session, v_max=runner.v_max)
    player.mute()
    player.prepare(runner.renders())
    session.start()
    page, server = serve(runner, player)
    tok, port = page.experimenter_token, server.port
    stroke = Stroke(server.url)
    try:
        first = runner.current()
        assert call(port, "POST", "/api/stimulus", {"trial_id": first.id, "index": 0})[1]["ok"]
        wait_for(lambda: max(rec.peaks[-50:], default=0.0) > 1.0, "the stimulus to drive the output")
        st = call(port, "POST", "/experimenter/api/pause", token=tok)[1]
        assert st["paused"] and (st["trial"], st["block_number"], st["blocks"]) == (1, 1, 2)
        assert call(port, "GET", "/api/state")[1] == {"status": "paused", "done": 0, "total": 8}
        # the gain ramp of the safety stage: then 0 V in every block, the finger still moving
        wait_for(lambda: rec.peaks and rec.peaks[-1] == 0.0, "the output to ramp to 0 V")
        n = len(rec.peaks)
        assert call(port, "POST", "/api/stimulus", {"trial_id": first.id, "index": 0})[1] == {"ok": False}
        assert call(port, "POST", "/api/answer", {"trial_id": first.id, "answer": "1"})[1]["accepted"] is False
        wait_for(lambda: len(rec.peaks) >= n + 300, "300 more blocks")  # 0.3 s of output
        assert max(rec.peaks[n:]) == 0.0
        assert session.engine.counters["touches"] > 0 and not session.engine.halted
        # resume: the trial again, its stimulus plays again
        assert not call(port, "POST", "/experimenter/api/resume", token=tok)[1]["paused"]
        assert call(port, "GET", "/api/state")[1]["trial"]["id"] == first.id
        assert call(port, "POST", "/api/stimulus", {"trial_id": first.id, "index": 0})[1]["ok"]
        wait_for(lambda: max(rec.peaks[-50:], default=0.0) > 1.0, "the output after resume")
        # a note, a skipped trial, then the participant answers the rest
        call(port, "POST", "/experimenter/api/note", {"text": "finger dry, wiped"}, token=tok)
        assert call(port, "POST", "/experimenter/api/skip", {"trial_id": first.id}, token=tok)[1]["trial"] == 2
        assert call(port, "POST", "/experimenter/api/skip", {"trial_id": first.id}, token=tok)[1]["trial"] == 2
        while (st := call(port, "GET", "/api/state")[1])["status"] != "done":
            if st["status"] == "rest":
                call(port, "POST", "/api/resume")
                continue
            call(port, "POST", "/api/stimulus", {"trial_id": st["trial"]["id"], "index": 0})
            assert call(port, "POST", "/api/answer", {"trial_id": st["trial"]["id"], "answer": "1"})[1]["accepted"]
    finally:
        stroke.close()
        server.stop()
        session.stop()
        runner.close()
    log = read_log(study / "logs" / "P01.jsonl")
    events = [e["event"] for e in log.events]
    assert events[:3] == ["pause", "pause-end", "note"] and events.count("pause") == 1
    note = log.events[2]
    assert note["text"] == "finger dry, wiped" and note["participant"] == "P01" and note["trial_id"] == first.id
    assert note["at"] >= log.events[1]["at"]  # timestamped, in order
    skipped = [t for t in log.trials if t.get("skipped")]
    assert [t["trial_id"] for t in skipped] == [first.id] and skipped[0]["answer"] is None
    assert len(log.trials) == 8
    res = analyze_study(study)
    assert res.n_trials == 7 and not res.incomplete  # the skipped trial: logged, not analysed, not missing
    assert any("1 trial(s) skipped" in w for w in res.warnings)
    confusion = sum(len(rows) for s in res.sections for _, rows in s.tables)
    assert confusion  # the analysis ran on the 7 answers


def test_training_trials_give_feedback_and_are_not_analysed(tmp_path):
    """The 003 identification template opens with training: each material once per condition,
    with feedback after the answer; logged with training (and practice) flags, left out of the
    analysis, flagged in the export."""
    import pandas as pd

    from surfhap.lab.analyze_study import analyze_study
    from surfhap.lab.designs import build_study, template
    from surfhap.lab.session import SessionRunner

    plan = build_study(template("otake2022-identification", participants=2)).participants[0]
    training = [t for t in plan.trials if t.training]
    assert plan.trials[:8] == training and all(t.practice and t.block == 0 for t in training)
    assert sorted((t.condition["condition"], t.correct) for t in training) == sorted(
        (c, m) for c in ("friction+texture", "friction-only") for m in ("leather", "cork", "denim", "wood"))
    assert len(plan.trials) == 24 and {t.block for t in plan.trials[8:]} == {1, 2}
    study = tmp_path / "s"
    assert main(["study", "new", "otake2022-identification", "--out", str(study), "--participants", "2"]) == 0
    runner = SessionRunner(study, "P01")
    try:
        for k in range(len(training)):
            t = runner.current()
            ans = t.correct if k % 2 == 0 else next(c.id for c in t.choices if c.id != t.correct)
            st = runner.answer(t.id, ans, 1.0)
            assert st["feedback"] == {"correct": k % 2 == 0, "answer": t.correct}, st
        assert runner.state()["status"] == "rest"  # after training, before the first block
        runner.resume()
        t = runner.current()
        assert "feedback" not in runner.answer(t.id, t.correct, 1.0)  # no feedback in the experiment
    finally:
        runner.close()
    for p in ("P01", "P02"):
        assert main(["study", "run", str(study), "-p", p, "--simulate", "1", "--p-correct", "1.0"]) == 0
    log = read_log(study / "logs" / "P01.jsonl")
    assert [bool(r.get("training")) for r in log.trials] == [True] * 8 + [False] * 16
    assert all(r.get("practice") for r in log.trials[:8])
    res = analyze_study(study)
    assert res.n_trials == 32 and not res.incomplete  # 2 x 16: training never counted
    text = " ".join(t for s in res.sections for t in s.text)
    # P01 missed half the training; analysed, its perfect answers are all there is
    assert "overall 1.00 correct" in text
    assert main(["study", "export", str(study), "--format", "csv", "--out", str(tmp_path / "t.csv")]) == 0
    table = pd.read_csv(tmp_path / "t.csv")
    assert len(table) == 48 and table["training"].fillna(False).astype(bool).sum() == 16
    assert (table["practice"] == table["training"].fillna(False).astype(bool)).all()


def test_pause_and_resume_clicked_on_the_experimenter_page_in_chromium(tmp_path):
    """Two pages of one Chromium: the participant answers a training trial (feedback: right or
    wrong and the right answer, then Next); the experimenter clicks Pause (the participant's
    page shows the neutral paused screen, no trial) and Resume (the trial comes back)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
    from browser_support import CHROMIUM, FLAGS, poll
    from test_lab_page import _need_browser, opaque, play

    _need_browser()
    from playwright.sync_api import sync_playwright

    from surfhap.lab.session import SessionRunner

    design = {"format": "surfhap-study-design", "version": 1, "kind": "identification", "name": "browser",
              "participants": 1, "seed": 3, "params": {"materials": ["cork", "denim"], "repetitions": 1,
                                                       "training": 1}}
    (tmp_path / "d.json").write_text(json.dumps(design))
    assert main(["study", "new", str(tmp_path / "d.json"), "--out", str(tmp_path / "s")]) == 0
    runner = SessionRunner(tmp_path / "s", "P01", mode="page")
    first = runner.current()
    wrong = next(c for c in first.choices if c.id != first.correct)
    page, server = serve(runner)
    ms = int(PATIENCE * 1000)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
            try:
                part = browser.new_page(viewport={"width": 1024, "height": 600})
                part.goto(server.url + "/", timeout=ms)
                exp = browser.new_page(viewport={"width": 1024, "height": 700})
                exp.goto(f"{server.url}/experimenter?token={page.experimenter_token}", timeout=ms)
                poll(exp, "window.experimenter.state && window.experimenter.state.trial === 1", ms)
                assert exp.inner_text("#participant") == "P01" and exp.inner_text("#block") == "1 of 3"
                assert exp.inner_text("#trial") == "1 of 8 (practice)" and " s" in exp.inner_text("#elapsed")
                assert exp.inner_text("#condition") == "hidden (blinded design)"
                # a training trial answered wrongly: feedback with the right answer
                poll(part, f"window.study.trialId === {first.id!r}", ms)
                assert "(training)" in part.inner_text("#prompt")
                play(part)
                part.click(f"#choices button[data-choice='{opaque(first, wrong.id)}']")
                part.wait_for_selector("#feedback:not([hidden])", timeout=ms)
                assert part.inner_text("#fb-result") == "Not quite."
                assert part.inner_text("#fb-answer") == f"The right answer: {first.correct}"
                for _ in range(2):  # the page's polls (the first surely rendered) must not replace the feedback
                    with part.expect_response(lambda r: r.url.endswith("/api/state"), timeout=ms):
                        pass
                assert part.is_visible("#feedback") and part.evaluate("window.study.status") == "feedback"
                part.click("#fb-next")
                second = runner.current()
                poll(part, f"window.study.trialId === {second.id!r}", ms)
                # pause on the experimenter page
                exp.click("#pause")
                poll(part, "window.study.status === 'paused'", ms)
                assert part.is_visible("#paused") and not part.is_visible("#trial")
                assert "Paused" in part.inner_text("#paused")
                poll(exp, "document.querySelector('#status').textContent === 'paused'", ms)
                assert exp.is_disabled("#pause") and exp.is_enabled("#resume")
                exp.fill("#note", "participant asked a question")
                exp.click("#add-note")
                poll(exp, "window.experimenter.notes === 1", ms)
                exp.click("#resume")
                poll(part, f"window.study.status === 'trial' && window.study.trialId === {second.id!r}", ms)
                assert part.is_visible("#trial") and not part.is_visible("#paused")
                exp.screenshot(path=str(tmp_path / "experimenter.png"))
            finally:
                browser.close()
    finally:
        server.stop()
        runner.close()
    log = read_log(tmp_path / "s" / "logs" / "P01.jsonl")
    assert log.trials[0]["training"] and log.trials[0]["is_correct"] is False
    assert [e["event"] for e in log.events] == ["pause", "note", "pause-end"]
    assert log.events[1]["text"] == "participant asked a question" and log.events[1]["trial_id"] == second.id
