"""Shape-rendering files: ``shape.npz`` + ``summary.json`` per scan, calibration JSON.

``shape.npz`` holds the touch-rate arrays ``t`` (s), ``x``, ``y`` (m), ``z`` (hit height,
mesh units, NaN off the mesh), ``face`` (-1 off the mesh), ``force`` (lateral, N), ``fsq``
(sqrt(N)), ``intensity`` (area grain, 0.3..1.0), ``edge`` (tick intensity, 0 where none),
``theta`` (deg), ``load`` (N), and the drive-rate ``t_drive``, ``drive`` (V after the
safety stage), ``target`` (N), plus ``friction_sim`` (N, at ``friction_rate``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError, writing
from surfhap.exchange.files import read_json_object, write_text
from surfhap.shape.calibration import ShapeCalibration

__all__ = ["write_shape", "write_calibration", "read_calibration", "default_calibration_path"]

def write_shape(result, out_dir: str | Path) -> dict[str, Path]:
    """Write ``shape.npz`` and ``summary.json`` into ``out_dir`` (created); returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"npz": out / "shape.npz", "summary": out / "summary.json"}
    arrays = {
        "t": result.t, "x": result.x, "y": result.y, "z": result.z, "face": result.face, "force": result.force,
        "fsq": result.fsq, "intensity": result.intensity, "edge": result.edge, "theta": result.theta,
        "load": result.load, "t_drive": result.t_drive, "drive": result.drive, "target": result.target,
        "friction_sim": result.friction_sim, "friction_rate": np.array(result.friction_rate),
        "drive_rate": np.array(result.drive_rate), "fsq_range": np.array([result.calibration.fmin, result.calibration.fmax]),
    }
    with writing(paths["npz"]):
        np.savez_compressed(paths["npz"], **arrays)
    summary = result.summary()
    summary["calibration"] = result.calibration.to_dict()
    write_text(paths["summary"], json.dumps(summary, indent=2, default=float) + "\n")
    return paths


def default_calibration_path(mesh_path: str | Path) -> Path:
    """``<mesh>.calibration.json`` next to the mesh (e.g. bunny.ply.calibration.json)."""
    p = Path(mesh_path)
    return p.with_name(p.name + ".calibration.json")


def write_calibration(cal: ShapeCalibration, path: str | Path) -> Path:
    """Write a calibration JSON (its folder created if missing)."""
    return write_text(path, json.dumps(cal.to_dict(), indent=2) + "\n")


def read_calibration(path: str | Path) -> ShapeCalibration:
    """Read a calibration JSON; ConfigError naming the file (and the field) for anything unusable."""
    data = read_json_object(path, ConfigError)
    try:
        return ShapeCalibration.from_dict(data)
    except ConfigError as exc:
        raise ConfigError(exc.message, source=str(path), field=exc.field) from None
