"""SIGTERM (and Ctrl-C) stop every long-running command the same way (issue 17 item 4): the
output ramps to zero, the recording is flushed, the status is printed, one ``interrupted``
line, exit code 130. Each command runs as a real process (``python -m surfhap``); the test
waits until it is really driving (a line, a growing recording), then sends SIGTERM.

``render`` (single) and a batch render (the same path as ``fit imu`` on a folder) have their
own SIGTERM/SIGINT tests in tests/test_render_stream.py and tests/test_batch.py; ``ff run``
also in tests/test_ff_cli.py.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from live_support.studies import identification_study
from surfhap.cli._signals import EXIT_INTERRUPTED, StopSignals
from surfhap.exchange.trajectory_csv import write_trajectory_csv
from surfhap.models.trajectory import Trajectory

SRC = Path(__file__).resolve().parents[1] / "src"
SURFHAP = [sys.executable, "-m", "surfhap"]
DRIVE_RATE = 20000
V_MAX = 250.0
RISE_STEP = 2.5e6 / DRIVE_RATE  # V per sample: the default rise limit (SafetyLimits.rise_rate)
FASTEST_RAMP = 0.005  # s: the documented ramps to zero (stop 10 ms, watchdog 5 ms) are no faster than this
START_TIMEOUT = 300.0  # s, failure guard only: start-up compiles the renderer on a loaded machine


class Proc:
    """A CLI process with its stdout and stderr collected by threads (no pipe can fill up)."""

    def __init__(self, args, **kw):
        env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        self.p = subprocess.Popen([*SURFHAP, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  env=env, **kw)
        self.out: list[str] = []
        self.err: list[str] = []
        self._readers = [threading.Thread(target=lambda f=f, into=into: into.extend(iter(f.readline, "")), daemon=True)
                         for f, into in ((self.p.stdout, self.out), (self.p.stderr, self.err))]
        for r in self._readers:
            r.start()

    @property
    def stdout(self) -> str:
        return "".join(self.out)

    @property
    def stderr(self) -> str:
        return "".join(self.err)

    def wait_for(self, cond, what: str, timeout: float = START_TIMEOUT):
        """Poll ``cond()`` until truthy (returned); fails if the process ends first."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            got = cond()
            if got:
                return got
            assert self.p.poll() is None, f"ended (exit {self.p.returncode}) before {what}:\n{self.stderr}"
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {what}:\n{self.stderr}")

    def stop(self, sig=signal.SIGTERM, timeout: float = 120.0) -> int:
        self.p.send_signal(sig)
        code = self.p.wait(timeout)
        for r in self._readers:
            r.join(10)
        return code

    def kill(self) -> None:
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait(10)


def driving(partial: Path, volts: float = 1.0) -> bool:
    """True once the streamed recording (``PATH.npz.partial.npy``: 128-byte header, float64
    volts) holds a sample beyond ``volts``: the command is running and driving."""
    try:
        data = np.fromfile(partial, dtype="<f8", offset=128)
    except (OSError, ValueError):
        return False
    return data.size > 0 and float(np.max(np.abs(data))) > volts


def assert_ends_with_a_ramp(drive: np.ndarray) -> None:
    """The recording ends at 0 V through a ramp no faster than the documented ones, and no
    sample rises faster than the rise limit; it was driving just before (the stop happened
    while driving, not after the watchdog had already silenced it)."""
    assert drive.size > 0.05 * DRIVE_RATE
    rises = np.diff(np.abs(drive))
    assert rises.max() <= RISE_STEP + 1e-9, rises.max()
    active = np.flatnonzero(np.abs(drive) > 1e-9)
    assert active.size, "the recording never drove"
    last = int(active[-1])
    assert last < drive.size - 1, f"the recording ends at {drive[-1]:.1f} V, not at 0 V"
    n = FASTEST_RAMP * DRIVE_RATE
    tail = np.abs(drive[max(0, last + 1 - int(n)) : last + 1])
    to_end = np.arange(tail.size, 0, -1)  # samples from each to the first silent one
    over = tail - V_MAX * to_end / n
    assert over.max() <= 1e-6, f"{tail[-5:]} V in the last samples: no ramp to zero"
    before = np.abs(drive[max(0, last - int(0.1 * DRIVE_RATE)) : last + 1])
    assert before.max() > 1.0, "the output was already silent when the stop came"


