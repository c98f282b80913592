"""The outputs a live session can drive, as typed specs, and the registry that opens one.

An output is one of :class:`SimOutput`, :class:`FileOutput`, :class:`SoundOutput`,
:class:`OscOutput` or :class:`DaqOutput` (the command line's ``--output`` text becomes one in ``surfhap.cli``; the
library never parses it). This module is the registry of backends: it imports the
implementations on demand (an optional dependency such as sounddevice loads only when that
output is chosen); they import only :mod:`surfhap.live.backends.base`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Literal, Union

from surfhap.errors import ConfigError

__all__ = ["SimOutput", "FileOutput", "SoundOutput", "OscOutput", "DaqOutput", "Output", "OutputOptions", "open_backend"]


@dataclass(frozen=True)
class SimOutput:
    """The embedded simulated display (no hardware)."""

    reaches_amplifier: ClassVar[bool] = False
    default_drive_rate: ClassVar[int] = 20000


@dataclass(frozen=True)
class FileOutput:
    """A .wav or .npz recording of the drive at ``path``."""

    path: str
    reaches_amplifier: ClassVar[bool] = False
    default_drive_rate: ClassVar[int] = 20000


@dataclass(frozen=True)
class SoundOutput:
    """A sound card (PortAudio ``device`` index or name; None = the default device)."""

    device: int | str | None = None
    reaches_amplifier: ClassVar[bool] = True
    default_drive_rate: ClassVar[int] = 48000


@dataclass(frozen=True)
class OscOutput:
    """OSC messages to an amplifier bridge at ``host``:``port`` (``mode``: per-block intensity or drive)."""

    host: str
    port: int
    mode: Literal["intensity", "drive"] = "intensity"
    reaches_amplifier: ClassVar[bool] = True
    default_drive_rate: ClassVar[int] = 20000


@dataclass(frozen=True)
class DaqOutput:
    """An NI-DAQmx analog output ``channel`` such as ``Dev1/ao0`` (nidaqmx and NI's driver)."""

    channel: str
    reaches_amplifier: ClassVar[bool] = True
    default_drive_rate: ClassVar[int] = 20000


Output = Union[SimOutput, FileOutput, SoundOutput, OscOutput, DaqOutput]


@dataclass(frozen=True)
class OutputOptions:
    """The typed options of the outputs; each backend takes only the ones it has.

    amp_gain    : V per DAC full-scale unit (sound, file); V per V at the amplifier input (daq).
    channels    : 0-based sound channels that carry the drive (sound; None = all).
    max_seconds : end a file recording with the stop ramp after this long (file; None = no cap).
    """

    amp_gain: float = 250.0
    channels: tuple[int, ...] | None = None
    max_seconds: float | None = None


def open_backend(output: Output, options: OutputOptions | None = None):
    """Build the backend of ``output`` with the ``options`` it takes; an option the output has
    no use for (channels of a file, a cap on a sound card) is an error."""
    opt = options or OutputOptions()
    if opt.channels is not None and not isinstance(output, SoundOutput):
        raise ConfigError("only applies to sound outputs", source="--channels")
    if opt.max_seconds is not None and not isinstance(output, FileOutput):
        raise ConfigError("only applies to file outputs", source="--max-seconds")
    if isinstance(output, SimOutput):
        from surfhap.live.backends.sim import SimBackend

        return SimBackend()
    if isinstance(output, FileOutput):
        from surfhap.live.backends.file import FileBackend

        return FileBackend(output.path, amp_gain=opt.amp_gain, max_seconds=opt.max_seconds)
    if isinstance(output, SoundOutput):
        from surfhap.live.backends.sound import SoundBackend

        chans = opt.channels
        return SoundBackend(device=output.device, amp_gain=opt.amp_gain, channels=chans,
                            n_channels=None if chans is None else max(chans) + 1)
    if isinstance(output, DaqOutput):
        from surfhap.live.backends.daq import DaqBackend

        return DaqBackend(output.channel, amp_gain=opt.amp_gain)
    from surfhap.live.backends.osc import OscBackend

    return OscBackend(output.host, output.port, mode=output.mode)
