"""IMU recordings of a tool stroked over a surface (the HapMat CSV layout).

Columns: ``time`` (s) and ``accel_x``, ``accel_y``, ``accel_z``; other columns (gyro,
rotation) are ignored; a header may give a unit (``accel_x[g]``). The HapMat files (MIT,
shared/data/hapmat-imu) do not state the acceleration unit; ``unit_scale`` converts file
units to m/s^2 (1.0 takes them as m/s^2). Parsed by :func:`surfhap.exchange.table.read_csv_table`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import RecordingFormatError
from surfhap.exchange.table import UNITS, read_csv_table, time_step

__all__ = ["ImuRecording", "read_imu_csv", "IMU_COLUMNS"]

IMU_COLUMNS = ("time", "accel_x", "accel_y", "accel_z")
_CHANNELS = {"time": UNITS["s"], **{c: UNITS["m/s^2"] for c in IMU_COLUMNS[1:]}}


@dataclass(frozen=True)
class ImuRecording:
    """t (n,) s, accel (n, 3) m/s^2, sample_rate Hz, name (file name), sha256 of the file bytes."""

    t: np.ndarray
    accel: np.ndarray
    sample_rate: float
    name: str
    sha256: str


def read_imu_csv(path: str | Path, unit_scale: float = 1.0) -> ImuRecording:
    """Read an IMU CSV; raises RecordingFormatError naming the file and column on bad input."""
    path = Path(path)
    src = str(path)
    table = read_csv_table(path, _CHANNELS, required=IMU_COLUMNS, min_rows=2, error=RecordingFormatError)
    t = table.columns["time"]
    rate = 1.0 / time_step(t, src, RecordingFormatError)
    accel = np.column_stack([table.columns[c] for c in IMU_COLUMNS[1:]]) * float(unit_scale)
    return ImuRecording(t, accel, round(rate, 6), path.name, table.sha256)
