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
    est, ceilings = [], []
    for seed in range(6):
        (study / "logs" / "P01-comfort.jsonl").unlink(missing_ok=True)
        r = ComfortRunner(study, "P01")
        ans = _observer(100.0, np.random.default_rng(seed))
        while not r.finished:
            r.answer(r.state()["trial"]["id"], ans(r.stair.level))
        est.append(r.result().threshold)
        ceilings.append(comfort_voltage_of(study, "P01"))
        r.close()
    # 3 "comfortable" up / 1 "uncomfortable" down settles where the observer (50 % at 100 V,
    # slope 10 V) is uncomfortable 20.6 % of the time: 100 + 10 ln(0.206 / 0.794) = 86.5 V
    assert np.exp(np.mean(np.log(est))) == pytest.approx(86.5, rel=0.15)
    # the written comfort voltage is one final step (2 dB) below each estimate
    assert ceilings == pytest.approx([e * 10 ** (-2 / 20) for e in est])
    assert all(c <= 250.0 for c in ceilings)


def _p_uncomfortable(threshold, slope):
    return lambda v: 1.0 / (1.0 + np.exp(-(v - threshold) / slope))


@pytest.mark.parametrize("threshold,slope", [(100.0, 10.0), (150.0, 30.0), (40.0, 2.0)])
def test_the_comfort_ceiling_is_uncomfortable_at_most_levitts_21_percent(threshold, slope):
    """A simulated participant with a known logistic discomfort function. Levitt (1971): a
    staircase that goes down after 1 "uncomfortable" and up after 3 "comfortable" in a row is
    stationary where P(comfortable)^3 = 1/2, so the analytic convergence point is
    v* = threshold + slope ln(p / (1 - p)) with p = 1 - 0.5^(1/3) = 0.206. Over many seeded
    runs the staircase's estimate must not lie above v* beyond the run-to-run spread, and the
    comfort ceiling (one step below) must be uncomfortable at most 20.6 % of the time."""
    from surfhap.lab.comfort import COMFORT_TARGET, comfort_ceiling, default_comfort_params
    from surfhap.lab.staircase import run_simulated, target_probability

    p = 1.0 - 0.5 ** (1.0 / 3.0)
    assert COMFORT_TARGET == pytest.approx(p) and 1.0 - target_probability(3, 1) == pytest.approx(1.0 - p)
    p_unc = _p_uncomfortable(threshold, slope)
    v_star = threshold + slope * np.log(p / (1.0 - p))
    params = default_comfort_params(60.0)
    runs = [run_simulated(params, p_unc, np.random.default_rng(seed)) for seed in range(120)]
    est = np.log([r.threshold for r in runs])
    tol = 3.0 * est.std(ddof=1) / np.sqrt(est.size)  # three standard errors of the mean
    # not above the convergence point, and not more than one final step (2 dB) below it
    assert np.log(v_star) - np.log(10 ** (2 / 20)) - tol <= est.mean() <= np.log(v_star) + tol
    ceilings = np.array([comfort_ceiling(r.threshold, params) for r in runs])
    assert ceilings == pytest.approx(np.exp(est) * 10 ** (-2 / 20))
    assert np.mean(p_unc(ceilings)) <= p
    assert np.mean(p_unc(ceilings) > 0.5) < 0.05  # a ceiling that is mostly uncomfortable is rare


def test_uncomfortable_down_to_the_floor_gives_no_threshold_and_study_run_refuses(study, capsys):
    r = ComfortRunner(study, "P01")
    while not r.finished:
        r.answer(r.state()["trial"]["id"], "no")
    res = r.result()
    r.close()
    assert res.levels.min() == 5.0 and res.threshold is None  # the floor, no reversal
    assert json.loads((study / "logs" / "P01-comfort.json").read_text())["comfort_voltage"] is None
    capsys.readouterr()
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no threshold" in err[0] and "P01-comfort.json" in err[0], err
    assert not (study / "logs" / "P01.jsonl").exists()  # no session was started
    # an explicit --comfort-voltage is a threshold: the session starts with it
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1", "--comfort-voltage", "20"]) == 0
    assert read_log(study / "logs" / "P01.jsonl").sessions[0]["config"]["v_max"] == pytest.approx(20.0)


