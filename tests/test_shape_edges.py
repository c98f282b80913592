"""Edge emphasis (Kim et al. eq. 10-11) on the square frustum of Fig. 11b."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.render.shape_renderer import ShapeConfig, ShapeRenderer
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.edges import edge_tick_one
from surfhap.shape.scan import straight_scan
from surfhap.shape.scenes import builtin_shape

# frustum: base 3 x 3 cm, top 1 x 1 cm, height 2 cm -> side slope 2 / 1
THETA_TOP = 180.0 - np.degrees(np.arctan(2.0))  # side face / top face
THETA_CORNER = 180.0 - np.degrees(np.arccos(1.0 / 5.0))  # two neighbouring side faces: n1.n2 = 1/5
CAL = ShapeCalibration.manual(-1.0, 1.0)


def scan(surface, y, speed=0.1, rate=60, **cfg):
    tr = straight_scan(-0.03, y, 0.03, y, speed, rate=rate)
    return ShapeRenderer(surface, CAL, ShapeConfig(**cfg)).process(tr.x, tr.y)


def ie(theta, theta_min):
    return 0.7 * (180.0 - theta) / (180.0 - theta_min) + 0.3


def test_theta_min_of_frustum_bump_is_the_corner_edge():
    assert builtin_shape("frustum-bump").theta_min == pytest.approx(THETA_CORNER, abs=1e-9)
    assert builtin_shape("frustum-hole").theta_min == pytest.approx(THETA_TOP, abs=1e-9)


@pytest.mark.parametrize("speed,rate", [(0.05, 60), (0.10, 60), (0.20, 100)])
def test_one_tick_per_convex_edge_over_the_top(speed, rate):
    out = scan(builtin_shape("frustum-bump"), 0.001, speed, rate)
    ticks = out.edge[out.edge > 0]
    assert ticks.size == 2  # side -> top and top -> side; the concave base edges stay silent
    np.testing.assert_allclose(ticks, ie(THETA_TOP, THETA_CORNER), rtol=1e-9)
    # the ticks fall where the hit moves onto / off the top plateau (z = 2 cm)
    k = np.nonzero(out.edge)[0]
    assert np.isclose(out.z[k[0]], 0.02) and np.isclose(out.z[k[1] - 1], 0.02)


def test_scan_past_the_top_crosses_two_corner_edges():
    out = scan(builtin_shape("frustum-bump"), 0.01)  # |y| = 1 cm: side faces only
    ticks = out.edge[out.edge > 0]
    assert ticks.size == 2
    np.testing.assert_allclose(ticks, 1.0)  # theta = theta_min -> S = 1 -> Ie = 1


def test_hole_ticks_at_the_rim_only():
    out = scan(builtin_shape("frustum-hole"), -0.002)
    ticks = out.edge[out.edge > 0]
    assert ticks.size == 2
    np.testing.assert_allclose(ticks, 1.0)
    k = np.nonzero(out.edge)[0]
    assert np.isclose(out.z[k[0] - 1], 0.0) and np.isclose(out.z[k[1]], 0.0)


def test_smooth_bump_has_no_ticks_by_default_but_does_at_180():
    g = builtin_shape("gaussian-bump")
    assert not np.any(scan(g, 0.0).edge)
    all_convex = scan(g, 0.0, edge_threshold_deg=180.0).edge
    assert np.any(all_convex) and np.all(all_convex[all_convex > 0] >= 0.3)
    assert not np.any(scan(builtin_shape("frustum-bump"), 0.001, edges=False).edge)


def _step(n1, n2, p1, p2, theta_min=0.0, threshold=180.0):
    """edge_tick_one for one step from p1 on a face of up normal n1 to p2 on one of n2."""
    normals = np.array([n1, n2], dtype=float)
    return edge_tick_one(normals, 0, 1, *map(float, p1), *map(float, p2), theta_min, threshold)


def test_dihedral_angle_convexity():
    up = np.array([0.0, 0.0, 1.0])
    side = np.array([2.0, 0.0, 1.0]) / np.sqrt(5)
    # top plateau -> descending side: convex, theta = 180 - angle between the normals
    tick, th = _step(up, side, (0.0, 0, 1), (1.0, 0, 0))
    assert tick > 0 and th == pytest.approx(THETA_TOP)
    # ground -> rising wall: concave (180 + phi), never a tick
    rising = np.array([-2.0, 0.0, 1.0]) / np.sqrt(5)
    tick, th = _step(up, rising, (0.0, 0, 0), (1.0, 0, 1))
    assert tick == 0 and th == pytest.approx(180 + (180 - THETA_TOP))
    assert _step(up, up, (0, 0, 0), (1, 1, 1)) == (0.0, 180.0)


def _paper_tick(theta, theta_min):
    """Kim et al. eq. 10 (S = -(theta - 180) / (180 - theta_min), within [0, 1]) and eq. 11 (Ie = 0.7 S + 0.3)."""
    s = min(max(-(theta - 180.0) / (180.0 - theta_min), 0.0), 1.0)
    return 0.7 * s + 0.3


@settings(max_examples=200, deadline=None)
@given(st.floats(min_value=0.01, max_value=179.9), st.floats(min_value=0, max_value=179.9))
def test_tick_intensity_is_eq_10_11_within_limits(phi, theta_min):
    # a convex step bending down by phi degrees: theta = 180 - phi
    a = np.radians(phi)
    tick, th = _step((0.0, 0.0, 1.0), (np.sin(a), 0.0, np.cos(a)), (0.0, 0.0, 0.0), (1.0, 0.0, -1.0), theta_min)
    assert th == pytest.approx(180.0 - phi, abs=1e-9)
    assert 0.3 <= tick <= 1.0 and tick == pytest.approx(_paper_tick(th, theta_min), abs=1e-12)


def test_sharpness_end_points():
    for phi, expected in ((80.0, 1.0), (40.0, 0.65)):  # theta 100 = theta_min: S = 1; theta 140: S = 0.5
        a = np.radians(phi)
        tick, _ = _step((0.0, 0.0, 1.0), (np.sin(a), 0.0, np.cos(a)), (0, 0, 0), (1.0, 0.0, -1.0), 100.0)
        assert tick == pytest.approx(expected)
    # above the threshold: no tick, the angle is still reported
    tick, th = _step((0.0, 0.0, 1.0), (np.sin(0.5), 0.0, np.cos(0.5)), (0, 0, 0), (1.0, 0.0, -1.0), 100.0, 135.0)
    assert tick == 0.0 and th > 135.0


@pytest.mark.parametrize("speed,rate,y", [(0.05, 60, 0.001), (0.2, 100, -0.003), (0.1, 60, 0.01)])
def test_walking_mode_agrees_with_the_paper_where_steps_are_short(speed, rate, y):
    fr = builtin_shape("frustum-bump")
    a = scan(fr, y, speed, rate)
    b = scan(fr, y, speed, rate, edge_walk=True)
    np.testing.assert_allclose(b.edge, a.edge, rtol=1e-9)


def test_walking_mode_catches_a_narrow_step():
    from surfhap.shape.heightmap import heightmap_surface

    z = np.zeros((40, 200))
    z[:, 100:] = 1.0  # a 1 mm step over one 0.1 mm pixel
    surf = heightmap_surface(z, pixel_size=1e-4, height=1e-3)
    tr = straight_scan(-0.009, 0.0, 0.009, 0.0, 0.1)
    cal = CAL
    plain = ShapeRenderer(surf, cal, ShapeConfig()).process(tr.x, tr.y)
    walk = ShapeRenderer(surf, cal, ShapeConfig(edge_walk=True)).process(tr.x, tr.y)
    assert not np.any(plain.edge)  # flat face to flat face: the paper's test sees no edge
    ticks = walk.edge[walk.edge > 0]
    assert ticks.size == 1  # the convex top of the step; its concave foot stays silent
    theta = 180.0 - np.degrees(np.arctan(1e-3 / 1e-4))
    assert ticks[0] == pytest.approx(ie(theta, surf.theta_min))