def assert_interrupted(code: int, proc: Proc, words: str) -> None:
    assert code == EXIT_INTERRUPTED, proc.stderr
    err = proc.stderr
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and lines[0].startswith("error: interrupted:") and words in lines[0], err
    assert lines[0].rstrip().endswith("(SIGTERM)"), err


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def strokes_csv(path: Path, dur: float = 4.0, rate: float = 125.0, x0: float = 0.05, y0: float = 0.03,
                load: float = 0.5) -> Path:
    t = np.arange(0.0, dur, 1.0 / rate)
    x = x0 + 0.03 * np.sin(2 * np.pi * 0.5 * t)
    write_trajectory_csv(Trajectory(t, x, np.full(t.size, y0), np.full(t.size, load)), path)
    return path


# ------------------------------------------------------------------------ the guard itself
def test_the_guard_turns_both_signals_into_one_stop_and_restores_the_handlers():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    calls = []
    with StopSignals(on_stop=lambda: calls.append(1)) as guard:
        assert not guard.stopped and not guard.wait(0.0)
        os.kill(os.getpid(), signal.SIGTERM)
        assert guard.wait(30.0) and guard.name == "SIGTERM"
        os.kill(os.getpid(), signal.SIGINT)  # later signals are ignored while stopping
        guard.wait(0.01)
        assert guard.name == "SIGTERM" and calls == [1]
        assert guard.call(lambda: 1) is None  # a blocking stretch after the stop does not even start
    assert {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)} == before
    with StopSignals() as guard:  # a blocking call is interrupted, and the guard says why
        assert guard.call(lambda: (os.kill(os.getpid(), signal.SIGINT), time.sleep(60))) is None
        assert guard.name == "SIGINT"
    with StopSignals() as guard:
        assert guard.call(lambda: 7) == 7 and not guard.stopped
    assert guard.finish("nothing") is None  # not stopped: no line, no exit


def test_the_guard_is_inert_outside_the_main_thread():
    seen = {}

    def worker():
        with StopSignals() as guard:
            seen["stopped"] = guard.stopped
            seen["value"] = guard.call(lambda: 3)
    t = threading.Thread(target=worker)
    t.start()
    t.join(30)
    assert seen == {"stopped": False, "value": 3}


# ------------------------------------------------------------------------ one test per command
def test_serve_to_a_file_stops_on_sigterm_with_a_ramp(tmp_path):
    rec = tmp_path / "serve.npz"
    port = free_port()
    proc = Proc(["serve", "--json", "--material", "cork", "--port", str(port), "--output", f"file:{rec}",
                 "--replay", str(strokes_csv(tmp_path / "t.csv"))])
    try:
        proc.wait_for(lambda: "open http" in proc.stdout, "the start line")
        proc.wait_for(lambda: driving(Path(str(rec) + ".partial.npy")), "a driving recording")
        code = proc.stop()
    finally:
        proc.kill()
    assert_interrupted(code, proc, "ramped to 0 V")
    status = json.loads(proc.stdout.strip().splitlines()[-1])
    assert status["stopped"] is True and status["failure"] is None
    with np.load(rec) as z:
        assert int(z["drive_rate"]) == DRIVE_RATE
        assert_ends_with_a_ramp(z["drive"])


