"""Write a render to a folder: drive.wav, render.npz or render.h5, summary.json.

``drive.wav`` is float32 at the drive rate in DAC units: volts divided by the amplifier gain
(V per DAC full-scale unit; default: the safety limit v_max, so +-1.0 is +-v_max). The render
file's layout is :mod:`surfhap.exchange.render_store`'s; :func:`write_render` writes an
in-memory :class:`RenderResult`, :func:`render_file_spec` and :func:`render_file_attrs` give the
channels and attributes a streamed render writes too (``surfhap render``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from surfhap.exchange.files import write_text
from surfhap.exchange.render_store import RENDER_CHANNELS as CHANNELS
from surfhap.exchange.render_store import open_render_writer
from surfhap.exchange.wav import DriveWavWriter

if TYPE_CHECKING:  # exchange/ sits below render/: it writes the result's arrays, it does not compute
    from surfhap.render.offline import RenderResult

__all__ = ["write_render", "render_file_spec", "render_file_attrs", "write_summary"]


def render_file_spec(control_rate: float, drive_rate: float, texture_quantity: str | None) -> dict[str, tuple[float, str]]:
    """channel -> (rate Hz, unit) of a render file; ``texture_quantity`` "cof", "acceleration" or None."""
    units = {"texture": {"cof": "1", "acceleration": "m/s^2"}.get(texture_quantity or "", "1")}
    return {name: (float(drive_rate if rate == "drive" else control_rate), units.get(name, unit))
            for name, (rate, unit) in CHANNELS.items()}


#: the summary's entries a render file carries as attributes (what a reader needs besides the arrays)
FILE_ATTRS = ("material", "method", "seed", "trajectory", "control_rate_hz", "drive_rate_hz", "carrier_hz", "latency_s",
              "v_max", "mu_panel", "interrupted")


def render_file_attrs(result: RenderResult) -> dict:
    """File attributes of ``result``: its summary's :data:`FILE_ATTRS` and the texture quantity."""
    s = result.to_dict()
    return {k: s[k] for k in FILE_ATTRS} | {"texture_quantity": result.texture_quantity}


def write_summary(path: str | Path, summary: dict, amp_gain: float) -> Path:
    """summary.json: the render's summary plus the amplifier gain (V per DAC unit)."""
    return write_text(path, json.dumps(summary | {"amp_gain_v_per_unit": amp_gain}, indent=2, default=float) + "\n")


def write_render(result: RenderResult, out_dir: str | Path, amp_gain: float | None = None,
                 format: str = "npz") -> dict[str, Path]:
    """Write drive.wav, render.npz (or render.h5 with ``format="h5"``) and summary.json into
    ``out_dir`` (created); returns the paths (keys wav, render, summary)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    gain = float(amp_gain) if amp_gain is not None else float(result.v_max)
    wav = DriveWavWriter(out / "drive.wav", result.drive_rate, gain)  # refuses a drive beyond +-1 full scale
    try:
        wav(result.drive)
    except BaseException:
        wav.abort()
        raise
    wav.close()
    writer = open_render_writer(out, format, render_file_spec(result.control_rate, result.drive_rate, result.texture_quantity))
    for name in CHANNELS:
        writer(name, getattr(result, name))
    writer.close(render_file_attrs(result))
    return {"wav": wav.path, "render": writer.path,
            "summary": write_summary(out / "summary.json", result.summary(), gain)}
