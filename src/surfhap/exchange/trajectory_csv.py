"""Finger trajectories as CSV: columns ``time`` (s), ``x`` (m), ``y`` (m), ``load`` (N).

Extra columns are ignored. Errors name the file, the column and the first bad row
(1-based data row, header excluded).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from surfhap.errors import TrajectoryFormatError
from surfhap.models.trajectory import Trajectory

__all__ = ["read_trajectory_csv", "write_trajectory_csv", "TRAJECTORY_COLUMNS"]

TRAJECTORY_COLUMNS = ("time", "x", "y", "load")


def read_trajectory_csv(path: str | Path) -> Trajectory:
    """Read and validate a trajectory CSV; raises TrajectoryFormatError on any problem."""
    path = Path(path)
    src = str(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise TrajectoryFormatError(f"cannot read file ({exc.strerror})", source=src) from None
    except UnicodeDecodeError:
        raise TrajectoryFormatError("not a UTF-8 text file", source=src) from None
    rows = [r for r in rows if any(c.strip() for c in r)]
    if not rows:
        raise TrajectoryFormatError("empty file", source=src)
    header = [h.strip() for h in rows[0]]
    missing = [c for c in TRAJECTORY_COLUMNS if c not in header]
    if missing:
        raise TrajectoryFormatError(f"missing column (need {', '.join(TRAJECTORY_COLUMNS)})", source=src, field=missing[0])
    body = rows[1:]
    if len(body) < 2:
        raise TrajectoryFormatError("needs at least two data rows", source=src)
    cols = {}
    for name in TRAJECTORY_COLUMNS:
        j = header.index(name)
        vals = np.empty(len(body))
        for i, row in enumerate(body):
            try:
                vals[i] = float(row[j])
            except (ValueError, IndexError):
                raise TrajectoryFormatError(f"row {i + 1}: not a number ({row[j] if j < len(row) else 'missing'!r})", source=src, field=name) from None
        bad = np.nonzero(~np.isfinite(vals))[0]
        if bad.size:
            raise TrajectoryFormatError(f"row {bad[0] + 1}: NaN or infinite value", source=src, field=name)
        cols[name] = vals
    dt = np.diff(cols["time"])
    if np.any(dt <= 0):
        i = int(np.nonzero(dt <= 0)[0][0]) + 2
        raise TrajectoryFormatError(f"row {i}: time does not increase", source=src, field="time")
    neg = np.nonzero(cols["load"] < 0)[0]
    if neg.size:
        raise TrajectoryFormatError(f"row {neg[0] + 1}: negative load", source=src, field="load")
    return Trajectory(cols["time"], cols["x"], cols["y"], cols["load"], name=path.name)


def write_trajectory_csv(trajectory: Trajectory, path: str | Path) -> Path:
    """Write a trajectory as CSV (SI columns time, x, y, load)."""
    path = Path(path)
    data = np.column_stack([trajectory.t, trajectory.x, trajectory.y, trajectory.load])
    np.savetxt(path, data, delimiter=",", header=",".join(TRAJECTORY_COLUMNS), comments="", fmt="%.9g")
    return path
