"""Trial logs lose nothing: SIGKILL mid-session, resume, every completed trial exactly once."""

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from surfhap.cli import main
from surfhap.errors import StudyFormatError
from surfhap.lab.session import SessionRunner, check_answer
from surfhap.lab.triallog import TrialLog, read_log

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _new_study(tmp_path, template="otake2021-3afc"):
    out = tmp_path / "study"
    assert main(["study", "new", template, "--out", str(out), "--participants", "2"]) == 0
    return out


def _run(study, pace):
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen([sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())",
                             "study", "run", str(study), "--participant", "P01", "--simulate", "3",
                             "--pace", str(pace)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)


def test_sigkill_mid_session_then_resume_has_every_trial_once(tmp_path):
    study = _new_study(tmp_path)
    proc = _run(study, pace=0.05)
    acknowledged = []
    deadline = time.monotonic() + 120
    while len(acknowledged) < 10 and time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        if line.startswith("logged "):
            acknowledged.append(line.split()[1])
    assert len(acknowledged) >= 10, proc.stderr.read()
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    log = study / "logs" / "P01.jsonl"
    mid = read_log(log)
    ids = [t["trial_id"] for t in mid.trials]
    assert len(ids) == len(set(ids))
    assert set(acknowledged) <= set(ids)  # every acknowledged (fsynced) trial survived the kill
    # resume to the end
    proc2 = _run(study, pace=0.0)
    out, err = proc2.communicate(timeout=300)
    assert proc2.returncode == 0, err
    assert "resuming P01" in err
    final = read_log(log)
    plan = json.loads((study / "study.json").read_text())["participants"][0]["trials"]
    want = [t["id"] for t in plan]
    got = [t["trial_id"] for t in final.trials]
    assert Counter(got) == Counter(want)  # every trial exactly once
    assert got == want  # and in the planned order
    assert len(final.sessions) == 2 and final.sessions[1]["resumed_after"] == len(ids)
    assert final.sessions[0]["config"]["study_sha256"] == final.sessions[1]["config"]["study_sha256"]
    assert final.sessions[0]["software_version"]


def test_partial_last_line_is_cut_and_trial_rerun(tmp_path):
    study = _new_study(tmp_path)
    r = SessionRunner(study, "P01", mode="test")
    t0 = r.current()
    r.answer(t0.id, t0.correct)
    r.close()
    log = study / "logs" / "P01.jsonl"
    with open(log, "ab") as fh:  # a write torn by a kill
        fh.write(b'{"type":"trial","trial_id":"P01-0001","ans')
    assert read_log(log).dropped_tail > 0
    r = SessionRunner(study, "P01", mode="test")
    assert r.current().id == "P01-0001" and r.n_done == 1
    r.close()
    assert read_log(log).dropped_tail == 0
    assert [t["trial_id"] for t in read_log(log).trials] == [t0.id]


def test_duplicate_and_stale_answers_are_not_logged(tmp_path):
    study = _new_study(tmp_path)
    r = SessionRunner(study, "P02", mode="test")
    t = r.current()
    assert r.answer(t.id, "1")["accepted"] is True
    assert r.answer(t.id, "1")["accepted"] is False  # double click
    assert r.log.append_trial({"trial_id": t.id}) is False
    r.close()
    assert [x["trial_id"] for x in read_log(study / "logs" / "P02.jsonl").trials] == [t.id]


def test_one_session_at_a_time(tmp_path):
    p = tmp_path / "x.jsonl"
    with TrialLog(p, participant="P01", config={}, software_version="0"):
        with pytest.raises(StudyFormatError, match="another session"):
            TrialLog(p, participant="P01", config={}, software_version="0")


def test_rest_between_blocks(tmp_path):
    study = _new_study(tmp_path, "otake2022-identification")
    r = SessionRunner(study, "P01", mode="test")
    for _ in range(8):
        st = r.answer(r.current().id, r.current().correct)
    assert st["status"] == "rest"
    r.resume()
    assert r.state()["status"] == "trial"
    r.close()


