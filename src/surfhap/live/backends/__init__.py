"""Output backends of the live engine, each a :class:`surfhap.runtime.protocols.Sink`.

``sim`` (simulated display, default), ``file`` (WAV/NPZ), ``sound`` (PortAudio through
sounddevice) and ``osc`` (drive or intensity values to an external renderer).
:func:`open_backend` turns a typed output (:class:`SimOutput`, :class:`FileOutput`,
:class:`SoundOutput`, :class:`OscOutput`) and :class:`OutputOptions` into a backend.
"""

from __future__ import annotations

from surfhap.live.backends.base import PacedBackend
from surfhap.live.backends.output import (FileOutput, OscOutput, Output, OutputOptions, SimOutput, SoundOutput,
                                          open_backend)

__all__ = ["PacedBackend", "Output", "SimOutput", "FileOutput", "SoundOutput", "OscOutput", "OutputOptions",
           "open_backend"]
