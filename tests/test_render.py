"""End to end on the simulated display: the rendered friction reproduces its target."""

import dataclasses

import numpy as np
import pytest

from surfhap import ChainConfig, constant_scan, load_material, strokes
from surfhap.texture import render
from surfhap.models.texture import ARModel, TextureBank
from surfhap.models.trajectory import Trajectory
from surfhap.report.figures import render_spectrum
from surfhap.signal.bands import spectral_deviation_db

# a textural-CoF model at Otake's 2 kHz control rate (synthetic ground truth, not a material)
TRUTH = TextureBank("cof", 2000.0, (ARModel([1.3, -0.62, 0.1], 2.5e-5, 0.1),))


@pytest.fixture(scope="module")
def cork_with_known_texture():
    # the built-in cork's texture calibration belongs to its own texture: drop it with the texture
    return dataclasses.replace(load_material("cork"), texture=TRUTH, texture_relative_scale=None)


@pytest.fixture(scope="module")
def long_scan(cork_with_known_texture):
    return render(cork_with_known_texture, constant_scan(0.1, 0.3, 60.0), ChainConfig(seed=3))


def test_low_band_equals_quasi_static_law(long_scan):
    r = long_scan
    expected = load_material("cork").quasi_static.coefficient([0.3], [0.1])[0] * 0.3
    warm = r.t > 1.0
    # the display adds the law's force times the planned rendering gain G = (alpha / alpha_calibrated)^2
    assert r.rendering_gain < 1.0 and r.alpha == pytest.approx(r.plan.alpha)
    assert np.mean(r.added_friction[warm]) == pytest.approx(r.rendering_gain * expected, rel=2e-3)
    assert r.summary()["clipped_fraction"] == 0.0
    assert r.summary()["max_abs_voltage"] <= 250.0


def test_high_band_follows_ar_model_within_1_5_db(long_scan):
    f, p, e = render_spectrum(long_scan)
    centres, dev = spectral_deviation_db(f, p, e, 3.5, 500.0)
    assert centres.size >= 20
    assert np.max(np.abs(dev)) <= 1.5, dict(zip(np.round(centres), np.round(dev, 2)))


@pytest.mark.parametrize("method", ["otake2022", "otake2021", "zhao", "friction-only", "square"])
def test_every_method_renders_within_limits(method, cork_with_known_texture):
    r = render(cork_with_known_texture, strokes(0.12, 0.4, 2.0), ChainConfig(method=method, drive_rate=16000))
    assert r.method == method
    assert np.all(np.abs(r.drive) <= 250.0)
    assert np.all(np.isfinite(r.friction_sim))
    assert r.drive.size == r.t.size * 8
    if method == "friction-only":
        assert np.all(r.mu_tex == 0)


def test_square_baseline_mean_matches_friction_only(cork_with_known_texture):
    traj = constant_scan(0.1, 0.3, 3.0)
    # the same alpha for both, and the square's reference point at the scan's load and speed
    sq = render(cork_with_known_texture, traj, ChainConfig(method="square", square_frequency=100.0, alpha=300.0,
                                                           square_reference_load=0.3, square_reference_speed=0.1))
    fo = render(cork_with_known_texture, traj, ChainConfig(method="friction-only", alpha=300.0))
    warm = sq.t > 0.5
    # band-limiting the gate at the control rate removes the harmonics above 900 Hz (~2.5 % of its power)
    assert np.mean(sq.added_friction[warm]) == pytest.approx(np.mean(fo.added_friction[warm]), rel=0.04)
    f, p, _ = render_spectrum(sq)
    assert f[np.argmax(p * (f > 20))] == pytest.approx(100.0, abs=2.0)


def test_zhao_law_with_acceleration_texture():
    leather = load_material("leather")
    assert leather.texture.quantity == "acceleration"
    r = render(leather, constant_scan(0.1, 0.3, 3.0), ChainConfig(method="zhao"))
    assert r.acc is not None and r.acc.shape == r.t.shape
    touching = r.load > 0
    expected = leather.coulomb.mu0 * 1.6 + 0.05 * r.acc
    np.testing.assert_allclose(r.target[touching], expected[touching], rtol=1e-12)


def test_same_seed_same_drive(cork_with_known_texture):
    traj = constant_scan(0.08, 0.3, 1.0)
    a = render(cork_with_known_texture, traj, ChainConfig(seed=5))
    b = render(cork_with_known_texture, traj, ChainConfig(seed=5), block_seconds=0.013)
    np.testing.assert_array_equal(a.drive, b.drive)
    c = render(cork_with_known_texture, traj, ChainConfig(seed=6))
    assert not np.array_equal(a.drive, c.drive)


