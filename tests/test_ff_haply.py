"""Haply Inverse3 device (``--device haply://HOST:PORT``) against a loopback Inverse Service that
speaks the documented simulation-channel messages over a real WebSocket
(:mod:`live_support.haply_service`): frame and units, the safety stage last for any effect and
position, the spring's analytic force, silence -> ramp to zero and exit 3, malformed messages
counted and ignored, no service -> one line and exit 2, SIGTERM -> ramp to zero and exit 130.

``SURFHAP_HAPLY_EXAMPLES`` sets the number of hypothesis sequences (default 20).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from surfhap.cli import main
from surfhap.ff import DeviceParams, FFEngine, RectsField, Roughness, Shape, Sliding, Stiffness
from surfhap.live.ff_haply import DeviceSilent, HaplyDevice
from surfhap.live.ff_loop import FFLoop
from surfhap.render.kinematics import TouchPredictor
from surfhap.runtime.clock import now

sys.path.insert(0, str(Path(__file__).parent))
from live_support.haply_service import HaplyService  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src"
EXAMPLES = int(os.environ.get("SURFHAP_HAPLY_EXAMPLES", "20"))
P0 = (0.01, -0.12, 0.15)  # the cursor at start, service frame (m)
M = np.array([1.0, -1.0, 1.0])  # service frame <-> surfhap frame (docs/live.md, "Haply Inverse3")
LENIENT = 10.0  # s of silence tolerated by the tests that are not about silence (a loaded CI machine stalls)


@pytest.fixture(scope="module")
def service():
    with HaplyService(position=P0) as svc:
        yield svc


def reset(svc: HaplyService) -> None:
    # the last test's connection first ends and its last messages are counted: a late one counted
    # after the reset made the next test wait for an answer that never comes (seen beside a busy loop)
    assert svc.wait_closed(), "the previous test's connection did not end"
    svc.position, svc.silent_after = P0, None
    svc.script.clear()
    svc.inject.clear()
    svc.silent.clear()
    with svc.changed:
        svc.forces.clear()
        svc.sessions.clear()
        svc.messages = 0


def poll(cond, timeout: float = 30.0) -> bool:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            return False
        time.sleep(0.0002)
    return True


def answered(be: HaplyDevice, n: int) -> bool:
    """Wait until ``n`` answers have arrived (read() takes them; the loop's next tick would)."""
    return poll(lambda: be.read(0.0) is not None and be.received + be.malformed >= n)


def lockstep(loop: FFLoop, svc: HaplyService, be: HaplyDevice) -> bool:
    """One tick, then wait for the service to get its command and for its answer to arrive."""
    k = svc.messages
    go = loop.tick_once(now())
    assert svc.wait(lambda: svc.messages > k), "the service got no command"
    assert answered(be, svc.messages), "no answer"
    return go


def free_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


# ----------------------------------------------------------------- the protocol and the frame
def test_frame_units_and_messages_against_the_service(service):
    """Positions: p = M (P - P0) in m; forces: the service receives gain M F in N, the first
    command naming the session; the device id comes from the initial inventory."""
    reset(service)
    be = HaplyDevice("127.0.0.1", service.port, gain=1.0, silence=LENIENT)
    be.start()
    try:
        assert be.device_id == service.device_id and be.read(0.0)[:3] == (0.0, 0.0, 0.0)
        d = np.array([0.004, 0.003, -0.002])
        service.script.append(tuple(np.add(P0, d)))
        be.write(np.array([1.0, 2.0, 3.0]), 0.0)
        assert answered(be, 1) and be.received == 1
        assert np.allclose(be.read(0.0)[:3], M * d, atol=1e-12)
        assert service.forces == [(1.0, -2.0, 3.0)]
        assert service.sessions == [{"configure": {"profile": {"name": "surfhap"}}}]
    finally:
        be.stop()


def test_malformed_messages_are_counted_and_ignored(service):
    """Not JSON, no state of this device, a string, a missing coordinate or an integer too large
    for a float: counted, ignored (the position stays the last good one); the next good state is taken."""
    reset(service)
    be = HaplyDevice("127.0.0.1", service.port, silence=LENIENT)
    be.start()
    try:
        bad = ["not json", json.dumps({"inverse3": []}), json.dumps([1, 2]),
               json.dumps({"inverse3": [{"device_id": service.device_id, "state": {"cursor_position": {"x": "1"}}}]}),
               json.dumps({"inverse3": [{"device_id": service.device_id,
                                         "state": {"cursor_position": {"x": 10**400, "y": 0, "z": 0}}}]}),
               json.dumps({"inverse3": [{"device_id": "other", "state": {"cursor_position": {"x": 0, "y": 0, "z": 0}}}]})]
        service.inject.extend(bad)
        for k in range(len(bad)):
            be.write(np.zeros(3), 0.0)
            assert answered(be, k + 1) and be.malformed == k + 1
            assert be.read(0.0)[:3] == (0.0, 0.0, 0.0)
        service.script.append((P0[0] + 0.001, P0[1], P0[2]))
        be.write(np.zeros(3), 0.0)
        assert answered(be, len(bad) + 1) and be.received == 1 and be.malformed == len(bad)
        assert be.read(0.0)[0] == pytest.approx(0.001)
    finally:
        be.stop()


def test_only_malformed_answers_are_silence(service):
    """Once the session is open (one good answer), answers that are all malformed end it as silence does."""
    reset(service)
    be = HaplyDevice("127.0.0.1", service.port, silence=0.02)
    be.start()
    try:
        be.write(np.zeros(3), 0.0)
        assert answered(be, 1) and be.received == 1
        service.inject.extend(["{}"] * 100000)
        t0 = now()

        def silent():
            be.write(np.zeros(3), 0.0)
            try:
                be.read(0.0)
            except DeviceSilent as exc:
                return str(exc)
            return None

        assert poll(lambda: silent() is not None)
        assert now() - t0 >= 0.02 and be.received == 1 and be.malformed > 0
        assert "malformed" in silent()
    finally:
        be.stop()


# ----------------------------------------------------------------- the loop
def engine(device: DeviceParams, effects=()) -> FFEngine:
    return FFEngine(list(effects), device, TouchPredictor(latency=0.0), rate=1000.0)


def test_spring_gives_the_analytic_force_in_the_service_frame(service):
    """Untouched, the engine centres the screen on X0 with K_max (eq. 5): F = -K p. The cursor
    held at P0 + d (service frame) gives p = M d in surfhap's frame, so the service must receive
    M (-K M d) = -K d newtons (weight compensation off: moving mass 0). X0 is where the cursor
    was at connection (the initial inventory)."""
    reset(service)
    dev = DeviceParams(gain=1.0, moving_mass=0.0, k_max=800.0)
    d = np.array([0.002, -0.003, 0.001])
    service.script.append(tuple(np.add(P0, d)))  # the inventory at P0 (= X0), then held at P0 + d
    be = HaplyDevice("127.0.0.1", service.port, dev.gain, silence=LENIENT)
    eng = engine(dev)
    loop = FFLoop(eng, be)
    eng.reset()
    be.start()
    try:
        for _ in range(300):
            assert lockstep(loop, service, be)
    finally:
        be.stop()
    assert np.allclose(service.forces[-1], -dev.k_max * d, atol=1e-9), service.forces[-1]
    # the step of the spring onto a cursor already at P0 + d may be slew-limited for a tick or two
    # (how many depends on when the first state arrives), never beyond the axis limits
    assert loop.error is None and np.all(np.abs(np.asarray(service.forces)) <= np.asarray(dev.f_max) + 1e-9)


def effect_set(k, h, depth, period, alpha):
    return [Stiffness(RectsField([(0.0, 0.0, 0.07, 0.07, k)])), Shape(RectsField([(0.1, 0.0, 0.2, 0.07, h)])),
            Roughness(RectsField([(0.0, 0.07, 0.1, 0.14, depth)]), period),
            Sliding(RectsField([(0.07, 0.0, 0.2, 0.14, alpha)]), mass=0.389)]


coord = st.one_of(st.floats(-0.06, 0.06), st.sampled_from([0.0, 0.039, -0.041, 0.2, -0.2]))
step = st.tuples(st.tuples(coord, coord, coord),  # cursor offset from P0 (m, service frame)
                 st.one_of(st.none(), st.tuples(st.floats(0.0, 0.2), st.floats(0.0, 0.14), st.floats(0.0, 3.0))),
                 st.integers(1, 15),  # ticks it lasts
                 st.booleans())  # a malformed answer first


@settings(max_examples=EXAMPLES, deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(steps=st.lists(step, min_size=1, max_size=12),
       device=st.builds(DeviceParams, gain=st.floats(0.5, 2.0), f_max=st.tuples(*[st.floats(0.5, 10.0)] * 3),
                        slew=st.floats(20.0, 5000.0)),
       params=st.tuples(st.floats(0.0, 5000.0), st.floats(-0.05, 0.05), st.floats(0.0, 2e-3),
                        st.floats(1e-4, 0.02), st.floats(-50.0, 50.0)))
def test_service_never_receives_a_force_beyond_the_safety_limits(service, steps, device, params):
    """Any effect parameters, cursor positions (far outside the workspace, jumps), touches and
    malformed answers: every force the service receives is within gain * f_max per axis, moves by
    at most gain * slew / rate per command (from 0 N), and the stop ends at 0 N."""
    reset(service)
    be = HaplyDevice("127.0.0.1", service.port, device.gain, silence=LENIENT)
    eng = engine(device, effect_set(*params))
    loop = FFLoop(eng, be)
    eng.reset()
    be.start()
    try:
        for offset, tch, n, bad in steps:
            service.position = tuple(np.add(P0, offset))
            if bad:
                service.inject.append(json.dumps({"inverse3": [{"device_id": service.device_id, "state": {}}]}))
            for _ in range(n):
                if tch is not None:
                    loop.push_touch(0, *tch)
                lockstep(loop, service, be)
        loop.request_stop()
        for _ in range(int(eng.stop_duration * 1000) + 10):
            if not lockstep(loop, service, be):
                break
        assert not loop.running()
        loop.emit(np.zeros(3))  # the loop thread's final zero
        assert service.wait(lambda: len(service.forces) == loop.ticks + 1)
    finally:
        be.stop()
    f = np.array(service.forces)
    g = device.gain
    assert np.all(np.abs(f) <= g * np.asarray(device.f_max) + 1e-9)
    assert np.all(np.abs(np.diff(f, axis=0, prepend=0.0)) <= g * device.slew / 1000.0 + 1e-9)
    assert np.all(f[-2] == 0.0) and np.all(f[-1] == 0.0)


# ----------------------------------------------------------------- the command
def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


CLI = [sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main(sys.argv[1:]))"]


def cli(*args):
    """The command in its own process (the loopback service here must not share a GIL with the
    1 kHz loop: starved of it, it answers late, which the client rightly takes for silence)."""
    proc = subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(SRC)})
    return proc.returncode, proc.stdout, proc.stderr


