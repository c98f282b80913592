"""The one band split (signal.bands.BandSplit), the one AR spectrum (signal.ar.ar_psd) and the
texture interface (models.texture.TextureModel), checked against independent references: the
analytic Butterworth response, scipy.signal.freqz and statsmodels."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.signal import butter, freqz, periodogram, sosfilt_zi, sosfiltfilt
from statsmodels.tsa.arima_process import arma_acovf

from surfhap.models.interpolated import InterpolatedARMABank
from surfhap.models.texture import ARModel, TextureBank
from surfhap.signal.ar import ar_moments, ar_psd
from surfhap.signal.bands import BandSplit
from surfhap.signal.filters import sos_filtfilt
from surfhap.signal.lsf import ar_to_lsf


def _butter_h2(f, fs, fc=3.5, order=4):
    """|H|^2 of a digital Butterworth low-pass (bilinear transform, pre-warped corner), written out."""
    return 1.0 / (1.0 + (np.tan(np.pi * np.asarray(f) / fs) / np.tan(np.pi * fc / fs)) ** (2 * order))


def _amplitude(y, f0, fs):
    """Least-squares amplitude of the f0 sinusoid in y."""
    t = np.arange(y.size) / fs
    basis = np.column_stack([np.sin(2 * np.pi * f0 * t), np.cos(2 * np.pi * f0 * t)])
    return float(np.hypot(*np.linalg.lstsq(basis, y, rcond=None)[0]))


@pytest.mark.parametrize("f0", [1.0, 3.5, 6.0, 100.0])
def test_sinusoids_split_as_the_analytic_butterworth_response(f0):
    fs = 1000.0
    x = np.sin(2 * np.pi * f0 * np.arange(int(20 * fs)) / fs + 0.3)
    low, high = BandSplit().split(x, fs)
    mid = slice(int(5 * fs), int(15 * fs))
    h2 = _butter_h2(f0, fs)  # forward and backward: amplitude gain |H|^2, the texture band's 1 - |H|^2
    assert _amplitude(low[mid], f0, fs) == pytest.approx(h2, abs=1e-4)
    assert _amplitude(high[mid], f0, fs) == pytest.approx(1.0 - h2, abs=1e-4)
    np.testing.assert_allclose(low + high, x, rtol=0, atol=1e-12)
    assert BandSplit().high_gain(np.array([f0]), fs)[0] == pytest.approx((1.0 - h2) ** 2, rel=1e-9, abs=1e-15)


def test_one_hertz_stays_low_and_a_hundred_hertz_high():
    fs = 1000.0
    t = np.arange(int(10 * fs)) / fs
    slow, fast = np.sin(2 * np.pi * t), 0.2 * np.sin(2 * np.pi * 100 * t)
    low, high = BandSplit().split(2.0 + slow + fast, fs)
    mid = slice(int(2 * fs), int(8 * fs))
    assert np.max(np.abs(low[mid] - 2.0 - slow[mid])) < 1e-3
    assert np.max(np.abs(high[mid] - fast[mid])) < 1e-3


def _edge_rise(high, m):
    """Mean square of the texture band's mean over the first and last m samples, over that of
    windows in the middle: a low-frequency transient at the ends raises it above 1."""
    edge = np.mean(np.concatenate([high[:, :m].mean(axis=1), high[:, -m:].mean(axis=1)]) ** 2)
    n = high.shape[1]
    mid = np.mean(np.stack([high[:, a:a + m].mean(axis=1) for a in range(n // 4, 3 * n // 4 - m, m)]) ** 2)
    return edge / mid


def test_no_false_low_frequency_rise_at_the_ends_of_a_noisy_offset():
    # a constant offset with noise (an acceleration, a textured CoF) at the HapMat rate: the
    # texture band must hold no transient at the ends. The old fit/imu.py path (scipy's default
    # odd padding through the edge sample) carried a step of ~2 noise sd into the filter.
    fs, n, cut = 100.0, 400, 3.5
    x = 5.0 + np.random.default_rng(1).standard_normal((400, n))
    m = int(round(fs / cut))
    ours = BandSplit(cutoff=cut).high(x, fs)
    old = x - sosfiltfilt(butter(4, cut, fs=fs, output="sos"), x, axis=-1)
    assert _edge_rise(old, m) > 3.0  # the test sees the bug
    assert _edge_rise(ours, m) < 1.5
    # the same in the spectrum: the texture band's periodogram from 2 to 5 Hz over the analytic
    # expectation (white noise through (1 - |H|^2)^2)
    f, p_ours = periodogram(ours, fs=fs, axis=-1)
    _, p_old = periodogram(old, fs=fs, axis=-1)
    sel = (f >= 2.0) & (f < 5.0)
    expected = np.sum(2.0 / fs * (1.0 - _butter_h2(f[sel], fs, cut)) ** 2)
    assert np.sum(p_old.mean(axis=0)[sel]) / expected > 1.15
    assert 0.85 < np.sum(p_ours.mean(axis=0)[sel]) / expected < 1.1
    # a constant, or a line, passes into the low band whole
    np.testing.assert_allclose(BandSplit().high(np.full(500, 3.0), fs), 0.0, atol=1e-12)
    line = 0.3 + 0.05 * np.arange(3000) / 2000.0
    np.testing.assert_allclose(BandSplit().low(line, 2000.0), line, atol=1e-4)


def test_band_split_rejects_a_cutoff_above_nyquist():
    with pytest.raises(ValueError, match="cutoff"):
        BandSplit(cutoff=60.0).low(np.zeros(100), 100.0)
    with pytest.raises(ValueError, match="cutoff"):
        BandSplit(cutoff=-1.0).high(np.zeros(100), 100.0)


# ---------------------------------------------------------------- the AR spectrum

PHI = np.array([1.2, -0.8, 0.3])
THETA = np.array([0.5, -0.2])


@pytest.mark.parametrize("ma", [(), THETA])
def test_ar_psd_matches_scipy_freqz(ma):
    fs, var = 1000.0, 0.3
    f = np.linspace(0.0, fs / 2, 257)
    _, h = freqz(np.r_[1.0, ma], np.r_[1.0, -PHI], worN=f, fs=fs)
    np.testing.assert_allclose(ar_psd(PHI, var, fs, f, ma), 2.0 * var / fs * np.abs(h) ** 2, rtol=1e-10)


@pytest.mark.parametrize("ma", [(), THETA])
def test_ar_moments_match_statsmodels_and_quadrature(ma):
    fs, var = 200.0, 0.3
    sd, slope = ar_moments(PHI, var, fs, ma)
    ref = arma_acovf(np.r_[1.0, -PHI], np.r_[1.0, ma], nobs=1, sigma2=var)[0]
    assert sd == pytest.approx(np.sqrt(ref), rel=1e-6)

    def integrand(f):
        _, h = freqz(np.r_[1.0, ma], np.r_[1.0, -PHI], worN=[f], fs=fs)
        return 2.0 * var / fs * abs(h[0]) ** 2 * (2 * np.pi * f) ** 2

    assert slope == pytest.approx(np.sqrt(quad(integrand, 0.0, fs / 2, limit=200)[0]), rel=1e-6)


# ---------------------------------------------------------------- the texture interface

def test_both_banks_give_the_model_psd_at_a_speed_and_load():
    fs = 1000.0
    f = np.linspace(1.0, 490.0, 64)
    slow, fast = ARModel(PHI, 0.2, 0.05), ARModel(np.array([0.5]), 0.1, 0.2)
    bank = TextureBank("cof", fs, (fast, slow))
    _, h = freqz([1.0], [1.0, -0.5], worN=f, fs=fs)
    np.testing.assert_allclose(bank.psd_at(0.18, 1.0, f), 2.0 * 0.1 / fs * np.abs(h) ** 2, rtol=1e-10)
    assert tuple(bank.moments_at(np.array([0.06, 0.06]), np.array([1.0, 2.0])).T[1]) == slow.moments(fs)

    lsf = ar_to_lsf(PHI)
    hatt = InterpolatedARMABank.from_models("acceleration", fs, [0.01, 0.05, 0.01], [0.5, 0.5, 2.0], np.stack([lsf] * 3),
                                            [0.2, 0.4, 0.6], gains=[2.0, 1.0, 1.0])
    _, h = freqz([1.0], np.r_[1.0, -PHI], worN=f, fs=fs)
    np.testing.assert_allclose(hatt.psd_at(0.01, 0.5, f), 2.0 * 0.2 * 4.0 / fs * np.abs(h) ** 2, rtol=1e-8)
    (sd,), _ = hatt.moments_at(np.array([0.01]), np.array([0.5]))
    assert sd == pytest.approx(np.sqrt(arma_acovf(np.r_[1.0, -PHI], np.array([1.0]), nobs=1, sigma2=0.8)[0]), rel=1e-5)


def test_calibration_std_is_what_the_split_measures_on_the_synthesised_texture():
    # the texture calibration's sd(x) is the sd of the model's output in the texture band the
    # fidelity metric measures (before: a brick wall at 3.5 Hz, 4.6 % above it for drawing-paper)
    from scipy.signal import lfilter

    from surfhap.exchange.materials import load_material
    from surfhap.models.texture_calibration import texture_band_std

    tex = load_material("drawing-paper").texture
    m, fs = tex.models[0], tex.sample_rate
    x = lfilter([1.0], np.r_[1.0, -m.coefficients], np.sqrt(m.variance) * np.random.default_rng(5).standard_normal(2_000_000))
    measured = float(np.std(BandSplit().high(x[5000:], fs)))
    assert texture_band_std(m.coefficients, m.variance, fs, 3.5) == pytest.approx(measured, rel=0.015)


@pytest.mark.parametrize("order, cutoff, fs", [(4, 3.5, 2000.0), (1, 2.5, 1000.0), (8, 20.0, 500.0)])
def test_compiled_filtfilt_equals_scipy_sosfiltfilt_sample_for_sample(order, cutoff, fs):
    # the compiled forward-backward pass of BandSplit (signal.filters.sos_filtfilt) repeats
    # scipy's sosfilt recursion operation for operation: equal to the last bit on this machine
    # (rtol 1e-13 leaves room for a libm or compiler that rounds one step differently)
    sos = butter(order, cutoff, fs=fs, output="sos")
    x = np.random.default_rng(order).standard_normal((3, 4687)).cumsum(axis=1)
    np.testing.assert_allclose(sos_filtfilt(sos, sosfilt_zi(sos), x), sosfiltfilt(sos, x, axis=-1, padtype=None), rtol=1e-13,
                               atol=1e-13)