def test_an_unfinished_comfort_staircase_also_stops_study_run(study, capsys):
    r = ComfortRunner(study, "P02")
    r.answer(r.state()["trial"]["id"], "yes")
    r.close()
    capsys.readouterr()
    assert main(["study", "run", str(study), "-p", "P02", "--simulate", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unfinished" in err[0], err


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
    assert v == pytest.approx(r.result().threshold * 10 ** (-2 / 20))  # one final step below


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


def test_a_real_display_needs_a_comfort_voltage_before_a_session_starts(study, capsys):
    """No staircase was run: on a simulated or recorded output the session may start at the
    safety limit (with a line saying so); on an output that reaches an amplifier (sound, OSC)
    it does not start (one line, exit 2) unless --comfort-voltage is given."""
    capsys.readouterr()
    for output in ("sound:0", "osc://127.0.0.1:9000"):
        assert main(["study", "run", str(study), "-p", "P01", "--output", output, "--port", "0"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--output" in err[0] and "study comfort" in err[0], err
    assert not (study / "logs" / "P01.jsonl").exists()  # no session was started


def test_a_comfort_result_of_the_old_one_up_one_down_rule_is_refused(study, capsys):
    """A result written before the 3-up/1-down rule (no ``staircase_threshold_V``) holds a
    voltage judged uncomfortable half the time: study run refuses it in one line."""
    (study / "logs").mkdir(exist_ok=True)
    (study / "logs" / "P01-comfort.json").write_text(json.dumps(
        {"participant": "P01", "comfort_voltage": 80.0, "stopped_by": "reversals",
         "method": "1-up/1-down staircase"}))
    capsys.readouterr()
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "1-up/1-down" in err[0] and "P01-comfort.json" in err[0], err


def test_questplus_or_staircase_threshold_with_its_ci_in_results_json(study, tmp_path):
    """The simulated participant ('study comfort --simulate') is uncomfortable with probability
    1 / (1 + exp(-(v - 120) / 12)): 50 % at 120 V; Levitt's/QUEST+'s 20.6 % target point is
    120 + 12 ln(0.206 / 0.794) = 103.8 V. Through the CLI, with each method, 'study analyze'
    puts the 50 % point and its 95 % credible interval into results.json; it covers 120 V, and
    the ML psychometric fit lies near it."""
    for p, method in (("P01", "staircase"), ("P02", "questplus")):
        assert main(["study", "comfort", str(study), "-p", p, "--simulate", "3", "--method", method]) == 0
    doc = json.loads((study / "logs" / "P02-comfort.json").read_text())
    assert len(doc["levels_V"]) == 40 and doc["staircase_threshold_V"] == pytest.approx(103.8, rel=0.1)
    assert read_log(study / "logs" / "P02-comfort.jsonl").sessions[0]["config"]["method"] == "questplus"
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    assert main(["study", "analyze", str(study), "--report", str(tmp_path / "rep")]) == 0
    est = json.loads((tmp_path / "rep" / "results.json").read_text())["estimates"]
    assert [(e["participant"], e["method"].split()[-2]) for e in est] == [("P01", "staircase"), ("P02", "questplus")]
    for e in est:
        assert e["ci"][0] <= 120.0 <= e["ci"][1] and e["ci"][0] <= e["value"] <= e["ci"][1]
        assert e["ml_value"] == pytest.approx(120.0, rel=0.25) and e["n"] >= 29
    assert est[1]["ci"][1] - est[1]["ci"][0] < 40.0  # QUEST+ places its trials around the threshold


def test_a_bad_comfort_method_is_one_line_exit_2(study, capsys):
    assert main(["study", "comfort", str(study), "-p", "P01", "--simulate", "1", "--method", "qest"]) == 2
    assert "method" in capsys.readouterr().err
