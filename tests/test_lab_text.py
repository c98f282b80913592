"""Free-text answers (issue 18 item 3; 002 Sec. 4 Part 1: open descriptions before the closed
choice): a trial ``response: "text"`` is answered in a textarea, logged verbatim and
length-capped; the closed-choice analysis leaves the descriptions out."""

from __future__ import annotations

import http.client
import json

import pytest
from pydantic import ValidationError

from surfhap.cli import main
from surfhap.errors import ConfigError
from surfhap.lab.designs import build_study, template
from surfhap.lab.schema import Choice, Stimulus, Trial
from surfhap.lab.session import TEXT_MAX, SessionRunner
from surfhap.lab.triallog import read_log

VERBATIM = "  Ein Hügel,\n rough — like \"sand\"\t"


def _study(tmp_path, descriptions=True):
    d = template("kim-shapes", seed=4, participants=2)
    d = d.model_validate({**d.model_dump(), "params": {"descriptions": descriptions}})
    folder = tmp_path / ("with" if descriptions else "without")
    (folder / "logs").mkdir(parents=True)
    study = build_study(d)
    (folder / "study.json").write_text(json.dumps(study.model_dump(mode="json")))
    return folder, study


def test_part_1_describes_every_condition_before_the_closed_choice(tmp_path):
    _, study = _study(tmp_path)
    _, plain = _study(tmp_path, descriptions=False)
    trials = study.participants[0].trials
    text = [t for t in trials if t.response == "text"]
    # Kim et al. Table 1: 10 electrovibration conditions (bump/hole x 2 grains x 2 profiles, flat x 2 grains)
    assert len(text) == 10 and trials[:10] == text and all(not t.choices and t.block == 0 for t in text)
    assert len({json.dumps(t.condition, sort_keys=True) for t in text}) == 10
    # Part 2 is the closed choice as without descriptions, one block later
    closed = trials[10:]
    assert [(t.condition, t.correct, t.block) for t in closed] == [(t.condition, t.correct, 1)
                                                                   for t in plain.participants[0].trials]


def test_text_answers_are_logged_verbatim_and_capped(tmp_path):
    folder, _ = _study(tmp_path)
    r = SessionRunner(folder, "P01", mode="simulated")
    try:
        t = r.current()
        for bad in ("", " \n\t ", "x" * (TEXT_MAX + 1)):
            with pytest.raises(ConfigError, match="text answer"):
                r.answer(t.id, bad)
        assert r.answer(t.id, VERBATIM)["accepted"]
        t2 = r.current()
        assert r.answer(t2.id, "y" * TEXT_MAX)["accepted"]
    finally:
        r.close()
    recs = read_log(folder / "logs" / "P01.jsonl").trials
    assert [x["answer"] for x in recs] == [VERBATIM, "y" * TEXT_MAX]
    assert recs[0]["score"] is None and recs[0]["is_correct"] is None and recs[0]["task"] == "description"


def test_the_page_api_takes_a_text_answer_verbatim(tmp_path):
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    folder, _ = _study(tmp_path)
    runner = SessionRunner(folder, "P01", mode="page")
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner))).start()
    try:
        c = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
        c.request("GET", "/api/state")
        st = json.loads(c.getresponse().read())
        assert st["trial"]["response"] == "text" and st["trial"]["choices"] == []
        c.request("POST", "/api/answer", body=json.dumps({"trial_id": st["trial"]["id"], "answer": VERBATIM}),
                  headers={"Content-Type": "application/json"})
        reply = c.getresponse()
        assert reply.status == 200 and json.loads(reply.read())["accepted"]
        c.close()
    finally:
        server.stop()
        runner.close()
    assert read_log(folder / "logs" / "P01.jsonl").trials[0]["answer"] == VERBATIM


def test_analysis_leaves_the_descriptions_out(tmp_path):
    folder, study = _study(tmp_path)
    for p in ("P01", "P02"):
        assert main(["study", "run", str(folder), "-p", p, "--simulate", "3", "--comfort-voltage", "100"]) == 0
    assert sum(t["task"] == "description" for t in read_log(folder / "logs" / "P01.jsonl").trials) == 10
    assert main(["study", "analyze", str(folder), "--report", str(tmp_path / "rep")]) == 0
    tests = json.loads((tmp_path / "rep" / "results.json").read_text())["tests"]
    assert tests  # the closed choice's test runs on the 10 closed-choice trials of each participant


def test_schema_text_has_no_choices_and_a_choice_needs_them():
    stim = [Stimulus(label="touch", render={"real": "x"})]
    base = dict(id="a", index=0, block=0, block_label="b", task="t", prompt="p", stimuli=stim)
    with pytest.raises(ValidationError, match="choices"):
        Trial(**base, response="text", choices=[Choice(id="a", label="a"), Choice(id="b", label="b")])
    with pytest.raises(ValidationError, match="choices"):
        Trial(**base)
    assert Trial(**base, response="text").choices == []


def test_the_textarea_in_chromium_on_a_tablet(tmp_path):
    """Next opens once the stimulus was touched and something was typed; the text is logged as typed."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
    from browser_support import chromium_page, poll
    from test_lab_page import _need_browser

    _need_browser()  # skips only outside CI (where make test installs both)
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    folder, _ = _study(tmp_path)
    runner = SessionRunner(folder, "P01", mode="page")
    first = runner.current().id
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner))).start()
    typed = "a small bump,\nthen grainy"
    try:
        with chromium_page(server.url + "/", 1024, 600, 60_000) as page:
            poll(page, f"window.study.trialId === {first!r}", 60_000)
            assert page.locator("#text").is_visible() and page.locator("#submit").is_disabled()
            page.click("button.stim")
            box = page.locator("#pad").bounding_box()
            page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            poll(page, "window.study.answerable === true", 60_000)
            assert page.locator("#submit").is_disabled()  # nothing typed yet
            page.fill("#text", typed)
            assert page.locator("#submit").bounding_box()["y"] + 10 < 600
            page.screenshot(path=str(tmp_path / "text-1024x600.png"))
            page.click("#submit")
            poll(page, "window.study.answered === 1", 60_000)
    finally:
        server.stop()
        runner.close()
    assert read_log(folder / "logs" / "P01.jsonl").trials[0]["answer"] == typed
