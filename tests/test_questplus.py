"""QUEST+ (Watson 2017): exact posterior zeroing with a deterministic observer, expected
entropy against a brute-force loop, and convergence on a simulated observer."""

import math

import numpy as np
import pytest

from surfhap.errors import ConfigError
from surfhap.lab.psychometric import psychometric
from surfhap.lab.questplus import QuestPlus

STIM = np.linspace(0.0, 1.0, 11)
THRESH = np.linspace(0.05, 0.95, 10)


def _step_quest():
    """One parameter (threshold), deterministic: correct iff stimulus >= threshold."""
    p = (STIM[:, None] >= THRESH[None, :]).astype(float)
    return QuestPlus(STIM, THRESH[:, None], np.stack([1 - p, p], axis=2))


def _brute_expected_entropy(q, s):
    total = 0.0
    for r in range(q.likelihoods.shape[2]):
        weights = [q.posterior[m] * q.likelihoods[s, m, r] for m in range(q.posterior.size)]
        p_r = sum(weights)
        if p_r > 0:
            total += p_r * -sum(w / p_r * math.log2(w / p_r) for w in weights if w > 0)
    return total


def test_deterministic_response_zeroes_exactly_the_inconsistent_thresholds():
    q = _step_quest()
    q.update(0.5, 1)  # correct at 0.5: every threshold above 0.5 is ruled out
    assert np.array_equal(q.posterior > 0, THRESH <= 0.5)
    q.update(0.3, 0)  # wrong at 0.3: every threshold at or below 0.3 is ruled out
    assert np.array_equal(q.posterior > 0, (THRESH > 0.3) & (THRESH <= 0.5))
    assert np.allclose(q.posterior[q.posterior > 0], 0.5)  # uniform prior stays uniform on the rest


def test_expected_entropy_matches_brute_force_and_bisects():
    q = _step_quest()
    for stim, outcome in [(None, None), (0.6, 1)]:
        if stim is not None:
            q.update(stim, outcome)
        brute = [_brute_expected_entropy(q, s) for s in range(STIM.size)]
        assert np.allclose(q.expected_entropies(), brute, atol=1e-12)
    # 10 equally likely thresholds: the best split is 5/5, leaving log2(5) bits
    fresh = _step_quest()
    assert fresh.expected_entropies().min() == pytest.approx(math.log2(5))
    assert fresh.next_stimulus() == pytest.approx(0.5)


def test_converges_on_a_simulated_observer():
    rng = np.random.default_rng(4)
    stim = np.linspace(-1.0, 1.0, 41)
    q = QuestPlus.psychometric(stim, np.linspace(-0.8, 0.8, 33), [2.0, 4.0, 8.0, 16.0], [0.0, 0.04],
                               guess=0.5)
    h0 = q.entropy()
    for _ in range(250):
        x = q.next_stimulus()
        q.update(x, int(rng.random() < psychometric(x, 0.25, 8.0, 0.5, 0.02)))
    threshold, slope, _ = q.mean()
    sd = math.sqrt(q.posterior @ (q.params[:, 0] - threshold) ** 2)
    assert abs(threshold - 0.25) < max(3 * sd, 0.05) and sd < 0.1
    assert q.entropy() < h0 - 3


def test_bad_input_names_the_argument():
    q = _step_quest()
    with pytest.raises(ConfigError) as err:
        q.update(0.55, 1)
    assert err.value.field == "stimulus"
    with pytest.raises(ConfigError) as err:
        q.update(0.5, 2)
    assert err.value.field == "outcome"
    with pytest.raises(ConfigError) as err:
        QuestPlus(STIM, THRESH, np.ones((11, 10, 2)))
    assert err.value.field == "likelihoods"
    q.update(0.5, 1)
    with pytest.raises(ConfigError):  # wrong at 1.0 after correct at 0.5 is impossible for a step
        q.update(1.0, 0)


# Watson (2017) worked examples: the stimuli QUEST+ chose and the responses of his simulated
# observer, trial by trial (contrast in dB; 1 = correct). His Weibull in dB,
# 1 - lapse - (1 - guess - lapse) exp(-10^(slope (x - threshold) / 20)), is the Gumbel shape
# with slope * ln(10) / 20.
_DB = math.log(10.0) / 20.0
EXAMPLE_1 = dict(  # "Estimation of contrast threshold {1, 1, 2}"
    slopes=[3.5], lapses=[0.02], mode=(-20, 3.5, 0.02),
    stimuli=[-18, -22, -25, -28, -30, -22, -13, -15, -16, -18, -19, -20, -21, -22, -23, -19, -20, -20, -18, -18,
             -19, -17, -17, -18, -18, -18, -19, -19, -19, -19, -19, -19],
    correct="11110011111111011011011111111111")
EXAMPLE_2 = dict(  # "Estimation of contrast threshold, slope, and lapse {1, 3, 2}"
    slopes=[2, 3, 4, 5], lapses=[0.0, 0.01, 0.02, 0.03, 0.04], mode=(-20, 5, 0.04),
    stimuli=[-18, -22, -25, -28, -30, -21, -12, -14, -15, -16, -18, -19, -20, -22, -23, -18, -19, -16, -17, -17,
             -18, -18, -18, -19, -19, -17, -17, -18, -18, -18, -18, -19, -19, -20, -18, -18, -18, -18, -18, -19,
             -19, -19, -19, -20, -18, -18, -18, -18, -18, -18, -18, -18, -18, -19, -19, -19, -20, -18, -18, -18,
             -18, -19, -19, -19, -18, -18, -18, -18, -19, -19, -19, -19, -19, -19, -19, -19, -20, -21, -19, -19,
             -19, -19, -19, -19, -19, -18, -19, -19, -16, -16, -16, -16, -16, -16, 0, 0, -19, -19, -19, -19,
             -19, -19, -19, -19, -19, -19, -19, -19, -19, -19, -21, -21, -19, -19, -19, -19, -19, -19, -19, -19,
             -19, -19, -19, -19, -19, -19, -19, -19],
    correct="1111001111111101011111110111111110111111111011101111111101111110"
            "1111111111111010111101101111111011111111111111101110100111101111")


@pytest.mark.parametrize("example", [EXAMPLE_1, EXAMPLE_2], ids=["example1", "example2"])
def test_reproduces_watson_2017_examples(example):
    grid = np.arange(-40.0, 1.0)
    q = QuestPlus.psychometric(grid, grid, np.array(example["slopes"]) * _DB, example["lapses"], guess=0.5,
                               shape="gumbel")
    assert len(example["stimuli"]) == len(example["correct"])
    for trial, (stim, correct) in enumerate(zip(example["stimuli"], example["correct"])):
        assert q.next_stimulus() == stim, trial
        q.update(stim, int(correct))
    threshold, slope, lapse = q.mode()
    assert (threshold, slope / _DB, lapse) == pytest.approx(example["mode"])


def test_credible_interval_of_a_normal_posterior():
    # a prior (the posterior before any trial) shaped as N(3, 2) over a fine threshold grid: its
    # central 95 % interval is 3 -+ 1.96 x 2 (scipy's normal quantiles, independent of the code)
    from scipy.stats import norm

    thr = np.linspace(-12.0, 18.0, 3001)
    q = QuestPlus.psychometric([0.0, 1.0], thr, [1.0], prior=norm.pdf(thr, 3.0, 2.0))
    assert q.interval(0) == pytest.approx(norm.ppf([0.025, 0.975], 3.0, 2.0), abs=0.02)
    assert q.interval(1) == (1.0, 1.0)
