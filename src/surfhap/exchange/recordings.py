"""Recordings for fitting: CSV and NPZ readers (and writers) with named, unit-checked channels.

Channels (SI inside)::

    time          s       required, strictly increasing, uniformly sampled (or NPZ sample_rate)
    normal_force  N
    shear_force   N
    cof           1       (instead of shear_force: shear = cof * normal)
    speed         m/s
    position      m       (instead of speed: speed = d position / dt)
    acceleration  m/s^2

A CSV header names each column ``name`` (SI), ``name[unit]`` or ``name (unit)``
(parsed by :func:`surfhap.exchange.table.read_csv_table`); units are converted at this edge (e.g. ``speed[mm/s]``, ``normal_force[mN]``, ``acceleration[g]``).
Other column names are mapped with ``columns={"speed": "v_x[mm/s]", ...}`` (CLI
``--columns speed=v_x[mm/s],normal_force=Fz``). Lines starting with ``#`` may carry
metadata ``# participant: P3``, ``# trial: 2``. An NPZ file holds one 1-D array per channel
(keys named like CSV columns) and optional ``participant`` / ``trial`` strings; ``time`` may
be replaced by a scalar ``sample_rate`` (Hz).

Every problem raises :class:`surfhap.errors.RecordingFormatError` with the file and the
column: missing columns, unknown units, non-monotonic time, NaN runs, too few samples.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from surfhap.errors import RecordingFormatError, writing
from surfhap.exchange.files import file_sha256, load_npz, npz_number, numeric, parse_pairs
from surfhap.exchange.table import UNITS, read_csv_table, resolve_columns, time_step, write_csv_table

__all__ = [
    "CHANNELS",
    "Recording",
    "read_recording",
    "read_recordings",
    "parse_column_map",
    "write_recording_csv",
    "write_recording_npz",
]

#: canonical channel -> SI unit
CHANNELS: dict[str, str] = {
    "time": "s",
    "normal_force": "N",
    "shear_force": "N",
    "cof": "1",
    "speed": "m/s",
    "position": "m",
    "acceleration": "m/s^2",
}

_CHANNEL_UNITS = {channel: UNITS[si] for channel, si in CHANNELS.items()}


def parse_column_map(text: str | None, option: str = "--columns") -> dict[str, str]:
    """``"speed=v_x[mm/s],normal_force=Fz"`` -> {"speed": "v_x[mm/s]", "normal_force": "Fz"}."""
    return parse_pairs(text or "", option, CHANNELS, RecordingFormatError, what="channel=column")


@dataclass(frozen=True)
class Recording:
    """One recording (one trial of one participant), SI channels on a uniform time base.

    source      : file name (or a label for in-memory recordings).
    time        : (n,) s, strictly increasing.
    channels    : canonical name -> (n,) float array (SI); ``speed`` is filled from
                  ``position`` and ``shear_force`` from ``cof`` when only those are present.
    participant : label (file metadata, else the file stem).
    trial       : label.
    sha256      : hex digest of the file bytes ("" for in-memory recordings).
    """

    source: str
    time: np.ndarray
    channels: dict[str, np.ndarray]
    participant: str = ""
    trial: str = ""
    sha256: str = ""
    meta: dict[str, str] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.time.size)

    @cached_property
    def sample_rate(self) -> float:
        """Hz, from the median sampling interval (snapped to a whole number of Hz when within
        1 ppm of one, so that 2 kHz written as time stamps stays 2000 Hz); computed once."""
        return _rate(float(np.median(np.diff(self.time))))

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0] + 1.0 / self.sample_rate)

    def has(self, name: str) -> bool:
        return name in self.channels

    def get(self, name: str) -> np.ndarray:
        """Channel (n,) in SI; RecordingFormatError when absent."""
        self.require(name)
        return self.channels[name]

    def require(self, *names: str) -> None:
        """Raise RecordingFormatError naming the first missing channel."""
        for name in names:
            if name not in self.channels:
                have = ", ".join(["time", *self.channels]) or "none"
                raise RecordingFormatError(f"missing column (have: {have}; map others with --columns {name}=COLUMN)", source=self.source, field=name)

    @classmethod
    def from_arrays(cls, time=None, *, sample_rate: float | None = None, source: str = "<memory>", participant: str = "",
                    trial: str = "", **channels) -> "Recording":
        """Build and check a recording from SI arrays (time, or sample_rate)."""
        data = {k: np.asarray(v, dtype=float) for k, v in channels.items() if v is not None}
        return _finish(source, time, sample_rate, data, participant or Path(source).stem, trial, "", {})


def _rate(step: float) -> float:
    """Hz of a median sampling interval ``step`` s (see :attr:`Recording.sample_rate`)."""
    r = float(1.0 / step)
    whole = round(r)
    return float(whole) if whole > 0 and abs(r - whole) <= 1e-6 * r else r


def _check_finite(source: str, name: str, x: np.ndarray, t: np.ndarray | None) -> None:
    bad = ~np.isfinite(x)
    if np.any(bad):
        i = int(np.argmax(bad))
        run = int(np.argmin(bad[i:])) or bad.size - i  # up to the next finite sample, or to the end
        where = f"t = {t[i]:.6g} s" if t is not None and np.isfinite(t[i]) else f"sample {i}"
        raise RecordingFormatError(f"NaN or missing values: a run of {run} sample(s) from row {i + 1} ({where}); "
                                   "cut the recording or fill the gap before fitting", source=source, field=name)


def checked_time(source: str, time, sample_rate: float | None, data: dict[str, np.ndarray], *, min_samples: int = 16,
                 tolerance: float = 0.05) -> tuple[np.ndarray, float]:
    """(time (n,) s, step s) of a recording's channels (``data``, one-dimensional, of one
    length, finite): ``time`` itself or, when None, n samples at ``sample_rate`` Hz; strictly
    increasing and uniformly sampled within ``tolerance``. RecordingFormatError otherwise."""
    n = None
    for name, x in data.items():
        if x.ndim != 1:
            raise RecordingFormatError("must be one-dimensional", source=source, field=name)
        if n is None:
            n = x.size
        elif x.size != n:
            raise RecordingFormatError(f"has {x.size} samples, other channels have {n}", source=source, field=name)
    if time is None:
        if sample_rate is None:
            raise RecordingFormatError("missing column (or an NPZ 'sample_rate')", source=source, field="time")
        if not (np.isfinite(sample_rate) and sample_rate > 0):
            raise RecordingFormatError("must be a positive number of Hz", source=source, field="sample_rate")
        if n is None:
            raise RecordingFormatError("no data channels", source=source)
        time = np.arange(n) / float(sample_rate)
    time = np.asarray(time, dtype=float)
    if n is not None and time.size != n:
        raise RecordingFormatError(f"has {time.size} samples, other channels have {n}", source=source, field="time")
    if time.size < min_samples:
        raise RecordingFormatError(f"only {time.size} samples; a recording needs at least {min_samples}", source=source,
                                   field="time")
    _check_finite(source, "time", time, None)
    step = time_step(time, source, RecordingFormatError, tolerance)
    for name, x in data.items():
        _check_finite(source, name, x, time)
    return time, step


def _finish(source, time, sample_rate, data, participant, trial, digest, meta) -> Recording:
    time, step = checked_time(source, time, sample_rate, data)
    if "speed" not in data and "position" in data:
        data["speed"] = np.gradient(data["position"], time)
    if "shear_force" not in data and "cof" in data and "normal_force" in data:
        data["shear_force"] = data["cof"] * data["normal_force"]
    rec = Recording(source, time, data, str(participant), str(trial), digest, dict(meta))
    rec.__dict__["sample_rate"] = _rate(step)  # the cached_property's value: checked_time took the same median
    return rec


def read_channels(path: str | Path, units: Mapping[str, Mapping[str, float]], columns: Mapping[str, str] | None = None,
                  *, required: Sequence[str] = (), meta_keys: Sequence[str] = ("participant", "trial")):
    """(time or None, sample_rate or None, the other channels in SI, metadata, sha256) of a
    ``.csv`` (:func:`~surfhap.exchange.table.read_csv_table`, NaN kept for :func:`checked_time`
    to locate; a ``# sample_rate:`` line) or ``.npz`` file (1-D arrays named like CSV columns, a
    scalar ``sample_rate``, strings ``meta_keys``). ``units``: channel -> {unit: factor to SI};
    ``columns``: channel -> column spec (``--columns``); ``required``: channels that must be there."""
    path, columns = Path(path), dict(columns or {})
    source, suffix = str(path), path.suffix.lower()
    if suffix == ".npz":
        arrays = load_npz(path, RecordingFormatError)
        meta = {key: str(arrays.pop(key)) for key in meta_keys if key in arrays}
        rate = npz_number(arrays.pop("sample_rate"), source, "sample_rate", RecordingFormatError) \
            if "sample_rate" in arrays else None
        headers = list(arrays)
        mapping = resolve_columns(headers, units, columns, source, RecordingFormatError, required)
        data = {ch: _scaled(numeric(arrays[headers[i]], source, headers[i], RecordingFormatError), f)
                for ch, (i, f) in mapping.items()}
        digest = file_sha256(path, RecordingFormatError)
    elif suffix in (".csv", ".txt", ".tsv"):
        table = read_csv_table(path, units, required=required, rename=columns, allow_nan=True,
                               error=RecordingFormatError)
        if table.n == 0:
            raise RecordingFormatError("no data rows", source=source)
        data, meta, digest, rate = dict(table.columns), table.meta, table.sha256, None
        if "sample_rate" in meta:
            try:
                rate = float(meta["sample_rate"])
            except ValueError:
                raise RecordingFormatError(f"{meta['sample_rate']!r} is not a number of Hz", source=source,
                                           field="sample_rate") from None
    else:
        raise RecordingFormatError(f"unknown recording type {path.suffix!r} (use .csv or .npz)", source=source)
    return data.pop("time", None), rate, data, meta, digest


def _scaled(x: np.ndarray, factor: float) -> np.ndarray:
    """(n,) float of x in SI: times the unit's factor, without a copy when it is 1 (an NPZ
    array is freshly read, so it is not shared)."""
    x = np.asarray(x, dtype=float).reshape(-1)
    return x if factor == 1 else x * factor


def read_recording(path: str | Path, columns: Mapping[str, str] | None = None, participant: str | None = None) -> Recording:
    """Read one CSV or NPZ recording into SI channels (see the module docstring)."""
    time, rate, data, meta, digest = read_channels(path, _CHANNEL_UNITS, columns)
    label = participant or meta.get("participant") or Path(path).stem
    return _finish(str(path), time, rate, data, label, meta.get("trial", ""), digest, meta)


def read_recordings(paths: Sequence[str | Path], columns: Mapping[str, str] | None = None) -> list[Recording]:
    """Read several recordings (participants and trials); participants come from each file's
    metadata, else its stem."""
    if not paths:
        raise RecordingFormatError("no recordings given")
    return [read_recording(p, columns) for p in paths]


def write_recording_csv(rec: Recording, path: str | Path) -> Path:
    """Write a recording as CSV with SI headers, participant/trial and the other ``meta`` lines."""
    meta = {"participant": rec.participant, **({"trial": rec.trial} if rec.trial else {})}
    meta |= {k: v for k, v in rec.meta.items() if k not in ("participant", "trial")}
    return write_csv_table(path, {"time": rec.time, **rec.channels}, meta)


def write_recording_npz(rec: Recording, path: str | Path) -> Path:
    """Write a recording as NPZ (one array per channel, SI)."""
    path = Path(path)
    with writing(path):
        np.savez(path, time=rec.time, participant=np.array(rec.participant), trial=np.array(rec.trial), **rec.channels)
    return path
