"""Pooled vs per-participant figures say which they are, and every interval they draw lies
within [0, 1]: the drawn error bars against statsmodels' / scipy's intervals computed here."""

import numpy as np
import pytest
from matplotlib.container import ErrorbarContainer
from scipy.stats import bootstrap
from statsmodels.stats.proportion import proportion_confint

from surfhap.lab.analysis import confusion, participant_means, proportions


def _bars(fig):
    """(k, 2) the drawn lower and upper ends of each error bar."""
    (eb,) = [c for c in fig.axes[0].containers if isinstance(c, ErrorbarContainer)]
    return np.array([sorted(seg[:, 1]) for seg in eb.lines[2][0].get_segments()])


@pytest.mark.parametrize("method,sm", [("wilson", "wilson"), ("beta", "beta")])
def test_pooled_bars_say_trials_pooled_and_draw_statsmodels_intervals(method, sm):
    k, n = np.array([28, 10, 0]), np.array([28, 30, 20])
    fig = proportions(k, n, ["a", "b", "c"], method=method, title="correct").plot()
    title = fig.axes[0].get_title()
    assert "trials pooled, n = 78" in title and ("Wilson" if method == "wilson" else "Clopper-Pearson") in title
    lo, hi = proportion_confint(k, n, alpha=0.05, method=sm)
    ends = _bars(fig)
    assert ends[:, 0] == pytest.approx(lo, abs=1e-12) and ends[:, 1] == pytest.approx(hi, abs=1e-12)
    assert np.all((ends >= 0) & (ends <= 1))


def test_participant_bars_say_mean_of_n_participants_and_stay_within_0_1():
    """Otake et al. 2022 Table II cork (.96 +- .07, 13 participants twice, one once): the printed
    normal interval passes 1 (the old bars drew 1.03); the bootstrap over participants matches
    scipy's percentile bootstrap and ends at 1."""
    values = [[1.0] * 13 + [0.5], [0.5] + [0.0] * 13, [0.5, 1.0, 0.0, 0.5, 1.0, 0.5, 0.5, 0.0, 1.0, 0.5, 0.5, 1.0, 0.5, 0.0]]
    res = participant_means(values, ["cork", "wood", "denim"], title="chose friction+texture")
    fig = res.plot(chance=0.5)
    assert "mean of 14 participants" in fig.axes[0].get_title() and "trials pooled" not in fig.axes[0].get_title()
    ends = _bars(fig)
    assert np.all((ends >= 0) & (ends <= 1))
    for (lo, hi), v in zip(ends, values):
        ref = bootstrap((np.array(v),), np.mean, method="percentile", n_resamples=9999,
                        random_state=np.random.default_rng(1)).confidence_interval
        assert lo == pytest.approx(ref.low, abs=0.03) and hi == pytest.approx(ref.high, abs=0.03)
    assert ends[0, 1] == 1.0 and ends[1, 0] == 0.0


def test_the_confusion_matrix_says_trials_pooled_with_its_n():
    conf = confusion(["a", "a", "b", "b", "b"], ["a", "b", "b", "b", "a"], ["a", "b"], title="friction-only")
    assert "trials pooled, n = 5" in conf.plot().axes[0].get_title()
