"""Output backends of the live engine, each a :class:`surfhap.runtime.protocols.Sink`.

``sim`` (simulated display, default), ``file`` (WAV/NPZ), ``sound`` (PortAudio through
sounddevice), ``osc`` (drive or intensity values to an external renderer) and ``daq`` (an NI
analog output through nidaqmx). :func:`open_backend` turns a typed output (:class:`SimOutput`,
:class:`FileOutput`, :class:`SoundOutput`, :class:`OscOutput`, :class:`DaqOutput`) and :class:`OutputOptions` into a backend.
"""

from __future__ import annotations

from surfhap.live.backends.base import PacedBackend
from surfhap.live.backends.output import (DaqOutput, FileOutput, OscOutput, Output, OutputOptions, SimOutput,
                                          SoundOutput, open_backend)

__all__ = ["PacedBackend", "Output", "SimOutput", "FileOutput", "SoundOutput", "OscOutput", "DaqOutput", "OutputOptions",
           "open_backend"]
