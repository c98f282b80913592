"""Write a render to a folder: drive.wav, render.npz, summary.json.

``drive.wav`` is float32 at the drive rate in DAC units: volts divided by the amplifier gain
(V per DAC full-scale unit; default: the safety limit v_max, so +-1.0 is +-v_max).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.io import wavfile

from surfhap.errors import ConfigError

if TYPE_CHECKING:  # exchange/ sits below render/: it writes the result's arrays, it does not compute
    from surfhap.render.offline import RenderResult

__all__ = ["write_render", "write_drive_wav", "render_arrays"]


def render_arrays(result: RenderResult) -> dict[str, np.ndarray]:
    """The named arrays stored in render.npz."""
    arrays = {
        "t": result.t, "speed": result.speed, "load": result.load, "mu_low": result.mu_low,
        "mu_tex": result.mu_tex, "target": result.target, "voltage": result.voltage,
        "t_drive": result.t_drive, "drive": result.drive, "friction_sim": result.friction_sim,
        "texture": result.texture, "latency": np.array(result.latency),
    }
    if result.acc is not None:
        arrays["acc"] = result.acc
    return arrays


def write_drive_wav(path: str | Path, drive: np.ndarray, drive_rate: int, amp_gain: float) -> Path:
    """Write volts as float32 DAC units (``drive / amp_gain``); refuses values beyond +-1."""
    if not (np.isfinite(amp_gain) and amp_gain > 0):
        raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
    units = (np.asarray(drive, dtype=float) / amp_gain).astype(np.float32)
    peak = float(np.max(np.abs(units))) if units.size else 0.0
    if peak > 1.0:
        raise ConfigError(f"the drive reaches {peak:.3g} DAC full scales; raise the amplifier gain", field="amp_gain")
    path = Path(path)
    wavfile.write(path, int(drive_rate), units)
    return path


def write_render(result: RenderResult, out_dir: str | Path, amp_gain: float | None = None) -> dict[str, Path]:
    """Write drive.wav, render.npz and summary.json into ``out_dir`` (created); returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    gain = float(amp_gain) if amp_gain is not None else float(result.v_max)
    paths = {
        "wav": write_drive_wav(out / "drive.wav", result.drive, result.drive_rate, gain),
        "npz": out / "render.npz",
        "summary": out / "summary.json",
    }
    np.savez_compressed(paths["npz"], **render_arrays(result))
    summary = result.summary()
    summary["amp_gain_v_per_unit"] = gain
    paths["summary"].write_text(json.dumps(summary, indent=2, default=float) + "\n", encoding="utf-8")
    return paths
