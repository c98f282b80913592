"""Force safety stage: limits, slew, watchdogs and workspace hold for any input (hypothesis)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.ff import FALCON, Attraction, DeviceParams, FFEngine, GridField, RectsField, Roughness, Shape, Sliding, Stiffness
from surfhap.render.kinematics import TouchPredictor
from surfhap.sim.ff_device import SimDevice

RATE = 1000.0
EPS = 1e-9


def all_effects(device=FALCON):
    """Every effect, driven by maps so that random strokes switch them on and off."""
    k = RectsField([(0.0, 0.0, 0.05, 0.05, 200.0), (0.1, 0.0, 0.15, 0.1, 800.0)])
    a = RectsField([(0.05, 0.0, 0.1, 0.1, 1.0), (0.15, 0.0, 0.2, 0.1, -1.0)])
    d = RectsField([(0.0, 0.05, 0.2, 0.1, 3e-4)])
    h = GridField(np.outer(np.hanning(16), np.hanning(16)) * 0.03, 0.0, 0.0, 0.2, 0.14)
    return [Stiffness(k), Shape(h), Roughness(d, 1e-3), Sliding(a, mass=device.moving_mass),
            Attraction([(0.1, 0.07, 0.05, 3.0), (0.03, 0.03, 0.02, -2.0)])]


def make_engine(device=FALCON):
    return FFEngine(all_effects(device), device, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45),
                    rate=RATE, touch_latency=0.04)


def bare_stage(device=FALCON):
    """The engine without effects: its safety stage fed a requested force directly."""
    return FFEngine([], device, TouchPredictor(), rate=RATE)


def process(eng, force, t, t_pos, px, py, pz, stop=False):
    """One tick of the safety stage alone for the requested ``force`` (3,) N."""
    eng.observe(t, t_pos, px, py, pz)
    return eng.limit(*force, stop)


def check(outs, device):
    outs = np.asarray(outs)
    assert np.all(np.isfinite(outs))
    assert np.all(np.abs(outs) <= np.asarray(device.f_max) + EPS)
    steps = np.abs(np.diff(np.vstack([np.zeros(3), outs]), axis=0))
    assert np.all(steps <= device.slew / RATE + EPS)


wild = st.one_of(st.floats(-1e6, 1e6, allow_nan=False), st.sampled_from([math.nan, math.inf, -math.inf, 0.0]),
                 st.floats(-0.3, 0.3))
tick_event = st.tuples(
    st.one_of(st.none(), st.tuples(wild, wild, st.one_of(st.floats(-5, 30), st.just(math.nan)))),  # touch
    st.one_of(st.none(), st.tuples(wild, wild, wild)),  # device position (None = none this tick)
    st.integers(0, 40),  # ticks to repeat this position before the next event
)
devices = st.builds(DeviceParams, f_max=st.tuples(*[st.floats(0.5, 10)] * 3), slew=st.floats(10, 5000),
                    workspace=st.tuples(*[st.floats(0.01, 0.06)] * 3))


@settings(max_examples=60, deadline=None)
@given(events=st.lists(tick_event, min_size=1, max_size=60), device=devices, stop_at=st.integers(0, 3000))
def test_engine_output_within_limits_and_slew_for_any_input(events, device, stop_at):
    eng = make_engine(device)
    outs = []
    t = 0.0
    pos = (0.0, 0.0, 0.0)
    t_pos = 0.0
    k = 0
    for touch, p, repeat in events:
        if touch is not None:
            eng.touch(t, *touch)
        if p is not None:
            pos, t_pos = p, t
        for _ in range(repeat + 1):
            if k == stop_at:
                eng.stop()
            outs.append(eng.tick(t, *pos, t_pos).copy())
            t += 1.0 / RATE
            k += 1
    check(outs, device)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), switch_every=st.integers(1, 200))
def test_closed_loop_random_strokes_and_switches_stay_within_limits(seed, switch_every):
    """Closed loop with the simulated device: random finger touches, lifts and jumps across
    the maps, and the engine's force always within limits and slew."""
    rng = np.random.default_rng(seed)
    eng = make_engine()
    dev = SimDevice(rate=RATE, gain=FALCON.gain)
    outs = []
    x, y, load = 0.1, 0.07, 1.0
    cmd = np.zeros(3)
    for k in range(1500):
        t = k / RATE
        if k % switch_every == 0:
            x, y = rng.uniform(-0.05, 0.25), rng.uniform(-0.05, 0.2)
            load = float(rng.choice([0.0, rng.uniform(0.1, 5.0)]))
        if k % 16 == 0:
            x += rng.normal(0, 0.003)
            y += rng.normal(0, 0.003)
            eng.touch(t, x - dev.p[0], y - dev.p[1], load)
        f = eng.tick(t, float(dev.p[0]), float(dev.p[1]), float(dev.p[2]), t)
        outs.append(f.copy())
        cmd[:] = f * FALCON.gain
        dev.step(cmd, np.array([0.0, 0.0, -load]))
    check(outs, FALCON)


