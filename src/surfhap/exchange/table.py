"""One reader for tabular recordings: a CSV with named columns, optional units and metadata.

Every CSV surfhap reads (recordings for fitting, IMU strokes, trajectories, tribometer runs)
goes through :func:`read_csv_table`. The layout::

    # participant: P3          optional metadata lines "# key: value" before the header
    time[ms],speed (mm/s),Fz   header: ``name``, ``name[unit]`` or ``name (unit)``
    0,12.5,0.31                numbers; "" / "nan" / "na" are NaN only where NaN is allowed

The caller names the channels it knows with their units (unit -> factor to SI); values come
back in SI. Every problem raises the caller's error class (a
:class:`surfhap.errors.InputError`) naming the file and the column: unreadable file, not
UTF-8, no header, missing column, unknown unit, a cell that is not a number (with its
1-based data row), NaN where it is not allowed.
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from array import array
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from surfhap.errors import InputError, reading
from surfhap.exchange.files import file_sha256, write_text

__all__ = ["Table", "UNITS", "read_csv_table", "write_csv_table", "split_header", "unit_factor", "resolve_columns", "time_step"]

#: SI unit -> {accepted unit: factor to SI}; matched without spaces and case
UNITS: dict[str, dict[str, float]] = {
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6},
    "N": {"N": 1.0, "mN": 1e-3},
    "1": {"1": 1.0, "": 1.0, "-": 1.0},
    "V": {"V": 1.0, "kV": 1e3},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2},
    "m": {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6},
    "m/s^2": {"m/s^2": 1.0, "m/s2": 1.0, "m/s**2": 1.0, "mm/s^2": 1e-3, "g": 9.80665},
}

_NAME_UNIT = re.compile(r"^\s*([^\[\(]+?)\s*(?:[\[\(]\s*([^\]\)]*)\s*[\]\)])?\s*$")
_NAN_CELLS = ("", "nan", "na")


@dataclass(frozen=True)
class Table:
    """A parsed CSV.

    source  : the file path as given.
    columns : canonical channel -> (n,) float array in SI (only the channels found).
    headers : the header cells as written.
    meta    : metadata lines, lower-case keys.
    sha256  : hex digest of the file bytes.
    """

    source: str
    columns: dict[str, np.ndarray]
    headers: list[str]
    meta: dict[str, str]
    sha256: str

    @property
    def n(self) -> int:
        return next(iter(self.columns.values())).size if self.columns else 0


def split_header(header: str) -> tuple[str, str | None]:
    """``"speed[mm/s]"`` or ``"speed (mm/s)"`` -> ("speed", "mm/s"); ``"speed"`` -> ("speed", None)."""
    m = _NAME_UNIT.match(header)
    if not m:
        return header.strip(), None
    return m.group(1).strip(), (None if m.group(2) is None else m.group(2).strip())


def _unit_key(unit: str) -> str:
    return unit.replace(" ", "").lower()


def unit_factor(channel: str, unit: str | None, units: Mapping[str, float], source: str, column: str,
                error: type[InputError]) -> float:
    """Factor from ``unit`` to SI for ``channel`` (1 without a unit); ``error`` names the column."""
    if unit is None:
        return 1.0
    table = {_unit_key(k): v for k, v in units.items()}
    if _unit_key(unit) not in table:
        known = ", ".join(k for k in units if k) or "1"
        raise error(f"unit {unit!r} is not a unit of {channel} (use one of: {known})", source=source, field=column)
    return table[_unit_key(unit)]


def resolve_columns(headers: list[str], channels: Mapping[str, Mapping[str, float]], rename: Mapping[str, str],
                    source: str, error: type[InputError], required: Sequence[str] = ()) -> dict[str, tuple[int, float]]:
    """canonical channel -> (column index, factor to SI); ``rename`` maps a channel to a column
    spec ``"v_x[mm/s]"`` (name, and optionally the unit when the header has none); a channel of
    ``required`` not found is ``error`` ("missing column (need ...)")."""
    parsed = [split_header(h) for h in headers]
    by_full = {h.strip(): i for i, h in enumerate(headers)}
    by_name: dict[str, int] = {}
    for i, (name, _) in enumerate(parsed):
        by_name.setdefault(name, i)
    out: dict[str, tuple[int, float]] = {}
    for channel, spec in rename.items():
        col_name, unit = split_header(spec)
        i = by_full.get(spec.strip(), by_name.get(col_name))
        if i is None:
            raise error(f"--columns maps it to {spec!r}, which is not a column (have: {', '.join(headers)})",
                        source=source, field=channel)
        unit = unit if unit is not None else parsed[i][1]
        out[channel] = (i, unit_factor(channel, unit, channels[channel], source, headers[i], error))
    taken = {i for i, _ in out.values()}
    for i, (name, unit) in enumerate(parsed):
        if name in channels and name not in out and i not in taken:
            out[name] = (i, unit_factor(name, unit, channels[name], source, headers[i], error))
    missing = [c for c in required if c not in out]
    if missing:
        raise error(f"missing column (need {', '.join(required)})", source=source, field=missing[0])
    return out


def time_step(t: np.ndarray, source: str, error: type[InputError], tolerance: float | None = 0.05) -> float:
    """The median step (s) of a time column that increases strictly and (unless ``tolerance``
    is None) is uniformly sampled within ``tolerance``; otherwise ``error`` naming the field
    ``time`` and the 1-based data row (the second sample is row 2)."""
    dt = np.diff(t)
    bad = np.nonzero(~(dt > 0))[0]
    if bad.size:
        i = int(bad[0])
        raise error(f"not strictly increasing at row {i + 2} ({t[i]:.6g} s then {t[i + 1]:.6g} s)", source=source,
                    field="time")
    step = float(np.median(dt)) if dt.size else 0.0
    dev = np.abs(dt - step)
    if tolerance is not None and dt.size and dev.max() > tolerance * step:
        i = int(np.argmax(dev))
        raise error(f"not uniformly sampled within {tolerance:.0%}: step of {dt[i]:.6g} s at row {i + 2}, median step "
                    f"{step:.6g} s; resample first", source=source, field="time")
    return step


def _head(fh) -> tuple[dict[str, str], str | None, int]:
    """Metadata lines and the header line; the file is left at the first body line."""
    meta: dict[str, str] = {}
    while True:
        line = fh.readline()
        if not line:
            return meta, None, fh.tell()
        if line.startswith("#"):
            if ":" in line:
                key, value = line[1:].split(":", 1)
                meta[key.strip().lower()] = value.strip()
        elif line.strip():
            return meta, line.rstrip("\r\n"), fh.tell()


def _body_lines(fh):
    """The data lines (no blank line, no "#" line), streamed."""
    for line in fh:
        if line.strip() and not line.startswith("#"):
            yield line


def _fast_columns(fh, cols: list[int]) -> np.ndarray | None:
    """(n, len(cols)) float of a clean numeric body (numpy's C reader, chunked), else None."""
    if not cols:
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            return np.loadtxt(fh, delimiter=",", comments="#", quotechar='"', ndmin=2, dtype=float, usecols=cols)
    except ValueError:
        return None


def _slow_columns(fh, mapping, headers, allow_nan: bool, source: str, error: type[InputError]) -> tuple[dict, int]:
    """Cell by cell (empty / "nan" cells, quoted or ragged rows), naming the first bad cell;
    one float per cell is kept (stdlib arrays), never the rows. Returns the columns and the
    number of data rows (counted even without any column to read)."""
    vals = {channel: array("d") for channel in mapping}
    r = -1
    for r, row in enumerate(csv.reader(_body_lines(fh))):
        for channel, (i, _) in mapping.items():
            cell = row[i].strip() if i < len(row) else ""
            if allow_nan and cell.lower() in _NAN_CELLS:
                vals[channel].append(np.nan)
                continue
            try:
                vals[channel].append(float(cell))
            except ValueError:
                shown = repr(cell) if cell else "a missing value"
                raise error(f"row {r + 1}: {shown} is not a number", source=source, field=headers[i]) from None
    return {channel: np.frombuffer(v, dtype=float) if len(v) else np.empty(0) for channel, v in vals.items()}, r + 1


def write_csv_table(path: str | Path, columns: Mapping[str, np.ndarray], meta: Mapping[str, str] | None = None) -> Path:
    """Write ``columns`` (header cell -> (n,) array, 9 significant digits) as a CSV that
    :func:`read_csv_table` reads, after one ``# key: value`` line per ``meta`` entry."""
    buf = io.StringIO()
    buf.writelines(f"# {k}: {v}\n" for k, v in (meta or {}).items())
    np.savetxt(buf, np.column_stack(list(columns.values())), delimiter=",", fmt="%.9g", header=",".join(columns),
               comments="")
    return write_text(path, buf.getvalue())


def read_csv_table(path: str | Path, channels: Mapping[str, Mapping[str, float]], *,
                   required: Sequence[str] = (), rename: Mapping[str, str] | None = None,
                   allow_nan: bool = False, min_rows: int = 1, error: type[InputError] = InputError) -> Table:
    """Read a CSV into SI channels (see the module docstring).

    channels  : canonical channel -> {unit: factor to SI} (a unit-less header is taken as SI).
    required  : channels that must be present ("missing column (need ...)").
    rename    : channel -> column spec for columns with other names (CLI ``--columns``).
    allow_nan : empty / "nan" cells and non-finite values are kept as NaN for the caller to
                report; otherwise the first one is an error naming its row and column.
    min_rows  : fewer data rows is an error.
    error     : the InputError subclass raised.

    The file is streamed: memory holds the parsed columns (8 bytes per used cell), not the text.
    """
    path = Path(path)
    source = str(path)
    digest = file_sha256(path, error)
    with reading(path, error, what="CSV file"), open(path, encoding="utf-8-sig", newline="") as fh:
        meta, header, body_at = _head(fh)
        if header is None:
            raise error("empty file (no header line)", source=source)
        headers = [h.strip() for h in next(csv.reader([header]))]
        mapping = resolve_columns(headers, channels, dict(rename or {}), source, error, required)
        order = list(mapping)
        table = _fast_columns(fh, [mapping[c][0] for c in order])
        if table is not None:
            raw = {channel: table[:, k] for k, channel in enumerate(order)}
            n = table.shape[0]
        else:
            fh.seek(body_at)
            raw, n = _slow_columns(fh, mapping, headers, allow_nan, source, error)
    if n < min_rows:
        raise error(f"needs at least {min_rows} data row{'s' if min_rows > 1 else ''}", source=source)
    columns: dict[str, np.ndarray] = {}
    for channel, (i, factor) in mapping.items():
        vals = raw[channel]
        if not allow_nan:
            bad = np.nonzero(~np.isfinite(vals))[0]
            if bad.size:
                raise error(f"row {bad[0] + 1}: NaN or infinite value", source=source, field=channel)
        columns[channel] = vals * factor
    return Table(source, columns, headers, meta, digest)
