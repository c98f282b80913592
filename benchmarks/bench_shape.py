"""Shape rendering: top-surface hit queries and scan calibration (issue 4 targets).

Meshes: the Stanford bunny res2 (16 301 faces; ../shared/data, skipped if absent) and a
99 840-face closed mesh (a displaced UV sphere: two layers under most rays, so "highest
hit" matters). Per mesh, measured in one run:

* batch: 1e6 random points over the bounding box in one ``query`` call, >= 1e6 queries/s;
* single: p99 of 20 000 ``query_point`` calls, <= 50 us;
* versus trimesh ``ray.intersects_location`` (rtree, multiple hits, highest kept) on the
  same 20 000 rays: the same hits (miss pattern identical, heights within 1e-9) and >= 10x
  faster (our batch query time for those rays vs trimesh's).

Times are the thread's CPU time (``time.thread_time``; best of a few runs), which other jobs
on a shared machine do not inflate; wall-clock figures are printed beside them.

Calibration: Suzanne (shipped), 36 directions x 5 speeds (2-20 cm/s) at 60 Hz, 16 lines per
direction, scaled to 10 cm on the screen; also at Blender scale (2.7 m, sample budget
applies) for reference. Target <= 1 s (warm: numba compiled once before timing).
"""

import sys
import time
from pathlib import Path

import numpy as np
import trimesh
from _common import best_time, report, run


