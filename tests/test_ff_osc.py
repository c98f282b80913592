"""OSC round trips of the force-feedback loop against real OSC clients (liblo's oscsend / oscdump, and
python-osc reference bridges of the bridge contract).

liblo-tools is a system package (Makefile SYSTEM_PACKAGES); these tests install nothing.
"""

import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from surfhap.ff import FALCON, FFEngine
from surfhap.ff.scene import load_scene
from surfhap.live.ff_devices import OscDeviceBackend, SimDeviceBackend
from surfhap.live.ff_loop import FFLoop, OscFeedback
from surfhap.render.kinematics import TouchPredictor
from surfhap.live.sources import OscTouchSource, TouchSpace
from surfhap.sim.ff_device import SimDevice

sys.path.insert(0, str(Path(__file__).parent))
from live_support.ff_bridges import ReferenceBridge  # noqa: E402

needs_liblo = pytest.mark.skipif(not (shutil.which("oscsend") and shutil.which("oscdump")),
                                reason="liblo-tools (oscsend, oscdump) not installed; run make system-deps")


def free_udp_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def udp_bound(port: int) -> bool:
    """Some process has a UDP socket bound to ``port`` (/proc/net/udp, udp6): a listener is up."""
    tables = [Path(p) for p in ("/proc/net/udp", "/proc/net/udp6") if Path(p).exists()]
    return any(line.split()[1].endswith(f":{port:04X}") for t in tables for line in t.read_text().splitlines()[1:])


def wait_for(cond, timeout=60.0):  # a failure guard (a loaded machine), not a speed target
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


class Dump:
    """oscdump on a UDP port, its lines collected in a file."""

    def __init__(self, port, path):
        self.path = path
        self.fh = open(path, "w")
        self.proc = subprocess.Popen(["oscdump", "-L", str(port)], stdout=self.fh, stderr=subprocess.STDOUT)
        assert wait_for(lambda: udp_bound(port) or self.proc.poll() is not None) and self.proc.poll() is None

    def lines(self):
        if not self.fh.closed:
            self.fh.flush()
        return self.path.read_text().splitlines()

    def close(self):
        self.proc.terminate()
        self.proc.wait(5)
        self.fh.close()


def parse(lines, address):
    out = []
    for ln in lines:
        parts = ln.split()
        if address in parts:
            i = parts.index(address)
            out.append([float(v) for v in parts[i + 2:]])
    return np.array(out)


@needs_liblo
def test_touch_from_oscsend_reaches_the_haptic_loop():
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    loop = FFLoop(eng, SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain))
    src = OscTouchSource(loop, port=0, space=TouchSpace(width=sc.size[0], height=sc.size[1]))
    src.start()
    loop.start()
    try:
        end = time.monotonic() + 20.0
        # press the hardest button (x 0.15-0.185, y 0.055-0.093) until the loop reports it active
        while time.monotonic() < end and eng.mask != 1:
            subprocess.run(["oscsend", "127.0.0.1", str(src.port), "/surfhap/touch", "fff", "0.17", "0.07", "1.0"],
                           check=True, timeout=60)
        assert eng.mask == 1 and eng.state.touched
        assert src.accepted >= 1
        # a lift ends the touch
        subprocess.run(["oscsend", "127.0.0.1", str(src.port), "/surfhap/lift"], check=True, timeout=60)
        assert wait_for(lambda: not eng.state.touched)
        # garbage is rejected, not evaluated
        subprocess.run(["oscsend", "127.0.0.1", str(src.port), "/surfhap/touch", "s", "boom"], check=True, timeout=60)
        assert wait_for(lambda: src.rejects.count >= 1)
    finally:
        src.stop()
        loop.stop()
    assert loop.error is None


