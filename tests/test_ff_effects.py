"""Force-feedback effects in closed-loop simulation against analytic references (issue 10)."""

import math

import numpy as np
import pytest

from surfhap.ff import FALCON, FFEngine, GridField, Idle, RectsField, Roughness, Shape, Sliding, Stiffness
from surfhap.ff import tick_kernel
from surfhap.ff.effects import TickState
from surfhap.render.kinematics import TouchPredictor
from surfhap.models.trajectory import Trajectory, constant_scan
from surfhap.sim.ff_device import SimDevice, SimFinger
from surfhap.live.ff_loop import simulate_ff

LAT = 0.040  # s, touch latency of the simulated tablet (004: "a few dozens of ms")


def sine_strokes(freq=0.5, amp=0.03, dur=6.0, load=1.0, rate=1000.0):
    t = np.arange(0.0, dur, 1.0 / rate)
    return Trajectory(t, 0.1 + amp * np.sin(2 * np.pi * freq * t), np.full(t.size, 0.07), np.full(t.size, load))


def run(effects, tr, lat=LAT, predict=True, device=FALCON, tail=0.2, **finger):
    pred = TouchPredictor(latency=lat if predict else 0.0, alpha=0.15 if predict else 1.0, velocity_alpha=0.45)
    eng = FFEngine(effects, device, pred, touch_latency=lat)
    return simulate_ff(eng, SimFinger(tr, latency=lat, **finger), SimDevice(gain=device.gain), tail=tail)


def steady(r, t0=2.0, t1=5.0):
    return (r.t > t0) & (r.t < t1)


@pytest.mark.parametrize("k_mat", [150.0, 300.0, 800.0])
def test_stiffness_force_is_k_mat_times_penetration(k_mat):
    load = 1.5
    r = run([Stiffness(k_mat)], sine_strokes(load=load))
    m = steady(r)
    pen = -r.screen[m, 2]  # X0 - X_t along z
    spring = r.force[m, 2] - FALCON.weight  # force beyond the weight compensation
    np.testing.assert_allclose(spring, k_mat * pen, rtol=0.01)
    # and the equilibrium is Hooke's law under the finger's load (device gain applied once)
    np.testing.assert_allclose(pen.mean(), load / k_mat, rtol=0.01)
    # lateral axes locked: the stroke does not move the screen
    assert np.abs(r.screen[m, :2]).max() < 1e-4


def _sliding_ratio(alpha):
    r = run([Sliding(alpha, mass=FALCON.moving_mass)], sine_strokes())
    m = steady(r)
    rel = np.sqrt(np.mean(np.sum(r.sliding[m] ** 2, axis=1)))
    fin = np.sqrt(np.mean(np.sum(r.finger_v[m] ** 2, axis=1)))
    return rel / fin, r


def test_follow_reduces_relative_sliding_by_80_percent():
    static, r0 = _sliding_ratio(0.0)
    follow, r1 = _sliding_ratio(1.0)
    assert static == pytest.approx(1.0, abs=0.02)  # screen held: relative sliding = finger speed
    assert follow <= 0.2 * static
    # the screen really travels with the finger (inside the workspace)
    m = steady(r1)
    assert np.ptp(r1.screen[m, 0]) > 0.05
    assert np.abs(r1.screen[:, :2]).max() <= FALCON.workspace[0]


def test_reverse_increases_relative_sliding():
    static, _ = _sliding_ratio(0.0)
    reverse, r = _sliding_ratio(-1.0)
    assert reverse > 1.5 * static
    assert np.abs(r.force).max(axis=0).tolist() <= list(FALCON.f_max)


@pytest.mark.parametrize("speed,period", [(0.05, 1e-3), (0.1, 2.5e-3), (0.03, 0.5e-3)])
def test_roughness_frequency_is_speed_over_period(speed, period):
    tr = constant_scan(speed, 1.0, 3.0, sensor_rate=1000.0)
    tr = Trajectory(tr.t, tr.x + 0.02, tr.y + 0.05, tr.load)
    r = run([Roughness(1e-4, period)], tr)
    m = (r.t > 1.0) & (r.t < 2.9)
    z = r.force[m, 2] - r.force[m, 2].mean()
    n = 1 << 18  # zero-padded FFT: bin 1000/2^18 = 0.004 Hz
    spec = np.abs(np.fft.rfft(z * np.hanning(z.size), n))
    freqs = np.fft.rfftfreq(n, 1e-3)
    f_peak = freqs[np.argmax(spec)]
    assert f_peak == pytest.approx(speed / period, rel=0.02)
    # amplitude: a grating of depth delta under K_max
    assert np.ptp(z) / 2 == pytest.approx(FALCON.k_max * 1e-4, rel=0.15)


