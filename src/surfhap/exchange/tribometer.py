"""Tribometer recordings for display calibration: CSV / NPZ reader and writer.

One recording is one drive level, measured with a pen or finger rig moving over the panel at a
steady speed (Kim et al. 2017 Sec. 2.1-2.2: 20 s per intensity, 10 kHz), with the drive
switched on and off along the path (their sector experiment, Fig. 3) so that the same file
gives the friction with and without electrovibration.

Channels (SI; a CSV header may name units as ``name[unit]``, converted here)::

    time            s     strictly increasing, uniformly sampled (NPZ: or a scalar sample_rate)
    lateral_force   N     tangential (friction) force; mN accepted
    normal_force    N     load on the panel; mN accepted
    level           -/V   the commanded drive at each sample: 0 where the drive is off, the
                          recording's level where it is on (one level per file)

The kind of level is given once per file: a CSV metadata line ``# input: intensity`` (device
intensity in (0, 1], e.g. a Senseg Feelscreen grain) or ``# input: voltage`` (the drive
envelope in volts with a polarity carrier, so that V^2 is constant while on; the level may be
written ``level[kV]``). An NPZ file holds the arrays under the same keys and a string
``input``. Both are read by :func:`surfhap.exchange.recordings.read_channels`. Every
problem raises :class:`~surfhap.errors.RecordingFormatError` naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import RecordingFormatError, writing
from surfhap.exchange.recordings import checked_time, read_channels
from surfhap.exchange.table import UNITS, write_csv_table

__all__ = ["TRIBOMETER_CHANNELS", "INPUT_KINDS", "TribometerRecording", "read_tribometer", "write_tribometer_csv",
           "write_tribometer_npz"]

TRIBOMETER_CHANNELS = ("time", "lateral_force", "normal_force", "level")
INPUT_KINDS = ("intensity", "voltage")
_UNITS = {"time": UNITS["s"], "lateral_force": UNITS["N"], "normal_force": UNITS["N"],
          "level": {"1": 1.0, **UNITS["V"]}}
MIN_SAMPLES = 256


@dataclass(frozen=True)
class TribometerRecording:
    """One tribometer recording at one drive level.

    time, lateral_force, normal_force, level : (n,) float arrays (s, N, N, intensity or V).
    sample_rate : Hz.  input : "intensity" or "voltage".  source : file name.
    """

    source: str
    input: str
    sample_rate: float
    time: np.ndarray
    lateral_force: np.ndarray
    normal_force: np.ndarray
    level: np.ndarray

    @property
    def drive_level(self) -> float:
        """The recording's level: the value of ``level`` where the drive is on."""
        on = self.level[self.level > 0]
        return float(np.median(on))

    @property
    def on(self) -> np.ndarray:
        """(n,) bool, drive on."""
        return self.level > 0

    @classmethod
    def from_arrays(cls, *, input: str, lateral_force, normal_force, level, sample_rate: float,
                    source: str = "<memory>") -> "TribometerRecording":
        data = {"lateral_force": lateral_force, "normal_force": normal_force, "level": level}
        return _finish(source, input, None, sample_rate, {k: np.asarray(v, dtype=float) for k, v in data.items()})


def _err(source: str, field: str, message: str) -> RecordingFormatError:
    return RecordingFormatError(message, source=source, field=field)


def _finish(source: str, kind: str, time, sample_rate: float | None, data: dict) -> TribometerRecording:
    kind = str(kind).strip().lower()
    if kind not in INPUT_KINDS:
        raise _err(source, "input", f"must be one of {', '.join(INPUT_KINDS)}, got {kind!r}")
    t, step = checked_time(source, time, sample_rate, data, min_samples=MIN_SAMPLES, tolerance=0.01)
    lev = data["level"]
    if np.any(lev < 0):
        raise _err(source, "level", "must be >= 0 (0 = drive off)")
    on = lev > 0
    if on.sum() < 16 or (~on).sum() < 16:
        raise _err(source, "level", "needs samples with the drive on (> 0) and off (0)")
    vals = lev[on]
    if np.ptp(vals) > 1e-6 * max(1.0, float(np.max(vals))):
        raise _err(source, "level", "one drive level per recording: the non-zero values differ")
    if kind == "intensity" and vals[0] > 1.0:
        raise _err(source, "level", f"an intensity must be in (0, 1], got {vals[0]:g}")
    if np.any(data["normal_force"] < 0):
        raise _err(source, "normal_force", "must be >= 0 N")
    return TribometerRecording(source, kind, 1.0 / step, t, data["lateral_force"], data["normal_force"], lev)


def read_tribometer(path: str | Path) -> TribometerRecording:
    """Read one tribometer recording (``.csv`` or ``.npz``)."""
    time, rate, data, meta, _ = read_channels(path, _UNITS, required=TRIBOMETER_CHANNELS[1:], meta_keys=("input",))
    if "input" not in meta:
        raise _err(str(path), "input", "missing: a line '# input: intensity' or '# input: voltage' (CSV), "
                                       "a string array 'input' (NPZ)")
    return _finish(str(path), meta["input"], time, rate, data)


def write_tribometer_csv(rec: TribometerRecording, path: str | Path) -> Path:
    """Write ``rec`` as CSV in the schema above."""
    level = f"level[{'1' if rec.input == 'intensity' else 'V'}]"
    columns = {"time[s]": rec.time, "lateral_force[N]": rec.lateral_force, "normal_force[N]": rec.normal_force,
               level: rec.level}
    return write_csv_table(path, columns, {"input": rec.input})


def write_tribometer_npz(rec: TribometerRecording, path: str | Path) -> Path:
    """Write ``rec`` as NPZ in the schema above."""
    p = Path(path)
    with writing(p), open(p, "wb") as fh:
        np.savez(fh, time=rec.time, lateral_force=rec.lateral_force, normal_force=rec.normal_force,
                 level=rec.level, input=np.array(rec.input))
    return p
