"""The ``--output`` string: parse it and open the backend it names.

This module is the registry of backends: it imports the implementations (on demand, so an
optional dependency such as sounddevice loads only when that output is chosen); they import
only :mod:`surfhap.live.backends.base`.
"""

from __future__ import annotations

from dataclasses import dataclass

from surfhap.errors import ConfigError
from surfhap.live.netaddr import parse_osc_address

__all__ = ["parse_output", "open_backend", "OutputOptions"]


@dataclass(frozen=True)
class OutputOptions:
    """The typed options of the outputs; each backend takes only the ones it has.

    amp_gain    : V per DAC full-scale unit (sound, file).
    channels    : 0-based sound channels that carry the drive (sound; None = all).
    max_seconds : end a file recording with the stop ramp after this long (file; None = no cap).
    """

    amp_gain: float = 250.0
    channels: tuple[int, ...] | None = None
    max_seconds: float | None = None


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


def open_backend(text: str, options: OutputOptions | None = None):
    """Build the backend named by an ``--output`` string with the ``options`` it takes; an
    option the output has no use for (channels of a file, a cap on a sound card) is an error."""
    kind, args = parse_output(text)
    opt = options or OutputOptions()
    if opt.channels is not None and kind != "sound":
        raise ConfigError("only applies to sound outputs", source="--channels")
    if opt.max_seconds is not None and kind != "file":
        raise ConfigError("only applies to file outputs", source="--max-seconds")
    if kind == "sim":
        from surfhap.live.backends.sim import SimBackend

        return SimBackend()
    if kind == "file":
        from surfhap.live.backends.file import FileBackend

        return FileBackend(args["path"], amp_gain=opt.amp_gain, max_seconds=opt.max_seconds)
    if kind == "sound":
        from surfhap.live.backends.sound import SoundBackend

        chans = opt.channels
        return SoundBackend(device=args["device"], amp_gain=opt.amp_gain, channels=chans,
                            n_channels=None if chans is None else max(chans) + 1)
    from surfhap.live.backends.osc import OscBackend

    return OscBackend(args["host"], args["port"], mode=args["mode"])
