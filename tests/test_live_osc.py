"""OSC in and out over loopback UDP: a separate OSC client process drives the engine; the
OSC output backend's intensity stream follows the touch and drops to zero on lift."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import ThreadingOSCUDPServer

from surfhap.live.backends.output import OscOutput
from surfhap.live.session import build_session

HERE = Path(__file__).parent


def test_osc_client_process_drives_osc_output():
    got: list[tuple[float, float]] = []
    lock = threading.Lock()

    def on_intensity(_addr, value):
        with lock:
            got.append((time.perf_counter(), float(value)))

    disp = Dispatcher()
    disp.map("/surfhap/intensity", on_intensity)
    receiver = ThreadingOSCUDPServer(("127.0.0.1", 0), disp)
    rx = threading.Thread(target=receiver.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    rx.start()
    out_port = receiver.server_address[1]
    session = build_session("cork", OscOutput("127.0.0.1", out_port, "intensity"), osc_in=("127.0.0.1", 0))
    session.start()
    osc_in = session.sources[0]
    try:
        t_start = time.perf_counter()
        r = subprocess.run([sys.executable, str(HERE / "live_support" / "osc_sender.py"), str(osc_in.port), "0.6"],
                           capture_output=True, text=True, timeout=30)
        t_lift = time.perf_counter()
        assert r.returncode == 0, r.stderr
        end = time.monotonic() + 60  # bounded: until the output has dropped to zero after the lift
        while time.monotonic() < end:
            with lock:
                if any(t > t_lift and v == 0.0 for t, v in got):
                    break
            time.sleep(0.01)
        time.sleep(0.15)
    finally:
        session.stop()
        receiver.shutdown()
        receiver.server_close()
    sent = int(r.stdout.strip())
    eng = session.engine
    assert osc_in.accepted >= sent * 0.9
    assert osc_in.rejects.count >= 5 * (sent // 20) * 0.9  # NaN, unknown, wrong type, garbage, oversize
    assert eng.counters["errors"] == 0
    with lock:
        vals = list(got)
    during = [v for t, v in vals if t_start < t < t_lift]
    after = [v for t, v in vals if t > t_lift]
    assert during and max(during) > 0.5, "OSC output did not follow the touch"
    assert 0.0 in after, "OSC output did not drop to zero after /surfhap/lift"
    assert max(after[after.index(0.0):]) == 0.0, "OSC output came back after the lift"
    assert all(0.0 <= v <= 1.0 for _, v in vals)


# --------------------------------------------------------------------------- hostile senders

from pythonosc.osc_message_builder import OscMessageBuilder  # noqa: E402

from surfhap.live.sources import OscTouchSource, finite_in_range  # noqa: E402


class FakeEngine:
    def __init__(self):
        self.pushed = []

    def push_touch(self, source, x, y, load, t_event=float("nan"), t_arrival=None):
        self.pushed.append((source, x, y, load))
        return True


class FakeClock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t


def osc(address, *args):
    b = OscMessageBuilder(address)
    for a in args:
        if isinstance(a, tuple):
            b.add_arg(a[0], a[1])
        else:
            b.add_arg(a)
    return b.build().dgram


TOUCH = osc("/surfhap/touch", 0.05, 0.05)
JUNK = [b"garbage", b"/surfhap/touch\x00\x00,fff\x00", osc("/other", 1.0), osc("/surfhap/touch", "x", "y")]


def source_with_clock(**kw):
    clock = FakeClock()
    eng = FakeEngine()
    return OscTouchSource(eng, port=0, clock=clock, **kw), eng, clock


def test_junk_from_many_new_senders_does_not_lock_out_a_new_one():
    src, eng, clock = source_with_clock()
    for i in range(200):  # a burst of junk, each datagram from a new source port
        src._datagram(JUNK[i % len(JUNK)], ("127.0.0.1", 40000 + i))
        assert src.senders <= src.max_senders
    assert not eng.pushed and src.rejects.count == 200
    clock.t += 1.0 / 20.0 + 1e-6  # one admission token later (admit_rate = 20/s)
    src._datagram(TOUCH, ("127.0.0.1", 50000))
    assert len(eng.pushed) == 1 and eng.pushed[0][1:] == pytest.approx((0.05, 0.05, src.space.default_load))
    # a second new sender in the same instant waits for the next token, not for minutes
    src._datagram(TOUCH, ("127.0.0.1", 50001))
    clock.t += 0.05 + 1e-6
    src._datagram(TOUCH, ("127.0.0.1", 50001))
    assert len(eng.pushed) == 2 and eng.pushed[0][0] != eng.pushed[1][0]


def test_an_established_sender_keeps_working_through_a_flood():
    src, eng, clock = source_with_clock()
    src._datagram(TOUCH, ("127.0.0.1", 9999))
    for i in range(2000):  # 2 s of flood: 1000 new source ports a second, and the sender at 100 Hz
        clock.t += 0.001
        src._datagram(JUNK[0], ("127.0.0.1", 10000 + i))
        if i % 10 == 0:
            src._datagram(TOUCH, ("127.0.0.1", 9999))
    assert len(eng.pushed) == 1 + 200
    assert len({p[0] for p in eng.pushed}) == 1
    # the flood changed the table at most at the admission rate
    assert src.evicted <= 16 + 20 * 2 + 1


def test_idle_senders_expire_so_a_full_table_admits_again():
    src, eng, clock = source_with_clock(max_senders=8)
    for i in range(8):  # eight real senders, admitted one per 0.1 s
        src._datagram(TOUCH, ("127.0.0.1", 20000 + i))
        clock.t += 0.1
    assert len(eng.pushed) == 8
    src._datagram(TOUCH, ("127.0.0.1", 30000))  # all eight are active: no room
    assert len(eng.pushed) == 8
    clock.t += 5.0  # some stay active, the others fall silent
    for i in range(4):
        src._datagram(TOUCH, ("127.0.0.1", 20000 + i))
    clock.t += src.sender_idle - 5.0 + 0.5
    src._datagram(TOUCH, ("127.0.0.1", 30000))
    assert len(eng.pushed) == 8 + 4 + 1
    assert src.expired == 4 and src.senders == 5


def test_numeric_osc_arguments_that_overflow_or_are_not_finite_are_rejected():
    src, eng, clock = source_with_clock()
    bad = [(2**63 - 1, "h"), (-(2**63), "h"), (float("inf"), "d"), (float("-inf"), "d"), (float("nan"), "d"),
           (1e308, "d"), (float("inf"), "f"), (2**31 - 1, "i"), (True, "T")]
    good = {"/surfhap/touch": [0.05, 0.05, 0.5], "/surfhap/touch/norm": [0.5, 0.5, 0.5]}
    n = 0
    for address, args in good.items():
        for k in range(3):  # x, y, load / u, v, pressure
            for value, tag in bad:
                a = list(args)
                a[k] = (value, tag)
                clock.t += 0.01
                src._datagram(osc(address, *a), ("127.0.0.1", 7000))
                n += 1
                assert src.rejects.count == n, (address, k, value)
    assert not eng.pushed
    src._datagram(osc("/surfhap/touch/norm", 0.5, 0.5, 0.5), ("127.0.0.1", 7000))
    assert len(eng.pushed) == 1
    # the shared check: integers too large for a float are bad input, not an OverflowError
    for v in (10**400, -(10**400), float("nan"), float("inf"), "1", None, True, [1]):
        assert finite_in_range(v, -1e300, 1e300) is None
    assert finite_in_range(10**20, 0, 1e21) == 1e20


def test_junk_from_many_ports_over_udp_then_a_new_sender_is_accepted():
    """Real sockets on loopback: 100 junk datagrams from 100 source ports, then a new sender."""
    import socket

    eng = FakeEngine()
    src = OscTouchSource(eng, "127.0.0.1", 0)
    src.start()
    try:
        for i in range(100):
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.sendto(JUNK[i % len(JUNK)], ("127.0.0.1", src.port))
        legit = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            for _ in range(500):  # bounded; at 50 Hz as a touching sender would
                legit.sendto(TOUCH, ("127.0.0.1", src.port))
                time.sleep(0.02)
                if eng.pushed:
                    break
        finally:
            legit.close()
    finally:
        src.stop()
    assert eng.pushed, "a new OSC sender was locked out after a burst of junk"
    assert src.rejects.count >= 1


def test_osc_input_listens_on_ipv6_loopback():
    import socket

    if not socket.has_ipv6:
        pytest.skip("no IPv6 in this Python")
    eng = FakeEngine()
    src = OscTouchSource(eng, "::1", 0)
    try:
        src.start()
    except OSError as exc:
        pytest.skip(f"no IPv6 loopback here ({exc})")
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_DGRAM) as s:
            for _ in range(250):  # bounded
                s.sendto(TOUCH, ("::1", src.port))
                time.sleep(0.02)
                if eng.pushed:
                    break
    finally:
        src.stop()
    assert eng.pushed