def test_no_service_is_one_line_naming_the_address_exit_2(capsys):
    port = free_port()
    code, out, err = run(capsys, "ff", "run", "follow", "--device", f"haply://127.0.0.1:{port}",
                         "--touch", "osc://127.0.0.1:0")
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and f"ws://127.0.0.1:{port}" in lines[0] and "--device" in lines[0], err


@pytest.mark.parametrize("url", ["haply://127.0.0.1", "haply://999.1.1.1:10001", "haply:127.0.0.1:10001",
                                 "haply://127.0.0.1:10001/x"])
def test_bad_haply_address_is_one_line_exit_2(capsys, url):
    code, out, err = run(capsys, "ff", "run", "follow", "--device", url, "--touch", "osc://127.0.0.1:0")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--device" in err, err


def test_silence_out_of_range_is_one_line_exit_2(capsys):
    code, out, err = run(capsys, "ff", "run", "follow", "--device", "haply://127.0.0.1:10001", "--touch",
                         "osc://127.0.0.1:0", "--device-silence-ms", "0")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--device-silence-ms" in err, err


def test_silent_service_ramps_to_zero_and_ends_the_run_exit_3(service):
    """The service stops answering (it still records the commands): the safety stage ramps the
    force to zero, the run ends with one line and exit 3 (default --device-silence-ms 20)."""
    reset(service)
    service.silent_after = 200
    code, out, err = cli("ff", "run", "follow", "--device", f"haply://127.0.0.1:{service.port}",
                         "--touch", "osc://127.0.0.1:0", "--duration", "60", "--json")
    assert service.wait_closed()
    assert code == 3, err
    errors = [ln for ln in err.strip().splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "no state from the Haply Inverse Service" in errors[0], err
    st = json.loads(out.strip().splitlines()[-1])
    assert st["device"]["name"] == "haply" and st["error"] is not None
    f = np.abs(np.array(service.forces))
    assert f[:, 2].max() > 1.0  # the weight compensation was up (gain 1: newtons)
    # the end: the safety stage's ramp (<= slew / rate per command, one command per tick) to 0 N
    k = len(f) - 1
    while k > 0 and np.all(f[k - 1] >= f[k]):
        k -= 1
    assert f[k].max() > 0.0 and np.all(f[-1] == 0.0)
    assert np.all(np.diff(f[k:], axis=0) >= -DeviceParams().slew / 1000.0 - 1e-9), f[k:]


def test_sigterm_ramps_the_force_to_zero_and_exits_130(service):
    """SIGTERM on ``ff run --device haply://``: the safety stage puts the tablet down (the weight
    compensation lowered over land_time, never above it) and the last command is 0 N; exit 130."""
    reset(service)
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.Popen([*CLI, "ff", "run", "follow", "--device", f"haply://127.0.0.1:{service.port}",
                             "--touch", "osc://127.0.0.1:0", "--device-silence-ms", "1000", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert service.wait(lambda: len(service.forces) >= 200, timeout=120), proc.stderr.read() if proc.poll() else ""
        with service.changed:
            at_signal = len(service.forces)
            proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert service.wait_closed()
    assert proc.returncode == 130, err
    st = json.loads(out.strip().splitlines()[-1])
    assert st["error"] is None and st["safety"]["stopped"] >= 1
    f = np.array(service.forces)
    weight = DeviceParams().weight
    assert np.isclose(f[:at_signal, 2], weight, atol=1e-9).any()  # held up, in newtons (gain 1)
    after = f[at_signal:]
    assert np.all(np.abs(after[:, :2]) <= 1e-9) and np.all(after[:, 2] <= weight + 1e-9)
    # down to 0 N through the safety stage's ramps (the landing, or the watchdog's if the loaded
    # machine stalled past device_timeout): never a step beyond slew / rate per command
    assert np.all(after[-1] == 0.0)
    assert np.all(np.abs(np.diff(f[:, 2])) <= DeviceParams().slew / 1000.0 + 1e-9)


# ----------------------------------------------------------------- study run --ff-device haply://
def _study(tmp_path):
    from test_lab_ff_study import _study as study_folder

    return study_folder(tmp_path)


def test_study_without_a_service_is_one_line_naming_the_address_exit_2(tmp_path, capsys):
    folder, port = _study(tmp_path), free_port()
    assert main(["study", "run", str(folder), "-p", "P01", "--ff-device", f"haply://127.0.0.1:{port}",
                 "--port", "0"]) == 2
    errors = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error")]
    assert len(errors) == 1 and f"ws://127.0.0.1:{port}" in errors[0], errors
    assert main(["study", "run", str(folder), "-p", "P01", "--simulate", "1", "--ff-device",
                 f"haply://127.0.0.1:{port}"]) == 2  # a simulated participant strokes the simulated device only
    assert "--ff-device" in capsys.readouterr().err


def test_study_on_a_silent_haply_ends_with_exit_3_and_zero_force(service, tmp_path):
    """The study's force loop on the Inverse3: the service goes silent, the force ramps to zero,
    the page stops and the command exits 3 with one error line."""
    reset(service)
    service.silent_after = 200
    folder = _study(tmp_path)
    code, out, err = cli("study", "run", str(folder), "-p", "P01", "--ff-device", f"haply://127.0.0.1:{service.port}",
                         "--port", "0")
    assert service.wait_closed()
    assert code == 3, err
    errors = [ln for ln in err.splitlines() if ln.startswith("error")]
    assert len(errors) == 1 and "no state from the Haply Inverse Service" in errors[0], errors
    assert np.all(np.array(service.forces[-1]) == 0.0)
