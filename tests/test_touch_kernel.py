"""The compiled touch step (render/hold.py, render/kinematics.py ``predict``): its speed and
position against the paper's filter written here independently (004 eq. 6-7 and the speed
low-pass), and one implementation for offline and live: neither runs the Python predictor
per sample (the offline render ran it per touch sample and halved its speed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from surfhap.exchange.materials import load_material
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.models.trajectory import Trajectory
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.hold import TouchHold, TrajectoryRows
from surfhap.render.kinematics import TouchPredictor
from surfhap.runtime.offline import render


def _reference(samples, latency, alpha, cutoff=20.0, velocity_alpha=None, max_gap=0.1, max_k=20.0):
    """004 Sec. 4.2 per sample: f_pred = f + k (f - f_prev) with k = latency/dt + (1-alpha)/alpha,
    f_out = alpha f_pred + (1 - alpha) f_out_prev; speed = one-pole low-pass (cutoff) of
    |d f_out / dt|, or |v| with v smoothed by velocity_alpha. Restarts after a gap > max_gap."""
    out, state = [], None
    for t, x in samples:
        if state is not None and 0.0 < t - state["t"] <= max_gap:
            dt = t - state["t"]
            k = min(latency / dt + (1 - alpha) / alpha, max_k) if latency else 0.0
            pred = x + k * (x - state["m"])
            f = alpha * pred + (1 - alpha) * state["f"]
            v = (f - state["f"]) / dt
            if velocity_alpha is None:
                g = dt / (1 / (2 * math.pi * cutoff) + dt)
                state["speed"] += g * (abs(v) - state["speed"])
            else:
                state["v"] += velocity_alpha * (v - state["v"])
                state["speed"] = abs(state["v"])
            state.update(t=t, m=x, f=f)
        elif state is not None and t - state["t"] <= 0.0 and t > state["t"] - max_gap:
            state["m"] = x  # duplicate stamp: position taken, filter kept
        else:
            state = {"t": t, "m": x, "f": x, "speed": 0.0, "v": 0.0}
        out.append((state["f"], state["speed"]))
    return np.array(out)


@pytest.mark.parametrize("latency, alpha, velocity_alpha", [(0.0, 1.0, None), (0.04, 0.15, None), (0.03, 0.5, 0.45)])
def test_the_compiled_predictor_follows_the_papers_filter(latency, alpha, velocity_alpha):
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.004, 0.012, 400))
    t[150:] += 0.3  # a gap: the filter restarts
    t[60] = t[59]  # a duplicate stamp
    x = 0.05 + 0.03 * np.sin(2 * np.pi * 0.8 * t) + rng.normal(0, 1e-4, t.size)
    p = TouchPredictor(latency=latency, alpha=alpha, velocity_alpha=velocity_alpha)
    got = []
    for ti, xi in zip(t, x):
        p.update(ti, xi, 0.0)
        got.append((p.x, p.speed))
    np.testing.assert_allclose(np.array(got), _reference(zip(t, x), latency, alpha, velocity_alpha=velocity_alpha),
                               rtol=1e-9, atol=1e-12)


def test_offline_and_live_hold_run_the_compiled_step_not_the_python_method(monkeypatch):
    def python_path(*_):
        raise AssertionError("the per-sample Python predictor ran")

    monkeypatch.setattr(TouchPredictor, "update", python_path)
    t = np.arange(0.0, 0.5, 0.008)
    traj = Trajectory(t, 0.02 + 0.1 * t, np.full(t.size, 0.03), np.full(t.size, 0.5), name="ramp")
    speed = render(load_material("cork"), traj, ChainConfig(drive_rate=20000), block_seconds=0.1).speed
    assert speed[-100:] == pytest.approx(0.1, rel=0.02)  # the ramp's 0.1 m/s, held per model sample
    e = LiveEngine(TextureChain(load_material("cork"), ChainConfig(drive_rate=20000)), EngineConfig())
    for k in range(100):
        if k % 8 == 0:
            e.push_touch(1, 0.02 + 1e-4 * k, 0.03, 0.5, t_arrival=k * 1e-3)
        e.render(e.block_frames, k * 1e-3)
    assert e.counters["errors"] == 0 and e.counters["touches"] == 13
    assert e.predictor.speed == pytest.approx(0.1, rel=0.05)


def test_a_hold_drains_a_source_longer_than_its_buffer_in_order():
    t = np.arange(40) * 0.001
    traj = Trajectory(t, t, np.zeros(40), np.full(40, 0.5), name="steps")
    hold = TouchHold(TrajectoryRows(traj), TouchPredictor(), 0.05, capacity=4)
    hold.take(0.0, 0.0)
    out = np.empty((5, 80))
    hold.fill(0, 2000.0, out)
    np.testing.assert_array_equal(out[3], np.repeat(t, 2))  # x in force at each model sample
