"""High-band pieces: spectra averaging, similarity index, Burg, splicing, AIC on clean signals."""

import numpy as np
import pytest
from scipy.signal import periodogram, welch
from statsmodels.regression.linear_model import burg as sm_burg
from statsmodels.tsa.stattools import acovf

from surfhap.fit.synthetic import ar_process
from surfhap.fit.texture import fit_velocity_texture
from surfhap.signal.ar import ar_psd
from surfhap.signal.burg import burg, burg_all_orders, select_order_burg
from surfhap.signal.spectra import average_spectra, similarity_index, welch_spans
from surfhap.signal.splice import speed_spans, splice, true_runs

PHI4 = np.array([1.1, -0.75, 0.35, -0.2])  # a stable AR(4)


def test_average_spectra_is_mean_of_participant_autocovariances():
    rng = np.random.default_rng(0)
    groups = [[rng.standard_normal(n) for n in (300, 500, 120)], [rng.standard_normal(n) for n in (800, 250)]]
    avg = average_spectra(groups, 2000.0, max_lag=20)
    ref = []
    for g in groups:
        n_g = sum(s.size for s in g)
        ref.append(sum(acovf(s - s.mean(), adjusted=False, demean=False, fft=False)[:21] * s.size for s in g) / n_g)
    np.testing.assert_allclose(avg.autocovariance, np.mean(ref, axis=0), atol=1e-12)
    assert avg.n_samples == 1970 and avg.n_groups == 2


def test_welch_spans_matches_scipy_on_one_long_span():
    x = np.random.default_rng(1).standard_normal(5000)
    f, p = welch_spans([x], 1000.0, nperseg=256)
    f2, p2 = welch(x, 1000.0, nperseg=256)
    np.testing.assert_allclose(f, f2)
    np.testing.assert_allclose(p, p2, rtol=1e-10)


def test_welch_spans_of_long_and_short_spans_weights_every_window_equally():
    # reference: scipy's Welch of each long span counts once per window, a short span is one
    # Hann periodogram zero-padded to nperseg; spans in mixed order (they are FFT'd in chunks)
    rng = np.random.default_rng(2)
    spans = [rng.standard_normal(n) for n in (700, 100, 256, 40, 1500, 10, 300)]
    f, p = welch_spans(spans, 1000.0, nperseg=256)
    total, count = 0.0, 0
    for s in spans:
        if s.size >= 256:
            k = 1 + (s.size - 256) // 128
            total, count = total + k * welch(s, 1000.0, nperseg=256)[1], count + k
        elif s.size >= 16:
            total, count = total + periodogram(s, 1000.0, window="hann", nfft=256)[1], count + 1
    np.testing.assert_allclose(p, total / count, rtol=1e-10)


def test_similarity_index_properties():
    f = np.linspace(0, 500, 101)
    s = 1.0 / (1 + (f / 50) ** 2)
    assert similarity_index(f, s, s) == pytest.approx(1.0)
    assert similarity_index(f, 2 * s, s) == pytest.approx(2 / 3)
    a = np.where(f < 100, 1.0, 0.0)
    assert similarity_index(f, a, 1 - a) == pytest.approx(0.0)
    assert similarity_index(f, s, 3 * s) == pytest.approx(similarity_index(f, 3 * s, s))


def test_burg_matches_statsmodels():
    x = ar_process(PHI4, 1.0, 4000, np.random.default_rng(2))
    for order in (1, 4, 9):
        phi, var = burg(x, order)
        ref_phi, ref_var = sm_burg(x, order, demean=True)
        np.testing.assert_allclose(phi, ref_phi, atol=1e-10)
        assert var == pytest.approx(ref_var, rel=1e-10)


def test_multisegment_burg_recovers_model_from_short_spans():
    rng = np.random.default_rng(3)
    x = ar_process(PHI4, 1.0, 60000, rng)
    spans = [x[i : i + 200] for i in range(0, 60000, 300)]
    sel = select_order_burg(spans, max_order=15)
    assert sel.order >= 4
    f = np.linspace(5, 490, 100)
    d = 10 * np.log10(ar_psd(sel.coefficients, sel.variance, 1000, f) / ar_psd(PHI4, 1.0, 1000, f))
    assert np.max(np.abs(d)) < 1.0
    assert burg_all_orders(spans, 4).variances.shape == (5,)


def test_speed_spans_and_splice():
    fs = 1000.0
    v = np.r_[np.full(150, 0.05), np.full(50, 0.09), np.full(80, 0.06), np.full(300, 0.045)]
    spans = speed_spans(v, fs, 0.05, tolerance=0.02, min_duration=0.1)
    np.testing.assert_array_equal(spans, [[0, 150], [200, 580]])
    valid = np.ones(v.size, bool)
    valid[400] = False
    np.testing.assert_array_equal(speed_spans(v, fs, 0.05, valid=valid), [[0, 150], [200, 400], [401, 580]])
    assert [p.size for p in splice(np.arange(580), spans)] == [150, 380]
    np.testing.assert_array_equal(true_runs([0, 1, 1, 0, 1], 2), [[1, 3]])


def test_runs_cut_at_breaks_equal_the_runs_of_each_piece():
    # reference: true_runs of every piece on its own (how the friction fit found spans run by run)
    rng = np.random.default_rng(3)
    mask = rng.uniform(size=3000) < 0.9
    starts = np.array([0, 400, 401, 1000, 2500])
    ref = np.concatenate([true_runs(mask[a:b], 5) + a for a, b in zip(starts, np.r_[starts[1:], mask.size])])
    np.testing.assert_array_equal(true_runs(mask, 5, breaks=starts), ref)
    spans = speed_spans(np.full(300, 0.05), 1000.0, 0.05, min_duration=0.05, breaks=np.array([0, 120]))
    np.testing.assert_array_equal(spans, [[0, 120], [120, 300]])


@pytest.mark.parametrize("criterion", ["aic", "bic"])
def test_order_criterion_picks_true_order_on_long_clean_signals(criterion):
    rng = np.random.default_rng(11)
    groups = [[ar_process(PHI4, 2e-6, 4000, rng) for _ in range(10)] for _ in range(3)]
    tex = fit_velocity_texture(groups, ["A", "B", "C"], 2000.0, 0.1, max_order=30, criterion=criterion)
    assert tex.model.order == 4
    np.testing.assert_allclose(tex.model.coefficients, PHI4, atol=0.02)
    assert tex.similarity_mean > 0.85 and tex.model.reference_speed == 0.1


def test_burg_estimator_in_velocity_fit():
    rng = np.random.default_rng(12)
    groups = [[ar_process(PHI4, 1.0, 3000, rng) for _ in range(5)] for _ in range(2)]
    tex = fit_velocity_texture(groups, ["A", "B"], 1000.0, 0.05, max_order=20, estimator="burg")
    assert tex.estimator == "burg" and tex.model.order >= 4
    with pytest.raises(ValueError):
        fit_velocity_texture(groups, ["A", "B"], 1000.0, 0.05, estimator="magic")
