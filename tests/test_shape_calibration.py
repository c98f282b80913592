"""Force range by simulated scans (Kim et al. Sec. 4.2)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from surfhap.errors import ConfigError
from surfhap.exchange.shape_files import default_calibration_path, read_calibration, write_calibration
from surfhap.shape.calibration import ScanPlan, ShapeCalibration, calibrate, scan_fsq, scan_lines
from surfhap.shape.gradient import lateral_force, signed_sqrt
from surfhap.shape.scenes import builtin_shape
from surfhap.shape.topsurface import TopSurface


@pytest.fixture(scope="module")
def suzanne():
    return TopSurface.from_file("suzanne", size=0.10)


def test_range_is_mean_plus_minus_two_sd(suzanne):
    plan = ScanPlan()
    cal = calibrate(suzanne, plan)
    fsq, _ = scan_fsq(suzanne, plan)
    assert cal.fmin == pytest.approx(fsq.mean() - 2 * fsq.std())
    assert cal.fmax == pytest.approx(fsq.mean() + 2 * fsq.std())
    assert cal.fmin < 0 < cal.fmax
    # scanning all around makes the distribution nearly symmetric
    assert abs(cal.mean) < 0.05 * cal.sd
    assert cal.n_samples == fsq.size and sum(cal.hist_counts) == fsq.size
    assert cal.plan["directions"] == 36 and len(cal.plan["speeds_m_s"]) == 5
    pc = calibrate(suzanne, plan, method="percentile", percentiles=(5, 95))
    assert pc.fmin == pytest.approx(np.percentile(fsq, 5)) and pc.fmax == pytest.approx(np.percentile(fsq, 95))


def test_scan_kernel_matches_the_renderer_gradient():
    surf = builtin_shape("gaussian-bump")
    plan = ScanPlan(directions=3, speeds=(0.05,), lines=2)
    starts, dirs, steps, counts, _ = scan_lines(surf, plan)
    ref = []
    for s0, d, st, n in zip(starts, dirs, steps, counts):
        xy = s0 + np.arange(n)[:, None] * st * d
        z, _ = surf.query(xy)
        f, moved = lateral_force(xy[:, 0], xy[:, 1], z)
        ref.append(signed_sqrt(f[moved]))
    fsq, _ = scan_fsq(surf, plan)
    np.testing.assert_allclose(fsq, np.concatenate(ref), rtol=1e-12, atol=1e-12)


def test_sample_budget_reduces_lines(suzanne):
    big = TopSurface.from_file("suzanne")  # 2.7 m wide at SI scale
    cal = calibrate(big, ScanPlan(max_samples=200_000))
    assert cal.plan["lines_per_direction"] < cal.plan["lines_requested"]


def test_json_round_trip(tmp_path, suzanne):
    cal = calibrate(suzanne, ScanPlan(directions=8, speeds=(0.05, 0.1)))
    path = write_calibration(cal, tmp_path / "c.json")
    back = read_calibration(path)
    assert back == cal
    assert default_calibration_path("a/b/mesh.ply").name == "mesh.ply.calibration.json"


def test_bad_calibration_files(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text("{not json")
    with pytest.raises(ConfigError, match="malformed JSON"):
        read_calibration(p)
    p.write_text(json.dumps({"fmin": 1.0}))
    with pytest.raises(ConfigError, match="fmax"):
        read_calibration(p)
    p.write_text(json.dumps({"fmin": 1.0, "fmax": -1.0}))
    with pytest.raises(ConfigError):
        read_calibration(p)
    with pytest.raises(ConfigError):
        read_calibration(tmp_path / "missing.json")


def test_plan_validation():
    with pytest.raises(ConfigError):
        ScanPlan(directions=0)
    with pytest.raises(ConfigError):
        ScanPlan(speeds=(0.0,))
    with pytest.raises(ConfigError):
        ScanPlan(sensor_rate=1.0)
    with pytest.raises(ConfigError):
        calibrate(builtin_shape("frustum-bump"), method="median")
    assert ScanPlan.evenly(36, 5).speeds == pytest.approx((0.02, 0.065, 0.11, 0.155, 0.2))
    with pytest.raises(ConfigError):
        ShapeCalibration(0.0, 0.0)


def test_flat_mesh_gets_a_tiny_range():
    v = np.array([[0, 0, 0], [0.05, 0, 0], [0.05, 0.05, 0], [0, 0.05, 0.0]])
    surf = TopSurface(v, np.array([[0, 1, 2], [0, 2, 3]]))
    cal = calibrate(surf, ScanPlan(directions=4, speeds=(0.1,)))
    assert cal.fmin < 0 < cal.fmax and cal.fmax - cal.fmin < 1e-8
