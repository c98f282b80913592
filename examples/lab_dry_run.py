"""A lab dry run without hardware: calibrate a (synthetic) display from tribometer recordings,
generate the identification study of Otake et al. 2022, let simulated participants answer, and
write the paper-style report.

Run: .venv/bin/python examples/lab_dry_run.py     (from any folder; writes lab-dry-run/ there)
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from surfhap.exchange.tribometer import write_tribometer_csv
from surfhap.lab.tribometer_synth import synthetic_tribometer

out = Path("lab-dry-run")
rec_dir = out / "tribometer"
rec_dir.mkdir(parents=True, exist_ok=True)

# 1. tribometer recordings of a display with k = 4e-6 N/V^2 and mu_panel = 0.5 (synthetic)
paths = []
for i, volts in enumerate(np.arange(50.0, 251.0, 50.0)):
    rec = synthetic_tribometer(volts, "voltage", k=4e-6, mu_panel=0.5, duration=5.0, seed=i)
    paths.append(str(write_tribometer_csv(rec, rec_dir / f"v{int(volts):03d}.csv")))


def surfhap(*args):
    subprocess.run([sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())", *args],
                   check=True)


surfhap("calibrate", "tribometer", *paths, "--out", str(out / "cal.json"), "--plot", str(out / "cal.png"), "--overwrite")
cal = json.loads((out / "cal.json").read_text())
print(f"fitted k = {cal['k']:.3g} N/V^2 (true 4e-06), mu_panel = {cal['mu_panel']:.3f} (true 0.5)")

# 2. the study, three simulated participants, the analysis
study = out / "study"
if not (study / "study.json").exists():
    surfhap("study", "new", "otake2022-identification", "--out", str(study), "--participants", "3", "--seed", "1")
for p in ("P01", "P02", "P03"):
    surfhap("study", "run", str(study), "-p", p, "--simulate", p[-1], "--p-correct", "0.7")
surfhap("study", "analyze", str(study), "--report", str(out / "report"))
print(f"open {out / 'report' / 'index.html'}")
