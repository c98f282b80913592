"""Options that several commands share, as ``Annotated`` aliases: one definition, one help text.

Use them as a parameter's type with its default, e.g. ``display: DisplayOption = None``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

__all__ = ["DisplayOption", "LoadRangeOption", "SpeedRangeOption", "ConfigOption", "SeedOption",
           "TrajectoryOption", "FigureOption", "LiveAmpGainOption", "JobsOption", "SchedulerOption", "JsonOption",
           "OverwriteOption"]

# what a command reports, and whether it may replace files (cli/_common.py report, check_out)
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result as one JSON object on one line (for scripts) instead of the summary lines.")]
OverwriteOption = Annotated[bool, typer.Option("--overwrite", help="Replace an existing, non-empty --out (refused by default).")]

# the simulated / user's display (see cli/_display_options.py)
DisplayOption = Annotated[Optional[str], typer.Option("--display", help=(
    "Your display: 'k=N/V^2,mu_panel=..,area=m^2[,leakage=s]' or a surfhap-display JSON file; a measured device "
    "curve in the file maps forces to voltages (default: the documented assumptions, docs/texture.md)."))]
LoadRangeOption = Annotated[Optional[str], typer.Option(
    "--load-range", help="Loads the gain plan must serve, 'LOW,HIGH' in N (default 0.1,1.0).")]
SpeedRangeOption = Annotated[Optional[str], typer.Option(
    "--speed-range", help="Speeds the gain plan must serve, 'LOW,HIGH' in m/s (default 0.02,0.3).")]
ConfigOption = Annotated[Optional[Path], typer.Option("--config", help=(
    "TOML file with a \\[display] section (file, k, mu_panel, area, leakage_time_constant, load_range, speed_range)."))]

# rendering
SeedOption = Annotated[int, typer.Option("--seed", help="Seed of the texture noise (same seed, same output).")]
TrajectoryOption = Annotated[Optional[Path], typer.Option(
    "--trajectory", help="Recorded trajectory CSV: time (s), x, y (m), load (N); units may be given as x\\[mm].")]
FigureOption = Annotated[bool, typer.Option("--figure/--no-figure", help="Write figure.png.")]
LiveAmpGainOption = Annotated[float, typer.Option(
    "--amp-gain", help="Amplifier gain, V per DAC full scale (sound/file outputs); V per V of its input (daq).")]

# fitting many recordings
JobsOption = Annotated[int, typer.Option("--jobs", help="Parallel workers, local processes (-1 = all cores): the jobs of a batch (one folder each under --out), or the fits of one fit.")]
SchedulerOption = Annotated[Optional[str], typer.Option(
    "--scheduler", help="Run on Dask instead of local processes: tcp://HOST:PORT (a running scheduler; output folders must be on storage the workers share) or local:N (a LocalCluster of N workers); needs the 'dask' extra.")]
