"""Live engine targets, measured in one run (one JSON line per figure; ratio >= 1 passes).

The engine overhead per block (every built-in material and a mesh) is
``bench_live_overhead.py``.

live_touch_to_drive: the sim backend paced in real time, a producer thread pushing
   touches at 125 Hz at random phases; arrival -> first drive sample computed from it,
   p99 <= 2 blocks (ratio = 2 / p99_blocks).
The 50 web clients' figure (web_50_clients) is ``bench_web.py``.

``--quick`` shortens the run to 5 s.
"""

import os
import sys
import time

import numpy as np
from _common import report, run

from surfhap.exchange.materials import load_material
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.models.panel import SimulatedDisplay
from surfhap.render.chain import ChainConfig, TextureChain


def engine_for(material: str, display: bool) -> LiveEngine:
    chain = TextureChain(load_material(material), ChainConfig(drive_rate=20000))
    disp = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate) if display else None
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


def main():
    quick = "--quick" in sys.argv
    bench_latency(5.0 if quick else 10.0)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    run(main)
