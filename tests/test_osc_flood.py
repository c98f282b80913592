"""Issue 17 #5 (OSC part): a junk flood from one sender beside a real sender.

Before: ``ff run --touch osc`` let 32 of 585 real touches through (the flood filled the
socket's queue and the kernel dropped every sender's datagrams alike) and logged every
100th rejection, unthrottled. Now the flooding sender's bucket runs dry after ``burst``
datagrams and it is put in a kernel-level penalty box (surfhap.live.udpguard): the real
sender's datagrams keep arriving. Bound: >= 95 % of the real touches get through (the ones
at risk are those queued behind the flood in the ``burst`` datagrams before the penalty and
after each ``penalty_hold``; at 100 Hz for 3 s that is a few touches at most), and the log
holds at most one line per kind per second (RateLimitFilter)."""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from surfhap.live.udpguard import UdpListener

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="kernel steering to connected sockets")

TOUCH = b"/surfhap/touch\x00\x00,fff\x00\x00\x00\x00" + bytes.fromhex("3dcccccd 3d8f5c29 3f000000")  # 0.1 0.07 0.5

FLOOD = """
import socket, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
junk = [b"garbage", b"/other\\x00\\x00,\\x00\\x00\\x00", b"/surfhap/touch\\x00\\x00,s\\x00\\x00boom\\x00\\x00\\x00\\x00"]
target = ("127.0.0.1", int(sys.argv[1]))
end = time.monotonic() + float(sys.argv[2])
n = 0
while time.monotonic() < end:
    s.sendto(junk[n % 3], target)
    n += 1
print(n)
"""


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_ff_run_osc_touch_gets_nearly_all_real_touches_through_a_one_sender_flood():
    port = free_udp_port()
    env = dict(os.environ, COLUMNS="200")
    run = subprocess.Popen([sys.executable, "-m", "surfhap", "ff", "run", "buttons", "--json", "--device", "sim",
                            "--touch", f"osc://127.0.0.1:{port}"],  # until stopped: no window to outlast
                           env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t_start = time.monotonic()
    try:
        # wait until the listener is up: its port is taken (bind fails)
        probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        end = time.monotonic() + 60
        while time.monotonic() < end:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                break
            probe.close()
            probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            time.sleep(0.05)
        probe.close()
        flood = subprocess.Popen([sys.executable, "-c", FLOOD, str(port), "3.5"], stdout=subprocess.PIPE, text=True)
        real = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        time.sleep(0.2)  # let the flood begin before the first real touch (not a synchronisation)
        sent = 0
        for _ in range(300):  # 100 Hz for 3 s, while the flood lasts
            real.sendto(TOUCH, ("127.0.0.1", port))
            sent += 1
            time.sleep(0.01)
        real.close()
        flooded = int(flood.communicate(timeout=60)[0])
        time.sleep(1.0)  # grace for the last real touches after the flood ended (a bound, not a handshake)
        run.send_signal(signal.SIGTERM)
        out, err = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
    elapsed = time.monotonic() - t_start
    assert run.returncode == 130, err[-2000:]  # stopped by SIGTERM (docs/live.md, "Stopping")
    stats = json.loads(out.strip().splitlines()[-1])
    assert flooded > 20 * sent  # it was a flood
    assert stats["touches_received"] >= 0.95 * sent, (stats["touches_received"], sent, flooded)
    assert stats["touches_received"] <= sent  # nothing of the flood reached the loop
    # at most one line per kind per second of the run (3 kinds of junk + the rate limit), plus the
    # banner and the stop's lines
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) <= 4 * (math.ceil(elapsed) + 1) + 5, "\n".join(lines[:50])


def test_penalised_sender_is_dropped_by_the_kernel_and_released_after_hold():
    lis = UdpListener("127.0.0.1", 0, hold=1.0)
    offender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    offender.bind(("127.0.0.1", 0))
    other = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    lis.sock.settimeout(5.0)
    try:
        assert lis.penalise(offender.getsockname(), t=100.0) and lis.boxed == 1
        assert not lis.penalise(offender.getsockname(), t=100.0)  # already in the box
        for _ in range(1000):
            offender.sendto(b"junk", ("127.0.0.1", lis.port))
        other.sendto(b"real", ("127.0.0.1", lis.port))
        assert lis.sock.recvfrom(64)[0] == b"real"  # the first datagram on the listener is the real one
        lis.release_due(100.5)
        assert lis.boxed == 1
        lis.release_due(101.0)
        assert lis.boxed == 0 and lis.penalised == 1
        offender.sendto(b"back", ("127.0.0.1", lis.port))
        assert lis.sock.recvfrom(64)[0] == b"back"  # out of the box: the listener hears it again
    finally:
        offender.close()
        other.close()
        lis.close()


def test_a_port_in_use_still_fails_to_bind_despite_the_reuseport_group():
    lis = UdpListener("127.0.0.1", 0)
    try:
        with pytest.raises(OSError):
            UdpListener("127.0.0.1", lis.port)  # a second surfhap listener
        plain = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        with pytest.raises(OSError):
            plain.bind(("127.0.0.1", lis.port))  # any other program
        plain.close()
    finally:
        lis.close()
