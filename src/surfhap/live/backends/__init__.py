"""Output backends of the live engine behind one small protocol (:class:`Backend`).

``sim`` (simulated display, default), ``file`` (WAV/NPZ), ``sound`` (PortAudio through
sounddevice) and ``osc`` (drive or intensity values to an external renderer).
:func:`open_backend` turns an ``--output`` string into a backend.
"""

from __future__ import annotations

from surfhap.live.backends.base import Backend, PacedBackend
from surfhap.live.backends.output import open_backend, parse_output

__all__ = ["Backend", "PacedBackend", "parse_output", "open_backend"]
