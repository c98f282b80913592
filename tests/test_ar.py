"""AR estimation against statsmodels (independent reference implementations)."""

import warnings

import numpy as np
import pytest
from scipy.signal import lfilter, welch
from statsmodels.regression.linear_model import yule_walker as sm_yule_walker
from statsmodels.tsa.stattools import acovf, levinson_durbin as sm_levinson

from surfhap.signal.ar import ar_is_stable, ar_psd, autocovariance, levinson_durbin, select_order, yule_walker

TRUE_PHI = np.array([1.2, -0.75, 0.3, -0.1])


def _ar_signal(n, phi=TRUE_PHI, seed=1, sigma=1.0):
    rng = np.random.default_rng(seed)
    return lfilter([1.0], np.concatenate(([1.0], -phi)), sigma * rng.standard_normal(n))


def _sm_yw(x, order):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sm_yule_walker(x, order, method="mle")


def test_autocovariance_matches_statsmodels():
    x = _ar_signal(5000)
    np.testing.assert_allclose(autocovariance(x, 40), acovf(x, adjusted=False, nlag=40, fft=False), atol=1e-12)


@pytest.mark.parametrize("order", [1, 4, 17, 60])
def test_yule_walker_equals_statsmodels_mle(order):
    x = _ar_signal(20000)
    phi, var = yule_walker(x, order)
    rho, sigma = _sm_yw(x, order)
    np.testing.assert_allclose(phi, rho, atol=1e-10)
    assert var == pytest.approx(sigma**2, rel=1e-10)


def test_levinson_all_orders_match_statsmodels():
    x = _ar_signal(8000)
    r = autocovariance(x, 30)
    lev = levinson_durbin(r, 30)
    _, arcoefs, pacf, sig, phi = sm_levinson(r, nlags=30, isacov=True)
    np.testing.assert_allclose(lev.coefficients[30, :30], arcoefs, atol=1e-10)
    np.testing.assert_allclose(lev.reflection, pacf[1:], atol=1e-10)
    for p in (1, 5, 12):
        np.testing.assert_allclose(lev.order(p)[0], _sm_yw(x, p)[0], atol=1e-10)


def test_aic_picks_true_order_on_long_clean_signal():
    x = _ar_signal(200_000, seed=3)
    sel = select_order(x, max_order=40)
    assert sel.order == TRUE_PHI.size
    np.testing.assert_allclose(sel.coefficients, TRUE_PHI, atol=0.01)
    assert select_order(x, max_order=40, criterion="bic").order == TRUE_PHI.size


def test_ar_psd_matches_welch_of_synthesised_process():
    x = _ar_signal(400_000, sigma=0.5)
    f, p = welch(x, fs=2000.0, nperseg=1024)
    model = ar_psd(TRUE_PHI, 0.25, 2000.0, f)
    band = (f > 5) & (f < 990)
    ratio_db = 10 * np.log10(p[band] / model[band])
    assert abs(np.mean(ratio_db)) < 0.1
    assert np.max(np.abs(ratio_db)) < 1.0


def test_stability_check():
    assert ar_is_stable(TRUE_PHI)
    assert not ar_is_stable([1.0])
    assert not ar_is_stable([2.0, -0.5])


def test_select_order_rejects_bad_input():
    with pytest.raises(ValueError):
        select_order(np.r_[1.0, np.nan, np.zeros(500)], 10)
    with pytest.raises(ValueError):
        select_order(np.ones(20), 30)