@needs_liblo
def test_osc_device_force_messages_decoded_by_oscdump(tmp_path):
    """liblo decodes the force message: /surfhap/ff/force iifff token seq fx fy fz, the session
    token in each, sequence numbers counting up; no device position yet: zero force."""
    force_port = free_udp_port()
    dump = Dump(force_port, tmp_path / "dump.txt")
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    be = OscDeviceBackend("127.0.0.1", force_port, FALCON.gain, listen=("127.0.0.1", 0))
    loop = FFLoop(eng, be)
    loop.start()
    try:
        assert wait_for(lambda: len(parse(dump.lines(), "/surfhap/ff/force")) > 50)
    finally:
        loop.stop()
        dump.close()
    lines = [ln.split() for ln in dump.lines() if "/surfhap/ff/force" in ln.split()]
    i = lines[0].index("/surfhap/ff/force")
    assert all(ln[i + 1] == "iifff" for ln in lines)
    assert {int(ln[i + 2]) for ln in lines} == {be.token}
    seqs = [int(ln[i + 3]) for ln in lines]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    assert all(float(v) == 0.0 for ln in lines for v in ln[i + 4:])  # the device watchdog holds zero


def test_osc_device_forces_follow_the_positions_of_a_reference_bridge():
    """A python-osc bridge (tests/live_support/ff_bridges.py) reports the screen 5 mm to the right."""
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    listen = free_udp_port()
    with ReferenceBridge(("127.0.0.1", listen), position=(0.005, 0.0, 0.0)) as bridge:
        be = OscDeviceBackend("127.0.0.1", bridge.port, FALCON.gain, listen=("127.0.0.1", listen))
        loop = FFLoop(eng, be)
        loop.start()
        try:
            # Idle centring pulls back (-x) and the weight compensation pushes up (+z), in device units
            assert wait_for(lambda: any(c[0] < -0.5 for c in list(bridge.commands))
                            and any(c[2] > 0.5 for c in list(bridge.commands)), timeout=30)
        finally:
            loop.stop()
        forces = np.array(bridge.commands)
    assert be.received >= 1 and be.read(0.0)[:3] == pytest.approx((0.005, 0.0, 0.0))
    assert be.dropped_sender == be.dropped_token == be.dropped_sequence == be.rejected == 0
    # device units = gain x newtons, never beyond gain x f_max
    assert np.all(np.abs(forces) <= FALCON.gain * np.asarray(FALCON.f_max) * (1 + 1e-6))
    assert loop.error is None


def test_positions_from_another_local_process_are_dropped_and_counted():
    """Issue 17 #7: any local process could inject device positions. An intruder on another
    port sends well-formed positions (even with the session token, in the old three-float
    format too): none is taken, each is counted; the bridge's own positions still are."""
    from pythonosc.udp_client import SimpleUDPClient

    from surfhap.live.ff_bridge_wire import encode_position

    listen = free_udp_port()
    with ReferenceBridge(("127.0.0.1", listen), position=(0.002, -0.001, 0.0)) as bridge:
        be = OscDeviceBackend("127.0.0.1", bridge.port, FALCON.gain, listen=("127.0.0.1", listen))
        be.start()
        intruder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        old_style = SimpleUDPClient("127.0.0.1", listen)
        try:
            for k in range(100):  # the bridge needs forces to learn the token
                be.write(np.zeros(3), 0.0)
                intruder.sendto(encode_position(be.token, 10**6 + k, -0.03, 0.02, 0.01, 0, 0, 0), ("127.0.0.1", listen))
                old_style.send_message("/surfhap/ff/position", [-0.03, 0.02, 0.01])
                time.sleep(0.002)
            assert wait_for(lambda: be.dropped_sender >= 200 and be.received >= 1)
            assert be.read(0.0)[:3] == pytest.approx((0.002, -0.001, 0.0))
        finally:
            intruder.close()
            be.stop()
    assert be.dropped_sender == 200


