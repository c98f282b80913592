"""The ``--output`` option's text -> a typed output spec (:mod:`surfhap.live.backends.output`)."""

from __future__ import annotations

import re

from surfhap.errors import ConfigError

__all__ = ["parse_output", "OUTPUT_FORMS"]

OUTPUT_FORMS = "sim | file:PATH.wav|.npz | sound[:DEVICE] | osc://HOST:PORT[/intensity|/drive] | daq:DEVICE/aoN"
_DAQ_CHANNEL = re.compile(r"[^/\s:]+/ao[0-9]+")


def parse_output(text: str | None):
    """``sim`` | ``file:PATH.wav|.npz`` | ``sound`` | ``sound:DEVICE`` | ``osc://HOST:PORT[/intensity|/drive]``
    | ``daq:DEVICE/aoN`` -> SimOutput | FileOutput | SoundOutput | OscOutput | DaqOutput; bad text is one
    ConfigError naming --output."""
    from surfhap.live.backends.output import DaqOutput, FileOutput, OscOutput, SimOutput, SoundOutput
    from surfhap.live.netaddr import parse_osc_address

    text = (text or "sim").strip()
    if text == "sim":
        return SimOutput()
    if text.startswith("file:"):
        if not text[5:].lower().endswith((".wav", ".npz")):
            raise ConfigError("file output needs a .wav or .npz path, e.g. file:drive.wav", source="--output")
        return FileOutput(text[5:])
    if text == "sound" or text.startswith("sound:"):
        dev = text[6:] if text.startswith("sound:") else ""
        return SoundOutput(None if not dev else int(dev) if dev.isdigit() else dev)
    if text.startswith("osc://"):
        host, port, mode = parse_osc_address(text, "--output")  # checked here: no DNS lookup, port 1-65535
        mode = mode or "intensity"
        if mode not in ("intensity", "drive"):
            raise ConfigError(f"OSC output mode must be /intensity or /drive, got /{mode}", source="--output")
        return OscOutput(host, port, mode)
    if text.startswith("daq:"):
        if not _DAQ_CHANNEL.fullmatch(text[4:]):
            raise ConfigError(f"DAQ output needs a channel like daq:Dev1/ao0, got {text!r}", source="--output")
        return DaqOutput(text[4:])
    raise ConfigError(f"unknown output {text!r} (sim, file:PATH, sound[:DEVICE], osc://HOST:PORT, daq:DEV/aoN)",
                      source="--output")
