"""``--scan`` / ``--trajectory``: the virtual or recorded finger of ``surfhap render`` (one
render or a batch)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from surfhap.errors import ConfigError

__all__ = ["SCAN_KEYS", "scan_trajectory", "trajectory_from_options"]

SCAN_KEYS = {"speed": None, "load": None, "duration": None, "length": 0.0, "rate": 125.0}


def scan_trajectory(values: Mapping[str, float]):
    """The virtual finger of ``--scan`` from typed values: speed (m/s), load (N), duration (s)
    required; length (m, strokes when > 0) and rate (Hz) default as in :data:`SCAN_KEYS`."""
    from surfhap.models.trajectory import constant_scan, strokes

    missing = [k for k, default in SCAN_KEYS.items() if default is None and k not in values]
    if missing:
        raise ConfigError("missing (required)", source="--scan", field=missing[0])
    kv = {**{k: d for k, d in SCAN_KEYS.items() if d is not None}, **values}
    try:  # the plausibility bounds of models.trajectory, the ones trajectory files are read with
        if kv["length"] > 0:
            return strokes(kv["speed"], kv["load"], kv["duration"], length=kv["length"], sensor_rate=kv["rate"])
        return constant_scan(kv["speed"], kv["load"], kv["duration"], sensor_rate=kv["rate"])
    except ConfigError as e:
        if e.source is not None:
            raise
        raise ConfigError(e.message, source="--scan", field=e.field) from None


def trajectory_from_options(scan: str | None, trajectory: Path | None):
    """Build the trajectory from ``--scan key=value,...`` or ``--trajectory FILE``."""
    from surfhap.exchange.files import parse_pairs
    from surfhap.exchange.trajectory_csv import read_trajectory_csv

    if (scan is None) == (trajectory is None):
        raise ConfigError("give exactly one of --scan or --trajectory", source="--scan/--trajectory")
    if trajectory is not None:
        return read_trajectory_csv(trajectory)
    return scan_trajectory(parse_pairs(scan, "--scan", SCAN_KEYS, ConfigError, numbers=True))