def test_wrong_token_and_stale_sequence_numbers_are_dropped_and_counted():
    from surfhap.live.ff_bridge_wire import encode_position

    be = OscDeviceBackend("127.0.0.1", 9, FALCON.gain, listen=("127.0.0.1", 0), token=12345)
    be.start()
    try:
        bridge = ("127.0.0.1", 9)
        pos = lambda token, seq, x: encode_position(token, seq, x, 0.0, 0.0, 0.0, 0.0, 0.0)  # noqa: E731
        assert be.accept(pos(12345, 7, 0.001), bridge)
        assert not be.accept(pos(54321, 8, 0.002), bridge)  # another session's token
        assert not be.accept(pos(12345, 7, 0.003), bridge)  # a repeat
        assert not be.accept(pos(12345, 3, 0.004), bridge)  # older than the last one taken
        assert not be.accept(pos(12345, 9, 5.0), bridge)  # not metres
        assert not be.accept(b"/surfhap/ff/position\0\0\0\0,fff\0\0\0\0" + bytes(12), bridge)  # the old format
        assert be.read(0.0)[:3] == (pytest.approx(0.001), 0.0, 0.0)
        assert be.accept(pos(12345, 8, 0.005), bridge)  # the next number after a gap of drops
        assert be.read(0.0)[0] == pytest.approx(0.005)
        assert (be.received, be.dropped_token, be.dropped_sequence, be.rejected, be.dropped_sender) == (2, 1, 2, 2, 0)
        assert be.info()["dropped_sequence"] == 2
    finally:
        be.stop()


@needs_liblo
def test_feedback_thread_sends_position_offset_and_force(tmp_path):
    port = free_udp_port()
    dump = Dump(port, tmp_path / "fb.txt")
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    loop = FFLoop(eng, SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain),
                  feedback=OscFeedback("127.0.0.1", port))
    loop.start()
    try:
        assert wait_for(lambda: len(parse(dump.lines(), "/surfhap/ff/offset")) >= 5)
    finally:
        loop.stop()
        dump.close()
    lines = dump.lines()
    screen = parse(lines, "/surfhap/ff/screen")
    offset = parse(lines, "/surfhap/ff/offset")
    assert screen.shape[1] == 3 and offset.shape[1] == 2
    n = min(len(screen), len(offset))
    np.testing.assert_allclose(offset[:n], -screen[:n, :2], atol=1e-6)  # content drawn still in the world


def test_bridge_check_and_the_osc_device_accept_the_same_positions():
    """Issue 20: ``ff bridge-check`` and the OSC device backend share one position receiver:
    the same datagrams are taken or dropped, for the same reasons."""
    from surfhap.live.ff_bridge_check import BridgeCheck
    from surfhap.live.ff_bridge_wire import encode_position

    bridge, other = ("127.0.0.1", 9), ("127.0.0.1", 10)
    cases = [  # (datagram, sender, taken by the contract)
        (encode_position(777, 1, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0), bridge, True),
        (encode_position(777, 2, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0), other, False),  # another process
        (encode_position(778, 3, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0), bridge, False),  # another session
        (encode_position(777, 4, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0), bridge, False),  # not metres
        (b"/surfhap/ff/position\0\0\0\0,fff\0\0\0\0" + bytes(12), bridge, False),  # another layout
        (encode_position(777, 5, 0.002, 0.0, 0.0, 0.0, 0.0, 0.0), bridge, True),
    ]
    check = BridgeCheck("127.0.0.1", 9, listen=("127.0.0.1", 0), token=777)
    be = OscDeviceBackend("127.0.0.1", 9, FALCON.gain, listen=("127.0.0.1", 0), token=777)
    check.receiver.open(0.0)
    be.start()
    try:
        got_check = [check.receiver.accept(d, a) is not None for d, a, _ in cases]
        got_device = [be.accept(d, a) for d, a, _ in cases]
    finally:
        check.receiver.close()
        be.stop()
    assert got_check == got_device == [ok for _, _, ok in cases]
    rx = check.receiver
    assert (rx.dropped_sender, rx.dropped_token, rx.rejected) == (be.dropped_sender, be.dropped_token, be.rejected) \
        == (1, 1, 2)
