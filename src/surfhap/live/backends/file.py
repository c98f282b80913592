"""``file``: record the live drive to a WAV (float32 DAC units, volts / amp_gain) or NPZ
(volts, with the drive rate) file, written incrementally.

The path is checked when the backend is made (a missing directory, a directory, or a place
that cannot be written gives a :class:`~surfhap.errors.ConfigError` naming the path, before
anything runs). While running, the samples are appended to the file and flushed every
``flush_seconds`` (0.1 s), and the header is updated at each flush, so a crash (even
SIGKILL) keeps a valid file with everything up to the last flush:

* ``.wav``: the WAV file itself (IEEE float, one channel) is written as it goes;
* ``.npz``: the samples go to ``PATH.partial.npy`` (volts, float64, a plain NumPy file
  loadable with ``numpy.load``) and are packed into ``PATH`` (``drive``, ``drive_rate``)
  on a clean stop, which removes the partial file.

The in-memory copy (``recorded``, allocated at start for ``max_seconds``) and the file hold
the same samples; blocks beyond ``max_seconds`` are counted in ``dropped_blocks`` and not
recorded. A write error halts the engine (0 V) through the backend failure path.
"""

from __future__ import annotations

import logging
import os
import struct
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError
from surfhap.exchange.wav import float_wav_header
from surfhap.live.backends.base import STALL_TIMEOUT, PacedBackend

__all__ = ["FileBackend", "check_writable"]

log = logging.getLogger("surfhap.live")

_NPY_HEADER = 128  # bytes of the partial .npy header (magic, version, length, padded dict)


def check_writable(path: Path) -> None:
    """Raise ConfigError (naming ``path``) unless a file can be created or overwritten there.

    Tries it: opens the file for appending (and removes it again if it did not exist)."""
    src = str(path)
    if path.is_dir():
        raise ConfigError("is a directory, not a file", source=src)
    parent = path.parent
    if not parent.is_dir():
        raise ConfigError(f"directory {str(parent)!r} does not exist", source=src)
    existed = path.exists()
    try:
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise ConfigError(f"cannot be written ({exc.strerror or exc})", source=src) from None
    if not existed:
        try:
            path.unlink()
        except OSError:
            pass


def _npy_header(n: int) -> bytes:
    d = "{'descr': '<f8', 'fortran_order': False, 'shape': (%d,), }" % n
    head = b"\x93NUMPY\x01\x00" + struct.pack("<H", _NPY_HEADER - 10)
    return head + d.ljust(_NPY_HEADER - 10 - 1).encode("latin1") + b"\n"


class FileBackend(PacedBackend):
    name = "file"

    def __init__(self, path: str | Path, amp_gain: float = 250.0, max_seconds: float = 120.0,
                 flush_seconds: float = 0.1, stall_timeout: float = STALL_TIMEOUT, **_ignored):
        super().__init__(stall_timeout)
        self.path = Path(path)
        if self.path.suffix.lower() not in (".wav", ".npz"):
            raise ConfigError("must end in .wav or .npz", source="--output", field="file")
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
        if not (np.isfinite(max_seconds) and 0 < max_seconds <= 3600):
            raise ConfigError("must be within 0-3600 s", field="max_seconds")
        if not (np.isfinite(flush_seconds) and 0.001 <= flush_seconds <= 60):
            raise ConfigError("must be within 1 ms-60 s", field="flush_seconds")
        self.npz = self.path.suffix.lower() == ".npz"
        self.stream_path = self.path.with_name(self.path.name + ".partial.npy") if self.npz else self.path
        check_writable(self.path)
        if self.npz:
            check_writable(self.stream_path)
        self.amp_gain = float(amp_gain)
        self.max_seconds = float(max_seconds)
        self.flush_seconds = float(flush_seconds)
        self._buf = None
        self._n = 0
        self._written = 0
        self._file = None
        self.dropped_blocks = 0

    def start(self, engine) -> None:
        self._buf = np.zeros(int(self.max_seconds * engine.drive_rate))
        self._buf.fill(0.0)  # commit the pages now, not block by block in the loop
        self._n = 0
        self._written = 0
        self._flush_every = max(1, int(self.flush_seconds * engine.drive_rate))
        self._rate = int(engine.drive_rate)
        try:
            self._file = open(self.stream_path, "wb")
            self._file.write(self._header(0))
            self._file.flush()
        except OSError as exc:
            raise ConfigError(f"cannot be written ({exc.strerror or exc})", source=str(self.stream_path)) from None
        super().start(engine)

    def _header(self, n: int) -> bytes:
        return _npy_header(n) if self.npz else float_wav_header(self._rate, n)

    def _samples(self, volts: np.ndarray) -> bytes:
        if self.npz:
            return volts.astype("<f8").tobytes()
        return np.clip(volts / self.amp_gain, -1.0, 1.0).astype("<f4").tobytes()

    def flush(self) -> None:
        """Append what was recorded since the last flush and update the header (own thread
        while running; the file is always valid up to the last flush)."""
        f = self._file
        if f is None or self._written == self._n:
            return
        f.write(self._samples(self._buf[self._written : self._n]))
        self._written = self._n
        end = f.tell()
        f.seek(0)
        f.write(self._header(self._written))
        f.seek(end)
        f.flush()

    def emit(self, volts) -> None:
        n = volts.shape[0]
        if self._n + n > self._buf.shape[0]:
            self.dropped_blocks += 1
            return
        self._buf[self._n : self._n + n] = volts
        self._n += n
        if self._n - self._written >= self._flush_every:
            self.flush()

    @property
    def recorded(self) -> np.ndarray:
        return self._buf[: self._n] if self._buf is not None else np.zeros(0)

    def close(self) -> None:
        if self._file is None or self.engine is None:
            return
        try:
            self.flush()
            self._file.close()
            if self.npz:
                np.savez_compressed(self.path, drive=self.recorded, drive_rate=np.array(self._rate))
                os.remove(self.stream_path)
            log.info("wrote %d drive samples to %s", self._n, self.path)
        except OSError as exc:
            self.error = f"file output failed: {exc}"
            self.engine.fail(self.error)
            log.error("%s", self.error)
        finally:
            self._file = None

    def info(self) -> dict:
        return {"name": self.name, "path": str(self.path), "seconds": self._n / self.engine.drive_rate if self.engine else 0.0}
