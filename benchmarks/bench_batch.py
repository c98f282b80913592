"""Benchmark of batch rendering over a scheduler; one JSON line per figure, all from one run.

The grid of issue 12: 5 built-in materials x 3 loads x 4 speeds = 60 renders of 30 s each
(``surfhap render ... --grid load=... --grid speed=...``, figures on), run end to end as
the command line from a fresh interpreter, in ``--repeat`` interleaved rounds (best time of
each variant counts; the machine is shared):

* ``--jobs 1`` (serial, the reference), ``--jobs 2`` (two local worker processes) and
  ``--scheduler local:2`` (a Dask LocalCluster of two single-threaded worker processes).
* batch_jobs2: ratio = serial time / --jobs 2 time, target >= 1.7 on 2 cores.
* batch_dask_local2: ratio = serial time / LocalCluster time, target >= 1.5.

Every run must finish all 60 jobs, and each parallel run's drive arrays must equal the
serial run's bit for bit (checked on every job), or the figure fails.

Run: ``.venv/bin/python benchmarks/bench_batch.py [--seconds S] [--repeat N]`` (S < 30 for a quick check).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from _common import log, report, run  # noqa: E402

MATERIALS = "leather,cork,denim,wood,drawing-paper"
LOADS = "0.26,0.5,0.96"
SPEEDS = "0.05,0.1,0.15,0.2"
SRC = Path(__file__).resolve().parents[1] / "src"


def _render(out: Path, seconds: float, *extra: str) -> float:
    cmd = [sys.executable, "-m", "surfhap", "render", MATERIALS, "--scan", f"duration={seconds:g}",
           "--grid", f"load={LOADS}", "--grid", f"speed={SPEEDS}", "--out", str(out), *extra]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")])))
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - t0
    log(f"{' '.join(extra) or '--jobs 1'}: {elapsed:.1f} s, exit {r.returncode}: {r.stdout.strip()}")
    if r.returncode != 0:
        log(r.stderr[-2000:])
    return elapsed


def _same(a: Path, b: Path) -> bool:
    ia, ib = (json.loads((d / "index.json").read_text()) for d in (a, b))
    if ia["failed"] or ib["failed"] or ia["jobs"] != 60 or ib["jobs"] != 60:
        return False
    for row in ia["rows"]:
        da, db = np.load(a / row["out"] / "render.npz"), np.load(b / row["out"] / "render.npz")
        if not np.array_equal(da["drive"], db["drive"]) or not np.array_equal(da["voltage"], db["voltage"]):
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=30.0, help="duration of each render, s (issue 12: 30)")
    ap.add_argument("--repeat", type=int, default=2, help="rounds; each variant's best time counts")
    args = ap.parse_args()
    load_before = os.getloadavg()[0]
    variants = {"serial": ("--jobs", "1"), "jobs2": ("--jobs", "2"), "dask2": ("--scheduler", "local:2")}
    best = dict.fromkeys(variants, float("inf"))
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        for rep in range(args.repeat):  # interleaved, so a burst of load from elsewhere hits one round, not one variant
            for name, extra in variants.items():
                best[name] = min(best[name], _render(root / f"{name}{rep}", args.seconds, *extra))
        same_jobs2 = all(_same(root / "serial0", root / f"jobs2{r}") for r in range(args.repeat))
        same_dask2 = all(_same(root / "serial0", root / f"dask2{r}") for r in range(args.repeat))
    serial, jobs2, dask2 = best["serial"], best["jobs2"], best["dask2"]
    common = {"renders": 60, "seconds_each": args.seconds, "repeat": args.repeat, "cores": os.cpu_count(), "serial_s": round(serial, 2),
              "load_avg_1min_before": round(load_before, 2), "load_avg_1min_after": round(os.getloadavg()[0], 2)}
    r1 = serial / jobs2
    report("batch_jobs2", {**common, "parallel_s": round(jobs2, 2), "identical_to_serial": same_jobs2}, r1,
           "serial / --jobs 2 >= 1.7", bool(r1 >= 1.7 and same_jobs2))
    r2 = serial / dask2
    report("batch_dask_local2", {**common, "parallel_s": round(dask2, 2), "identical_to_serial": same_dask2}, r2,
           "serial / --scheduler local:2 >= 1.5", bool(r2 >= 1.5 and same_dask2))


if __name__ == "__main__":
    run(main)
