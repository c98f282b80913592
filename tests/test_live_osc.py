"""OSC in and out over loopback UDP: a separate OSC client process drives the engine; the
OSC output backend's intensity stream follows the touch and drops to zero on lift."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("pythonosc")

from pythonosc.dispatcher import Dispatcher  # noqa: E402
from pythonosc.osc_server import ThreadingOSCUDPServer  # noqa: E402

from surfhap.live.server import build_session  # noqa: E402

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
    session = build_session("cork", f"osc://127.0.0.1:{out_port}/intensity", osc_in=("127.0.0.1", 0))
    session.start()
    osc_in = session.sources[0]
    try:
        t_start = time.perf_counter()
        r = subprocess.run([sys.executable, str(HERE / "live_support" / "osc_sender.py"), str(osc_in.port), "0.6"],
                           capture_output=True, text=True, timeout=30)
        t_lift = time.perf_counter()
        assert r.returncode == 0, r.stderr
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
    during = [v for t, v in vals if t_start + 0.2 < t < t_lift - 0.05]
    after = [v for t, v in vals if t > t_lift + 0.05]
    assert during and max(during) > 0.5, "OSC output did not follow the touch"
    assert after and max(after) == 0.0, "OSC output did not drop to zero after /surfhap/lift"
    assert all(0.0 <= v <= 1.0 for _, v in vals)
