"""The one device curve (models/device_curve.py) and the display's force -> voltage map,
checked against numpy.polynomial, an analytic square law and Kim et al.'s published points."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import Polynomial
from pydantic import ValidationError

from surfhap.errors import ConfigError
from surfhap.models.device_curve import DeviceCurve
from surfhap.models.panel import DisplayModel


def _smallest_drive(coefficients, force, top):
    """Independent inverse: the smallest u in [0, top] with F(u) >= min(force, max F), from the
    polynomial's roots (numpy.polynomial) and its values on [0, top]."""
    p = Polynomial(coefficients)
    grid_max = max(p(0.0), p(top), *(p(r.real) for r in p.deriv().roots() if abs(r.imag) < 1e-12 and 0 < r.real < top))
    g = min(force, grid_max)
    if g <= p(0.0):
        return 0.0
    roots = [r.real for r in (p - g).roots() if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= top * (1 + 1e-9)]
    return min(roots)


def test_kim2017_passes_through_the_three_published_points():
    # Kim et al. (paper 002, Sec. 3.1.2): about 0.075 N at the lowest measured intensity 0.1,
    # the median 0.16 N at about 0.7, the maximum 0.25 N at 1.0: the quadratic through them
    u = np.array([0.1, 0.7, 1.0])
    f = np.array([0.075, 0.16, 0.25])
    want = np.linalg.solve(np.vander(u, 3, increasing=True), f)
    curve = DeviceCurve.kim2017()
    np.testing.assert_allclose(curve.coefficients, want, atol=1e-7)
    np.testing.assert_allclose(curve.force(u), f, atol=1e-7)
    np.testing.assert_allclose(curve.drive_for_force(f), u, atol=1e-6)


def test_force_is_numpy_polynomial_in_ascending_order_clipped_to_the_range():
    c = (0.02, 0.3, -0.1)
    curve = DeviceCurve(input="intensity", coefficients=c)
    u = np.linspace(-0.5, 1.5, 41)
    np.testing.assert_allclose(curve.force(u), Polynomial(c)(np.clip(u, 0, 1)), rtol=1e-12)


@pytest.mark.parametrize("c,top", [
    ((0.0, 0.0, 3.2e-6), 250.0),        # square law over volts
    ((0.05, 0.0, 0.2), 1.0),            # offset (forces below it: zero drive)
    ((0.1, -0.01, 1e-4), 200.0),        # a dip first: the rising branch after the vertex
    ((0.0, 0.5, -0.4), 1.0),            # saturating: the peak at u = 0.625 is the largest force
    ((0.07314815, 0.00092593, 0.17592593), 1.0),
])
def test_drive_for_force_is_the_smallest_root_on_the_range(c, top):
    curve = DeviceCurve(input="voltage", coefficients=c, input_max=top)
    p = Polynomial(c)
    hi = max(p(np.linspace(0, top, 2001)))
    forces = np.concatenate([[-1.0, 0.0], np.linspace(p(0.0), hi * 1.2, 57)])
    got = curve.drive_for_force(forces)
    want = [_smallest_drive(c, f, top) for f in forces]
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-9 * top)
    assert np.all((got >= 0) & (got <= top))


def test_square_law_inverse_is_the_square_root():
    curve = DeviceCurve.square_law(0.3)
    f = np.linspace(0, 0.3, 31)
    np.testing.assert_allclose(curve.drive_for_force(f), np.sqrt(f / 0.3), rtol=1e-12)
    assert curve.drive_for_force(np.array([1.0]))[0] == 1.0  # above the range: clipped
    assert np.isnan(curve.drive_for_force(np.array([np.nan]))[0])  # the safety stage catches NaN


def test_fit_matches_numpy_polynomial_least_squares():
    rng = np.random.default_rng(2)
    u = np.linspace(0.1, 1.0, 12)
    f = 0.2 * u ** 2 + 0.01 * u + 0.05 + rng.normal(0, 0.003, u.size)
    curve = DeviceCurve.fit(u, f)
    np.testing.assert_allclose(curve.coefficients, np.polynomial.polynomial.polyfit(u, f, 2), rtol=1e-9, atol=1e-12)
    with pytest.raises(ConfigError):
        DeviceCurve.fit([0.1, 0.2], [0.1, 0.2])


def test_a_curve_that_never_rises_is_refused():
    with pytest.raises(ValidationError):
        DeviceCurve(input="intensity", coefficients=(0.0, 0.0, -1.0))
    with pytest.raises(ConfigError):
        DeviceCurve.of("intensity", (0.1, 0.0, 0.0))


def test_device_curve_from_simulated_tribometer():
    # bursts of a 150 Hz tangential force whose amplitude is quadratic in the intensity
    fs = 10_000
    t = np.arange(2 * fs) / fs
    rng = np.random.default_rng(0)
    recs = {}
    for i in np.round(np.arange(0.1, 1.01, 0.1), 2):
        amp = 0.18 * i ** 2 + 0.07  # peak-to-peak, N
        gate = (np.sin(2 * np.pi * 3 * t) > 0.5).astype(float)
        recs[i] = 0.5 * amp * np.sin(2 * np.pi * 150 * t) * gate + 0.002 * rng.standard_normal(t.size) + 0.3
    curve = DeviceCurve.from_tribometer(recs, fs)
    i = np.linspace(0.1, 1.0, 10)
    np.testing.assert_allclose(curve.force(i), 0.18 * i ** 2 + 0.07, rtol=0.05)


def test_display_map_without_a_curve_is_alpha_sqrt_f_and_the_compiled_tail():
    from surfhap.render.drive_kernel import target_to_voltage

    d = DisplayModel(mu_panel=0.4, k_measured=6e-6)
    f = np.array([-0.1, 0.0, 0.01, 0.2, np.nan])
    want = np.array([0.0, 0.0, np.sqrt(0.01 / (0.4 * 6e-6)), np.sqrt(0.2 / (0.4 * 6e-6)), np.nan])
    np.testing.assert_allclose(d.voltage_for_force(f, 250.0), want, rtol=1e-12)
    out = np.empty(f.size)
    target_to_voltage(f, np.ones(f.size), d.calibrated_alpha, out)
    np.testing.assert_allclose(out, want, rtol=1e-12)


def test_display_map_with_voltage_and_intensity_curves():
    volts = DisplayModel(device_curve=DeviceCurve(input="voltage", coefficients=(0.0, 1e-4, 2e-6), input_max=300))
    f = np.array([0.0, 0.05, 0.1])
    v = volts.voltage_for_force(f, 250.0)
    np.testing.assert_allclose(1e-4 * v + 2e-6 * v ** 2, f, rtol=1e-9, atol=1e-15)  # F(V) = F
    inten = DisplayModel(device_curve=DeviceCurve.kim2017())
    np.testing.assert_allclose(inten.voltage_for_force(np.array([0.075, 0.25]), 200.0), [20.0, 200.0], rtol=1e-5)
