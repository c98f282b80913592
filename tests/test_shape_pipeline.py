"""One shape pipeline (issue 12, item 5): the offline renderer, the calibration scans and the
live shape chain all run the one compiled eq. 3-9 kernel, checked against an independent
numpy reference of Kim et al. eq. 3-9 (written here from the paper, vectorised, as the
former array implementation computed it); the offline render and the live chain give
bit-identical drive for the same touch stream; one hold helper for every chain."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from surfhap.render.block import RenderBlock
from surfhap.runtime.protocols import Renderer
from surfhap.render.hold import hold_latest
from surfhap.render.shape_chain import ShapeChain
from surfhap.render.shape_chain import render_shape
from surfhap.render.shape_renderer import ShapeConfig, ShapeRenderer
from surfhap.shape.calibration import ScanPlan, ShapeCalibration, scan_fsq, scan_lines
from surfhap.shape.gradient import gradient_block
from surfhap.shape.scenes import builtin_shape
from surfhap.shape.topsurface import TopSurface
from surfhap.models.trajectory import Trajectory

SRC = Path(__file__).resolve().parents[1] / "src" / "surfhap"


def reference_eq3_9(x, y, z, fmin, fmax, fz=1.0, prev=None):
    """Kim et al. eq. 3-9 in vectorised numpy: dr = |P2 - P1| in xy, F = -Fz dz / dr where both
    hits are on the mesh and dr > 0, the previous F held at rest (dr = 0), 0 otherwise;
    Fsq = sgn(F) sqrt(|F|); intensity linear from (fmin, 1.0) to (fmax, 0.3), saturated."""
    px, py, pz, pf = (np.nan, np.nan, np.nan, 0.0) if prev is None else prev
    xp = np.concatenate(([px], x[:-1]))
    yp = np.concatenate(([py], y[:-1]))
    zp = np.concatenate(([pz], z[:-1]))
    dr = np.hypot(x - xp, y - yp)
    step = np.isfinite(z) & np.isfinite(zp) & (dr > 0)
    rest = ~(dr > 0) & np.isfinite(x) & np.isfinite(xp)
    with np.errstate(divide="ignore", invalid="ignore"):
        raw = np.where(step, -fz * (z - zp) / np.where(step, dr, 1.0), 0.0)
    last = np.maximum.accumulate(np.where(rest, -1, np.arange(x.size)))  # forward fill over rests
    force = np.where(last >= 0, raw[np.clip(last, 0, None)], pf)
    fsq = np.sign(force) * np.sqrt(np.abs(force))
    f = np.nan_to_num(fsq, nan=0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        lin = (0.7 * f + 0.3 * fmin - 1.0 * fmax) / (fmin - fmax)
    inten = np.clip(np.where(f <= fmin, 1.0, np.where(f >= fmax, 0.3, lin)), 0.3, 1.0)
    return force, fsq, inten, step


def walk(rng, n, scale=0.002, start=(-0.03, 0.0), rests=0.1):
    """A random finger walk (n, 2) m with rests (repeated points)."""
    steps = rng.normal(0, scale, size=(n, 2))
    steps[rng.random(n) < rests] = 0.0
    return np.cumsum(steps, axis=0) + start


@pytest.fixture(scope="module")
def bump():
    return builtin_shape("frustum-bump")


@pytest.fixture(scope="module")
def suzanne():
    return TopSurface.from_file(SRC / "data" / "suzanne.obj", size=0.09)


def test_kernel_matches_the_numpy_reference_with_lifts_rests_and_blocks():
    rng = np.random.default_rng(0)
    n = 500
    x, y = walk(rng, n, scale=0.5, start=(0.0, 0.0)).T
    z = rng.normal(0, 0.3, n)
    z[rng.random(n) < 0.1] = np.nan  # off the mesh
    lift = rng.random(n) < 0.05
    x[lift] = y[lift] = z[lift] = np.nan
    for fmin, fmax in ((-1.0, 1.0), (-0.4, 1.3)):
        ref = reference_eq3_9(x, y, z, fmin, fmax, fz=2.0)
        got = gradient_block(x, y, z, fmin, fmax, fz=2.0)
        for r, g in zip(ref, got):
            np.testing.assert_allclose(g, r, rtol=1e-13, atol=0)
        # in blocks, with the state carried over, exactly as one call
        prev = None
        parts = []
        for s in range(0, n, 37):
            f, q, i, mv = gradient_block(x[s:s + 37], y[s:s + 37], z[s:s + 37], fmin, fmax, fz=2.0, prev=prev)
            parts.append((f, q, i, mv))
            prev = (x[s + len(f) - 1], y[s + len(f) - 1], z[s + len(f) - 1], f[-1])
        for k in range(4):
            np.testing.assert_array_equal(np.concatenate([p[k] for p in parts]), got[k])
    assert ref[3].any() and (~ref[3]).any()


def test_offline_renderer_runs_the_kernel(suzanne):
    rng = np.random.default_rng(1)
    pts = walk(rng, 600)
    cal = ShapeCalibration.manual(-0.8, 0.6)
    out = ShapeRenderer(suzanne, cal, ShapeConfig()).process(pts[:, 0], pts[:, 1])
    z, _ = suzanne.query(pts)
    force, fsq, inten, _ = gradient_block(pts[:, 0], pts[:, 1], z, cal.fmin, cal.fmax)
    np.testing.assert_array_equal(out.force, force)
    np.testing.assert_array_equal(out.fsq, fsq)
    np.testing.assert_array_equal(out.intensity, inten)
    ref = reference_eq3_9(pts[:, 0], pts[:, 1], z, cal.fmin, cal.fmax)
    for r, g in zip(ref[:3], (out.force, out.fsq, out.intensity)):
        np.testing.assert_allclose(g, r, rtol=1e-12, atol=1e-15)
    assert np.isfinite(out.z).any() and (~np.isfinite(out.z)).any()


def test_calibration_scans_run_the_kernel(suzanne):
    plan = ScanPlan(directions=5, speeds=(0.03, 0.12), lines=3)
    starts, dirs, steps, counts, _ = scan_lines(suzanne, plan)
    kern, ref = [], []
    for s0, d, st, n in zip(starts, dirs, steps, counts):
        k = np.arange(n)
        xy = np.column_stack([s0[0] + k * (d[0] * st), s0[1] + k * (d[1] * st)])  # the scan's own positions
        z, _ = suzanne.query(xy)
        _, fsq, _, moved = gradient_block(xy[:, 0], xy[:, 1], z, -1.0, 1.0)
        kern.append(fsq[moved])
        _, rfsq, _, rmoved = reference_eq3_9(xy[:, 0], xy[:, 1], z, -1.0, 1.0)
        ref.append(rfsq[rmoved])
    got, _ = scan_fsq(suzanne, plan)
    np.testing.assert_array_equal(got, np.concatenate(kern))
    np.testing.assert_allclose(got, np.concatenate(ref), rtol=1e-12, atol=1e-15)
    assert got.size > 100


def test_live_touch_step_is_the_offline_renderer(suzanne):
    cal = ShapeCalibration.manual(-0.8, 0.6)
    cfg = ShapeConfig(edge_threshold_deg=180.0)
    live = ShapeChain(suzanne, cal, cfg)
    pts = walk(np.random.default_rng(2), 500)
    fast = np.array([live.touch_point(float(x), float(y)) for x, y in pts])
    blk = ShapeRenderer(suzanne, cal, cfg).process(pts[:, 0], pts[:, 1])
    on = blk.face >= 0
    np.testing.assert_array_equal(fast[:, 0], np.where(on, blk.intensity, 0.0))
    np.testing.assert_array_equal(fast[:, 1], np.where(on, blk.edge, 0.0))
    z, _ = suzanne.query(pts)
    ref = reference_eq3_9(pts[:, 0], pts[:, 1], z, cal.fmin, cal.fmax)
    np.testing.assert_allclose(fast[:, 0], np.where(on, ref[2], 0.0), rtol=1e-12, atol=1e-15)
    assert on.any() and (~on).any() and (fast[:, 1] > 0).any()


def test_offline_and_live_give_identical_drive(bump):
    """The same 1 kHz touch stream (strokes, rests, a lift, off-mesh excursions) through
    ``render_shape`` and through the live shape chain block by block: identical volts."""
    rate = 1000
    rng = np.random.default_rng(4)
    n = 900
    xy = walk(rng, n, scale=0.0008, start=(-0.03, 0.001), rests=0.15)
    xy[:, 0] += np.linspace(0.0, 0.05, n)  # sweep over the bump and off its far side
    xy = np.round(xy * 2**16) / 2**16  # dyadic: the page <-> mesh mapping is exact
    load = np.full(n, 0.5)
    load[400:430] = 0.0  # a lift
    t = np.arange(n) / rate
    cal = ShapeCalibration.manual(-1.5, 1.5)
    # area-even: the grainy grain's overlap-add sums in block-size dependent order (1 ulp)
    cfg = ShapeConfig(edge_threshold_deg=180.0)
    off = render_shape(bump, Trajectory(t, xy[:, 0], xy[:, 1], load, name="stream"), cal, cfg)
    size = (0.25, 0.25)
    live = ShapeChain(bump, cal, cfg, control_rate=rate, surface_size=size)
    ratio = cfg.drive_rate // rate
    blocks = off.drive.size // ratio
    drive = []
    for b in range(blocks):
        k = min(b, n - 1)  # after the stream the last sample is held, as offline
        blk = live.process(np.zeros(1), np.array([load[k]]), np.array([t[k]]),
                           np.array([xy[k, 0] + size[0] / 2]), np.array([size[1] / 2 - xy[k, 1]]))
        assert isinstance(blk, RenderBlock) and blk.target.shape == (1,)
        drive.append(blk.drive)
    drive = np.concatenate(drive)
    np.testing.assert_array_equal(drive, off.drive[:drive.size])
    assert off.n_ticks > 0 and np.abs(drive).max() > 0
    assert (off.face < 0).any() and (off.face >= 0).any()
    assert np.all(drive[400 * ratio + 1:430 * ratio] == 0.0)  # lifted: silent


def test_hold_helper_against_searchsorted():
    rng = np.random.default_rng(5)
    src = np.sort(rng.uniform(0, 0.05, 40))
    load = rng.uniform(0, 1, 40)
    stamp = src - rng.uniform(0, 0.01, 40)
    for n0 in (0, 137):
        m = 1200
        out_load, out_age, idx = np.empty(m), np.empty(m), np.empty(m, dtype=np.int64)
        hold_latest(n0, 20000.0, src, 1e-12, load, stamp, 0.25, -1.0, out_load, out_age, idx)
        t = (n0 + np.arange(m)) / 20000.0
        k = np.searchsorted(src, t + 1e-12, side="right") - 1
        np.testing.assert_array_equal(idx, k)
        np.testing.assert_array_equal(out_load, np.where(k >= 0, load[np.clip(k, 0, None)], 0.25))
        np.testing.assert_allclose(out_age, np.where(k >= 0, t - stamp[np.clip(k, 0, None)], t + 1.0), rtol=0, atol=1e-15)


def test_both_chains_are_renderers(bump):
    from surfhap.exchange.materials import load_material
    from surfhap.render.chain import ChainConfig, TextureChain

    tex = TextureChain(load_material("cork"), ChainConfig(drive_rate=20000))
    shp = ShapeChain(bump, ShapeCalibration.manual(-1, 1))
    for r in (tex, shp):
        assert isinstance(r, Renderer)
        r.reset()
        n = 3
        blk = r.process(np.full(n, 0.1), np.full(n, 0.5), np.zeros(n), np.full(n, 0.1), np.full(n, 0.07))
        assert isinstance(blk, RenderBlock)
        assert blk.drive.shape == blk.load_drive.shape == (n * r.drive_rate // r.control_rate,)
        assert blk.target.shape == (n,)


def test_shape_modules_do_not_import_each_others_private_helpers():
    """edges and calibration take the ray test from shape.raycast; edges no longer imports
    topsurface (the edges <-> topsurface cycle is gone)."""
    for name in ("edges.py", "calibration.py", "touch.py", "raycast.py"):
        tree = ast.parse((SRC / "shape" / name).read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not any(a.name.startswith("_") for a in node.names), (name, node.module)
                if name in ("edges.py", "raycast.py"):
                    assert node.module != "surfhap.shape.topsurface", name
