"""The live engine with a manual clock: latency, watchdog, lift, stop ramp, arbitration,
hostile input, and the paced backends (sim, file) in real time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from surfhap.exchange.materials import load_material
from surfhap.live.audit import audit_drive
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.kinematics import TouchPredictor
from surfhap.live.queues import CommandQueue, TouchRing
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.safety import SafetyLimits
from surfhap.runtime.clock import SimClock
from surfhap.runtime.commands import SetGain, Stop, SwapRenderer


def make_engine(material="cork", drive_rate=20000, **cfg):
    chain = TextureChain(load_material(material), ChainConfig(drive_rate=drive_rate))
    return LiveEngine(chain, EngineConfig(**cfg))


def run(engine, t0, t1, touch=None, rate=125.0):
    """Render blocks on a manual clock from t0 to t1; touch(t) -> (x, y, load) or None."""
    out = []
    nb = int(round((t1 - t0) / engine.block_period))
    next_touch = t0
    for k in range(nb):
        t = t0 + k * engine.block_period
        while touch is not None and next_touch <= t:
            s = touch(next_touch)
            if s is not None:
                engine.push_touch(1, *s, t_event=next_touch, t_arrival=next_touch)
            next_touch += 1.0 / rate
        out.append(engine.render(engine.block_frames, t).copy())
    return np.concatenate(out) if out else np.zeros(0)


def stroke(t):
    return (0.02 + 0.1 * t, 0.03, 0.5)


def test_predictor_identity_without_prediction():
    p = TouchPredictor()
    for i in range(10):
        p.update(i / 60, 0.01 * i, 0.0)
    assert p.x == pytest.approx(0.09)
    assert p.speed == pytest.approx(0.6, rel=0.05)


@pytest.mark.parametrize("alpha", [1.0, 0.15, 0.5])
def test_predictor_leads_a_ramp_by_the_configured_latency(alpha):
    v, lat, rate = 0.1, 0.030, 60.0
    p = TouchPredictor(latency=lat, alpha=alpha)
    for i in range(300):
        t = i / rate
        p.update(t, v * t, 0.0)
    assert p.x == pytest.approx(v * (t + lat), abs=1e-6)


def test_predictor_paper_parameters_give_net_lead():
    # KinesTouch 004 Sec. 4.2: k_pred = 8, alpha = 0.15 at 60 Hz -> lead (8 - 0.85/0.15) / 60 s
    p = TouchPredictor(k_pred=8, alpha=0.15)
    v = 0.1
    for i in range(600):
        t = i / 60
        p.update(t, v * t, 0.0)
    lead = (p.x - v * t) / v
    assert lead == pytest.approx((8 - 0.85 / 0.15) / 60, rel=1e-3)


def test_predictor_restarts_after_gap_and_ignores_duplicates():
    p = TouchPredictor(latency=0.02, alpha=0.5)
    p.update(0.0, 0.0, 0.0)
    p.update(0.01, 0.001, 0.0)
    p.update(0.01, 0.002, 0.0)  # duplicate stamp: no division by zero
    assert math.isfinite(p.x) and math.isfinite(p.speed)
    p.update(5.0, 0.05, 0.0)  # long gap: restart at the measured position
    assert p.x == 0.05 and p.speed == 0.0


def test_touch_ring_bounded_and_fifo():
    r = TouchRing(4)
    assert all(r.push(1, i, i, i, 0, 1) for i in range(4))
    assert not r.push(1, 9, 9, 9, 0, 1) and r.dropped == 1
    buf = np.zeros((8, 6))
    assert r.pop_into(buf) == 4 and list(buf[:4, 3]) == [0, 1, 2, 3]
    q = CommandQueue(2)
    assert q.put(("a",)) and q.put(("b",)) and not q.put(("c",))
    assert q.get_nowait() == ("a",)


def test_drive_follows_touch_within_two_blocks():
    e = make_engine()
    run(e, 0.0, 0.1)  # silence, no finger
    assert not np.any(e.out[: e.block_frames])
    rng = np.random.default_rng(1)
    t = 0.1
    for i in range(200):  # touches at random phases between blocks
        t_arr = t + rng.uniform(0, e.block_period)
        e.push_touch(1, 0.02 + 0.001 * i, 0.03, 0.5, t_event=t_arr, t_arrival=t_arr)
        t_blk = t + e.block_period
        e.render(e.block_frames, t_blk)
        t = t_blk + 4 * e.block_period
        for _ in range(4):
            e.render(e.block_frames, t - 3 * e.block_period)
    st = e.latency_stats()
    assert st["n"] == 200
    assert st["p99"] <= 2 * e.block_period  # on the engine's simulated clock (times passed in), not wall time
    assert np.abs(e.out[: e.block_frames]).max() > 10.0


def test_first_block_after_touch_already_changes_the_drive():
    e = make_engine()
    run(e, 0.0, 0.02)
    e.push_touch(1, 0.02, 0.03, 0.5, t_arrival=0.0205)
    v = e.render(e.block_frames, 0.021)
    assert np.abs(v).max() > 0.0


def test_watchdog_ramps_to_zero_when_touches_stop():
    e = make_engine()
    out = run(e, 0.0, 0.3, touch=lambda t: stroke(t) if t < 0.2 else None)
    fs = e.drive_rate
    assert np.abs(out[int(0.15 * fs) : int(0.2 * fs)]).max() > 50
    # last touch at <= 0.2 s; 50 ms timeout + 5 ms ramp (+ one sensor period)
    assert np.abs(out[int(0.2665 * fs) :]).max() == 0.0
    assert e.safety_counters()["watchdog"] > 0


def test_lift_silences_at_once_even_with_a_slow_model():
    e = make_engine("denim")  # 100 Hz texture model (resampled up to the 2 kHz control rate)
    assert e.renderer.texture_rate == 100
    run(e, 0.0, 0.2, touch=stroke)
    assert np.abs(e.out[: e.block_frames]).max() > 0
    e.push_touch(1, 0.0, 0.0, 0.0, t_arrival=0.2)
    v = e.render(e.block_frames, 0.2005)
    assert not np.any(v)
    assert not np.any(run(e, 0.201, 0.25))


def test_stop_ramps_down_and_stays_silent():
    e = make_engine(stop_ramp=0.005)
    run(e, 0.0, 0.1, touch=stroke)
    e.request_stop()
    tail = run(e, 0.1, 0.12, touch=stroke)
    fs = e.drive_rate
    assert e.stopped
    assert np.abs(tail[int(0.0055 * fs) :]).max() == 0.0
    assert np.abs(tail[: int(0.001 * fs)]).max() > 0.0  # a ramp, not a cut


def test_second_source_waits_while_first_touches():
    e = make_engine()
    for k in range(20):
        t = k * 0.004
        e.push_touch(1, 0.02, 0.03, 0.5, t_arrival=t)
        e.push_touch(2, 0.10, 0.10, 0.5, t_arrival=t + 0.001)
        e.render(e.block_frames, t + 0.002)
    assert e.counters["touches_ignored"] == 20
    assert e.predictor.x == pytest.approx(0.02)


def test_hostile_values_pushed_directly_keep_output_safe():
    e = make_engine()
    bad = [(math.nan, 0, 0.5), (math.inf, 0, 0.5), (0, 0, math.nan), (0, 0, -5), (1e300, -1e300, 1e9), (0, 0, math.inf)]
    out = []
    for k in range(300):
        x, y, ld = bad[k % len(bad)] if k % 3 else stroke(k * 1e-3)
        e.push_touch(1, x, y, ld, t_event=math.nan if k % 2 else k * 1e-3, t_arrival=k * 1e-3)
        out.append(e.render(e.block_frames, k * 1e-3 + 5e-4).copy())
    out = np.concatenate(out)
    assert e.counters["errors"] == 0
    assert audit_drive(out, e.drive_rate, SafetyLimits())["violations"] == 0


def test_full_touch_ring_is_counted_not_fatal():
    e = make_engine(touch_capacity=16)
    for _ in range(100):
        e.push_touch(1, 0.01, 0.01, 0.5, t_arrival=0.0)
    assert e.touches.dropped == 84
    e.render(e.block_frames, 0.001)
    assert e.status()["counters"]["touches_dropped"] == 84


def test_audit_finds_violations():
    lim = SafetyLimits()
    step = lim.rise_rate / 20000
    bad = np.array([0.0, 300.0, 0.0, 0.0, min(lim.v_max, 1.5 * step)])
    a = audit_drive(bad, 20000, lim)
    assert a["over_v_max"] == 1 and a["rise_too_fast"] == 2


def push_and_wait(e, t0, n=25, patience=60.0):
    """Push n touches 8 ms apart from another thread than the backend's, then wait (bounded,
    generously) until the engine has consumed them. Returns the number accepted."""
    import time

    accepted = 0
    for _ in range(n):
        accepted += bool(e.push_touch(1, *stroke(time.perf_counter() - t0)))
        time.sleep(0.008)
    end = time.monotonic() + patience
    while e.counters["touches"] < accepted and time.monotonic() < end:
        time.sleep(0.005)
    return accepted


def test_sim_backend_runs_in_real_time(tmp_path):
    import time

    from surfhap.live.backends.output import FileOutput, SimOutput, open_backend

    e = make_engine()
    e.warm_up()
    b = open_backend(SimOutput())
    t_start = time.perf_counter()
    b.start(e)
    pushed = push_and_wait(e, t_start)
    b.stop()
    t_stop = time.perf_counter()
    assert e.stopped
    assert e.counters["touches"] == pushed  # every touch reached the renderer
    # paced: never ahead of the clock (a loaded machine may only make it slower)
    assert 1 <= e.counters["blocks"] <= (t_stop - t_start) / e.block_period + 2
    assert e.latency_stats()["n"] > 0


@pytest.mark.parametrize("suffix", [".wav", ".npz"])
def test_file_backend_records_what_the_engine_rendered(tmp_path, suffix):
    import time

    from surfhap.live.backends.output import FileOutput, SimOutput, open_backend

    e = make_engine()
    e.warm_up()
    path = tmp_path / f"drive{suffix}"
    b = open_backend(FileOutput(str(path)))
    b.start(e)
    pushed = push_and_wait(e, time.perf_counter())
    b.stop()
    assert e.counters["touches"] == pushed
    assert path.exists()
    rec = b.recorded
    assert rec.size == e.counters["frames"] and np.abs(rec).max() > 10
    if suffix == ".npz":
        z = np.load(path)
        assert int(z["drive_rate"]) == e.drive_rate and np.array_equal(z["drive"], rec)
    else:
        from scipy.io import wavfile

        rate, u = wavfile.read(path)
        assert rate == e.drive_rate and np.allclose(u, rec / 250.0, atol=1e-6)


def test_output_parser_errors():
    from surfhap.cli._output import parse_output
    from surfhap.errors import ConfigError
    from surfhap.live.backends.output import FileOutput, OscOutput, SimOutput, SoundOutput

    assert parse_output("sound:3") == SoundOutput(3)
    assert parse_output("sound:Dummy") == SoundOutput("Dummy")
    assert parse_output("osc://127.0.0.1:9001/drive") == OscOutput("127.0.0.1", 9001, "drive")
    assert parse_output("file:d.npz") == FileOutput("d.npz") and parse_output(None) == SimOutput()
    assert parse_output("sound").reaches_amplifier and not parse_output("file:d.wav").reaches_amplifier
    for bad in ("file:x.txt", "osc://nohost", "osc://127.0.0.1:9/whatever", "pigeon"):
        with pytest.raises(ConfigError):
            parse_output(bad)


def test_renderer_swap_keeps_rendering():
    e = make_engine()
    run(e, 0.0, 0.1, touch=stroke)
    new = TextureChain(load_material("leather"), ChainConfig(drive_rate=20000))
    assert e.send(SwapRenderer(new))
    out = run(e, 0.1, 0.2, touch=stroke)
    assert e.renderer is new and e.counters["errors"] == 0
    assert np.abs(out[-e.drive_rate // 50 :]).max() > 50
    assert e.safety_counters()["faults"] == 0


@pytest.mark.parametrize("stamp", [3.0, 1e300, math.inf, -math.inf, math.nan, "back"])
def test_a_callers_stamp_never_extends_a_touch_life(stamp):
    # issue 17 #1: a normal stroke, then one sample whose caller's t_arrival is from the
    # future / non-finite / going backwards, then silence: the engine stamps arrival on its
    # own clock, so the output is 0 V from 50 + 5 ms after the last trusted sample
    clock = [0.0]
    chain = TextureChain(load_material("cork"), ChainConfig(drive_rate=20000))
    e = LiveEngine(chain, EngineConfig(), clock=lambda: clock[0])
    out, t_last = [], 0.0
    for k in range(300):
        t = clock[0] = k * e.block_period
        if t < 0.2 and k % 8 == 0:
            e.push_touch(1, *stroke(t), t_event=t, t_arrival=t)
            t_last = t
        if k == 200:  # 0.2 s: the hostile stamp on an otherwise fresh sample
            e.push_touch(1, *stroke(t), t_arrival=(t_last - 0.01) if stamp == "back" else t + stamp)
        out.append(e.render(e.block_frames, t).copy())
    out = np.concatenate(out)
    fs = e.drive_rate
    assert np.abs(out[int(0.15 * fs) : int(0.19 * fs)]).max() > 50
    assert not np.any(out[int((t_last + 0.055) * fs) + 1 :])
    assert e.counters["stale_stamps"] == 1
    assert e.output_safety_counters()["watchdog"] + e.safety_counters()["watchdog"] > 0


def test_the_engine_stamps_arrival_on_its_own_clock():
    clock = [5.0]
    e = LiveEngine(TextureChain(load_material("cork"), ChainConfig(drive_rate=20000)), clock=lambda: clock[0])
    e.push_touch(1, 0.02, 0.03, 0.5)  # no stamp: now
    e.push_touch(1, 0.02, 0.03, 0.5, t_arrival=4.9)  # older: kept
    e.push_touch(1, 0.02, 0.03, 0.5, t_arrival=5.1)  # future: stale
    buf = np.zeros((8, 6))
    assert e.touches.pop_into(buf) == 3
    assert list(buf[:3, 2]) == [5.0, 4.9, -math.inf]


def _touching_file_backend(path, **kw):
    """A file backend whose blocks are followed by a firm, moving touch (the finger stays on)."""
    from surfhap.live.backends.file import FileBackend

    class Touching(FileBackend):
        def emit(self, volts):
            super().emit(volts)
            t = self.engine.clock()
            self.engine.push_touch(1, 0.05 + 0.03 * math.sin(t), 0.03, 2.0)

    return Touching(path, **kw)


def _run_file_backend(monkeypatch, b, seconds, rate=20000, block=0.005):
    """Run ``b`` on a simulated clock for ``seconds``, then stop."""
    import time

    import surfhap.live.backends.base as base

    sim = SimClock(100.0)
    monkeypatch.setattr(base, "now", sim.now)  # the stall watch's clock
    b.clock = sim
    e = LiveEngine(TextureChain(load_material("cork"), ChainConfig(drive_rate=rate)), EngineConfig(block_seconds=block),
                   clock=sim.now)
    t0 = sim.t
    b.start(e)
    guard = time.monotonic() + 600.0  # failure guard only
    while sim.t - t0 < seconds and time.monotonic() < guard:
        time.sleep(0.05)
    b.stop()
    return e


def _ends_with_a_stop_ramp(rec, e):
    """The recording drives until a linear stop ramp, then holds exactly 0 V to its end."""
    nz = np.flatnonzero(rec)
    i_last = nz[-1]
    ramp_n = int(round(e.config.stop_ramp * e.drive_rate))
    assert i_last < rec.size - 1 and not np.any(rec[i_last + 1 :])  # ends at 0 V
    assert np.abs(rec[i_last - ramp_n - 100 : i_last - ramp_n]).max() > 100  # driving before the ramp
    j = np.arange(ramp_n)
    env = 250.0 * (ramp_n - j + 1) / ramp_n + 1e-3  # a linear ramp from v_max (one sample of slack)
    assert np.all(np.abs(rec[i_last - ramp_n + 1 + j]) <= env)


@pytest.mark.parametrize("suffix", [".npz", ".wav"])
def test_file_output_longer_than_the_old_cap_keeps_everything_and_the_stop_ramp(tmp_path, monkeypatch, suffix):
    # issue 17 #6: `serve --output file:x.wav --duration 130` wrote 120.0 s (a silent cap)
    # and lost the stop ramp; 130 s on a simulated clock (a few s of wall time)
    path = tmp_path / f"long{suffix}"
    b = _touching_file_backend(path)
    e = _run_file_backend(monkeypatch, b, 130.0)
    assert e.stopped and e.failure is None
    rec = b.recorded
    assert rec.size == e.counters["frames"] and rec.size >= 130 * e.drive_rate  # nothing dropped
    assert b.info()["capped_blocks"] == 0 and not b.info()["cap_reached"]
    if suffix == ".npz":
        assert audit_drive(rec, e.drive_rate, e.renderer.safety.limits)["violations"] == 0
    else:
        from scipy.io import wavfile

        rate, u = wavfile.read(path)
        assert rate == e.drive_rate and u.size == rec.size
    _ends_with_a_stop_ramp(rec, e)


def test_file_output_cap_is_explicit_warned_counted_and_ramped(tmp_path, monkeypatch, caplog):
    import logging

    path = tmp_path / "capped.npz"
    b = _touching_file_backend(path, max_seconds=2.0)
    with caplog.at_level(logging.WARNING, logger="surfhap.live"):
        e = _run_file_backend(monkeypatch, b, 10.0)
    rec = b.recorded
    assert rec.size == 2 * e.drive_rate  # exactly the cap: it ran on past it
    info = b.info()
    assert info["cap_reached"] and info["capped_blocks"] >= 1 and info["max_seconds"] == 2.0
    assert sum("reaches --max-seconds" in r.getMessage() for r in caplog.records) == 1
    assert audit_drive(rec, e.drive_rate, e.renderer.safety.limits)["violations"] == 0
    _ends_with_a_stop_ramp(rec, e)


def test_file_output_cap_option_is_checked(tmp_path):
    from surfhap.errors import ConfigError
    from surfhap.live.backends.file import FileBackend

    for bad in (0.0, -1.0, math.nan, math.inf, 0.01):
        with pytest.raises(ConfigError, match="--max-seconds"):
            FileBackend(tmp_path / "x.wav", max_seconds=bad)


def test_engine_commands_are_typed_and_an_unknown_one_is_an_error():
    # issue 20: commands were tuples and an unknown one was silently ignored
    from surfhap.errors import ConfigError

    e = make_engine()
    for bad in (("gain", 0.5), "stop", ("stop",), None, 0.5):
        with pytest.raises(TypeError):
            e.send(bad)
    for g in (float("nan"), -0.1, 1.5, True, "1"):
        with pytest.raises(ConfigError):
            SetGain(g)
    assert e.commands.get_nowait() is None  # nothing reached the queue
    assert e.send(SetGain(0.25)) and e.send(Stop())
    e.render(e.block_frames, 0.0)
    assert e._gain == 0.25 and e.stopping


def test_a_swapped_in_renderer_is_reset_by_the_engine_in_the_thread_that_renders():
    """SwapRenderer: the engine resets the renderer it takes (its sample clock restarts at 0),
    in the thread that calls render, never at send: a reset from the sender's thread (a page's
    stimulus switch) could land inside a block the engine renders with it (the texture buffer's
    fill then changes between its kernel_args and its kernel)."""
    import threading

    a = TextureChain(load_material("cork"), ChainConfig(drive_rate=20000))
    b = TextureChain(load_material("denim"), ChainConfig(drive_rate=20000))
    clock = [10.0]
    eng = LiveEngine(a, EngineConfig(), clock=lambda: clock[0])
    resets = []
    b_reset = b.reset
    b.reset = lambda: (resets.append(threading.current_thread()), b_reset())[1]
    eng.push_touch(1, 0.02, 0.03, 0.5)
    eng.render(eng.block_frames)
    assert eng.send(SwapRenderer(b)) and resets == []  # not when sent
    renderer_thread = threading.Thread(target=eng.render, args=(eng.block_frames,))
    renderer_thread.start()
    renderer_thread.join(60)
    assert eng.renderer is b and resets == [renderer_thread]
