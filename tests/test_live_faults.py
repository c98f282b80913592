"""Faults of a live run (issue 8, items 9-11): SIGTERM stops like Ctrl-C, a recording is
checked at start and survives a crash, a backend that raises or stalls is reported and
the output is driven to 0 V."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.io import wavfile

import surfhap
from surfhap.cli import main
from surfhap.exchange.materials import load_material
from surfhap.live.backends.base import PacedBackend
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain

SURFHAP = [sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())"]
RATE = 20000
FULL = "speed=0.1,load=2.0,duration=120"  # friction-only cork at 2 N: the drive sits at the 250 V limit


def _friction_only_cork(tmp_path: Path) -> Path:
    """Cork's friction law without its texture (a material file): a firm press pins the drive at
    v_max, so the stop ramp starts at full scale and its length can be measured."""
    spec = json.loads((Path(surfhap.__file__).parent / "models" / "builtin" / "cork.json").read_text())
    spec.pop("texture")
    spec["name"] = "cork-friction-only"
    path = tmp_path / "cork-friction-only.json"
    path.write_text(json.dumps(spec))
    return path


def _play(path: Path, scan: str = FULL) -> subprocess.Popen:
    material = _friction_only_cork(path.parent)
    return subprocess.Popen([*SURFHAP, "play", "--json", str(material), "--output", f"file:{path}", "--scan", scan],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_bytes(p: subprocess.Popen, path: Path, n_bytes: int, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end and p.poll() is None:
        try:  # no exists() first: `play` checks the output is writable by creating and removing it
            if path.stat().st_size >= n_bytes:
                return
        except FileNotFoundError:
            pass
        time.sleep(0.05)
    p.kill()
    p.wait(10)
    pytest.fail(f"{path} did not grow to {n_bytes} bytes (exit {p.returncode}): {p.stderr.read()[-2000:]}")


def _finish(p: subprocess.Popen, timeout: float = 60.0):
    try:
        return p.communicate(timeout=timeout)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(10)


# ---------------------------------------------------------------- SIGTERM (item 9)
def test_sigterm_ramps_to_zero_writes_the_recording_and_exits_130(tmp_path):
    path = tmp_path / "drive.wav"
    p = _play(path)
    _wait_for_bytes(p, path, 44 + 4 * RATE // 2)  # half a second recorded
    p.send_signal(signal.SIGTERM)
    out, err = _finish(p)
    assert p.returncode == 130, err  # interrupted (docs/live.md, "Stopping: SIGINT and SIGTERM")
    assert "Traceback" not in err and "interrupted" in err and "SIGTERM" in err
    status = json.loads(out.strip().splitlines()[-1])
    assert status["stopped"] is True and status["failure"] is None
    rate, u = wavfile.read(path)
    assert rate == RATE and u.size >= RATE // 2
    mag = np.abs(u.astype(float))
    last = int(np.nonzero(mag)[0][-1])
    assert last < u.size - 1 and not np.any(mag[last + 1 :])  # ends in silence
    full = int(np.nonzero(mag >= 0.999)[0][-1])  # the last full-scale sample before the stop
    ramp = 0.010 * RATE
    assert ramp / 2 <= last - full <= ramp  # a ramp, not a cut, and over within 10 ms
    assert np.all(np.diff(mag[full : last + 2]) <= 1e-6)  # falling all the way


def test_sigterm_stops_serve_the_same_way(tmp_path):
    import socket

    traj = tmp_path / "stroke.csv"
    t = np.arange(0, 2.0, 0.008)
    rows = "\n".join(f"{ti:.4f},{0.05 + 0.02 * ti:.5f},0.03,2.0" for ti in t)
    traj.write_text("time,x,y,load\n" + rows + "\n")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    path = tmp_path / "serve.wav"
    p = subprocess.Popen([*SURFHAP, "serve", "--json", "--material", str(_friction_only_cork(tmp_path)), "--port", str(port), "--replay", str(traj),
                          "--output", f"file:{path}", "--duration", "120"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_bytes(p, path, 44 + 4 * RATE // 2)
    p.send_signal(signal.SIGTERM)
    out, err = _finish(p)
    assert p.returncode == 130, err  # interrupted (docs/live.md, "Stopping: SIGINT and SIGTERM")
    assert "Traceback" not in err and "interrupted" in err and "SIGTERM" in err
    status = json.loads(out.strip().splitlines()[-1])
    assert status["stopped"] is True and status["failure"] is None
    rate, u = wavfile.read(path)
    mag = np.abs(u.astype(float))
    last = int(np.nonzero(mag)[0][-1])
    full = int(np.nonzero(mag >= 0.999)[0][-1])
    assert last < u.size - 1 and 0.005 * RATE <= last - full <= 0.010 * RATE
    assert np.all(np.diff(mag[full : last + 2]) <= 1e-6)


# ---------------------------------------------------------------- file output (item 10)
@pytest.mark.parametrize("where", ["missing-dir", "directory", "proc"])
def test_unwritable_output_file_is_refused_at_start(tmp_path, capsys, where):
    if where == "missing-dir":
        target = tmp_path / "no-such-dir" / "drive.wav"
    elif where == "directory":
        target = tmp_path / "drive.wav"
        target.mkdir()
    else:
        target = Path("/proc/surfhap-test-drive.wav")  # not writable, even for root
    for cmd in (["play", "cork", "--scan", "speed=0.1,load=0.5,duration=60"], ["serve", "--duration", "60"]):
        t0 = time.monotonic()
        code = main([*cmd, "--output", f"file:{target}"])
        err = capsys.readouterr().err
        assert code == 2, err
        lines = [line for line in err.strip().splitlines() if line.strip()]
        assert len(lines) == 1 and str(target) in lines[0] and "Traceback" not in err
        assert time.monotonic() - t0 < 60  # refused at start, not after the 60 s run


@pytest.mark.parametrize("suffix", [".wav", ".npz"])
def test_sigkill_keeps_the_recording_up_to_the_last_flush(tmp_path, suffix):
    path = tmp_path / f"drive{suffix}"
    stream = path if suffix == ".wav" else path.with_name(path.name + ".partial.npy")
    p = _play(path)
    _wait_for_bytes(p, stream, 128 + 8 * RATE)  # at least 1 s (wav: 2 s) flushed
    size = stream.stat().st_size
    p.kill()  # SIGKILL: no handler runs
    p.wait(30)
    assert p.returncode == -signal.SIGKILL
    if suffix == ".wav":
        rate, u = wavfile.read(path)
        assert rate == RATE
        drive = 250.0 * u.astype(float)
        assert u.size >= (size - 44) // 4
    else:
        drive = np.load(stream)
        assert drive.size >= (size - 128) // 8
    assert drive.size >= RATE and np.all(np.isfinite(drive))
    assert np.abs(drive).max() == pytest.approx(250.0)  # real drive, not an empty shell


# ---------------------------------------------------------------- backend failure (item 11)
def _engine():
    e = LiveEngine(TextureChain(load_material("cork"), ChainConfig(drive_rate=RATE)), EngineConfig())
    e.warm_up()
    return e


class _Recorder(PacedBackend):
    """A paced backend that keeps every block it is given; ``fault`` decides what block k does."""

    name = "fake"

    def __init__(self, fault, **kw):
        super().__init__(**kw)
        self.fault = fault
        self.blocks = []

    def emit(self, volts):
        self.fault(len(self.blocks))
        self.blocks.append(volts.copy())


def _touching(e, stop: threading.Event):
    while not stop.is_set():
        e.push_touch(1, 0.05, 0.03, 2.0)
        time.sleep(0.004)


def _wait(cond, timeout=60.0):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        time.sleep(0.01)
    return cond()


def test_backend_that_raises_is_reported_and_left_at_zero():
    e = _engine()

    raised = []

    def fault(k):
        if k == 150 and not raised:  # once: the zero block after it goes through
            raised.append(k)
            raise OSError("device unplugged")

    b = _Recorder(fault)
    stop = threading.Event()
    toucher = threading.Thread(target=_touching, args=(e, stop), daemon=True)
    toucher.start()
    try:
        b.start(e)
        assert _wait(lambda: e.failure is not None)
        assert _wait(lambda: not b._thread.is_alive())  # the thread ended, not silently
    finally:
        stop.set()
        b.stop()
    st = e.status()
    assert "device unplugged" in st["failure"] and st["counters"]["backend_failures"] >= 1
    assert np.abs(b.blocks[149]).max() == pytest.approx(250.0)  # it was driving
    assert len(b.blocks) == 151 and not np.any(b.blocks[-1])  # then one block of 0 V
    assert not np.any(e.render(e.block_frames))  # and the engine stays at 0 V


def test_backend_that_stalls_is_detected_and_resumes_at_zero():
    e = _engine()
    release = threading.Event()

    def fault(k):
        if k == 150:
            release.wait(120)  # a device write that hangs

    b = _Recorder(fault, stall_timeout=0.3)
    stop = threading.Event()
    toucher = threading.Thread(target=_touching, args=(e, stop), daemon=True)
    toucher.start()
    try:
        b.start(e)
        assert _wait(lambda: e.failure is not None)
        assert "stalled" in e.status()["failure"]
        n = len(b.blocks)
        release.set()  # the device comes back: from now on it only gets 0 V
        assert _wait(lambda: len(b.blocks) > n + 20)
    finally:
        stop.set()
        release.set()
        b.stop()
    assert np.abs(b.blocks[149]).max() == pytest.approx(250.0)
    assert not np.any(np.concatenate(b.blocks[151:]))


def test_cli_exits_3_when_the_output_fails(tmp_path):
    import resource

    def limit_file_size():  # writes beyond 300 kB fail with EFBIG (Python ignores SIGXFSZ)
        resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, 300_000))

    path = tmp_path / "drive.wav"
    p = subprocess.run([*SURFHAP, "play", "cork", "--json", "--output", f"file:{path}", "--scan", FULL],
                       capture_output=True, text=True, timeout=300, preexec_fn=limit_file_size)
    assert p.returncode == 3, p.stderr
    status = json.loads(p.stdout.strip().splitlines()[-1])
    assert "File too large" in status["failure"]
    assert status["counters"]["backend_failures"] >= 1
    assert "Traceback" not in p.stderr and "halted" in p.stderr
    rate, u = wavfile.read(path)  # what was written before the failure is a valid file
    assert rate == RATE and 0 < u.size <= 300_000 // 4


def test_sound_callback_that_raises_writes_zero_and_halts():
    from types import SimpleNamespace

    from surfhap.live.backends.sound import SoundBackend

    e = _engine()
    b = SoundBackend()
    b.bind(e, (0, 1))
    ok = SimpleNamespace(output_underflow=False)
    times = SimpleNamespace(currentTime=3.0, outputBufferDacTime=3.002, inputBufferAdcTime=0.0)  # 2 ms latency
    outdata = np.zeros((e.block_frames, 2), dtype=np.float32)
    for _ in range(50):  # a firm touch: the card gets a strong drive (real clock, as PortAudio's thread)
        e.push_touch(1, 0.05, 0.03, 2.0)
        b._callback(outdata, e.block_frames, times, ok)
    assert np.abs(outdata).max() > 0.5
    units = b._units
    b._units = np.zeros(0, dtype=np.float32)  # a bug inside the callback: it raises
    b._callback(outdata, e.block_frames, times, ok)
    assert not np.any(outdata) and "sound output failed" in e.status()["failure"]
    b._units = units  # later callbacks work again, but the engine stays at 0 V
    e.push_touch(1, 0.05, 0.03, 2.0)
    b._callback(outdata, e.block_frames, times, ok)
    assert not np.any(outdata) and e.status()["output_safety"]["halted"] > 0


# ---------------------------------------------------------------- file output cap (issue 17 #6)
def test_serve_max_seconds_ends_the_recording_with_a_ramp_a_warning_and_a_count(tmp_path):
    import socket

    traj = tmp_path / "stroke.csv"
    t = np.arange(0, 2.0, 0.008)
    traj.write_text("time,x,y,load\n" + "\n".join(f"{ti:.4f},{0.05 + 0.02 * ti:.5f},0.03,2.0" for ti in t) + "\n")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    path = tmp_path / "capped.wav"
    p = subprocess.Popen([*SURFHAP, "serve", "--json", "--material", str(_friction_only_cork(tmp_path)), "--port", str(port),
                          "--replay", str(traj), "--output", f"file:{path}", "--max-seconds", "1.5",
                          "--duration", "600", "--no-web-process"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, err = _finish(p, timeout=300.0)  # ends by itself at the cap, long before --duration
    assert p.returncode == 0, err
    assert "Traceback" not in err and "reaches --max-seconds 1.5" in err
    status = json.loads(out.strip().splitlines()[-1])
    assert status["stopped"] is True and status["failure"] is None
    assert status["output"]["cap_reached"] is True and status["output"]["max_seconds"] == 1.5
    rate, u = wavfile.read(path)
    assert 1.4 * RATE <= u.size <= 1.5 * RATE
    mag = np.abs(u.astype(float))
    last = int(np.nonzero(mag)[0][-1])
    full = int(np.nonzero(mag >= 0.999)[0][-1])
    assert last < u.size - 1 and 0.005 * RATE <= last - full <= 0.010 * RATE  # the 10 ms stop ramp
    assert np.all(np.diff(mag[full : last + 2]) <= 1e-6)


def test_max_seconds_only_for_file_output():
    assert main(["serve", "--output", "sim", "--max-seconds", "10"]) == 2
