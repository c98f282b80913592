"""Acceleration route: segmentation of piecewise-AR signals, interpolated bank from segments."""

import numpy as np
import pytest

from surfhap.errors import RecordingFormatError
from surfhap.exchange.material_json import read_material_json, write_material_json
from surfhap.fit.accel import fit_accel
from surfhap.fit.synthetic import piecewise_ar, synthetic_accel_recording
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.signal.ar import ar_psd
from surfhap.signal.segmentation import segment_ar


def resonance(f, r, fs=1000.0):
    th = 2 * np.pi * f / fs
    return np.array([2 * r * np.cos(th), -r * r])


PIECES = [(resonance(100, 0.9), 1.0, 3000, 0.05, 0.5), (resonance(200, 0.8), 2.0, 3000, 0.15, 0.5),
          (resonance(150, 0.85), 1.5, 3000, 0.05, 1.5), (resonance(250, 0.9), 3.0, 3000, 0.15, 1.5)]


def test_segmentation_finds_the_true_breaks():
    x, cps = piecewise_ar([([0.9], 1.0, 3000), ([-0.5, 0.3], 1.0, 2500), ([1.3, -0.8], 0.5, 4000), ([0.2], 4.0, 3000)], seed=2)
    seg = segment_ar(x, max_order=10, step=25)
    assert seg.change_points.size == cps.size
    assert np.max(np.abs(seg.change_points - cps)) <= 25
    np.testing.assert_array_equal(seg.orders, [1, 2, 2, 1])


def test_stationary_signal_is_one_segment():
    x = np.random.default_rng(0).standard_normal(4000)
    seg = segment_ar(x, max_order=8)
    assert seg.segments == [(0, 4000)] and seg.orders[0] == 0


@pytest.fixture(scope="module")
def accel_fit():
    rec = synthetic_accel_recording(PIECES, mu=0.4, seed=1)
    return fit_accel([rec], "tool", highpass=0.0, max_order=10)


def test_accel_fit_recovers_segment_spectra(accel_fit):
    fit = accel_fit
    assert len(fit.segments) == 4 and fit.order == 2
    assert fit.mu0 == pytest.approx(0.4)
    f = np.linspace(20, 480, 100)
    for phi, var, _, v, force in PIECES:
        d = 10 * np.log10(fit.bank.psd_at(v, force, f) / ar_psd(phi, var, 1000.0, f))
        assert np.max(np.abs(d)) < 1.0
    assert fit.bank.psd_at(0.0, 1.0, f).max() == 0.0  # zero-variance edge


def test_accel_material_round_trip_and_zhao_render(accel_fit, tmp_path):
    mat = accel_fit.to_material(command="surfhap fit accel test")
    back = read_material_json(write_material_json(mat, tmp_path / "tool.json"))
    assert back.spec.texture.kind == "interpolated-arma" and back.texture.quantity == "acceleration"
    chain = TextureChain(back, ChainConfig(method="zhao"))
    out = chain.process(np.full(1000, 0.1), np.full(1000, 1.0), np.zeros(1000))
    assert np.std(out.texture) > 0 and np.all(np.isfinite(out.drive))


def test_accel_needs_mu_source():
    rec = synthetic_accel_recording(PIECES[:2], seed=1)
    with pytest.raises(RecordingFormatError) as err:
        fit_accel([rec], "tool", highpass=0.0, max_order=6)
    assert err.value.field == "shear_force"
    assert fit_accel([rec], "tool", highpass=0.0, max_order=6, mu0=0.3).mu0 == 0.3