def test_shape_follows_height_field():
    # a ramp 0 -> 10 mm over x = 0.05 .. 0.15 m
    xs = np.linspace(0.0, 0.2, 201)
    h = np.clip((xs - 0.05) / 0.1, 0, 1) * 0.01
    field = GridField(np.tile(h, (3, 1)), x0=-0.0005, y0=0.0, width=0.201, height=0.14)
    tr = constant_scan(0.02, 0.5, 5.0, sensor_rate=1000.0)
    tr = Trajectory(tr.t, tr.x + 0.03, tr.y + 0.07, tr.load)
    r = run([Shape(field)], tr)
    m = r.touched & (r.t > 0.5)
    expected = np.interp(r.finger[m, 0], xs, h)
    # position control at K_max under a 0.5 N finger: height minus 0.5 mm sag, within 1 mm
    np.testing.assert_allclose(r.screen[m, 2], expected - 0.5 / FALCON.k_max, atol=1e-3)


def _delayed_stream_errors(freq, amp=0.03, alpha=0.15, lat=LAT, rate=60.0, pixel=0.197 / 2048):
    """RMS error (m) of the raw delayed 60 Hz stream and of the predictor's output, against
    the true position at the moment each sample arrives (pixel: SM-T810, 2048 px on 197 mm)."""
    ts = np.arange(0.0, 8.0, 1.0 / rate)
    raw = np.round(amp * np.sin(2 * np.pi * freq * (ts - lat)) / pixel) * pixel
    p = TouchPredictor(latency=lat, alpha=alpha, velocity_alpha=0.45)
    e_raw, e_pred = [], []
    for t, x in zip(ts, raw):
        p.update(float(t), float(x), 0.0)
        if t > 2.0:
            true = amp * np.sin(2 * np.pi * freq * t)
            e_raw.append(x - true)
            e_pred.append(p.x - true)
    rms = lambda e: float(np.sqrt(np.mean(np.square(e))))  # noqa: E731
    return rms(e_raw), rms(e_pred)


@pytest.mark.parametrize("freq", [0.25, 0.5, 1.0])  # 4.7 - 19 cm/s peak over +-3 cm: usual strokes
def test_prediction_reduces_position_error_of_delayed_stream(freq):
    raw, pred = _delayed_stream_errors(freq)
    assert pred < raw
    if freq <= 0.5:
        assert pred < 0.5 * raw


def test_engine_world_estimate_beats_raw_delayed_stream():
    """In the closed loop (screen moving under Follow), the engine's world estimate of the
    finger is closer to the truth than the raw delayed touch stream converted to the world."""
    tr = sine_strokes(freq=0.5)
    r = run([Sliding(1.0, mass=FALCON.moving_mass)], tr)
    m = steady(r)
    t = r.t[m]
    true = r.finger[m, 0]
    delayed = np.interp(t - LAT, r.t, r.finger[:, 0])  # what a 40 ms late stream says now
    e_raw = np.sqrt(np.mean((delayed - true) ** 2))
    e_est = np.sqrt(np.mean((r.finger_est[m, 0] - true) ** 2))
    assert e_est < 0.5 * e_raw


