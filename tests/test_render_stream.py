"""Streaming offline render: the same drive and summary as ``render()``, the render files and
their one reader, a bounded figure preview, constant memory, and clean interruption."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from surfhap import ChainConfig, constant_scan, load_material, strokes
from surfhap.texture import render
from surfhap.cli import main
from surfhap.errors import ConfigError
from surfhap.exchange.render_files import write_render
from surfhap.exchange.render_store import read_render, store_dtype
from surfhap.runtime.offline import CHANNELS, stream_render
from surfhap.models.trajectory import Trajectory

REPO = Path(__file__).resolve().parents[1]


def collect(material, traj, cfg, **kw):
    blocks = {}
    res = stream_render(material, traj, cfg, lambda name, b: blocks.setdefault(name, []).append(np.array(b)), **kw)
    return res, {k: np.concatenate(v) for k, v in blocks.items()}


def assert_same_summary(in_memory: dict, streamed: dict):
    for key, value in in_memory.items():
        if key in ("mean_friction_sim_n", "texture_share"):  # block sums vs numpy's pairwise sum of the whole
            assert streamed[key] == pytest.approx(value, rel=1e-12, abs=1e-15)
        else:
            assert streamed[key] == value, key


def test_streamed_drive_and_channels_equal_render_bitwise():
    leather = load_material("leather")
    traj, cfg = strokes(0.1, 0.4, 3.0), ChainConfig(drive_rate=20000)
    ref = render(leather, traj, cfg)
    res, got = collect(leather, traj, cfg, block_seconds=0.37)
    assert set(got) == set(CHANNELS)
    for name in CHANNELS:
        np.testing.assert_array_equal(got[name], getattr(ref, name), err_msg=name)
    assert got["drive"].size == 60010 and not res.interrupted
    assert_same_summary(ref.summary(), res.summary())


def test_render_and_stream_render_return_the_one_result_type_through_the_one_loop(monkeypatch):
    """Both entry points return a RenderResult (the surfhap.results.Result base: summary,
    to_dict, plot) and drive their blocks through surfhap.runtime.loop.run on a SimClock."""
    import surfhap.runtime.offline as offline
    from surfhap.render.offline import RenderResult
    from surfhap.results import Result
    from surfhap.runtime.clock import SimClock

    clocks = []
    real_run = offline.run

    def spy(source, engine, clock, sink, **kw):
        clocks.append(clock)
        return real_run(source, engine, clock, sink, **kw)

    monkeypatch.setattr(offline, "run", spy)
    cork, traj = load_material("cork"), constant_scan(0.1, 0.3, 0.5)
    mem = render(cork, traj)
    streamed, _ = collect(cork, traj, ChainConfig())
    assert type(mem) is type(streamed) is RenderResult and isinstance(mem, Result)
    assert len(clocks) == 2 and all(isinstance(c, SimClock) for c in clocks)
    assert mem.drive is not None and streamed.drive is None  # the streamed arrays went to the sink
    assert json.loads(json.dumps(streamed.to_dict())) == json.loads(json.dumps(mem.to_dict()))
    import surfhap as sh

    assert {"render", "stream_render", "RenderResult"} <= set(sh.texture.__all__)


def test_incremental_summary_equals_in_memory_with_saturation():
    """A load ramp past the plan's range with a manual alpha: clamping, an onset load, clipped
    samples, a lift and a dropout; every counter and statistic matches the in-memory render."""
    t = np.arange(0.0, 4.0, 0.008)
    t = t[(t < 2.0) | (t > 2.2)]
    load = np.where((t > 1.0) & (t < 1.2), 0.0, 0.05 + 0.3 * t)
    traj = Trajectory(t, 0.1 * t, 0 * t, load, name="ramp")
    cfg = ChainConfig(alpha=700.0, seed=2)
    mat = load_material("leather")
    ref = render(mat, traj, cfg)
    res, got = collect(mat, traj, cfg, block_seconds=0.25)
    s_ref, s = ref.summary(), res.summary()
    assert s_ref["saturated_fraction"] > 0.01 and s_ref["saturation_onset_load_n"] is not None
    assert s_ref["safety"]["watchdog"] > 0 and s_ref["safety"]["lifted"] > 0
    assert_same_summary(s_ref, s)
    assert res.saturation_warning() == ref.saturation_warning() is not None
    np.testing.assert_array_equal(got["drive"], ref.drive)


@pytest.mark.parametrize("fmt", ["npz", "h5"])
def test_render_file_round_trip(tmp_path, fmt):
    leather = load_material("leather")
    r = render(leather, constant_scan(0.1, 0.3, 1.0), ChainConfig(seed=1))
    paths = write_render(r, tmp_path, format=fmt)
    assert paths["render"].name == f"render.{fmt}"
    data = read_render(paths["render"])
    for name in CHANNELS:
        assert data[name].dtype == store_dtype(name)
        np.testing.assert_array_equal(data[name], getattr(r, name).astype(store_dtype(name)), err_msg=name)
    np.testing.assert_array_equal(data["t"], r.t)
    np.testing.assert_array_equal(data["t_drive"], r.t_drive)
    np.testing.assert_array_equal(data["acc"], r.acc.astype(np.float32))  # leather's texture is an acceleration
    assert data.rates["drive"] == 20000 and data.rates["voltage"] == r.control_rate
    assert data.units["drive"] == "V" and data.units["texture"] == "m/s^2" and data.units["friction_sim"] == "N"
    assert data.attrs["material"] == "leather" and data.attrs["complete"] is True and data.attrs["interrupted"] is False
    assert float(data["latency"]) == r.latency
    summary = json.loads(paths["summary"].read_text())
    assert summary["max_abs_voltage"] == r.summary()["max_abs_voltage"]


def test_reader_registry(tmp_path):
    r = render(load_material("cork"), constant_scan(0.1, 0.3, 0.5))
    write_render(r, tmp_path / "h", format="h5")
    assert read_render(tmp_path / "h").attrs["format"] == "surfhap-render"  # a folder: its render file
    # a render.npz of the earlier layout (t, t_drive and latency stored, no metadata)
    legacy = tmp_path / "old.npz"
    np.savez(legacy, t=r.t, t_drive=r.t_drive, drive=r.drive, voltage=r.voltage, latency=np.array(r.latency))
    old = read_render(legacy)
    np.testing.assert_array_equal(old["drive"], r.drive)
    assert old.rates["drive"] == 20000 and old["latency"] == r.latency
    for bad, message in (("render.csv", "unknown render file type"), ("missing.h5", "no such file")):
        with pytest.raises(ConfigError, match=message):
            read_render(tmp_path / bad)
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(ConfigError, match="junk.h5"):
        read_render(tmp_path / "junk.h5")
    with pytest.raises(ConfigError, match="no render.h5 or render.npz"):
        read_render(tmp_path)


def test_preview_is_bounded_and_matches_the_in_memory_figure_data():
    cork = load_material("cork")
    cfg = ChainConfig(seed=4)
    short, long_ = constant_scan(0.1, 0.3, 3.0), strokes(0.1, 0.3, 90.0)
    res, _ = collect(cork, short, cfg)
    ref = render(cork, short, cfg)  # the full arrays: each preview field is a slice or a bin of them
    pv, fm, fd = res.preview, ref.control_rate, ref.drive_rate
    a = int(round(pv.win_t[0] * fm))
    w = slice(a, a + pv.win_t.size)
    np.testing.assert_array_equal(pv.win_t, ref.t[w])
    for field, full in (("win_friction", ref.friction_sim), ("win_target", ref.target), ("win_load", ref.load)):
        np.testing.assert_array_equal(getattr(pv, field), full[w], err_msg=field)
    d = int(round(pv.drv_t[0] * fd))
    np.testing.assert_array_equal(pv.drv, ref.drive[d:d + pv.drv.size])
    e = int(round(pv.env_t[0] * fm))
    np.testing.assert_array_equal(pv.env, ref.voltage[e:e + pv.env.size])
    np.testing.assert_array_equal(pv.spec_added, ref.added_friction[int(0.5 * fm):][:pv.spec_added.size])
    per = int(round(pv.col_t[1] * fm))
    np.testing.assert_array_equal(pv.speed_max, [ref.speed[i:i + per].max() for i in range(0, ref.t.size, per)])
    np.testing.assert_array_equal(pv.load_min, [ref.load[i:i + per].min() for i in range(0, ref.t.size, per)])
    big, _ = collect(cork, long_, cfg, preview_columns=500)
    pv = big.preview
    assert pv.win_t.size <= 2001 and pv.drv.size <= 1001 and pv.col_t.size <= 500
    assert pv.spec_added.size <= 30 * 2000  # 30 s of added friction, not 90
    assert pv.speed_max.max() == pytest.approx(0.1, rel=0.05) and pv.load_min.min() == 0.3


def test_bad_format_one_line_exit_2(tmp_path, capsys):
    code = main(["render", "cork", "--scan", "speed=0.1,load=0.3,duration=1", "--format", "zarr", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and "--format" in lines[0] and "zarr" in lines[0], err
    assert not (tmp_path / "o").exists()


def test_cli_format_choice(tmp_path, capsys):
    for fmt, seconds, name in (("auto", 1.0, "render.npz"), ("h5", 1.0, "render.h5"), ("auto", 61.0, "render.h5")):
        out = tmp_path / f"{fmt}{seconds:g}"
        code = main(["render", "cork", "--scan", f"speed=0.1,load=0.3,duration={seconds:g}", "--format", fmt,
                     "--out", str(out), "--no-figure"])
        assert code == 0, capsys.readouterr().err
        assert [p.name for p in out.glob("render.*")] == [name]
        assert read_render(out / name)["voltage"].size == int(seconds * 2000) + 1


CHILD = """
import resource, sys
from pathlib import Path
from surfhap import ChainConfig, load_material, strokes
from surfhap.batch.jobs import render_to_folder
mat = load_material("cork")
render_to_folder(mat, strokes(0.1, 0.3, 2.0), ChainConfig(), Path(sys.argv[2]) / "warm", fmt="h5", figure=False)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
render_to_folder(mat, strokes(0.1, 0.3, float(sys.argv[1])), ChainConfig(), Path(sys.argv[2]) / "r", fmt="h5", figure=False)
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base)
"""


def test_memory_does_not_grow_with_duration(tmp_path):
    """Peak RSS added by a 600 s render over a warmed-up process is within 12 MB of a 60 s
    render's (the in-memory path holds ~650 MB for 600 s; the 125 Hz trajectory itself is 3 MB)."""
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    grown = {}
    for seconds in (60, 600):
        out = subprocess.run([sys.executable, "-c", CHILD, str(seconds), str(tmp_path / str(seconds))], env=env,
                             capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        grown[seconds] = int(out.stdout.strip()) / 1024  # MB
        assert read_render(tmp_path / str(seconds) / "r")["drive"].size == seconds * 20000 + 10
    assert grown[600] <= grown[60] + 12.0, grown


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_interrupt_leaves_a_valid_file_and_says_so(tmp_path, sig):
    out = tmp_path / "r"
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    proc = subprocess.Popen([sys.executable, "-m", "surfhap", "render", "cork", "--scan", "speed=0.1,load=0.3,duration=3600",
                             "--out", str(out), "--no-figure"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300  # a guard against a hang, not a timing assertion
    while not (out / "render.h5").exists() or (out / "render.h5").stat().st_size < 2_000_000:
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read() if proc.poll() is not None else "no output"
        time.sleep(0.05)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] is True and 0 < summary["rendered_s"] < summary["requested_s"] == pytest.approx(3600, abs=0.01)
    data = read_render(out / "render.h5")
    assert data.attrs["complete"] is True and data.attrs["interrupted"] is True
    n = data["voltage"].size
    assert n == round(summary["rendered_s"] * 2000)
    assert all(data[name].size == n for name in CHANNELS if name != "drive")
    assert data["drive"].size >= (n - 1) * 10 and summary["safety"]["samples"] == data["drive"].size
    assert np.max(np.abs(data["drive"])) <= 250.0 and summary["max_abs_voltage"] == np.max(np.abs(data["drive"]))
    from scipy.io import wavfile

    rate, wav = wavfile.read(out / "drive.wav")
    assert rate == 20000 and wav.size == data["drive"].size


def test_drive_beyond_the_amplifier_gain_stops_with_one_line_and_no_partial_files(tmp_path, capsys):
    out = tmp_path / "o"
    code = main(["render", "cork", "--scan", "speed=0.1,load=0.3,duration=3", "--amp-gain", "20", "--format", "h5",
                 "--out", str(out)])
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and "amp_gain" in lines[0], err
    assert not (out / "render.h5").exists() and not (out / "drive.wav").exists() and not (out / "summary.json").exists()


def test_an_interrupted_render_written_later_says_so_in_its_file(tmp_path):
    """write_render of a kept, interrupted render wrote ``interrupted: False`` (the attribute
    was a separate argument); the file's attributes are now the summary's own entries."""
    polls = iter(range(1000))
    r = stream_render(load_material("cork"), constant_scan(0.1, 0.3, 3.0), ChainConfig(seed=2), None, keep=True,
                      stop=lambda: next(polls) >= 1)
    assert r.interrupted and 0 < r.n_model < r.n_total
    attrs = read_render(write_render(r, tmp_path)["render"]).attrs
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert attrs["interrupted"] is True and attrs["texture_quantity"] == r.texture_quantity
    for key in ("material", "method", "seed", "trajectory", "control_rate_hz", "drive_rate_hz", "carrier_hz", "latency_s",
                "v_max", "mu_panel"):
        assert attrs[key] == summary[key], key