def test_play_to_a_file_stops_on_sigterm_with_a_ramp(tmp_path):
    rec = tmp_path / "play.npz"
    proc = Proc(["play", "cork", "--json", "--output", f"file:{rec}", "--scan", "speed=0.1,load=0.5,duration=600,length=0.08"])
    try:
        proc.wait_for(lambda: driving(Path(str(rec) + ".partial.npy")), "a driving recording")
        code = proc.stop()
    finally:
        proc.kill()
    assert_interrupted(code, proc, "ramped to 0 V")
    status = json.loads(proc.stdout.strip().splitlines()[-1])
    assert status["stopped"] is True and status["failure"] is None and status["touches"] > 0
    with np.load(rec) as z:
        assert_ends_with_a_ramp(z["drive"])


def test_ff_run_stops_on_sigterm_with_the_force_at_zero(tmp_path):
    """``ff run`` on the simulated device, a replayed trajectory, and the tablet feedback
    (60 Hz ``/surfhap/ff/force``, after the safety stage) received here."""
    from pythonosc.osc_message import OscMessage

    fb = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    fb.bind(("127.0.0.1", 0))
    fb.settimeout(0.2)
    forces: list[tuple[float, float, float]] = []
    done = threading.Event()

    def listen():
        while not done.is_set():
            try:
                data = fb.recv(4096)
            except OSError:
                continue
            msg = OscMessage(data)
            if msg.address == "/surfhap/ff/force":
                forces.append(tuple(float(v) for v in msg.params))

    listener = threading.Thread(target=listen, daemon=True)
    listener.start()
    proc = Proc(["ff", "run", "follow", "--json", "--device", "sim", "--trajectory", str(strokes_csv(tmp_path / "t.csv", x0=0.1, y0=0.07, load=1.0)),
                 "--duration", "600", "--feedback", f"osc://127.0.0.1:{fb.getsockname()[1]}"])
    try:
        proc.wait_for(lambda: "Ctrl-C" in proc.stderr, "the start line")
        proc.wait_for(lambda: any(np.linalg.norm(f) > 0.05 for f in forces), "a force on the device")
        code = proc.stop()
    finally:
        proc.kill()
        done.set()
        listener.join(5)
        fb.close()
    assert_interrupted(code, proc, "force ramped to zero")
    st = json.loads(proc.stdout.strip().splitlines()[-1])
    assert st["safety"]["stopped"] >= 1 and st["error"] is None  # the run ended through the stop ramp
    assert forces and forces[-1] == (0.0, 0.0, 0.0), forces[-3:]


def test_study_run_while_touching_stops_on_sigterm_with_a_ramp(tmp_path):
    """The reproduction of issue 17 item 4: a participant touches a stimulus on the page
    (WebSocket moves, as the page sends them) with ``--output file:``; SIGTERM."""
    from websockets.sync.client import connect

    from surfhap.lab.triallog import read_log

    study = identification_study(tmp_path, repetitions=2, name="stop test")
    rec = tmp_path / "study.npz"
    proc = Proc(["study", "run", str(study), "-p", "P01", "--port", "0", "--comfort-voltage", "200",
                 "--output", f"file:{rec}"])
    stop_touching = threading.Event()
    try:
        url = proc.wait_for(lambda: (m := re.search(r"(http://127\.0\.0\.1:\d+)", proc.stderr)) and m.group(1),
                            "the page address")

        def call(path, body=None):
            req = urllib.request.Request(url + path, data=None if body is None else json.dumps(body).encode(),
                                         headers={"Content-Type": "application/json"})
            with urllib.request.urlopen(req, timeout=60) as r:
                return json.loads(r.read())

        # answer one trial, so the log has something the stop must keep
        st = call("/api/state")
        first = st["trial"]
        assert call("/api/answer", {"trial_id": first["id"], "answer": first["choices"][0]["id"], "rt_ms": 700})["accepted"]
        st = call("/api/state")
        assert call("/api/stimulus", {"trial_id": st["trial"]["id"], "index": 0})["playing"] == "on"

        def touch():  # strokes back and forth until the process closes the socket
            try:
                with connect(url.replace("http", "ws") + "/ws", origin=url) as ws:
                    ws.send(json.dumps({"type": "hello", "w": 800, "h": 400}))
                    t0 = time.monotonic()
                    seq = 0
                    while not stop_touching.is_set():
                        t = time.monotonic() - t0
                        seq += 1
                        ws.send(json.dumps({"type": "move", "seq": seq, "t": 1000.0 * t, "x": 0.5 + 0.3 * np.sin(2 * np.pi * t),
                                            "y": 0.5, "p": 0.5}))
                        time.sleep(0.004)
            except Exception:  # noqa: BLE001 - the server went away: the test is over
                pass

        toucher = threading.Thread(target=touch, daemon=True)
        toucher.start()
        proc.wait_for(lambda: driving(Path(str(rec) + ".partial.npy")), "a driving recording")
        code = proc.stop()  # the finger is still moving
    finally:
        stop_touching.set()
        proc.kill()
    assert_interrupted(code, proc, "paused")
    assert "1/8 trials logged" in proc.stderr
    log = read_log(study / "logs" / "P01.jsonl")
    assert [t["trial_id"] for t in log.trials] == [first["id"]]
    with np.load(rec) as z:
        assert_ends_with_a_ramp(z["drive"])