def test_gain_and_comfort_voltage_bounded(tmp_path):
    study = _new_study(tmp_path)
    with pytest.raises(StudyFormatError):
        SessionRunner(study, "P09")
    from surfhap.errors import ConfigError

    with pytest.raises(ConfigError, match="comfort-voltage"):
        SessionRunner(study, "P01", comfort_voltage=300.0)
    with pytest.raises(ConfigError, match="gain"):
        SessionRunner(study, "P01", gain=10.0)
    r = SessionRunner(study, "P01", comfort_voltage=180.0, gain=1.5)
    assert r.v_max == 180.0
    r.answer(r.current().id, "1")  # the session record is written with the session's first record
    r.close()
    cfg = read_log(study / "logs" / "P01.jsonl").sessions[-1]["config"]
    assert cfg["v_max"] == 180.0 and cfg["gain"] == 1.5


def test_check_answer_toggles():
    from surfhap.lab.designs import build_study, template

    t = build_study(template("kim-scenes", participants=1)).participants[0].trials[0]
    ans, score = check_answer(t, t.correct)
    assert score == 1.0
    flipped = ",".join(f"{k}={'hole' if v == 'bump' else 'bump'}" for k, v in (x.split("=") for x in t.correct.split(",")))
    assert check_answer(t, flipped)[1] == 0.0


def test_corrupt_log_releases_its_lock(tmp_path):
    p = tmp_path / "x.jsonl"
    p.write_text('{"type":"session"}\nnot json\n')
    for _ in range(2):  # the second attempt must not find the lock still held
        with pytest.raises(StudyFormatError, match="line 2"):
            TrialLog(p, participant="P01", config={}, software_version="0")


def test_page_state_does_not_reveal_the_condition(tmp_path):
    study = _new_study(tmp_path, "otake2022-identification")
    r = SessionRunner(study, "P01", mode="test")
    st = r.state()
    assert st["block_number"] == 1 and st["blocks"] == 3  # training, then the two conditions
    page_js = (Path(__file__).resolve().parents[1] / "src/surfhap/web/static/study/study.js").read_text()
    assert "st.block_label" not in page_js and "st.next_block" not in page_js  # the page shows numbers only
    r.close()


def test_a_failed_start_writes_no_session(tmp_path, capsys):
    """'study run' on a busy port fails (exit 2) before the page is served: the log gains no
    session record (nor the resume event of a resumed participant); the next run is session 2."""
    import socket

    study = _new_study(tmp_path, "otake2022-identification")
    log = study / "logs" / "P01.jsonl"
    r = SessionRunner(study, "P01", mode="test")
    for _ in range(3):
        r.answer(r.current().id, r.current().correct)
    r.close()
    before = log.read_bytes()
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        for _ in range(2):
            assert main(["study", "run", str(study), "-p", "P01", "--port", str(busy.getsockname()[1])]) == 2
    assert log.read_bytes() == before and len(read_log(log).sessions) == 1
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    final = read_log(log)
    assert [s["session"] for s in final.sessions] == [1, 2] and final.sessions[1]["resumed_after"] == 3
    assert final.events[0]["event"] == "resume" and final.events[0]["session"] == 2
    assert {t["participant"] for t in final.trials} == {"P01"}


def test_trial_records_carry_the_participant_and_old_logs_still_read(tmp_path):
    p = tmp_path / "x.jsonl"
    with TrialLog(p, participant="P07", config={"participant": "P07"}, software_version="0") as lg:
        lg.append_trial({"trial_id": "a"})
    assert json.loads(p.read_text().splitlines()[1])["participant"] == "P07"  # in the file itself
    old = tmp_path / "P03.jsonl"  # a log written before trial records held the participant
    old.write_text('{"type":"session","session":1,"config":{"participant":"P03"}}\n'
                   '{"type":"trial","trial_id":"P03-0000","answer":"1","session":1}\n')
    assert [t["participant"] for t in read_log(old).trials] == ["P03"]
