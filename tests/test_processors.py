"""Streaming processors: block-size invariance, seeding, continuity, resampling quality."""

import numpy as np
import pytest
from scipy.signal import freqz, lfilter, lfiltic, upfirdn

from surfhap.models.electrostatics import EPSILON_0, ElectrostaticStack, electrostatic_constant
from surfhap.models.panel import DisplayModel, SimulatedDisplay
from surfhap.models.synth import ARSynthesizer
from surfhap.models.texture import ARModel, TextureBank
from surfhap.signal.ar import yule_walker
from surfhap.signal.resample import RationalResampler

BANK = TextureBank("cof", 2000.0, (ARModel([1.5, -0.7], 1e-4, 0.05), ARModel([0.3], 4e-4, 0.1), ARModel([0.9, -0.2], 2e-4, 0.15)))


def _blocks(proc, x, sizes):
    out, i = [], 0
    while i < x.size:
        for b in sizes:
            out.append(proc.process(x[i:i + b]))
            i += b
    return np.concatenate(out)


def test_synth_same_seed_same_output_any_blocks():
    speed = np.linspace(0.0, 0.2, 5000)
    a = ARSynthesizer(BANK, seed=7).process(speed)
    b = _blocks(ARSynthesizer(BANK, seed=7), speed, [1, 7, 64, 3])[: speed.size]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, ARSynthesizer(BANK, seed=8).process(speed))


def test_synth_keeps_history_across_model_switch():
    """At a switch the new recursion continues from the shared output history (no reset)."""
    synth = ARSynthesizer(BANK, seed=1)
    speed = np.r_[np.full(1000, 0.05), np.full(1000, 0.15)]
    y = synth.process(speed)
    np.testing.assert_array_equal(synth.model_index, np.r_[np.zeros(1000, int), np.full(1000, 2)])
    noise = np.random.default_rng(1).standard_normal(2000)
    k = 1000
    phi = BANK.models[2].coefficients
    expected = phi[0] * y[k - 1] + phi[1] * y[k - 2] + np.sqrt(2e-4) * noise[k]
    assert y[k] == pytest.approx(expected, rel=1e-12)


def test_synth_equals_lfilter_on_its_noise_across_model_switches():
    """The compiled recursion (a vectorised sum, the newest output last) against scipy's lfilter
    on the same noise: each run of one model filtered from the previous outputs (lfiltic), for
    models of orders 37, 5 and 12 (zero-padded taps), blocks of any length; within 1e-9 of the RMS."""
    rng = np.random.default_rng(4)
    phis = [yule_walker(np.convolve(rng.standard_normal(20000), np.hanning(w), mode="same"), p)[0]
            for w, p in ((9, 37), (5, 5), (13, 12))]
    bank = TextureBank("cof", 2000.0, tuple(ARModel(phi, v, s) for phi, v, s in zip(phis, (1e-4, 4e-4, 2e-4), (0.05, 0.1, 0.15))))
    runs = rng.integers(1, 400, 40)
    models = np.repeat(rng.integers(0, 3, runs.size), runs)
    speed = np.array([0.05, 0.1, 0.15])[models]
    y = _blocks(ARSynthesizer(bank, seed=9), speed, [1, 500, 37, 2, 3000])[:speed.size]
    noise = np.random.default_rng(9).standard_normal(speed.size)
    ref = np.zeros(speed.size)
    for i0 in np.r_[0, np.cumsum(runs)[:-1]]:
        i1 = i0 + np.argmax(np.r_[models[i0:] != models[i0], True])
        m = bank.models[models[i0]]
        a = np.r_[1.0, -np.asarray(m.coefficients)]
        past = np.r_[ref[:i0][::-1], np.zeros(m.order)][:m.order]
        ref[i0:i1] = lfilter([np.sqrt(m.variance)], a, noise[i0:i1], zi=lfiltic([np.sqrt(m.variance)], a, past))[0]
    rms = np.sqrt(np.mean(ref ** 2))
    assert np.max(np.abs(y - ref)) <= 1e-9 * rms


def test_resampler_matches_scipy_upfirdn_and_is_flat():
    x = np.random.default_rng(0).standard_normal(4000)
    up = RationalResampler(2000, 20000)
    y = _blocks(up, x, [3, 50, 1])[: x.size * 10]
    np.testing.assert_allclose(y, RationalResampler(2000, 20000).process(x), atol=1e-12)
    h = up._H.T.reshape(-1)
    np.testing.assert_allclose(y, upfirdn(h, x, up=10)[: y.size], atol=1e-12)
    h = h / up.L
    _, resp = freqz(h, worN=np.linspace(1, 0.25 * 2000, 50), fs=20000)
    assert np.max(np.abs(20 * np.log10(np.abs(resp)))) < 0.01
    down = RationalResampler(20000, 2000)
    assert down.process(np.ones(20000))[-100:] == pytest.approx(1.0, abs=1e-3)


def test_rational_resampler_44k1():
    r = RationalResampler(2000, 44100)
    y = np.concatenate([r.process(np.ones(100)) for _ in range(20)])
    assert y.size == 2000 * 441 // 20
    assert np.allclose(y[500:], 1.0, atol=2e-3)


def test_electrostatic_constant_eq1():
    s = ElectrostaticStack(contact_area=2e-4, insulator_thickness=10e-6, insulator_permittivity=3.0,
                           stratum_corneum_thickness=30e-6, stratum_corneum_permittivity=50.0)
    expected = EPSILON_0 * 2e-4 / (2 * (10e-6 / 3.0 + 30e-6 / 50.0) * (40e-6))
    assert electrostatic_constant(s) == pytest.approx(expected, rel=1e-14)


def test_dc_fades_and_carrier_does_not():
    fs = 20000
    model = DisplayModel()
    n = fs  # 1 s
    load = np.full(n, 0.5)
    dc = SimulatedDisplay(model, fs, 2000).process(np.full(n, 150.0), load)
    sq = np.where((np.arange(n) // 5) % 2 == 0, 150.0, -150.0)
    ac = SimulatedDisplay(model, fs, 2000).process(sq, load)
    full = model.mu_panel * (0.5 + model.k * 150.0**2)
    bare = model.mu_panel * 0.5
    assert ac[-200:].mean() == pytest.approx(full, rel=5e-3)
    assert dc[-200:].mean() < bare + 0.05 * (full - bare)
