"""Grains, drive and simulated display for shapes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.errors import ConfigError
from surfhap.models.trajectory import Trajectory
from surfhap.models.device_curve import DeviceCurve
from surfhap.render.grains import TICK_WIDTH, GrainPlayer, grain_name
from surfhap.render.shape_chain import render_shape
from surfhap.render.shape_renderer import ShapeConfig, display_device_curve
from surfhap.shape.calibration import ShapeCalibration
from surfhap.shape.scan import straight_scan
from surfhap.shape.scenes import builtin_shape


def test_frustum_render_end_to_end():
    surf = builtin_shape("frustum-bump")
    tr = straight_scan(-0.03, 0.001, 0.03, 0.001, 0.1)
    cfg = ShapeConfig()
    res = render_shape(surf, tr, ShapeCalibration.manual(-1.5, 1.5), cfg)
    assert res.n_ticks == 2
    assert np.all((res.intensity >= 0.3) & (res.intensity <= 1.0))
    assert np.max(np.abs(res.drive)) <= cfg.limits.v_max + 1e-9
    assert res.safety.faults == 0 and res.safety.clamped == 0
    # each tick is a raised-cosine pulse of TICK_WIDTH at the device force of Ie
    dev = display_device_curve(cfg)
    k = np.nonzero(res.edge)[0][0]
    i0 = int(np.ceil(res.t[k] * cfg.drive_rate))
    w = int(round(TICK_WIDTH * cfg.drive_rate))
    seg = res.target[i0:i0 + w]
    assert seg.max() == pytest.approx(float(dev.force(res.edge[k])), rel=0.01)
    # between ticks the target is the device force of the held area intensity
    j = np.nonzero(res.edge == 0)[0][5]
    i1 = int(np.ceil(res.t[j] * cfg.drive_rate)) + 5
    assert res.target[i1] == pytest.approx(float(dev.force(res.intensity[j])))
    # the simulated display adds that friction (mu_panel * load removed), once settled
    n = res.friction_sim.size
    added = res.friction_sim - cfg.display.mu_panel * 1.0
    t_model = np.arange(n) / res.friction_rate
    tgt = np.interp(t_model, res.t_drive, res.target)
    sel = (t_model > 0.1) & (t_model < res.t[-1] - 0.05)
    assert abs(np.mean(added[sel]) - np.mean(tgt[sel])) < 0.1 * np.mean(tgt[sel])
    s = res.summary()
    assert s["ticks"] == 2 and s["intensity_range"][0] >= 0.3


def test_lifted_finger_is_silent_and_breaks_the_chain():
    surf = builtin_shape("gaussian-bump")
    t = np.arange(40) / 60.0
    x = np.linspace(-0.02, 0.02, 40)
    load = np.where((t > 0.2) & (t < 0.4), 0.0, 1.0)
    res = render_shape(surf, Trajectory(t, x, np.zeros(40), load), ShapeCalibration.manual(-1, 1))
    lifted = load == 0
    assert np.all(res.force[lifted] == 0)
    first_back = np.nonzero(~lifted & (t > 0.2))[0][0]
    assert res.force[first_back] == 0  # no gradient across the lift
    sel = (res.t_drive > 0.25) & (res.t_drive < 0.38)
    assert np.all(res.drive[sel] == 0)


def test_grain_player_blocks_and_seed():
    dev = DeviceCurve.square_law(0.2)
    inten = np.full(4000, 0.8)
    tick = np.zeros(4000)
    tick[[100, 1990, 3999]] = [0.5, 1.0, 0.7]
    p = GrainPlayer("area-grainy", 20000, dev, seed=4)
    one = p.process(inten, tick)
    p.reset()
    parts = np.concatenate([p.process(inten[s:s + 333], tick[s:s + 333]) for s in range(0, 4000, 333)])
    np.testing.assert_allclose(parts, one)
    assert np.all(one >= 0) and one.max() <= dev.force(1.0) + 1e-12
    even = GrainPlayer("edge-soft", 20000, dev).process(inten, np.zeros(4000))
    np.testing.assert_allclose(even, dev.force(0.8))
    assert np.all(GrainPlayer("area-even", 20000, dev).process(np.zeros(10), np.zeros(10)) == 0)


def test_grain_names():
    assert grain_name("grainy") == "area-grainy"
    with pytest.raises(ConfigError):
        grain_name("wobbly")
    with pytest.raises(ConfigError):
        ShapeConfig(grain="edge-tick")


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=4, max_size=60),
       st.integers(0, 10_000))
def test_drive_never_exceeds_safety_limits(xs, seed):
    # arbitrary touch positions (incl. NaN/inf -> off the mesh) on a frustum
    rng = np.random.default_rng(seed)
    n = len(xs)
    x = np.nan_to_num(np.array(xs), nan=0.0, posinf=1.0, neginf=-1.0) % 0.06 - 0.03
    t = np.cumsum(rng.uniform(0.005, 0.03, n))
    tr = Trajectory(t, x, rng.uniform(-0.03, 0.03, n), rng.uniform(0, 3, n))
    cfg = ShapeConfig(drive_rate=4000, carrier=2000, friction_rate=1000)
    res = render_shape(builtin_shape("frustum-bump"), tr, ShapeCalibration.manual(-1, 1), cfg)
    assert np.all(np.abs(res.drive) <= cfg.limits.v_max + 1e-9)
    assert np.all((res.intensity >= 0.3) & (res.intensity <= 1.0))
    assert np.all((res.edge == 0) | ((res.edge >= 0.3) & (res.edge <= 1.0)))


def test_grain_params_shape_the_waveforms():
    from surfhap.render.grains import GrainParams

    dev = DeviceCurve.square_law(1.0)
    fs = 20000
    tick = np.zeros(2000)
    tick[10] = 1.0
    out = GrainPlayer("area-even", fs, dev, params=GrainParams(tick_width=0.02)).process(np.zeros(2000), tick)
    assert np.count_nonzero(out) == pytest.approx(0.02 * fs, abs=2)
    g = GrainPlayer("area-grainy", fs, dev, seed=1, params=GrainParams(grainy_rate=50, grainy_width=0.002))
    env = g.process(np.ones(10 * fs), np.zeros(10 * fs))
    # mean of a sparse raised-cosine pulse train: rate * width * 1/2
    assert np.mean(env) == pytest.approx(50 * 0.002 * 0.5, rel=0.15)
    with pytest.raises(ValueError, match="tick_width"):
        GrainParams(tick_width=0.0)


@pytest.mark.parametrize("field, value", [("fz", "heavy"), ("drive_rate", float("nan")), ("friction_rate", 30000),
                                          ("carrier", 15000.0), ("edge_threshold_deg", 200.0), ("alpha", float("inf"))])
def test_a_bad_shape_setting_is_one_config_error_naming_its_field(field, value):
    with pytest.raises(ConfigError) as err:
        ShapeConfig(**{field: value})
    assert err.value.field == field