def best_cpu(fn, repeat: int = 3) -> float:
    """Smallest thread CPU time of ``repeat`` calls (s)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t0)
    return best

from surfhap.shape.calibration import ScanPlan, calibrate
from surfhap.shape.topsurface import TopSurface

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def big_mesh() -> TopSurface:
    m = trimesh.creation.uv_sphere(radius=0.05, count=[160, 160])
    v = np.asarray(m.vertices).copy()
    r = np.linalg.norm(v, axis=1, keepdims=True)
    bumps = 1.0 + 0.05 * np.sin(9 * np.arctan2(v[:, 1], v[:, 0]))[:, None] * np.cos(7 * v[:, 2:3] / 0.05)
    return TopSurface(v / r * 0.05 * bumps, np.asarray(m.faces), name=f"displaced sphere ({len(m.faces)} faces)")


def trimesh_highest(mesh: trimesh.Trimesh, xy: np.ndarray, top: float) -> np.ndarray:
    origins = np.column_stack([xy, np.full(len(xy), top)])
    dirs = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    loc, idx, _ = mesh.ray.intersects_location(origins, dirs, multiple_hits=True)
    z = np.full(len(xy), -np.inf)
    np.maximum.at(z, idx, loc[:, 2])
    return np.where(np.isfinite(z), z, np.nan)


def bench_queries(surf: TopSurface, label: str) -> None:
    rng = np.random.default_rng(0)
    lo, hi = surf.bounds
    xy = rng.uniform(lo[:2], hi[:2], (1_000_000, 2))
    surf.query(xy[:100])
    t_batch = best_cpu(lambda: surf.query(xy), repeat=3)
    t_wall = best_time(lambda: surf.query(xy), repeat=3)
    qps = xy.shape[0] / t_batch
    report(f"shape_hits_batch[{label}]", {"faces": surf.n_faces, "queries": xy.shape[0], "cpu_s": round(t_batch, 4),
                                          "queries_per_s": round(qps), "wall_queries_per_s": round(xy.shape[0] / t_wall)},
           qps / 1e6, "batch >= 1e6 queries/s (ratio = queries_per_s / 1e6 >= 1)", qps >= 1e6)

    pts = xy[:20_000]
    surf.query_point(*pts[0])
    times = np.empty(len(pts))
    qp = surf.query_point
    for k in range(len(pts)):
        x, y = pts[k]
        t0 = time.thread_time_ns()
        qp(x, y)
        times[k] = time.thread_time_ns() - t0
    wall = np.empty(2000)
    for k in range(2000):
        x, y = pts[k]
        t0 = time.perf_counter()
        qp(x, y)
        wall[k] = time.perf_counter() - t0
    p99 = float(np.percentile(times, 99)) / 1e3
    report(f"shape_hits_single[{label}]", {"faces": surf.n_faces, "calls": len(pts), "p99_us": round(p99, 2),
                                           "median_us": round(float(np.median(times)) / 1e3, 2),
                                           "wall_p99_us": round(float(np.percentile(wall, 99)) * 1e6, 2)},
           50.0 / p99, "single-query p99 <= 50 us (ratio = 50 / p99 >= 1)", p99 <= 50.0)

    mesh = trimesh.Trimesh(surf.vertices, surf.faces, process=False)
    rays = xy[:20_000]
    top = float(hi[2]) + 1.0
    trimesh_highest(mesh, rays[:10], top)  # build trimesh's rtree outside the timing
    t0, w0 = time.thread_time(), time.perf_counter()
    ref = trimesh_highest(mesh, rays, top)
    t_tm, w_tm = time.thread_time() - t0, time.perf_counter() - w0
    t_ours = best_cpu(lambda: surf.query(rays), repeat=5)
    w_ours = best_time(lambda: surf.query(rays), repeat=5)
    z, _ = surf.query(rays)
    same_miss = bool(np.array_equal(np.isnan(z), np.isnan(ref)))
    both = ~np.isnan(z) & ~np.isnan(ref)
    dz = float(np.max(np.abs(z[both] - ref[both]))) if np.any(both) else 0.0
    speedup = t_tm / t_ours
    ok = speedup >= 10 and same_miss and dz <= 1e-9
    report(f"shape_hits_vs_trimesh[{label}]", {"faces": surf.n_faces, "rays": len(rays), "ours_s": round(t_ours, 5),
                                               "trimesh_s": round(t_tm, 3), "speedup": round(speedup, 1),
                                               "wall_speedup": round(w_tm / w_ours, 1),
                                               "same_misses": same_miss, "max_dz": dz, "hit_fraction": round(float(both.mean()), 3)},
           speedup / 10.0, "same hits (misses identical, |dz| <= 1e-9) and >= 10x faster (ratio = speedup / 10 >= 1)", ok)


def bench_calibration() -> None:
    plan = ScanPlan.evenly(36, 5, 0.02, 0.20, sensor_rate=60.0, lines=16)
    for size, label in ((0.10, "suzanne 10 cm"), (None, "suzanne Blender scale 2.7 m")):
        surf = TopSurface.from_file("suzanne", size=size)
        calibrate(TopSurface.from_file("suzanne", size=0.1), ScanPlan(directions=2, speeds=(0.1,)))  # compile
        seconds = best_time(lambda: calibrate(TopSurface.from_file("suzanne", size=size), plan), repeat=3)
        cpu = best_cpu(lambda: calibrate(TopSurface.from_file("suzanne", size=size), plan), repeat=3)
        cal = calibrate(surf, plan)
        report(f"shape_calibration[{label}]", {"directions": 36, "speeds": 5, "sensor_rate_hz": 60,
                                               "lines_per_direction": cal.plan["lines_per_direction"],
                                               "samples": cal.n_samples, "seconds": round(seconds, 4), "cpu_s": round(cpu, 4),
                                               "fsq_range": [round(cal.fmin, 4), round(cal.fmax, 4)]},
               1.0 / seconds, "calibration (mesh load + theta_min + scans) <= 1 s wall (ratio = 1 / seconds >= 1)", seconds <= 1.0)


def main():
    bunny = SHARED / "stanford-bunny" / "bun_zipper_res2.ply"
    if bunny.exists():
        bench_queries(TopSurface.from_file(bunny, up="y"), "bunny res2")
    else:
        print(f"# skipped the bunny: {bunny} not found", file=sys.stderr)
    bench_queries(big_mesh(), "1e5 faces")
    bench_calibration()


if __name__ == "__main__":
    run(main)
