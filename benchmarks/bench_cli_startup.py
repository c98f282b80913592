"""Command-line start-up: ``surfhap --help`` and ``surfhap materials`` each within 0.5 s.

Median wall time of N fresh processes per command (after one untimed run that warms the
byte-code and file caches), beside the median of ``python -c pass`` as the floor no
command can beat: the ``x_python`` figures are the ratios to it. One JSON line; passes when
both medians are <= 0.5 s (ratio = 0.5 / slower median >= 1).

Run: ``.venv/bin/python benchmarks/bench_cli_startup.py [--runs N]`` (default 15).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from _common import log, report, run

TARGET_S = 0.5
SRC = Path(__file__).resolve().parents[1] / "src"


def surfhap_command() -> list[str]:
    """The installed ``surfhap`` script beside this interpreter, else ``python -m surfhap``."""
    script = Path(sys.executable).with_name("surfhap")
    return [str(script)] if script.exists() else [sys.executable, "-m", "surfhap"]


def median_wall(cmd: list[str], runs: int, env: dict) -> float:
    subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True, timeout=300)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True, timeout=300)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 15
    # the children run this tree's code, as this script does
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")])))
    cli = surfhap_command()
    log(f"cli start-up: {' '.join(cli)}, {runs} runs each")
    python = median_wall([sys.executable, "-c", "pass"], runs, env)
    helped = median_wall([*cli, "--help"], runs, env)
    listed = median_wall([*cli, "materials"], runs, env)
    slowest = max(helped, listed)
    report("cli_startup", {"runs": runs, "python_pass_s": round(python, 4), "help_s": round(helped, 4),
                           "materials_s": round(listed, 4), "help_x_python": round(helped / python, 1),
                           "materials_x_python": round(listed / python, 1), "target_s": TARGET_S},
           TARGET_S / slowest, f"median of 'surfhap --help' and 'surfhap materials' <= {TARGET_S} s each "
           f"(ratio = {TARGET_S} / slower median >= 1)", slowest <= TARGET_S)


if __name__ == "__main__":
    run(main)
