"""IMU recordings of a tool stroked over a surface (the HapMat CSV layout).

Columns: ``time`` (s) and ``accel_x``, ``accel_y``, ``accel_z``; other columns (gyro,
rotation) are ignored. The HapMat files (MIT, shared/data/hapmat-imu) do not state the
acceleration unit; ``unit_scale`` converts file units to m/s^2 (1.0 takes them as m/s^2).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import RecordingFormatError

__all__ = ["ImuRecording", "read_imu_csv", "IMU_COLUMNS"]

IMU_COLUMNS = ("time", "accel_x", "accel_y", "accel_z")


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
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise RecordingFormatError(f"cannot read file ({exc.strerror})", source=src) from None
    try:
        lines = raw.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        raise RecordingFormatError("not a UTF-8 text file", source=src) from None
    lines = [ln for ln in lines if ln.strip()]
    if len(lines) < 3:
        raise RecordingFormatError("needs a header and at least two data rows", source=src)
    header = [h.strip() for h in lines[0].split(",")]
    for col in IMU_COLUMNS:
        if col not in header:
            raise RecordingFormatError(f"missing column (need {', '.join(IMU_COLUMNS)})", source=src, field=col)
    idx = [header.index(c) for c in IMU_COLUMNS]
    try:
        data = np.array([[float(row.split(",")[j]) for j in idx] for row in lines[1:]])
    except (ValueError, IndexError):
        for i, row in enumerate(lines[1:]):
            cells = row.split(",")
            for c, j in zip(IMU_COLUMNS, idx):
                try:
                    float(cells[j])
                except (ValueError, IndexError):
                    raise RecordingFormatError(f"row {i + 1}: not a number", source=src, field=c) from None
        raise
    for k, c in enumerate(IMU_COLUMNS):
        bad = np.nonzero(~np.isfinite(data[:, k]))[0]
        if bad.size:
            raise RecordingFormatError(f"row {bad[0] + 1}: NaN or infinite value", source=src, field=c)
    t = data[:, 0]
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise RecordingFormatError(f"row {int(np.nonzero(dt <= 0)[0][0]) + 2}: time does not increase", source=src, field="time")
    rate = 1.0 / float(np.median(dt))
    if np.max(np.abs(dt * rate - 1.0)) > 0.05:
        raise RecordingFormatError("time is not uniformly sampled (within 5 %)", source=src, field="time")
    return ImuRecording(t, data[:, 1:] * float(unit_scale), round(rate, 6), path.name, hashlib.sha256(raw).hexdigest())
