"""Psychometric-function fitting: against statsmodels' binomial GLM (no guess, no lapse),
recovery of known parameters within the bootstrap interval, and input checks."""

import numpy as np
import pytest
import statsmodels.api as sm
from scipy.stats import norm

from surfhap.errors import ConfigError
from surfhap.lab.psychometric import fit_psychometric, psychometric

LEVELS = np.linspace(-2.0, 3.0, 8)
TRIALS = np.full(8, 40)


def _glm(levels, trials, correct, link):
    """(threshold, slope) = (-b0/b1, b1) of the binomial GLM with ``link``."""
    endog = np.column_stack([correct, trials - correct])
    res = sm.GLM(endog, sm.add_constant(levels), family=sm.families.Binomial(link=link)).fit(tol=1e-12)
    b0, b1 = res.params
    return -b0 / b1, b1


@pytest.mark.parametrize(("shape", "link", "cdf"), [
    ("logistic", sm.families.links.Logit(), lambda z: 1 / (1 + np.exp(-z))),
    ("normal", sm.families.links.Probit(), norm.cdf),
])
def test_no_guess_no_lapse_equals_glm(shape, link, cdf):
    rng = np.random.default_rng(1)
    correct = rng.binomial(TRIALS, cdf(1.3 * (LEVELS - 0.4)))
    fit = fit_psychometric(LEVELS, TRIALS, correct, shape=shape)
    threshold, slope = _glm(LEVELS, TRIALS, correct, link)
    assert fit.threshold == pytest.approx(threshold, abs=1e-4)
    assert fit.slope == pytest.approx(slope, abs=1e-4)


def test_weibull_is_gumbel_in_log_units():
    x = np.geomspace(0.5, 8.0, 7)
    # the Weibull law written out, independently of the module
    assert np.allclose(psychometric(x, 2.0, 3.0, 0.5, 0.02, "weibull"),
                       0.5 + 0.48 * (1 - np.exp(-(x / 2.0) ** 3.0)))
    correct = np.array([12, 14, 18, 27, 35, 39, 40])
    w = fit_psychometric(x, np.full(7, 40), correct, shape="weibull", guess=0.5)
    g = fit_psychometric(np.log(x), np.full(7, 40), correct, shape="gumbel", guess=0.5)
    assert np.log(w.threshold) == pytest.approx(g.threshold, abs=1e-5)
    assert w.slope == pytest.approx(g.slope, rel=1e-4)


@pytest.mark.parametrize(("shape", "truth"), [
    ("logistic", dict(threshold=0.5, slope=2.0, lapse=0.05)),
    ("weibull", dict(threshold=3.0, slope=2.5, lapse=0.04)),
])
def test_recovers_known_parameters_inside_bootstrap_ci(shape, truth):
    levels = np.geomspace(0.5, 12.0, 9) if shape == "weibull" else np.linspace(-2.0, 3.0, 9)
    trials = np.full(levels.size, 300)
    guess = 1 / 3
    rng = np.random.default_rng(2)  # one fixed draw: a 95 % CI misses ~5 % of draws
    correct = rng.binomial(trials, psychometric(levels, truth["threshold"], truth["slope"], guess,
                                                truth["lapse"], shape))
    fit = fit_psychometric(levels, trials, correct, shape=shape, guess=guess, lapse=None, n_boot=100, seed=3)
    for name, value in truth.items():
        lo, hi = fit.ci[name]
        assert lo <= value <= hi, (name, value, fit.ci[name])
    assert 0.0 <= fit.lapse <= 0.1
    assert set(fit.to_dict()) >= {"threshold", "slope", "lapse", "ci", "levels", "correct"}


def test_bootstrap_is_seeded_and_fixed_lapse_has_no_lapse_ci():
    correct = np.array([20, 22, 25, 30, 35, 38, 39, 40])
    a = fit_psychometric(LEVELS, TRIALS, correct, guess=0.5, lapse=0.02, n_boot=20, seed=5)
    b = fit_psychometric(LEVELS, TRIALS, correct, guess=0.5, lapse=0.02, n_boot=20,
                         seed=np.random.default_rng(5))
    assert a.ci == b.ci and set(a.ci) == {"threshold", "slope"} and a.lapse == 0.02


@pytest.mark.parametrize(("kwargs", "field"), [
    (dict(trials=np.full(8, -1)), "trials"),
    (dict(correct=np.full(8, 41)), "correct"),
    (dict(correct=np.ones(7, int)), "correct"),
    (dict(trials=np.full(8, 2.5)), "trials"),
    (dict(levels=np.ones((2, 4))), "levels"),
    (dict(lapse=0.2), "lapse"),
    (dict(guess=1.0), "guess"),
    (dict(shape="probit"), "shape"),
    (dict(shape="weibull"), "levels"),
])
def test_bad_input_names_the_argument(kwargs, field):
    args = dict(levels=LEVELS, trials=TRIALS, correct=np.full(8, 20)) | kwargs
    with pytest.raises(ConfigError) as err:
        fit_psychometric(**args)
    assert err.value.field == field


def test_plot_draws_curve_and_ci():
    correct = np.array([20, 22, 25, 30, 35, 38, 39, 40])
    fit = fit_psychometric(LEVELS, TRIALS, correct, guess=0.5, n_boot=10)
    fig = fit.plot()
    assert len(fig.axes) == 1 and fig.axes[0].get_lines()