def test_study_run_simulated_stops_on_sigterm_between_answers(tmp_path):
    from surfhap.lab.triallog import read_log

    study = identification_study(tmp_path, repetitions=2, name="stop test")
    proc = Proc(["study", "run", str(study), "-p", "P01", "--simulate", "1", "--pace", "60",
                 "--comfort-voltage", "200"])
    try:
        proc.wait_for(lambda: "logged" in proc.stdout, "the first answer")
        code = proc.stop()
    finally:
        proc.kill()
    assert_interrupted(code, proc, "paused")
    log = read_log(study / "logs" / "P01.jsonl")
    assert len(log.trials) == 1 and f"{len(log.trials)}/8 trials logged" in proc.stderr


SLOW_FIT = """
import sys, time
import surfhap.fit.accel, surfhap.fit.material_fit
def slow(*args, **kw):  # a fit that takes long: says it started, then computes for minutes
    print("FIT STARTED", flush=True)
    end = time.monotonic() + 600
    while time.monotonic() < end:
        sum(range(10000))
surfhap.fit.accel.fit_accel = surfhap.fit.material_fit.fit_friction = slow
from surfhap.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("kind", ["friction", "accel"])
def test_a_long_fit_stops_on_sigterm_without_writing_a_material(tmp_path, kind):
    """``fit friction`` / ``fit accel`` while the fit computes (the fit itself is replaced by
    a long computation that announces its start, so the test knows the command is in it)."""
    from surfhap.exchange.recordings import write_recording_csv
    from surfhap.fit.synthetic import synthetic_accel_recording, synthetic_friction_recordings
    from surfhap.models.friction import QuasiStaticLaw

    if kind == "friction":
        rec = synthetic_friction_recordings(QuasiStaticLaw(0.4, 0.3, 1.0, 1.0, 0.5), {0.05: (np.array([0.5]), 1e-6)},
                                            participants=1, duration=2.0, seed=0)[0]
    else:
        rec = synthetic_accel_recording([(np.array([0.5]), 1.0, 2000, 0.1, 0.5)], mu=0.4, seed=0)
    csv = write_recording_csv(rec, tmp_path / "rec.csv")
    out = tmp_path / "m.json"
    env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.Popen([sys.executable, "-c", SLOW_FIT, "fit", kind, str(csv), "--material", "m", "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = p.stdout.readline()  # blocks until the fit started (or the process ended)
        assert "FIT STARTED" in line, p.stderr.read() if p.poll() is not None else line
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(10)
    assert p.returncode == EXIT_INTERRUPTED, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: interrupted: the fit did not finish"), err
    assert lines[0].endswith("(SIGTERM)") and not out.exists()
