"""A mesh in the live engine (shape renderer behind the engine's renderer protocol)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from surfhap.live.session import build_session


@pytest.fixture
def bump_file(tmp_path):
    # a smooth bump on a plate, 10 x 10 cm
    n = 41
    xs = np.linspace(-0.05, 0.05, n)
    gx, gy = np.meshgrid(xs, xs)
    gz = 0.01 * np.exp(-(gx**2 + gy**2) / (2 * 0.015**2))
    verts = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            faces += [[a, a + 1, a + n], [a + 1, a + n + 1, a + n]]
    path = tmp_path / "bump.obj"
    trimesh.Trimesh(verts, np.array(faces), process=False).export(path)
    return path


def drive_along(engine, xs, y, t0=0.0):
    out = []
    for k, x in enumerate(xs):
        t = t0 + k * 1e-3
        if k % 8 == 0:
            engine.push_touch(1, x, y, 0.5, t_event=t, t_arrival=t)
        out.append(engine.render(engine.block_frames, t + 2e-4).copy())
    return np.concatenate(out)


def test_mesh_session_renders_on_the_shape_and_not_beside_it(bump_file):
    session = build_session(mesh=bump_file)
    eng = session.engine
    assert session.positions == "surface" and "mesh" in session.title
    assert session.preview["w"] * session.preview["h"] == len(session.preview["data"])
    eng.warm_up()
    w, h = session.space.width, session.space.height
    # across the middle of the surface, over the bump: a drive that varies with the slope
    on = drive_along(eng, np.linspace(w / 2 - 0.04, w / 2 + 0.04, 800), h / 2)
    assert np.abs(on).max() > 50.0
    env = np.abs(on).reshape(-1, eng.block_frames).max(axis=1)
    assert env[200:600].std() > 1.0  # the intensity follows the slope
    # a stroke in the far corner misses the mesh: silence
    eng.push_touch(1, 0.0, 0.0, 0.0, t_arrival=0.9)
    off = drive_along(eng, np.linspace(0.002, 0.01, 200), 0.003, t0=1.0)
    assert np.abs(off).max() == 0.0
    assert eng.counters["errors"] == 0


def test_scalar_touch_stage_matches_the_shape_renderer(bump_file):
    from surfhap.live.session import load_live_shape

    live, _ = load_live_shape(bump_file, 20000, (0.217, 0.136))
    ref = live.touch_stage
    rng = np.random.default_rng(3)
    # a random walk over and off the bump, with rests (repeated points)
    steps = rng.normal(0, 0.002, size=(400, 2))
    steps[rng.random(400) < 0.1] = 0.0
    pts = np.cumsum(steps, axis=0) + [-0.03, 0.0]
    live.reset_touch()
    fast = [live.touch_point(float(x), float(y)) for x, y in pts]
    ref.reset()
    blk = ref.process(pts[:, 0], pts[:, 1])
    on = np.isfinite(blk.z)
    want_i = np.where(on, blk.intensity, 0.0)
    want_t = np.where(on, blk.edge, 0.0)
    np.testing.assert_allclose([f[0] for f in fast], want_i, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([f[1] for f in fast], want_t, rtol=1e-12, atol=1e-12)
    assert on.any() and (~on).any()
