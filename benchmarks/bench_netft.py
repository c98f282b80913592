"""Net F/T RDT stream (issue 19 target): 7 kHz from the loopback box recorded for 60 s on one
core with no lost record. One JSON line: records expected and written, gaps, lost, rate.

The box (``tests/live_support/netft_box.py``, the RDT protocol byte for byte) runs in its own
process; this process, pinned to one core, runs ``surfhap record force`` and the figures come
from the CSV it wrote (its ``# gaps`` / ``# lost_records`` lines and its rows).
``--seconds S`` (default 60) and ``--rate HZ`` (default 7000, the Net F/T's highest RDT rate).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import log, report, run  # noqa: E402  (also puts src/ on sys.path)

BOX = Path(__file__).resolve().parents[1] / "tests" / "live_support" / "netft_box.py"


def main() -> None:
    from surfhap.cli import main as cli

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate", type=float, default=7000.0)
    args = ap.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cores[-1]})  # the recorder on one core; the box may use the others
    box = subprocess.Popen([sys.executable, str(BOX), "--rate", f"{args.rate:g}"], stdin=subprocess.PIPE,
                           stdout=subprocess.PIPE, text=True)
    try:
        udp, http = box.stdout.readline().split()
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "force.csv"
            code = cli(["record", "force", f"netft://127.0.0.1:{udp}?http={http}", "--duration", f"{args.seconds:g}",
                        "--out", str(out)])
            lines = out.read_text().splitlines() if code == 0 else []
    finally:
        box.stdin.close()
        box.wait(10)
    meta = dict(line[2:].split(": ", 1) for line in lines if line.startswith("# "))
    rows = sum(1 for line in lines if line and line[0].isdigit())
    expected = int(round(args.seconds * args.rate))
    lost = int(meta.get("lost_records", -1))
    log(f"exit {code}, {rows} rows, meta {meta}")
    report("netft_rdt", {"rate_hz": args.rate, "seconds": args.seconds, "expected": expected, "written": rows,
                         "gaps": int(meta.get("gaps", -1)), "lost": lost, "cores": 1,
                         "load_avg_1min": round(os.getloadavg()[0], 2)},
           rows / expected, "all records of a 7 kHz, 60 s RDT stream written, none lost (ratio = written / expected)",
           code == 0 and lost == 0 and rows == expected)


if __name__ == "__main__":
    run(main)
