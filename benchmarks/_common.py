"""Shared helpers of the benchmark scripts: timing and the one-JSON-line report."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))


def best_time(fn, repeat: int = 5) -> float:
    """Smallest wall time of ``repeat`` calls (s): the least disturbed run on a noisy machine."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def report(name: str, figure: dict, ratio: float, target: str, passed: bool) -> None:
    """Print one JSON line: the benchmark's figures, the ratio it is judged by, and the verdict."""
    line = {"benchmark": name, **figure, "ratio": round(float(ratio), 3), "target": target, "pass": bool(passed)}
    print(json.dumps(line), flush=True)