def test_lift_and_sensor_dropout_give_zero():
    from surfhap.models.trajectory import Trajectory

    t = np.arange(0, 1.0, 0.008)
    t = t[(t < 0.6) | (t > 0.8)]  # the touch sensor falls silent for 200 ms while the finger presses
    load = np.where((t > 0.3) & (t < 0.4), 0.0, 0.4)
    traj = Trajectory(t, 0.1 * t, 0 * t, load)
    r = render(load_material("wood"), traj)
    lifted = (r.t_drive > 0.31) & (r.t_drive < 0.39)
    assert np.all(r.drive[lifted] == 0.0)
    last = t[t < 0.6][-1]
    stale = (r.t_drive > last + 0.050 + 0.005 + 1e-4) & (r.t_drive < 0.8)
    assert np.all(r.drive[stale] == 0.0)  # watchdog: zero within 5 ms of a 50 ms silence
    assert np.max(np.abs(r.drive[(r.t_drive > 0.5) & (r.t_drive < last)])) > 100.0
    assert np.max(np.abs(r.drive[r.t_drive > 0.85])) > 100.0  # and back once samples return


def test_hatt_model_set_renders_with_zhao_and_follows_its_spectrum(tmp_path):
    """A HaTT-schema file (written by the writer) renders through the zhao law; the added
    friction's spectrum follows the interpolated ARMA model (scaled by the rendering gain)."""
    from test_hatt import make_bank

    from surfhap.exchange.hatt import bank_to_hatt, write_hatt_xml

    path = tmp_path / "Models_Synthetic Cork.xml"
    write_hatt_xml(bank_to_hatt(make_bank(), "Synthetic Cork", 0.55, texture="24"), path)
    r = render(load_material(str(path)), constant_scan(0.1, 1.0, 60.0), ChainConfig(method="zhao"))
    # the gain plan keeps the texture's 99.9th percentile under v_max (docs/texture.md: <= 0.1 % saturated)
    assert r.summary()["saturated_fraction"] <= 1e-3
    assert r.summary()["max_abs_voltage"] <= 250.0
    f, p, e = render_spectrum(r)
    _, dev = spectral_deviation_db(f, p, e, 3.5, 250.0)
    assert np.max(np.abs(dev)) <= 1.5


@pytest.mark.parametrize("name, gain", [("cork", 1.0), ("cork", 0.5), ("wood", 1.0), ("denim", 1.0)])
def test_expected_texture_psd_of_builtin_materials_matches_the_render(name, gain):
    """The figure's 'AR model' line for a built-in material: its texture is calibrated relative to
    the friction law (mu_t = g s mu_low x) and fitted at 100 Hz. The expected PSD (texture PSD x
    (beta g s mu_low fn)^2 x rendering gain^2) must carry the same power as the rendered high band
    over 5-25 Hz (where the 100 Hz texture's resampler is flat) within 1 dB, texture gain included."""
    from scipy.integrate import trapezoid

    mat = load_material(name)
    r = render(mat, constant_scan(0.1, 0.5, 60.0), ChainConfig(seed=2, texture_gain=gain))
    assert mat.texture_relative_scale is not None and r.texture_rate == 100
    f, p, e = render_spectrum(r)
    band = (f >= 5.0) & (f <= 25.0)
    ratio_db = 10 * np.log10(trapezoid(p[band], f[band]) / trapezoid(e[band], f[band]))
    assert abs(ratio_db) <= 1.0, ratio_db


def test_kept_render_summary_is_numpy_of_its_arrays():
    """render() keeps its arrays (allocated once from the trajectory's length, each block
    written in place) and takes its statistics from them in one pass at the end: the summary
    is numpy's reductions of those arrays, whatever the block size."""
    tr = strokes(0.1, 0.4, 3.3)
    lifted = Trajectory(t=tr.t, x=tr.x, y=tr.y, load=np.where((tr.t > 1.0) & (tr.t < 1.6), 0.0, tr.load))
    r = render(load_material("leather"), lifted, ChainConfig(drive_rate=20000), block_seconds=0.1)
    s = r.summary()
    assert r.friction_sim.size == r.load.size == r.n_total and r.drive.size == 10 * r.n_total
    assert s["mean_friction_sim_n"] == np.mean(r.friction_sim)
    assert s["max_abs_voltage"] == np.max(np.abs(r.drive))
    on = r.load > 0
    assert 0 < on.sum() < on.size
    textural = r.target[on] - r.low_band.force(r.load, r.mu_low)[on]
    assert s["texture_share"] == np.sqrt(np.sum(textural**2) / on.sum()) / (np.sum(r.target[on]) / on.sum())
