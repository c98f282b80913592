"""Finger trajectories as CSV: columns ``time`` (s), ``x`` (m), ``y`` (m), ``load`` (N).

Read through :func:`surfhap.exchange.table.read_csv_table`: a header may give units
(``time[ms]``, ``x[mm]``, ``load[mN]``); extra columns are ignored. Errors name the file, the
column and the first bad row (1-based data row, header excluded). Values beyond a finger's
plausible speed, acceleration or load (:func:`surfhap.models.trajectory.implausible`, the bounds
``--scan`` has too) are refused with a unit hint: a file in millimetres or grams.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from surfhap.errors import TrajectoryFormatError
from surfhap.exchange.table import UNITS, read_csv_table, time_step, write_csv_table
from surfhap.models.trajectory import Trajectory, implausible

__all__ = ["read_trajectory_csv", "write_trajectory_csv", "TRAJECTORY_COLUMNS"]

TRAJECTORY_COLUMNS = ("time", "x", "y", "load")
_CHANNELS = {"time": UNITS["s"], "x": UNITS["m"], "y": UNITS["m"], "load": UNITS["N"]}


def read_trajectory_csv(path: str | Path) -> Trajectory:
    """Read and validate a trajectory CSV; raises TrajectoryFormatError on any problem."""
    path = Path(path)
    src = str(path)
    table = read_csv_table(path, _CHANNELS, required=TRAJECTORY_COLUMNS, min_rows=2, error=TrajectoryFormatError)
    cols = table.columns
    time_step(cols["time"], src, TrajectoryFormatError, tolerance=None)
    neg = np.nonzero(cols["load"] < 0)[0]
    if neg.size:
        raise TrajectoryFormatError(f"row {neg[0] + 1}: negative load", source=src, field="load")
    bad = implausible(cols["time"], cols["x"], cols["y"], cols["load"])
    if bad is not None:
        raise TrajectoryFormatError(f"row {bad.index + 1}: {bad.message}", source=src, field=_column(bad, cols))
    return Trajectory(cols["time"], cols["x"], cols["y"], cols["load"], name=path.name)


def _column(bad, cols: dict[str, np.ndarray]) -> str:
    """The column an implausible value comes from: load, or the position column (x or y) that
    moved most at that row."""
    if bad.quantity == "load":
        return "load"
    i = bad.index
    lo = max(0, i - 2)
    dx, dy = (float(np.ptp(cols[c][lo:i + 1])) for c in ("x", "y"))
    return "x" if dx >= dy else "y"


def write_trajectory_csv(trajectory: Trajectory, path: str | Path) -> Path:
    """Write a trajectory as CSV (SI columns time, x, y, load)."""
    arrays = (trajectory.t, trajectory.x, trajectory.y, trajectory.load)
    return write_csv_table(path, dict(zip(TRAJECTORY_COLUMNS, arrays)))
