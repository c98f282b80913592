"""The participant-information form (issue 18 item 3): a design's typed fields are asked on
the page before the first trial, checked, stored once in the log and exported to BIDS
participants.tsv."""

from __future__ import annotations

import http.client
import json

import pandas as pd
import pytest

from surfhap.cli import main
from surfhap.lab.triallog import read_log

FIELDS = [{"id": "age", "label": "Age (years)", "kind": "number", "min": 18, "max": 99},
          {"id": "handedness", "label": "Handedness", "kind": "choice", "choices": ["left", "right", "both"]},
          {"id": "gender", "label": "Gender", "kind": "text"}]


def _study(tmp_path, fields=FIELDS, participants=1):
    design = {"format": "surfhap-study-design", "version": 1, "kind": "identification", "name": "info test",
              "participants": participants, "seed": 3, "participant_info": fields,
              "params": {"materials": ["cork", "denim"], "repetitions": 1}}
    (tmp_path / "design.json").write_text(json.dumps(design))
    return main(["study", "new", str(tmp_path / "design.json"), "--out", str(tmp_path / "study")]), tmp_path / "study"


def _call(port, method, path, body=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    try:
        c.request(method, path, body=None if body is None else json.dumps(body),
                  headers={"Content-Type": "application/json"})
        r = c.getresponse()
        return r.status, json.loads(r.read())
    finally:
        c.close()


def _info_events(study):
    return [e for e in read_log(study / "logs" / "P01.jsonl").events if e["event"] == "participant-info"]


def test_the_page_asks_the_form_first_and_the_log_stores_it_once(tmp_path):
    from surfhap.lab.session import SessionRunner
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    code, study = _study(tmp_path)
    assert code == 0
    runner = SessionRunner(study, "P01", mode="page")
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner))).start()
    try:
        port = server.port
        status, st = _call(port, "GET", "/api/state")
        assert st["status"] == "info" and "trial" not in st
        assert [(f["id"], f["label"], f["kind"]) for f in st["info"]] == [(f["id"], f["label"], f["kind"])
                                                                          for f in FIELDS]
        first = runner.current().id  # no answer and no stimulus before the form
        assert _call(port, "POST", "/api/answer", {"trial_id": first, "answer": "1"})[1]["accepted"] is False
        assert _call(port, "POST", "/api/stimulus", {"trial_id": first, "index": 0})[1] == {"ok": False}
        for bad, field in (({"age": 12, "handedness": "left", "gender": "f"}, "participant_info.age"),
                           ({"age": 30, "handedness": "up", "gender": "f"}, "participant_info.handedness"),
                           ({"age": 30, "handedness": "left"}, "participant_info.gender"),
                           ({"age": 30, "handedness": "left", "gender": "f", "x": "1"}, "participant_info")):
            status, reply = _call(port, "POST", "/api/info", {"answers": bad})
            assert status == 400 and reply["error"].startswith(field + ":"), (bad, reply)
        assert _info_events(study) == []  # a refused form writes nothing
        status, st = _call(port, "POST", "/api/info", {"answers": {"age": "31", "handedness": "left",
                                                                   "gender": " female "}})
        assert status == 200 and st["status"] == "trial" and st["trial"]["id"] == first
        again = _call(port, "POST", "/api/info", {"answers": {"age": 40, "handedness": "right", "gender": "m"}})[1]
        assert again["accepted"] is False
        assert _call(port, "POST", "/api/answer", {"trial_id": first, "answer": "1"})[1]["accepted"] is True
    finally:
        server.stop()
        runner.close()
    events = _info_events(study)
    assert len(events) == 1 and events[0]["answers"] == {"age": 31.0, "handedness": "left", "gender": "female"}
    again = SessionRunner(study, "P01", mode="page")  # a resumed session does not ask again
    try:
        assert again.state()["status"] == "rest"
    finally:
        again.close()


@pytest.mark.parametrize("field", [{"id": "hand", "label": "Hand", "kind": "choice"},
                                   {"id": "Age", "label": "Age", "kind": "number"},
                                   {"id": "age", "label": "Age", "kind": "number", "choices": ["a", "b"]}])
def test_a_malformed_form_is_one_line_exit_2(tmp_path, capsys, field):
    code, _ = _study(tmp_path, [field])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "participant_info.0" in err


def test_bids_participants_tsv_holds_the_answers(tmp_path):
    code, study = _study(tmp_path, participants=2)
    assert code == 0
    for p in ("P01", "P02"):
        assert main(["study", "run", str(study), "-p", p, "--simulate", "1", "--comfort-voltage", "100"]) == 0
    assert main(["study", "export", str(study), "--format", "bids", "--out", str(tmp_path / "bids")]) == 0
    people = pd.read_csv(tmp_path / "bids" / "participants.tsv", sep="\t")
    # the simulated participant answers the lower bound, the first choice and "simulated"
    assert people["participant_id"].tolist() == ["sub-P01", "sub-P02"]
    assert people["age"].tolist() == [18.0, 18.0] and people["handedness"].tolist() == ["left", "left"]
    assert people["gender"].tolist() == ["simulated"] * 2


def test_the_form_in_chromium_on_a_tablet(tmp_path):
    """The form fits a 1024 x 600 tablet, a refused answer shows its field, a valid one starts
    the first trial."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent / "live_support"))
    from browser_support import chromium_page, poll
    from test_lab_page import _need_browser

    _need_browser()  # skips only outside CI (where make test installs both)
    from surfhap.lab.session import SessionRunner
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    _, study = _study(tmp_path)
    runner = SessionRunner(study, "P01", mode="page")
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner))).start()
    try:
        with chromium_page(server.url + "/", 1024, 600, 60_000) as page:
            page.wait_for_selector("#info:not([hidden])", timeout=60_000)
            page.fill("input[name=age]", "12")
            page.select_option("select[name=handedness]", "right")
            page.fill("input[name=gender]", "non-binary")
            page.evaluate("document.getElementById('info').noValidate = true")  # the server checks too
            page.click("#info button")
            page.wait_for_selector("#error:not([hidden])", timeout=60_000)
            assert "participant_info.age" in page.inner_text("#error")
            page.fill("input[name=age]", "45")
            assert page.locator("#info button").bounding_box()["y"] < 600
            page.screenshot(path=str(tmp_path / "info-1024x600.png"))
            page.click("#info button")
            poll(page, f"window.study.trialId === {runner.current().id!r}", 60_000)
    finally:
        server.stop()
        runner.close()
    assert _info_events(study)[0]["answers"] == {"age": 45.0, "handedness": "right", "gender": "non-binary"}
