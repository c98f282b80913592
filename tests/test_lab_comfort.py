"""Comfort staircase (Zhao et al.): estimate, resume, and the session limit it sets."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.lab.comfort import ComfortRunner, comfort_voltage_of
from surfhap.lab.triallog import read_log


@pytest.fixture()
def study(tmp_path):
    out = tmp_path / "s"
    assert main(["study", "new", "kim-shapes", "--out", str(out), "--participants", "2"]) == 0
    return out


def _observer(threshold, rng):
    return lambda v: "no" if rng.random() < 1 / (1 + np.exp(-(v - threshold) / (0.1 * threshold))) else "yes"


def test_estimate_near_the_simulated_threshold(study):
    est = []
    for seed in range(6):
        (study / "logs" / "P01-comfort.jsonl").unlink(missing_ok=True)
        r = ComfortRunner(study, "P01")
        ans = _observer(100.0, np.random.default_rng(seed))
        while not r.finished:
            r.answer(r.state()["trial"]["id"], ans(r.stair.level))
        est.append(r.result().threshold)
        r.close()
    # 1-up/1-down on "uncomfortable" settles at the 50 % point of the observer (100 V)
    assert np.exp(np.mean(np.log(est))) == pytest.approx(100.0, rel=0.15)
    assert all(e <= 250.0 for e in est)


def test_killed_run_resumes_by_replay(study):
    r = ComfortRunner(study, "P02")
    ans = _observer(150.0, np.random.default_rng(1))
    for _ in range(5):
        r.answer(r.state()["trial"]["id"], ans(r.stair.level))
    levels = list(r.result().levels)
    r.close()  # as after a kill: the log holds 5 answers
    r = ComfortRunner(study, "P02")
    assert list(r.result().levels) == levels and r.n_done == 5
    while not r.finished:
        r.answer(r.state()["trial"]["id"], ans(r.stair.level))
    r.close()
    ids = [t["trial_id"] for t in read_log(study / "logs" / "P02-comfort.jsonl").trials]
    assert len(ids) == len(set(ids)) == r.result().levels.size
    v = comfort_voltage_of(study, "P02")
    assert v == pytest.approx(r.result().threshold)


def test_study_run_uses_the_comfort_voltage(study, capsys):
    assert main(["study", "comfort", str(study), "-p", "P01", "--simulate", "3", "--simulated-threshold", "90"]) == 0
    v = json.loads((study / "logs" / "P01-comfort.json").read_text())["comfort_voltage"]
    assert 40 < v < 200
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    cfg = read_log(study / "logs" / "P01.jsonl").sessions[0]["config"]
    assert cfg["v_max"] == pytest.approx(v) and cfg["comfort_voltage_from"] == "study comfort"
    assert main(["study", "comfort", str(study), "-p", "P01", "--start", "400", "--simulate", "1"]) == 2


def test_comfort_thresholds_in_the_analysis(study, tmp_path):
    from surfhap.lab.analyze_study import analyze_study

    assert main(["study", "comfort", str(study), "-p", "P02", "--simulate", "4"]) == 0
    assert main(["study", "run", str(study), "-p", "P02", "--simulate", "1"]) == 0
    res = analyze_study(study)
    sec = [s for s in res.sections if s.title.startswith("Comfort")]
    assert sec and sec[0].tables[0][1][0][0] == "P02"
