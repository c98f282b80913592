"""Line spectral frequencies: exact round trips, independent root-finding reference, stability."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.signal.lsf import ar_to_lsf, interpolate_lsf, lsf_is_valid, lsf_to_ar, lsf_to_poly, poly_to_lsf


def random_lsf(rng, p, min_gap=0.05):
    """Random increasing LSFs in (0, pi) with gaps >= min_gap (HaTT files have p = 14..20
    LSFs spread over (0, pi), mean gap ~0.15 rad; tight clusters make the double-precision
    polynomial itself ill-conditioned, see docs/fitting.md)."""
    edge = 2 * min_gap  # HaTT's lowest LSFs are ~0.1 rad and above
    gaps = min_gap + rng.dirichlet(np.ones(p + 1)) * (np.pi - (p + 1) * min_gap - 2 * edge)
    return edge + np.cumsum(gaps)[:p]


def stable_poly(rng, p, rmax=0.97):
    m = p // 2
    r = rng.uniform(0.2, rmax, m)
    th = rng.uniform(0.05, np.pi - 0.05, m)
    roots = np.r_[r * np.exp(1j * th), r * np.exp(-1j * th)]
    if p % 2:
        roots = np.r_[roots, rng.uniform(-0.9, 0.9)]
    return np.real(np.poly(roots))


def reference_poly(lsf):
    """Independent construction: P and Q from their unit-circle roots with numpy.poly."""
    p = lsf.size
    wp, wq = lsf[0::2], lsf[1::2]
    P = np.real(np.poly(np.r_[np.exp(1j * wp), np.exp(-1j * wp)]))
    Q = np.real(np.poly(np.r_[np.exp(1j * wq), np.exp(-1j * wq)]))
    if p % 2 == 0:
        P = np.convolve(P, [1, 1])
        Q = np.convolve(Q, [1, -1])
    else:
        Q = np.convolve(Q, [1, 0, -1])
    return (0.5 * (P + Q))[: p + 1]


@pytest.mark.parametrize("p", [1, 2, 3, 8, 14, 19, 20])
def test_lsf_round_trip_exact(p):
    rng = np.random.default_rng(p)
    for _ in range(20):
        w = random_lsf(rng, p)
        assert np.max(np.abs(poly_to_lsf(lsf_to_poly(w)) - w)) < 1e-10
        a = stable_poly(rng, p)
        np.testing.assert_allclose(lsf_to_poly(poly_to_lsf(a)), a, atol=1e-10, rtol=0)


@pytest.mark.parametrize("p", [1, 2, 5, 10, 16])
def test_lsf_to_poly_matches_root_construction(p):
    rng = np.random.default_rng(100 + p)
    for _ in range(10):
        w = random_lsf(rng, p)
        np.testing.assert_allclose(lsf_to_poly(w), reference_poly(w), atol=1e-11)


def test_lsf_angles_are_the_roots_of_p_and_q():
    rng = np.random.default_rng(7)
    a = stable_poly(rng, 10)
    ext = np.r_[a, 0.0]
    P, Q = ext + ext[::-1], ext - ext[::-1]
    ang = np.angle(np.r_[np.roots(P), np.roots(Q)])
    ang = np.sort(ang[(ang > 1e-6) & (ang < np.pi - 1e-6)])
    np.testing.assert_allclose(poly_to_lsf(a), ang, atol=1e-7)


def test_white_noise_lsfs_are_equally_spaced():
    for p in (4, 5):
        np.testing.assert_allclose(poly_to_lsf(np.r_[1.0, np.zeros(p)]), np.arange(1, p + 1) * np.pi / (p + 1), atol=1e-13)


def test_ar_sign_convention():
    phi = np.array([1.2, -0.6])
    np.testing.assert_allclose(lsf_to_ar(ar_to_lsf(phi)), phi, atol=1e-12)


def test_unstable_polynomial_is_rejected():
    with pytest.raises(ValueError):
        poly_to_lsf([1.0, -2.5, 1.5])
    with pytest.raises(ValueError):
        poly_to_lsf([2.0, 0.1])


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 20), st.integers(2, 4), st.integers(0, 2**31 - 1))
def test_interpolated_models_are_always_stable(p, k, seed):
    rng = np.random.default_rng(seed)
    lsfs = np.array([random_lsf(rng, p, min_gap=1e-4) for _ in range(k)])
    w = rng.dirichlet(np.ones(k))
    mix = interpolate_lsf(lsfs, w)
    assert lsf_is_valid(mix)
    roots = np.roots(lsf_to_poly(mix))
    assert np.all(np.abs(roots) < 1.0)
