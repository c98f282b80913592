"""OSC round trips of the force-feedback loop against a real OSC client (liblo's oscsend / oscdump).

liblo-tools is a system package (Makefile SYSTEM_PACKAGES); these tests install nothing.
"""

import shutil
import socket
import subprocess
import time

import numpy as np
import pytest

from surfhap.ff import FALCON, FFEngine
from surfhap.ff.scene import load_scene
from surfhap.live.ff_devices import OscDeviceBackend, SimDeviceBackend
from surfhap.live.ff_loop import FFLoop, OscFeedback
from surfhap.live.prediction import TouchPredictor
from surfhap.live.sources import OscTouchSource, TouchSpace
from surfhap.sim.ff_device import SimDevice

pytestmark = pytest.mark.skipif(not (shutil.which("oscsend") and shutil.which("oscdump")),
                                reason="liblo-tools (oscsend, oscdump) not installed; run make system-deps")


def free_udp_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def wait_for(cond, timeout=10.0):
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
        time.sleep(0.3)

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
                           check=True, timeout=10)
        assert eng.mask == 1 and eng.state.touched
        assert src.accepted >= 1
        # a lift ends the touch
        subprocess.run(["oscsend", "127.0.0.1", str(src.port), "/surfhap/lift"], check=True, timeout=10)
        assert wait_for(lambda: not eng.state.touched)
        # garbage is rejected, not evaluated
        subprocess.run(["oscsend", "127.0.0.1", str(src.port), "/surfhap/touch", "s", "boom"], check=True, timeout=10)
        assert wait_for(lambda: src.rejects.count >= 1)
    finally:
        src.stop()
        loop.stop()
    assert loop.error is None


def test_osc_device_forces_to_oscdump_and_positions_from_oscsend(tmp_path):
    force_port = free_udp_port()
    dump = Dump(force_port, tmp_path / "dump.txt")
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    be = OscDeviceBackend("127.0.0.1", force_port, FALCON.gain, listen=("127.0.0.1", 0))
    loop = FFLoop(eng, be)
    loop.start()
    try:
        # no device position yet: the device watchdog keeps the force at zero
        assert wait_for(lambda: len(parse(dump.lines(), "/surfhap/ff/force")) > 50)
        before = parse(dump.lines(), "/surfhap/ff/force")
        assert np.all(before == 0.0)
        # the bridge reports the screen 5 mm to the right, repeatedly (the watchdog needs < 10 ms gaps
        # to hold the force; between bursts it ramps back to zero, which is fine here)
        shell = f"for i in $(seq 60); do oscsend 127.0.0.1 {be.listen_port} /surfhap/ff/position fff 0.005 0 0; done"
        subprocess.run(["sh", "-c", shell], check=True, timeout=60)
        assert be.received >= 1
        time.sleep(0.2)
        forces = parse(dump.lines(), "/surfhap/ff/force")
    finally:
        loop.stop()
        dump.close()
    # Idle centring pulls back (-x) and the weight compensation pushes up (+z), in device units
    assert forces[:, 0].min() < -0.5
    assert forces[:, 2].max() > 0.5
    # device units = gain x newtons, never beyond gain x f_max
    assert np.all(np.abs(forces) <= FALCON.gain * np.asarray(FALCON.f_max) * (1 + 1e-6))
    assert loop.error is None


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
