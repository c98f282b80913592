"""Staircases converge to their analytic targets on simulated observers."""

import numpy as np
import pytest

from surfhap.errors import ConfigError
from surfhap.lab.staircase import Staircase, StaircaseParams, run_simulated, target_probability


def test_target_probabilities_levitt():
    assert target_probability(1, 1) == pytest.approx(0.5)
    assert target_probability(1, 2) == pytest.approx(0.5 ** 0.5)  # 70.7 %
    assert target_probability(1, 3) == pytest.approx(0.5 ** (1 / 3))  # 79.4 %
    assert target_probability(2, 1) == pytest.approx(1 - 0.5 ** 0.5)


def _logistic(mu, s):
    return lambda x: 1.0 / (1.0 + np.exp(-(x - mu) / s))


@pytest.mark.parametrize("up,down", [(1, 1), (1, 2), (1, 3), (2, 1)])
def test_converges_to_the_target_point(up, down):
    # observer: P(positive | x) = logistic((x - 10) / 1); the staircase's level should settle
    # where P = target_probability(up, down), i.e. x* = 10 + ln(p / (1 - p))
    p = target_probability(up, down)
    x_star = 10.0 + np.log(p / (1 - p))
    params = StaircaseParams(start=10.0 + (4.0 if up == 1 else -4.0), steps=(1.0, 0.5, 0.25), up=up, down=down,
                             max_trials=5000, max_reversals=80, average_last=70)
    thresholds = [run_simulated(params, _logistic(10.0, 1.0), np.random.default_rng(seed)).threshold
                  for seed in range(24)]
    # the sample mean over 24 runs: its standard error is ~0.06; allow for the step-size bias too
    assert np.mean(thresholds) == pytest.approx(x_star, abs=0.25)


def test_db_staircase_and_clamp_to_safety_limit():
    params = StaircaseParams(start=100.0, steps=(6.0, 3.0), up=1, down=1, step_type="db", min_level=5.0,
                             max_level=250.0, max_trials=60, max_reversals=1000)
    # an observer who never reports a sensation: the level climbs and stays at the limit
    res = run_simulated(params, lambda x: 0.0, np.random.default_rng(0))
    assert res.levels.max() <= 250.0 and res.levels[-1] == 250.0
    assert res.stopped_by == "trials" and res.threshold is None


def test_stop_on_reversals_and_threshold_is_mean_of_last():
    s = Staircase(StaircaseParams(start=5.0, steps=(1.0,), up=1, down=1, max_reversals=4, average_last=2))
    for r in [True, False, True, False, True]:  # levels 5, 4, 5, 4, 5
        if s.finished:
            break
        s.update(r)
    res = s.result()
    assert res.stopped_by == "reversals"
    assert list(res.levels) == [5.0, 4.0, 5.0, 4.0, 5.0][: res.levels.size]
    assert res.threshold == pytest.approx(np.mean(res.reversal_levels[-2:]))
    with pytest.raises(ConfigError):
        s.update(True)


def test_bad_params():
    with pytest.raises(ConfigError, match="start"):
        StaircaseParams(start=300.0, max_level=250.0)
    with pytest.raises(ConfigError, match="steps"):
        StaircaseParams(start=1.0, steps=(0.0,))
    with pytest.raises(ConfigError, match="step_type"):
        StaircaseParams(start=1.0, step_type="log")
    with pytest.raises(ConfigError, match="up"):
        StaircaseParams(start=1.0, up=0)
    with pytest.raises(ConfigError, match="min_level"):
        StaircaseParams(start=1.0, step_type="db")
    with pytest.raises(ConfigError, match="start"):
        StaircaseParams(start=float("nan"))
    with pytest.raises(ConfigError, match="unknown"):
        StaircaseParams(start=1.0, unknown=2)


def _scripted(params, answers):
    """Feed ``answers`` until the staircase finishes; the result."""
    s = Staircase(params)
    for a in answers:
        if s.finished:
            break
        s.update(a)
    assert s.finished
    return s.result()


def test_initial_one_up_one_down_rule_until_the_first_reversal():
    # PsychoPy's applyInitialRule, worked by hand for 1-up/3-down, start 10, step 1:
    # T: 10->9, T: 9->8, F: 8->9 (reversal 1, 1-up/3-down from now), T T T: 9 (three times) -> 8 (reversal 2),
    # F: 8->9 (reversal 3)
    answers = [True, True, False, True, True, True, False]
    base = dict(start=10.0, steps=(1.0,), up=1, down=3, max_trials=7, max_reversals=99)
    res = _scripted(StaircaseParams(**base, initial_rule=True), answers)
    assert list(res.levels) == [10, 9, 8, 9, 9, 9, 8] and list(res.reversal_trials) == [2, 5, 6]
    # without it the 3-down rule holds from the start: 10 10 10 (F: up) 11 11 11 (down, reversal) 10 (F: reversal)
    res = _scripted(StaircaseParams(**base), answers)
    assert list(res.levels) == [10, 10, 10, 11, 11, 11, 10] and list(res.reversal_trials) == [5, 6]


@pytest.mark.parametrize("max_trials,max_reversals,answers,either,both", [
    # trials reached first: 10 9 8 7 stop ("either"); "both" goes on 6 5 (F, reversal 1) 6 (T, reversal 2)
    (4, 2, [True] * 5 + [False, True, True], [10, 9, 8, 7], [10, 9, 8, 7, 6, 5, 6]),
    # reversals reached first: 10 9 (rev 1) 10 (rev 2) stop; "both" goes on to 6 trials
    (6, 2, [True, False] * 4, [10, 9, 10], [10, 9, 10, 9, 10, 9]),
])
def test_stop_when_trials_and_reversals_are_both_reached(max_trials, max_reversals, answers, either, both):
    base = dict(start=10.0, steps=(1.0,), up=1, down=1, max_trials=max_trials, max_reversals=max_reversals)
    res = _scripted(StaircaseParams(**base), answers)
    assert list(res.levels) == either and res.stopped_by in ("trials", "reversals")
    res = _scripted(StaircaseParams(**base, stop="both"), answers)
    assert list(res.levels) == both and res.stopped_by == "trials and reversals"
    assert res.levels.size >= max_trials and res.reversal_trials.size >= max_reversals
