"""Force-feedback benchmarks (issue 10): one JSON line each on stdout; exit 1 on a missed target.

* ``ff_effects_tick``: one engine tick (kinematics, all effects active, control law, safety
  stage) timed over many ticks; target p99 <= 20 us of the thread's CPU time (what the tick
  costs; on a loaded machine wall time also counts preemption by other processes, so the
  wall-time distribution is reported alongside).
* ``ff_loop_1khz``: the live haptic loop with the simulated device and a replayed finger for
  ``--seconds`` (default 60); targets p99 period error <= 0.2 ms and <= 1 % missed ticks
  (issue 20, also beside a CPU-bound process); ``scheduling`` is the class the OS granted the
  haptic thread (``fifo`` where real-time scheduling is allowed).
"""

from __future__ import annotations

import argparse
import time

from _common import report, run  # noqa: E402  (also puts src/ on sys.path)

import numpy as np  # noqa: E402


def all_active_engine():
    from surfhap.ff import FALCON, Attraction, FFEngine, GridField, Roughness, Shape, Sliding, Stiffness
    from surfhap.render.kinematics import TouchPredictor

    h = GridField(np.outer(np.hanning(64), np.hanning(48)).T * 0.02, 0.0, 0.0, 0.197, 0.148)
    effects = [Stiffness(300.0), Shape(h), Roughness(2e-4, 1.5e-3), Sliding(0.5, mass=FALCON.moving_mass),
               Attraction([(0.1, 0.07, 0.05, 1.0), (0.12, 0.08, 0.05, -0.5)])]
    eng = FFEngine(effects, FALCON, TouchPredictor(latency=0.04, alpha=0.15, velocity_alpha=0.45), touch_latency=0.04)
    return eng


def bench_effects(n: int) -> bool:
    eng = all_active_engine()
    eng.reset()
    cpu = np.empty(n)
    wall = np.empty(n)
    pc = time.perf_counter_ns
    tc = time.thread_time_ns
    dt = 1e-3
    xs = [0.1 + 0.03 * np.sin(np.pi * k * dt) for k in range(n)]
    ps = [0.001 * np.sin(7.0 * k * dt) for k in range(n)]
    for k in range(n):
        t = k * dt
        if k % 16 == 0:  # 60 Hz touch samples along a stroke
            eng.touch(t, xs[k], 0.07, 1.0)
        p = ps[k]
        c0 = tc()
        w0 = pc()
        eng.tick(t, p, -p, -0.001, t)
        wall[k] = pc() - w0
        cpu[k] = tc() - c0
    assert eng.mask == 0b11111, "not all effects active"
    us = cpu[n // 10:] * 1e-3  # skip warm-up
    wus = wall[n // 10:] * 1e-3
    p99 = float(np.percentile(us, 99))
    ok = p99 <= 20.0
    report("ff_effects_tick", {"ticks": int(us.size), "effects_active": 5, "cpu_p50_us": round(float(np.median(us)), 2),
                               "cpu_p99_us": round(p99, 2), "wall_p50_us": round(float(np.median(wus)), 2),
                               "wall_p99_us": round(float(np.percentile(wus, 99)), 2),
                               "wall_max_us": round(float(wus.max()), 1)},
           20.0 / max(p99, 1e-3), "CPU-time p99 <= 20 us (ratio = 20 / p99 >= 1)", ok)
    return ok


def bench_loop(seconds: float) -> bool:
    from surfhap.ff import FALCON
    from surfhap.live.ff_devices import SimDeviceBackend
    from surfhap.live.ff_loop import FFLoop, WorldTouchAdapter
    from surfhap.runtime.sources import TrajectorySource
    from surfhap.models.trajectory import Trajectory
    from surfhap.sim.ff_device import SimDevice

    eng = all_active_engine()
    be = SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain)
    loop = FFLoop(eng, be)
    t = np.arange(0.0, 10.0, 1.0 / 60.0)
    tr = Trajectory(t, 0.1 + 0.03 * np.sin(np.pi * t), np.full(t.size, 0.07), np.ones(t.size))
    src = TrajectorySource(WorldTouchAdapter(loop, be), tr, loop=True, max_seconds=seconds + 5, wall_clock=True)
    loop.start()
    src.start()
    time.sleep(seconds)
    src.stop()
    loop.stop()
    st = loop.stats()
    p99 = st["period_error_ms"]["p99"]
    expected = int(seconds * 1000)
    missed = st["missed"] / max(1, expected)
    ok = p99 <= 0.2 and missed <= 0.01 and st["error"] is None
    report("ff_loop_1khz", {"seconds": seconds, "ticks": st["ticks"], "expected_ticks": expected,
                            "missed": st["missed"], "missed_fraction": round(missed, 5), "scheduling": st["scheduling"],
                            "p50_ms": round(st["period_error_ms"]["p50"], 4), "p99_ms": round(p99, 4),
                            "p999_ms": round(st["period_error_ms"]["p999"], 4),
                            "max_ms": round(st["period_error_ms"]["max"], 3), "safety": st["safety"]},
           0.2 / max(p99, 1e-4), "p99 period error <= 0.2 ms (ratio = 0.2 / p99 >= 1) and missed ticks <= 1 %", ok)
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=60.0, help="loop duration (s)")
    ap.add_argument("--ticks", type=int, default=50_000, help="ticks for the per-tick timing")
    args = ap.parse_args()
    bench_effects(args.ticks)
    bench_loop(args.seconds)


if __name__ == "__main__":
    run(main)
