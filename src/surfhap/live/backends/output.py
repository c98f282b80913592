"""The ``--output`` string: parse it and open the backend it names.

This module is the registry of backends: it imports the implementations (on demand, so an
optional dependency such as sounddevice loads only when that output is chosen); they import
only :mod:`surfhap.live.backends.base`.
"""

from __future__ import annotations

from surfhap.errors import ConfigError
from surfhap.live.netaddr import parse_osc_address

__all__ = ["parse_output", "open_backend"]


# the outputs that reach an amplifier, so a finger: a study session on one of them never
# starts without a comfort voltage (``study run``)
HARDWARE_OUTPUTS = frozenset({"sound", "osc"})


def parse_output(text: str) -> tuple[str, dict]:
    """``sim`` | ``file:PATH.wav|.npz`` | ``sound`` | ``sound:DEVICE`` | ``osc://HOST:PORT[/intensity|/drive]``."""
    text = (text or "sim").strip()
    if text == "sim":
        return "sim", {}
    if text.startswith("file:"):
        path = text[5:]
        if not path or not path.lower().endswith((".wav", ".npz")):
            raise ConfigError("file output needs a .wav or .npz path, e.g. file:drive.wav", source="--output")
        return "file", {"path": path}
    if text == "sound" or text.startswith("sound:"):
        dev = text[6:] if text.startswith("sound:") else ""
        device: int | str | None = None
        if dev:
            device = int(dev) if dev.isdigit() else dev
        return "sound", {"device": device}
    if text.startswith("osc://"):
        host, port, mode = parse_osc_address(text, "--output")  # checked here: no DNS lookup, port 1-65535
        mode = mode or "intensity"
        if mode not in ("intensity", "drive"):
            raise ConfigError(f"OSC output mode must be /intensity or /drive, got /{mode}", source="--output")
        return "osc", {"host": host, "port": port, "mode": mode}
    raise ConfigError(f"unknown output {text!r} (sim, file:PATH, sound[:DEVICE], osc://HOST:PORT)", source="--output")


def open_backend(text: str, **options):
    """Build the backend named by an ``--output`` string; ``options`` go to its constructor."""
    kind, args = parse_output(text)
    if kind == "sim":
        from surfhap.live.backends.sim import SimBackend

        return SimBackend(**options)
    if kind == "file":
        from surfhap.live.backends.file import FileBackend

        return FileBackend(args["path"], **options)
    if kind == "sound":
        from surfhap.live.backends.sound import SoundBackend

        return SoundBackend(device=args["device"], **options)
    from surfhap.live.backends.osc import OscBackend

    return OscBackend(args["host"], args["port"], mode=args["mode"], **options)
