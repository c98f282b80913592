"""Gradient rendering (Kim et al. eq. 3-9) against the analytic Gaussian bump."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.render.shape_renderer import ShapeConfig, ShapeRenderer
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.gradient import intensity_from_fsq, lateral_force, signed_sqrt
from surfhap.shape.scan import straight_scan
from surfhap.shape.scenes import CM, GAUSS_S, builtin_shape, gaussian_height


@pytest.fixture(scope="module")
def bump():
    return builtin_shape("gaussian-bump")  # z = 8/(1.4 pi) exp(-(x^2+y^2)/1.4) cm, 0.05 cm grid


def gaussian_slope(x, y):
    """(n, 2) gradient (dz/dx, dz/dy) of gaussian_height, by hand: d/dx exp(-(x^2 + y^2) / s) = -2 x / s exp(...)."""
    z = gaussian_height(x, y)
    k = -2.0 / (GAUSS_S * CM * CM)
    return np.stack([k * np.asarray(x) * z, k * np.asarray(y) * z], axis=-1)


def analytic_force(x, y):
    """-dz/dr at the midpoint of each pair of consecutive points (Fz = 1 N)."""
    mx, my = (x[1:] + x[:-1]) / 2, (y[1:] + y[:-1]) / 2
    dx, dy = np.diff(x), np.diff(y)
    g = gaussian_slope(mx, my)
    return -(g[:, 0] * dx + g[:, 1] * dy) / np.hypot(dx, dy)


@pytest.mark.parametrize("speed,rate,heading", [(0.02, 60, 0.0), (0.10, 60, 0.0), (0.20, 100, 0.0),
                                                  (0.10, 60, 37.0), (0.15, 100, 200.0)])
def test_scan_through_summit_matches_analytic_gradient(bump, speed, rate, heading):
    a = np.radians(heading)
    r = 0.029
    tr = straight_scan(-r * np.cos(a), -r * np.sin(a), r * np.cos(a), r * np.sin(a), speed, rate=rate)
    ren = ShapeRenderer(bump, ShapeCalibration.manual(-1.0, 1.0))
    out = ren.process(tr.x, tr.y)
    np.testing.assert_allclose(out.z, gaussian_height(tr.x, tr.y), atol=2e-5)  # mesh vs analytic height (m)
    ref = analytic_force(tr.x, tr.y)
    err = out.force[1:] - ref
    rms = np.sqrt(np.mean(err**2))
    assert rms <= 0.02 * np.max(np.abs(ref))
    # climbing resists (F < 0), descending assists (F > 0)
    assert out.force[1:][ref < -0.1].max() < 0 and out.force[1:][ref > 0.1].min() > 0
    assert np.all((out.intensity >= 0.3) & (out.intensity <= 1.0))


def test_finger_at_rest_keeps_previous_value():
    x = np.array([0.0, 1.0, 2.0, 2.0, 2.0, 3.0])
    z = np.array([0.0, 0.5, 0.7, 0.7, 0.7, 0.7])
    f, moved = lateral_force(x, np.zeros(6), z)
    np.testing.assert_allclose(f, [0.0, -0.5, -0.2, -0.2, -0.2, 0.0])
    assert list(moved) == [False, True, True, False, False, True]
    # the hold carries over block boundaries
    f2, _ = lateral_force(np.array([2.0, 2.0]), np.zeros(2), np.array([0.7, 0.7]), prev=(2.0, 0.0, 0.7, -0.2))
    np.testing.assert_allclose(f2, [-0.2, -0.2])
    assert np.all(np.isfinite(f))


def test_off_mesh_gives_zero_force_and_fz_scales():
    x = np.arange(4.0)
    z = np.array([0.0, np.nan, 1.0, 3.0])
    f, _ = lateral_force(x, np.zeros(4), z, fz=2.0)
    np.testing.assert_allclose(f, [0.0, 0.0, 0.0, -4.0])


def test_blocks_give_the_same_as_one_call(bump):
    tr = straight_scan(-0.03, 0.004, 0.03, -0.002, 0.08, rate=60)
    cfg = ShapeConfig(edge_threshold_deg=180.0)
    one = ShapeRenderer(bump, ShapeCalibration.manual(-1, 1), cfg).process(tr.x, tr.y)
    ren = ShapeRenderer(bump, ShapeCalibration.manual(-1, 1), cfg)
    parts = [ren.process(tr.x[s:s + 7], tr.y[s:s + 7]) for s in range(0, tr.x.size, 7)]
    for name in ("force", "intensity", "edge"):
        np.testing.assert_allclose(np.concatenate([getattr(p, name) for p in parts]), getattr(one, name))
    ren.reset()
    again = ren.process(tr.x, tr.y)
    np.testing.assert_allclose(again.force, one.force)


def test_eq9_end_points_and_saturation():
    i = intensity_from_fsq(np.array([-2.0, -1.0, 0.0, 1.0, 2.0, np.nan]), -1.0, 1.0)
    np.testing.assert_allclose(i, [1.0, 1.0, 0.65, 0.3, 0.3, 0.65])
    # asymmetric range: eq. 9 literally
    fmin, fmax, f = -0.4, 1.3, 0.2
    expect = (0.7 * f + 0.3 * fmin - fmax) / (fmin - fmax)
    assert intensity_from_fsq(np.array([f]), fmin, fmax)[0] == pytest.approx(expect)
    with pytest.raises(ValueError):
        intensity_from_fsq(np.zeros(1), 1.0, 1.0)
    np.testing.assert_allclose(signed_sqrt(np.array([-4.0, 0.0, 9.0])), [-2.0, 0.0, 3.0])


finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=30), finite, finite)
def test_intensity_always_within_limits(values, a, b):
    lo, hi = min(a, b), max(a, b)
    if not hi - lo > 1e-9:
        return
    i = intensity_from_fsq(np.array(values), lo, hi)
    assert np.all((i >= 0.3) & (i <= 1.0))


@settings(max_examples=100, deadline=None)
@given(st.lists(finite, min_size=2, max_size=30), finite, st.floats(min_value=1e-3, max_value=1e3))
def test_intensity_is_monotone_decreasing(values, lo, span):
    f = np.sort(np.array(values))
    i = intensity_from_fsq(f, lo, lo + span)
    assert np.all(np.diff(i) <= 1e-12)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(finite, finite, st.one_of(st.just(float("nan")), st.floats(min_value=-1e3, max_value=1e3))), min_size=1, max_size=40))
def test_renderer_outputs_stay_within_limits(points):
    arr = np.array(points, dtype=float)
    f, _ = lateral_force(arr[:, 0], arr[:, 1], arr[:, 2])
    assert np.all(np.isfinite(f))
    i = intensity_from_fsq(signed_sqrt(f), -1.0, 1.0)
    assert np.all((i >= 0.3) & (i <= 1.0))
