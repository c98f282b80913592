"""Live engine targets, measured in one run (one JSON line per figure; ratio >= 1 passes).

The engine overhead per block (every built-in material and a mesh) is
``bench_live_overhead.py``.

1. live_touch_to_drive: the sim backend paced in real time, a producer thread pushing
   touches at 125 Hz at random phases; arrival -> first drive sample computed from it,
   p99 <= 2 blocks (ratio = 2 / p99_blocks).
2. live_50_clients: the engine in this process, the page server in its own process (as
   ``surfhap serve`` runs them), 50 WebSocket clients in a third process streaming pointer events at 120 Hz for 60 s over loopback, plus one
   client that floods garbage and never reads. Passes when every client's events were all
   acknowledged with p99 ack lag < 0.25 s (no client stalls another), the RSS grows by
   < 10 % between 10 s and the end (memory flat) and the emitted drive has zero safety
   violations (|V| <= v_max, rise <= rise_rate). Engine underruns are reported beside.

``--quick`` shortens run 2 to 10 s (as in the tests).
"""

import json
import os
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
from _common import report, run

from surfhap.exchange.materials import load_material
from surfhap.live.audit import audit_drive
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.models.panel import SimulatedDisplay
from surfhap.render.chain import ChainConfig, TextureChain


def rss_bytes(pid: str = "self") -> int:
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def engine_for(material: str, display: bool) -> LiveEngine:
    chain = TextureChain(load_material(material), ChainConfig(drive_rate=20000))
    disp = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.model_rate) if display else None
    return LiveEngine(chain, EngineConfig(block_seconds=0.001), display=disp)


def bench_latency(seconds: float = 10.0) -> None:
    from surfhap.live.backends.sim import SimBackend

    eng = engine_for("cork", True)
    eng.warm_up()
    backend = SimBackend()
    backend.start(eng)
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    n = 0
    while time.perf_counter() - t0 < seconds:  # bounded
        t = time.perf_counter() - t0
        eng.push_touch(1, 0.02 + 0.05 * abs(((t * 2.0) % 2.0) - 1.0), 0.03, 0.5, t_event=t)
        n += 1
        time.sleep(0.008 + rng.uniform(0, 0.001))
    backend.stop()
    lat = eng.latencies[: min(eng.latency_count, eng.latencies.shape[0])]
    p99_blocks = float(np.percentile(lat, 99)) / eng.block_period
    report("live_touch_to_drive", {"touches": n, "measured": int(lat.size),
                                   "p50_ms": round(float(np.percentile(lat, 50)) * 1e3, 3),
                                   "p99_ms": round(float(np.percentile(lat, 99)) * 1e3, 3),
                                   "p99_blocks": round(p99_blocks, 3), "underruns": eng.counters["underruns"]},
           2.0 / max(p99_blocks, 1e-9), "arrival -> first affected drive sample p99 <= 2 blocks", p99_blocks <= 2.0)


def bench_clients(seconds: float, n_clients: int = 50, rate: float = 120.0) -> None:
    import urllib.request

    from surfhap.live.config import ServerConfig
    from surfhap.live.session import build_session
    from surfhap.live.webproc import WebProcess

    tmp = tempfile.mkdtemp(prefix="surfhap-bench-")
    session = build_session("cork", f"file:{tmp}/drive.npz", max_seconds=seconds + 60)
    session.start()
    web = WebProcess(session, ServerConfig(port=0, max_clients=n_clients + 8)).start()
    pids = {"engine": "self", "web": str(web.proc.pid)}
    rss: dict = {}
    done = threading.Event()

    def sample_rss():
        t0 = time.perf_counter()
        while not done.wait(0.5):
            t = time.perf_counter() - t0
            for name, pid in pids.items():
                if t < min(10.0, seconds / 3):
                    rss[name + "_early"] = rss_bytes(pid)
                else:
                    rss[name + "_late"] = rss_bytes(pid)

    th = threading.Thread(target=sample_rss, daemon=True)
    th.start()
    url = f"ws://127.0.0.1:{web.port}/ws"
    proc = subprocess.run([sys.executable, "-m", "surfhap.live.loadtest", url, str(n_clients), str(rate), str(seconds), "1"],
                          capture_output=True, text=True, timeout=seconds + 120)
    done.set()
    try:
        server = json.loads(urllib.request.urlopen(f"{web.url}/api/status", timeout=5).read()).get("server", {})
    except OSError:
        server = {}
    web.stop()
    session.stop()
    if proc.returncode != 0:
        raise SystemExit("load generator failed: " + proc.stderr[-2000:])
    res = json.loads(proc.stdout)["summary"]
    eng = session.engine
    audit = audit_drive(session.backend.recorded, eng.drive_rate, eng.renderer.safety.limits)
    growth = max(rss.get(k + "_late", 0) / max(1, rss.get(k + "_early", 1)) for k in pids)
    no_stall = res["all_acked"] and res["lag_p99_max"] < 0.25
    ok = no_stall and growth < 1.10 and audit["violations"] == 0
    st = eng.status()
    mb = {k: round(v / 2**20, 1) for k, v in rss.items()}
    report("live_50_clients", {"clients": n_clients, "rate_hz": rate, "seconds": seconds, "events": res["sent"],
                               "all_acked": res["all_acked"], "ack_lag_p99_worst_client_s": round(res["lag_p99_max"], 4),
                               "ack_lag_max_s": round(res["lag_max"], 4), "max_frame_gap_s": round(res["max_frame_gap"], 4),
                               "rss_mb": mb, "rss_growth_worst": round(growth, 4), "safety_violations": audit["violations"],
                               "drive_samples": int(session.backend.recorded.size),
                               "engine_blocks": st["counters"]["blocks"], "engine_underruns": st["counters"]["underruns"],
                               "touch_latency_p99_ms": round(st["latency"]["p99"] * 1e3, 3) if st["latency"]["p99"] else None,
                               "server": server},
           0.25 / max(res["lag_p99_max"], 1e-9) if ok else 0.0,
           "all events acked, worst client's p99 ack lag < 0.25 s, RSS growth < 10 % (engine and web process), "
           "0 safety violations (ratio = 0.25 / worst p99 lag, 0 if any condition fails)", ok)


def main():
    quick = "--quick" in sys.argv
    bench_latency(5.0 if quick else 10.0)
    bench_clients(10.0 if quick else 60.0)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    run(main)
