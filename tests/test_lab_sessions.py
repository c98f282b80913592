"""Sessions on different days (issue 18 item 3): a run stops at the end of a study session's
blocks, the next session is refused on the same calendar day unless overridden, and every
session record of the log holds its date. The day is injected (no wall clock)."""

from __future__ import annotations

import json
from datetime import date

import pytest

from surfhap.cli import main
from surfhap.errors import ConfigError
from surfhap.lab import session as session_mod
from surfhap.lab.blinding import participant_state
from surfhap.lab.designs import build_study, template
from surfhap.lab.session import SessionRunner
from surfhap.lab.triallog import read_log

DAY1, DAY2 = date(2026, 3, 2), date(2026, 3, 3)


def _study(tmp_path):
    """004's design, one repetition: 4 blocks, 2 per session, 2 practice trials opening each."""
    d = template("kinestouch-sliding", seed=2, participants=1)
    d = d.model_validate({**d.model_dump(), "params": {"repetitions": 1, "blocks_per_session": 2}})
    folder = tmp_path / "s"
    (folder / "logs").mkdir(parents=True)
    study = build_study(d)
    (folder / "study.json").write_text(json.dumps(study.model_dump(mode="json")))
    # independent reference: the blocks of session k are 2k-2 and 2k-1 of the participant's order
    trials = study.participants[0].trials
    return folder, [[t.id for t in trials if t.block // 2 == k] for k in (0, 1)]


def _answer_all(runner):
    while not runner.finished:
        runner.resume()
        t = runner.current()
        assert runner.answer(t.id, t.choices[0].id)["accepted"]


def test_run_stops_after_the_sessions_blocks_and_the_log_records_the_date(tmp_path):
    folder, (first, second) = _study(tmp_path)
    r = SessionRunner(folder, "P01", mode="simulated", today=DAY1)
    try:
        _answer_all(r)
        st = r.state()
        assert st["status"] == "done" and st["next_session"] == 2 and r.later == len(second)
        assert participant_state(st)["next_session"] == 2  # the page says "come back another day"
    finally:
        r.close()
    log = read_log(folder / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == first
    assert [(s["config"]["date"], s["config"]["study_session"]) for s in log.sessions] == [(DAY1.isoformat(), 1)]
    assert log.events[-1]["event"] == "session-end"


def test_next_session_refused_same_day_accepted_next_day(tmp_path):
    folder, (first, second) = _study(tmp_path)
    r = SessionRunner(folder, "P01", mode="simulated", today=DAY1)
    _answer_all(r)
    r.close()
    with pytest.raises(ConfigError, match="another day") as exc:
        SessionRunner(folder, "P01", mode="simulated", today=DAY1)
    assert "--allow-same-day" in str(exc.value) and "\n" not in str(exc.value)
    assert len(read_log(folder / "logs" / "P01.jsonl").sessions) == 1  # the refusal wrote nothing
    r = SessionRunner(folder, "P01", mode="simulated", today=DAY2)
    try:
        assert r.study_session == 2
        _answer_all(r)
        assert r.state()["status"] == "done" and "next_session" not in r.state() and not r.later
    finally:
        r.close()
    log = read_log(folder / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == first + second
    assert [(s["config"]["date"], s["config"]["study_session"]) for s in log.sessions] == [
        (DAY1.isoformat(), 1), (DAY2.isoformat(), 2)]
    assert log.events[-1]["event"] == "end"


def test_override_runs_the_next_session_the_same_day(tmp_path):
    folder, (first, second) = _study(tmp_path)
    for allow in (False, True):
        r = SessionRunner(folder, "P01", mode="simulated", today=DAY1, allow_same_day=allow)
        _answer_all(r)
        r.close()
    log = read_log(folder / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == first + second
    assert [s["config"]["date"] for s in log.sessions] == [DAY1.isoformat()] * 2


def test_study_run_cli_stops_refuses_and_overrides(tmp_path, monkeypatch, capsys):
    folder, (first, second) = _study(tmp_path)
    monkeypatch.setattr(session_mod, "local_today", lambda: DAY1)
    run = ["study", "run", str(folder), "-p", "P01", "--simulate", "1", "--comfort-voltage", "100"]
    assert main(run) == 0
    assert "session 1 done; session 2 on another day" in capsys.readouterr().out
    assert len(read_log(folder / "logs" / "P01.jsonl").trials) == len(first)
    assert main(run) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--allow-same-day" in err and "Traceback" not in err
    assert main([*run, "--allow-same-day"]) == 0
    assert "another day" not in capsys.readouterr().out
    assert len(read_log(folder / "logs" / "P01.jsonl").trials) == len(first) + len(second)
