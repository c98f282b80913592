"""Output backends of the live engine, each a :class:`surfhap.runtime.protocols.Sink`.

``sim`` (simulated display, default), ``file`` (WAV/NPZ), ``sound`` (PortAudio through
sounddevice) and ``osc`` (drive or intensity values to an external renderer).
:func:`open_backend` turns an ``--output`` string and :class:`OutputOptions` into a backend.
"""

from __future__ import annotations

from surfhap.live.backends.base import PacedBackend
from surfhap.live.backends.output import OutputOptions, open_backend, parse_output

__all__ = ["PacedBackend", "OutputOptions", "parse_output", "open_backend"]
