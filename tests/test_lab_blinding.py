"""Blinding by construction (issue 18): a whole session of every built-in design is run through
the participant's page over HTTP; the served HTML/JS/CSS, every API reply and every LSL marker
must name no condition, method, material, effect or block of the design, while the log still
maps the opaque ids back so that the analysis is unchanged."""

from __future__ import annotations

import json
import re
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from surfhap.cli import main
from surfhap.lab.designs import TEMPLATES
from surfhap.lab.triallog import read_log

PAGE_ASSETS = ("/", "/static/study.js", "/static/study.css")


class RecordedMarkers:
    """The markers as the LSL outlet would send them (the same JSON text)."""

    enabled = True

    def __init__(self):
        self.sent: list[str] = []

    def push(self, event: str, **fields) -> None:
        self.sent.append(json.dumps({"event": event, **fields}, separators=(",", ":")))

    def close(self) -> None:
        return None


def _secrets(study) -> set[str]:
    """Every name the design uses for what is manipulated or played (block labels, condition
    values, render specs), less what the participant is shown by design: the answers' and
    stimuli's labels (e.g. the identification study's material names are its answers)."""
    shown, names = set(), set()
    for plan in study.participants:
        for t in plan.trials:
            labels = [c.label for c in t.choices] + [s.label for s in t.stimuli]
            shown |= set(labels) | {w for lab in labels for w in lab.split()}
            values = [t.block_label, *t.condition.values(), *(v for s in t.stimuli for v in s.render.values())]
            for v in values:
                if isinstance(v, str):
                    names |= {v, *re.split(r"\s*\|\s*|\s+vs\s+", v)}
    return {n for n in names - shown if len(n) >= 2}


def _session(study_dir: Path, runner, markers):
    """Answer every trial through the page's API as the page does; returns the texts served
    and the opaque answers sent."""
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    served: list[str] = []
    sent: dict[str, str] = {}
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner, None, markers))).start()

    def call(path, body=None):
        req = urllib.request.Request(server.url + path, data=None if body is None else json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                text = r.read().decode()
        except urllib.error.HTTPError as err:  # a refused answer: its message is served too
            text = err.read().decode()
        served.append(text)
        return text

    try:
        for path in PAGE_ASSETS:
            # the URL prefix of the page's own assets is not the sliding study's "static" effect
            call(path)
            served[-1] = served[-1].replace("/static/study.", "/assets/study.")
        for _ in range(10_000):
            st = json.loads(call("/api/state"))
            if st["status"] == "done":
                break
            if st["status"] == "rest":
                call("/api/resume", {})
                continue
            t = st["trial"]
            for i in range(len(t["stimuli"])):
                call("/api/stimulus", {"trial_id": t["id"], "index": i})
            ids, k = [c["id"] for c in t["choices"]], len(sent)
            if k == 0:  # an answer the trial does not offer: refused without naming the real ids
                call("/api/answer", {"trial_id": t["id"], "answer": "nonsense", "rt_ms": 700})
            ans = (",".join(f"{p}={ids[(k + j) % len(ids)]}" for j, p in enumerate(t["toggles"]))
                   if t["response"] == "toggles" else ids[k % len(ids)])
            assert json.loads(call("/api/answer", {"trial_id": t["id"], "answer": ans, "rt_ms": 700}))["accepted"]
            sent[t["id"]] = ans
    finally:
        server.stop()
    return served, sent


@pytest.mark.parametrize("name", list(TEMPLATES))
def test_a_whole_session_names_no_condition(tmp_path, name):
    from surfhap.lab.schema import load_study
    from surfhap.lab.session import SessionRunner

    study_dir = tmp_path / "study"
    assert main(["study", "new", name, "--out", str(study_dir), "--participants", "2"]) == 0
    study = load_study(study_dir)
    secrets = _secrets(study)
    assert secrets  # the design has something to hide
    markers = RecordedMarkers()
    runner = SessionRunner(study_dir, "P01", mode="page")
    try:
        served, sent = _session(study_dir, runner, markers)
    finally:
        runner.close()
    assert len(sent) == sum(t.session == 1 for t in study.participants[0].trials)  # a run: one study session
    for text in served + markers.sent:
        found = [n for n in secrets if re.search(rf"(?<![\w+-]){re.escape(n)}(?![\w+-])", text)]
        assert not found, (found, text[:300])
    # the log maps every opaque answer back: the choice ids the runner logged
    trials = {t.id: t for t in study.participants[0].trials}
    for rec in read_log(study_dir / "logs" / "P01.jsonl").trials:
        key = rec["key"]["choices"]
        want = (",".join(f"{p}={key[v]}" for p, v in (x.split("=") for x in sent[rec["trial_id"]].split(",")))
                if "=" in sent[rec["trial_id"]] else key[sent[rec["trial_id"]]])
        assert rec["answer"] == want and rec["participant"] == "P01"
        assert set(want.replace(",", "=").split("=")) & {c.id for c in trials[rec["trial_id"]].choices}
        assert rec["key"]["stimuli"] == [s.render for s in trials[rec["trial_id"]].stimuli]


def test_analysis_of_a_page_session_equals_the_runners(tmp_path):
    """The realism study (its choice ids are the conditions) answered through the page with
    opaque ids and directly through the runner with the same choices: same analysis."""
    from surfhap.lab.analyze_study import analyze_study
    from surfhap.lab.session import SessionRunner

    dirs = []
    for how in ("page", "runner"):
        d = tmp_path / how
        assert main(["study", "new", "otake2022-realism", "--out", str(d), "--participants", "2"]) == 0
        dirs.append(d)
        for pid in ("P01", "P02"):
            runner = SessionRunner(d, pid, mode="page")
            try:
                if how == "page":
                    _session(d, runner, RecordedMarkers())
                else:  # the k-th trial answered with choice k % 2, as _session does
                    k = 0
                    while not runner.finished:
                        if runner.state()["status"] == "rest":
                            runner.resume()
                            continue
                        t = runner.current()
                        runner.answer(t.id, t.choices[k % 2].id, 0.7)
                        k += 1
            finally:
                runner.close()
    page, direct = (analyze_study(d).results() for d in dirs)
    assert page == direct
