"""Built-in shapes, study scenes, 1-D profiles, height maps, figures."""

from __future__ import annotations

import numpy as np
import pytest

from surfhap.errors import ConfigError, MeshFormatError
from surfhap.render.shape_renderer import ShapeRenderer
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.heightmap import heightmap_mesh, heightmap_surface, read_heightmap_image
from surfhap.shape.profiles import SIGMA, formative_profile, ip_intensity, piecewise_knots, profile_force
from surfhap.shape.scan import straight_scan, top_view
from surfhap.shape.scenes import (CONFIGURATIONS, all_scenes, builtin_shape, builtin_shape_names, gaussian_height,
                                  get_scene, light_direction)
from live_support.figures import assert_png_drawn


def test_twenty_scenes():
    scenes = all_scenes()
    assert len(scenes) == 20 and len({s.name for s in scenes}) == 20
    for s in scenes:
        assert len(s.bumps) == int(s.configuration[0])
    assert get_scene("gaussian-1B3H-spot").bumps == ("TR",)  # paper Sec. 5.1.1
    assert get_scene("frustum-1B3H-directional").bumps == ("BR",)
    with pytest.raises(ConfigError):
        get_scene("nope")
    assert set(CONFIGURATIONS) == {s.configuration for s in scenes}


def test_scene_meshes_have_bumps_and_holes_where_listed():
    for name in ("gaussian-2B2H-spot", "frustum-3B1H-directional"):
        sc = get_scene(name)
        surf = sc.surface()
        z, f = surf.query(np.array([[-0.03, 0.03], [0.03, 0.03], [-0.03, -0.03], [0.03, -0.03]]))
        assert np.all(f >= 0)
        for (pos, kind), zz in zip(sc.layout.items(), z):
            assert (zz > 0.015) if kind == "bump" else (zz < -0.015), (name, pos, zz)


def test_gaussian_bump_mesh_follows_fig11():
    surf = builtin_shape("gaussian-bump")
    lo, hi = surf.bounds
    assert hi[2] == pytest.approx(8 / (1.4 * np.pi) * 0.01)
    assert (hi[0] - lo[0], hi[1] - lo[1]) == pytest.approx((0.06, 0.06))
    np.testing.assert_allclose(surf.vertices[:, 2], gaussian_height(surf.vertices[:, 0], surf.vertices[:, 1]))
    fr = builtin_shape("frustum-bump")
    z, _ = fr.query(np.array([[0.0, 0.0], [0.01, 0.0], [0.02, 0.0]]))
    np.testing.assert_allclose(z, [0.02, 0.01, 0.0], atol=1e-12)  # top, half-way up the side, ground
    assert "suzanne" in builtin_shape_names() and builtin_shape("nothing") is None


def test_lights_and_top_view():
    np.testing.assert_allclose(light_direction("spot"), [0, 0, 1])
    d = light_direction("directional")
    assert np.linalg.norm(d) == pytest.approx(1.0) and d[2] > 0
    shade, z, ext = top_view(builtin_shape("frustum-bump"), d, n=50)
    assert shade.shape == (50, 50) and np.all((shade >= 0) & (shade <= 1))
    with pytest.raises(ConfigError):
        light_direction("moon")


def test_formative_profiles():
    bump = formative_profile("bump", "IP0.5")
    assert bump.height.max() == pytest.approx(0.01 / (np.sqrt(2 * np.pi) * 0.5))  # ~0.8 cm, in m
    assert SIGMA == pytest.approx(0.005)
    assert bump.force.min() == pytest.approx(-np.exp(-0.5) / (np.sqrt(2 * np.pi) * 0.5**2), rel=1e-3)  # ~ -0.97 N
    # force = -dz/dx, checked by finite differences
    fd = -np.gradient(bump.height, bump.x)
    np.testing.assert_allclose(bump.force[5:-5], fd[5:-5], atol=2e-3)
    # ascending (x < 0) resists: F < 0 -> intensity > 0.5; summit F = 0 -> 0.5
    assert bump.intensity[np.argmin(bump.force)] > 0.9
    mid = np.argmin(np.abs(bump.x))
    assert bump.intensity[mid] == pytest.approx(0.5)
    assert formative_profile("bump", "IP0.7").intensity[mid] == pytest.approx(0.7)
    np.testing.assert_allclose(ip_intensity(np.array([-1.0, 0.0, 1.0]), 0.7), [1.0, 0.7, 0.4])
    hole = formative_profile("hole", "IP0.5")
    np.testing.assert_allclose(hole.force, -bump.force)
    pw = formative_profile("bump", "IP0.7", piecewise=True, n=2001)
    k = piecewise_knots()
    np.testing.assert_allclose(np.interp(k, pw.x, pw.intensity), ip_intensity(profile_force(k), 0.7), atol=1e-3)
    with pytest.raises(ConfigError):
        formative_profile("ridge")


def test_heightmap_renders_like_the_mesh(tmp_path):
    n = 121
    xs = np.linspace(-0.03, 0.03, n)
    X, Y = np.meshgrid(xs, xs[::-1])  # row 0 at the top (largest y)
    Z = gaussian_height(X, Y)
    surf = heightmap_surface(Z, pixel_size=0.0005, height=1.0)
    mesh = builtin_shape("gaussian-bump")
    tr = straight_scan(-0.025, 0.003, 0.025, 0.003, 0.1)
    cal = ShapeCalibration.manual(-1, 1)
    a = ShapeRenderer(surf, cal).process(tr.x, tr.y)
    b = ShapeRenderer(mesh, cal).process(tr.x, tr.y)
    np.testing.assert_allclose(a.z, b.z, atol=1e-12)
    np.testing.assert_allclose(a.force, b.force, atol=1e-9)
    # greyscale PNG: 0..255 -> 0..height
    from PIL import Image

    img = (np.clip(Z / Z.max(), 0, 1) * 255).round().astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "bump.png")
    grey = read_heightmap_image(tmp_path / "bump.png")
    np.testing.assert_allclose(grey, img / 255.0)
    s2 = heightmap_surface(tmp_path / "bump.png", pixel_size=0.0005, height=0.018)
    assert s2.bounds[1, 2] == pytest.approx(0.018)
    with pytest.raises(MeshFormatError):
        read_heightmap_image(tmp_path / "missing.png")
    with pytest.raises(ConfigError):
        heightmap_mesh(np.zeros(5), 0.001)


def test_figures_draw(tmp_path):
    from surfhap.render.shape_chain import render_shape

    res = render_shape(builtin_shape("frustum-bump"), straight_scan(-0.03, 0.0, 0.03, 0.0, 0.1),
                       ShapeCalibration.manual(-1, 1))
    fig = res.plot()
    fig.savefig(tmp_path / "f.png", dpi=50)
    formative_profile().plot().savefig(tmp_path / "p.png", dpi=50)
    assert_png_drawn(tmp_path / "f.png", min_width=150, min_height=100)
    assert_png_drawn(tmp_path / "p.png", min_width=150, min_height=100)
