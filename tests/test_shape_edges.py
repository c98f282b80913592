"""Edge emphasis (Kim et al. eq. 10-11) on the square frustum of Fig. 11b."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.render.shape_renderer import ShapeConfig, ShapeRenderer
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.edges import dihedral_angles, sharpness, tick_intensity
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


def test_dihedral_angle_convexity():
    up = np.array([[0.0, 0.0, 1.0]])
    side = np.array([[2.0, 0.0, 1.0]]) / np.sqrt(5)
    # top plateau -> descending side: convex
    th, cv = dihedral_angles(up, side, np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]]))
    assert cv[0] and th[0] == pytest.approx(THETA_TOP)
    # ground -> ascending side of a hole wall going down is convex; ground -> rising wall concave
    rising = np.array([[-2.0, 0.0, 1.0]]) / np.sqrt(5)
    th, cv = dihedral_angles(up, rising, np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 1]]))
    assert not cv[0] and th[0] == pytest.approx(180 + (180 - THETA_TOP))
    th, cv = dihedral_angles(up, up, np.zeros((1, 3)), np.ones((1, 3)))
    assert not cv[0] and th[0] == 180.0


@settings(max_examples=200, deadline=None)
@given(st.floats(min_value=0, max_value=360), st.floats(min_value=0, max_value=179.9))
def test_tick_intensity_within_limits(theta, theta_min):
    i = tick_intensity(sharpness(np.array([theta]), theta_min))
    assert 0.3 <= i[0] <= 1.0


def test_sharpness_end_points():
    np.testing.assert_allclose(sharpness(np.array([180.0, 100.0, 140.0]), 100.0), [0.0, 1.0, 0.5])
    np.testing.assert_allclose(tick_intensity(np.array([0.0, 0.5, 1.0])), [0.3, 0.65, 1.0])


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