def test_effects_merge_per_axis_most_compliant():
    s = TickState()
    s.touched = True
    s.fx, s.fy = 0.05, 0.05
    law = FFEngine([Stiffness(200.0), Sliding(0.5)], FALCON, TouchPredictor())
    out = np.zeros(3)

    def compute(s):  # the merged terms through the compiled eq. 8 (no safety stage)
        tick_kernel.law(law.R, law.L, s.px, s.py, s.pz, s.vx, s.vy, s.vz, *law.merge(s), out)
        return out

    compute(s)  # first tick: the reference starts at the screen, here X0
    s.pz, s.py = -0.002, 0.01
    f = compute(s)
    assert law.mask == 0b11
    assert f[1] == pytest.approx(-FALCON.damping * 0.0)  # lateral free (Sliding), screen at rest
    assert f[2] == pytest.approx(FALCON.weight + 200.0 * 0.002)  # normal: k_mat
    # untouched: Idle (eq. 5) only; the lateral reference was following the free screen
    # (y = 0.01) and now returns to X0 at ref_speed: no jump of K_max x 1 cm
    s.touched = False
    f = compute(s)
    assert law.mask == 0
    step = FALCON.ref_speed / 1000.0
    assert f[1] == pytest.approx(-FALCON.k_max * step)
    for _ in range(200):
        f = compute(s)
    assert f[1] == pytest.approx(-FALCON.k_max * 0.01)  # reference back at X0
    idle = own_law(Idle(), s)
    assert idle[2] == pytest.approx(FALCON.k_max * 0.002)


def test_map_switches_effect_off_outside_its_region():
    buttons = RectsField([(0.0, 0.0, 0.05, 0.05, 300.0)])
    eff = Stiffness(buttons)
    s = TickState()
    s.fx = s.fy = 0.02
    assert eff.terms(s)[2] == 300.0
    s.fx = 0.1
    assert eff.terms(s) is None
    assert math.isnan(buttons.value(0.1, 0.1))


def test_lift_off_a_high_floor_does_not_slam_the_screen_into_the_walls():
    """Leaving a 20 mm shape (finger lifted) brings the screen back to X0 without overshooting
    far below it (bumpless reference), and well inside the workspace."""
    field = RectsField([(0.0, 0.0, 0.2, 0.15, 0.02)])
    t = np.arange(0.0, 2.0, 1e-3)
    tr = Trajectory(t, np.full(t.size, 0.1), np.full(t.size, 0.07), np.full(t.size, 0.5))
    r = run([Shape(field)], tr, tail=1.0)
    after = r.t > t[-1]
    assert r.screen[~after & (r.t > 1.0), 2].mean() == pytest.approx(0.02 - 0.5 / FALCON.k_max, abs=1e-3)
    assert r.screen[after, 2].min() > -0.005
    assert abs(r.screen[-1, 2]) < 1e-3


def own_law(effect, s):
    """An effect's own law from its terms: ``ff + K (X0 + h e_z - X_t)`` with X0 = 0 (zeros where
    it does not apply)."""
    r = effect.terms(s)
    if r is None:
        return np.zeros(3)
    kx, ky, kz, h, ffx, ffy, ffz = r
    return np.array([ffx - kx * s.px, ffy - ky * s.py, ffz + kz * (h - s.pz)])


def test_each_effect_tick_is_its_paper_law():
    """Each effect alone: eq. 1 (Stiffness), 2 (Shape), 3 fixed (Roughness), 4 fixed (Sliding), 5 (Idle)."""
    km = FALCON.k_max
    s = TickState()
    s.touched = True
    s.fx, s.fy, s.fvx, s.fvy, s.speed = 0.05, 0.06, 0.1, 0.0, 0.1
    s.px, s.py, s.pz, s.vx, s.vy = 0.002, -0.001, -0.003, 0.04, 0.01
    X = np.array([s.px, s.py, s.pz])
    np.testing.assert_allclose(own_law(Stiffness(300.0), s), -np.diag([km, km, 300.0]) @ X)  # eq. 1, X0 = 0
    np.testing.assert_allclose(own_law(Shape(0.01), s), km * (np.array([0, 0, 0.01]) - X))  # eq. 2
    np.testing.assert_allclose(own_law(Idle(), s), -km * X)  # eq. 5
    sl = own_law(Sliding(1.0, nu=20.0), s)  # eq. 4 as implemented: nu (alpha f_dot - v_screen), normal held
    np.testing.assert_allclose(sl, [20.0 * (0.1 - 0.04), 20.0 * (0.0 - 0.01), -km * s.pz])
    rough = Roughness(2e-4, 1e-3)
    for _ in range(3):  # the phase advances by 2 pi speed dt / lambda per tick
        f = own_law(rough, s)
    np.testing.assert_allclose(f[2], km * (2e-4 * np.sin(3 * 2 * np.pi * 0.1 * s.dt / 1e-3) - s.pz))
