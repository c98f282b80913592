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
``input``. CSV files are parsed by :func:`surfhap.exchange.table.read_csv_table`. Every
problem raises :class:`~surfhap.errors.RecordingFormatError` naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import RecordingFormatError, writing
from surfhap.exchange.files import load_npz, npz_number, numeric, write_text
from surfhap.exchange.table import UNITS, read_csv_table, time_step

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
        n = np.asarray(lateral_force).size
        time = np.arange(n) / float(sample_rate)
        return _finish(source, input, time, {"lateral_force": lateral_force, "normal_force": normal_force,
                                             "level": level})


def _err(source: str, field: str, message: str) -> RecordingFormatError:
    return RecordingFormatError(message, source=source, field=field)


def _finish(source: str, kind: str, time, data: dict) -> TribometerRecording:
    kind = str(kind).strip().lower()
    if kind not in INPUT_KINDS:
        raise _err(source, "input", f"must be one of {', '.join(INPUT_KINDS)}, got {kind!r}")
    t = np.asarray(time, dtype=float)
    arrays = {}
    for name in ("lateral_force", "normal_force", "level"):
        x = np.asarray(data[name], dtype=float).ravel()
        if x.shape != t.shape:
            raise _err(source, name, f"has {x.size} samples, time has {t.size}")
        if not np.all(np.isfinite(x)):
            raise _err(source, name, f"not finite at sample {int(np.argmin(np.isfinite(x)))}")
        arrays[name] = x
    if t.size < MIN_SAMPLES:
        raise _err(source, "time", f"need at least {MIN_SAMPLES} samples, got {t.size}")
    if not np.all(np.isfinite(t)):
        raise _err(source, "time", f"not finite at sample {int(np.argmin(np.isfinite(t)))}")
    step = time_step(t, source, RecordingFormatError, tolerance=0.01)
    lev = arrays["level"]
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
    if np.any(arrays["normal_force"] < 0):
        raise _err(source, "normal_force", "must be >= 0 N")
    return TribometerRecording(source, kind, 1.0 / step, t, arrays["lateral_force"], arrays["normal_force"], lev)


def _read_csv(path: Path) -> TribometerRecording:
    src = str(path)
    table = read_csv_table(path, _UNITS, required=TRIBOMETER_CHANNELS, error=RecordingFormatError)
    if "input" not in table.meta:
        raise _err(src, "input", "missing metadata line '# input: intensity' or '# input: voltage'")
    cols = dict(table.columns)
    return _finish(src, table.meta["input"], cols.pop("time"), cols)


def _read_npz(path: Path) -> TribometerRecording:
    src = str(path)
    z = load_npz(path, RecordingFormatError)
    if "input" not in z:
        raise _err(src, "input", "missing string array 'input' (intensity or voltage)")
    for name in ("lateral_force", "normal_force", "level"):
        if name not in z:
            raise _err(src, name, "missing array")
    data = {name: numeric(z[name], src, name, RecordingFormatError) for name in ("lateral_force", "normal_force", "level")}
    if "time" in z:
        t = numeric(z["time"], src, "time", RecordingFormatError)
    elif "sample_rate" in z:
        fs = npz_number(z["sample_rate"], src, "sample_rate", RecordingFormatError)
        if not (np.isfinite(fs) and fs > 0):
            raise _err(src, "sample_rate", "must be > 0 Hz")
        t = np.arange(np.asarray(data["level"]).size) / fs
    else:
        raise _err(src, "time", "missing array 'time' (or scalar 'sample_rate')")
    return _finish(src, str(z["input"]), t, data)


def read_tribometer(path: str | Path) -> TribometerRecording:
    """Read one tribometer recording (``.csv`` or ``.npz``)."""
    p = Path(path)
    if not p.is_file():
        raise _err(str(p), "file", "not found")
    if p.suffix.lower() == ".npz":
        return _read_npz(p)
    if p.suffix.lower() in (".csv", ".txt"):
        return _read_csv(p)
    raise _err(str(p), "file", "unknown extension (use .csv or .npz)")


def write_tribometer_csv(rec: TribometerRecording, path: str | Path) -> Path:
    """Write ``rec`` as CSV in the schema above."""
    p = Path(path)
    unit = "1" if rec.input == "intensity" else "V"
    lines = [f"# input: {rec.input}", f"time[s],lateral_force[N],normal_force[N],level[{unit}]"]
    lines += [f"{t:.9g},{f:.9g},{n:.9g},{v:.9g}" for t, f, n, v in
              zip(rec.time, rec.lateral_force, rec.normal_force, rec.level)]
    return write_text(p, "\n".join(lines) + "\n")


def write_tribometer_npz(rec: TribometerRecording, path: str | Path) -> Path:
    """Write ``rec`` as NPZ in the schema above."""
    p = Path(path)
    with writing(p), open(p, "wb") as fh:
        np.savez(fh, time=rec.time, lateral_force=rec.lateral_force, normal_force=rec.normal_force,
                 level=rec.level, input=np.array(rec.input))
    return p
