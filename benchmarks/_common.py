"""Shared helpers of the benchmark scripts: timing, the one-JSON-line report, and the exit code.

Every figure is one JSON line on stdout with a ``"pass"`` field; anything else a benchmark
(or a library it calls) prints goes to stderr. Run a script's ``main`` with :func:`run`:
the script exits 1 when any figure missed its target (or none was reported), so
``make bench`` fails on a miss.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

_STDOUT = sys.stdout  # the JSON lines go here; everything else is sent to stderr by run()
_results: list[dict] = []


def best_time(fn, repeat: int = 5) -> float:
    """Smallest wall time of ``repeat`` calls (s): the least disturbed run on a noisy machine."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def emit(row: dict) -> None:
    """Print one figure as one JSON line on stdout and remember whether it passed.
    ``row`` must hold a boolean ``"pass"``."""
    if not isinstance(row.get("pass"), bool):
        raise ValueError(f"a benchmark figure needs a boolean 'pass' field: {row}")
    _results.append(row)
    _STDOUT.write(json.dumps(row) + "\n")
    _STDOUT.flush()


def report(name: str, figure: dict, ratio: float, target: str, passed: bool) -> None:
    """One JSON line: the benchmark's figures, the ratio it is judged by, and the verdict."""
    emit({"benchmark": name, **figure, "ratio": round(float(ratio), 3), "target": target, "pass": bool(passed)})


def log(*parts) -> None:
    """Progress and notes: stderr, never stdout."""
    print(*parts, file=sys.stderr, flush=True)


def run(main) -> None:
    """Run ``main()`` with stdout redirected to stderr (only :func:`emit` writes to stdout),
    then exit 0 when every figure passed, 1 when one missed its target or none was reported."""
    with contextlib.redirect_stdout(sys.stderr):
        main()
    missed = [r.get("benchmark", r.get("figure", "?")) for r in _results if not r["pass"]]
    if not _results:
        log("benchmark reported no figure")
        sys.exit(1)
    if missed:
        log(f"missed target: {', '.join(map(str, missed))}")
        sys.exit(1)
    sys.exit(0)
