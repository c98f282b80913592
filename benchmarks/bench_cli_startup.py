"""Command-line start-up: ``--help`` of several commands and usage errors each within 0.3 s,
``surfhap materials`` within 0.5 s (issue 21 item 2).

Median wall time of N fresh processes per command (after one untimed run that warms the
byte-code and file caches), beside the median of ``python -c pass`` as the floor no
command can beat: the ``x_python`` figures are the ratios to it. One JSON line; passes when
every median is within its target (ratio = the smallest target / median >= 1).

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

TARGET_S = 0.5  # surfhap materials (lists every built-in material)
HELP_TARGET_S = 0.3  # --help and usage errors
# what a user types first: help of the root and of commands in several modules, and usage errors
QUICK = {"help": ["--help"], "render_help": ["render", "--help"], "shape_help": ["shape", "-h"],
         "fit_friction_help": ["fit", "friction", "--help"], "study_run_help": ["study", "run", "-h"],
         "ff_simulate_help": ["ff", "simulate", "-h"], "usage_missing_argument": ["render"],
         "usage_unknown_option": ["play", "cork", "--no-such-option"], "usage_unknown_command": ["rendr"]}
SRC = Path(__file__).resolve().parents[1] / "src"


def surfhap_command() -> list[str]:
    """The installed ``surfhap`` script beside this interpreter, else ``python -m surfhap``."""
    script = Path(sys.executable).with_name("surfhap")
    return [str(script)] if script.exists() else [sys.executable, "-m", "surfhap"]


def median_wall(cmd: list[str], runs: int, env: dict) -> float:
    def once() -> None:  # exit 2 is the usage errors' code
        code = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=300).returncode
        if code not in (0, 2):
            raise RuntimeError(f"{' '.join(cmd)} exited {code}")

    once()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        once()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 15
    # the children run this tree's code, as this script does; the untimed first run writes the
    # byte-code an installed copy has (pip compiles it), also when the caller's environment says not to
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")])))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    cli = surfhap_command()
    log(f"cli start-up: {' '.join(cli)}, {runs} runs each")
    python = median_wall([sys.executable, "-c", "pass"], runs, env)
    quick = {name: median_wall([*cli, *args], runs, env) for name, args in QUICK.items()}
    listed = median_wall([*cli, "materials"], runs, env)
    ratio = min(HELP_TARGET_S / max(quick.values()), TARGET_S / listed)
    report("cli_startup", {"runs": runs, "python_pass_s": round(python, 4),
                           **{f"{k}_s": round(v, 4) for k, v in quick.items()}, "materials_s": round(listed, 4),
                           "slowest_quick_x_python": round(max(quick.values()) / python, 1),
                           "help_target_s": HELP_TARGET_S, "target_s": TARGET_S},
           ratio, f"median of every --help and usage error <= {HELP_TARGET_S} s, of 'surfhap materials' <= "
           f"{TARGET_S} s (ratio = target / median, the smallest; >= 1)", ratio >= 1)


if __name__ == "__main__":
    run(main)