def test_device_watchdog_ramps_to_zero_after_10_ms():
    eng = make_engine()
    outs = [eng.tick(k / RATE, 0.0, 0.0, -0.01, k / RATE).copy() for k in range(100)]
    assert outs[-1][2] > 5.0  # weight + centring holding the screen
    # positions stop arriving at t = 0.1 s
    t_last = 99 / RATE
    for k in range(100, 200):
        outs.append(eng.tick(k / RATE, 0.0, 0.0, -0.01, t_last).copy())
    outs = np.asarray(outs)
    assert eng.counters.device_lost > 0
    lost = 99 + int(round(FALCON.device_timeout * RATE)) + 1  # first tick beyond the timeout
    assert np.all(outs[99:lost - 1, 2] == outs[99, 2])  # held until the timeout
    assert outs[lost, 2] < outs[99, 2]  # then ramping down
    ramp = math.ceil(FALCON.f_max[2] / (FALCON.slew / RATE)) + 1
    assert np.all(outs[lost + ramp:] == 0.0)
    check(outs, FALCON)


def test_touch_watchdog_falls_back_to_idle():
    eng = FFEngine([Stiffness(100.0)], FALCON, TouchPredictor(), rate=RATE)
    eng.touch(0.0, 0.02, 0.02, 1.0)
    eng.touch(0.01, 0.02, 0.02, 1.0)
    eng.tick(0.011, 0.0, 0.0, 0.0, 0.011)
    assert eng.mask == 1
    eng.tick(0.01 + FALCON.touch_timeout - 0.001, 0.0, 0.0, 0.0, 0.109)
    assert eng.mask == 1
    eng.tick(0.01 + FALCON.touch_timeout + 0.001, 0.0, 0.0, 0.0, 0.111)
    assert eng.mask == 0 and not eng.state.touched


def test_workspace_wall_pushes_back_and_drops_outward_force():
    saf = bare_stage()
    ws = FALCON.workspace[0]
    for k in range(200):
        out = process(saf, np.array([5.0, 0.0, 0.0]), k / RATE, k / RATE, ws + 0.002, 0.0, 0.0)
    assert out[0] == pytest.approx(-FALCON.wall_k * 0.002)
    assert saf.counters.workspace == 200


def test_stop_ramps_lateral_axes_to_zero_at_slew_rate():
    saf = bare_stage()
    for k in range(100):
        process(saf, np.array([4.0, -4.0, 0.0]), k / RATE, k / RATE, 0.0, 0.0, 0.0)
    outs = np.array([process(saf, np.array([4.0, -4.0, 0.0]), k / RATE, k / RATE, 0.0, 0.0, 0.0, stop=True).copy()
                     for k in range(100, 120)])
    assert outs[0, 0] == pytest.approx(4.0 - FALCON.slew / RATE)
    assert outs[-1, 0] == 0.0 and outs[-1, 1] == 0.0


def test_switch_keeps_the_safety_stage_and_ramps_to_the_new_scene():
    """Issue 20 (one engine): a scene switch replaces the effects only; the safety stage's clock,
    counters and output carry on (no reset to 0 N: the weight compensation stays up), and the
    step to the new scene's force is slew-limited, the new reference starting at the screen."""
    eng = FFEngine([Stiffness(300.0)], FALCON, TouchPredictor(), rate=RATE)
    outs = [eng.tick(k / RATE, 0.0, 0.0, -0.005, k / RATE).copy() for k in range(300)]
    ticks = eng.counters.ticks
    eng.switch([Shape(0.02)])
    for k in range(300, 600):
        eng.touch(k / RATE, 0.05, 0.05, 1.0)
        outs.append(eng.tick(k / RATE, 0.0, 0.0, -0.005, k / RATE).copy())
    assert eng.counters.ticks == ticks + 300 and eng.effects[0].name == "shape"
    assert outs[300][2] >= outs[299][2] - FALCON.slew / RATE - EPS  # held up, not dropped to 0 N
    check(outs, FALCON)
