"""``file``: record the live drive to a WAV (float32 DAC units, volts / amp_gain) or NPZ
(volts, with the drive rate) file, written incrementally.

The path is checked when the backend is made (a missing directory, a directory, or a place
that cannot be written is a :class:`~surfhap.errors.ConfigError` naming the path). While
running, only the samples since the last flush are in memory; every ``flush_seconds`` (0.1 s)
they are appended and the header updated, so a crash (even SIGKILL) keeps a valid file up to
the last flush: a ``.wav`` is written as it goes; an ``.npz`` streams to ``PATH.partial.npy``
(float64 volts, loadable with ``numpy.load``), packed into ``PATH`` (``drive``,
``drive_rate``) on a clean stop. There is no silent cap: ``max_seconds`` (default None) asks
the engine for its stop ramp shortly before the cap (``cap_reached``, one warning), so the
file ends at 0 V at most ``max_seconds`` long; later blocks count in ``capped_blocks``. A
normal stop records the stop ramp too; a write error halts the engine (0 V).
"""

from __future__ import annotations

import logging
import os
import struct
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError
from surfhap.exchange.wav import float_wav_header
from surfhap.live.backends.base import PacedBackend

__all__ = ["FileBackend", "check_writable", "MIN_SECONDS"]

log = logging.getLogger("surfhap.live")

_NPY_HEADER = 128  # bytes of the partial .npy header (magic, version, length, padded dict)
MIN_SECONDS = 0.1  # s, the shortest --max-seconds (room for the stop ramp before the cap)


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

    def __init__(self, path: str | Path, amp_gain: float = 250.0, max_seconds: float | None = None,
                 flush_seconds: float = 0.1):
        super().__init__()
        self.path = Path(path)
        if self.path.suffix.lower() not in (".wav", ".npz"):
            raise ConfigError("must end in .wav or .npz", source="--output", field="file")
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
        if max_seconds is not None and not (np.isfinite(max_seconds) and MIN_SECONDS <= max_seconds <= 1e7):
            raise ConfigError(f"must be within {MIN_SECONDS}-1e7 s", source="--max-seconds")
        if not (np.isfinite(flush_seconds) and 0.001 <= flush_seconds <= 60):
            raise ConfigError("must be within 1 ms-60 s", field="flush_seconds")
        self.npz = self.path.suffix.lower() == ".npz"
        self.stream_path = self.path.with_name(self.path.name + ".partial.npy") if self.npz else self.path
        check_writable(self.path)
        if self.npz:
            check_writable(self.stream_path)
        self.amp_gain = float(amp_gain)
        self.max_seconds = None if max_seconds is None else float(max_seconds)
        self.flush_seconds = float(flush_seconds)
        self._buf = np.zeros(0)
        self._pending = 0  # samples in _buf, not yet in the file
        self._written = 0  # samples in the file
        self._rate = 0
        self._file = None
        self.capped_blocks = 0
        self.cap_reached = False

    def open(self, engine) -> None:
        super().open(engine)
        self._rate = rate = int(engine.drive_rate)
        self._flush_every = max(1, int(self.flush_seconds * rate))
        self._buf = np.zeros(self._flush_every + int(engine.config.max_block_frames))
        self._buf.fill(0.0)  # commit the pages now, not block by block in the loop
        self._pending = 0
        self._written = 0
        self._cap = None if self.max_seconds is None else int(round(self.max_seconds * rate))
        # ask for the stop ramp early enough that it ends (and a few blocks of 0 V follow)
        # before the cap: two blocks for the command to be taken, the ramp, two blocks more
        ramp = int(np.ceil(engine.config.stop_ramp * rate))
        self._cap_stop = None if self._cap is None else self._cap - ramp - 4 * int(engine.block_frames)
        if self._cap_stop is not None and self._cap_stop < 0:
            need = (ramp + 4 * int(engine.block_frames)) / rate
            raise ConfigError(f"must be at least {need:.3f} s (the stop ramp and four blocks)", source="--max-seconds")
        self.capped_blocks = 0
        self.cap_reached = False
        try:
            self._file = open(self.stream_path, "wb")
            self._file.write(self._header(0))
            self._file.flush()
        except OSError as exc:
            raise ConfigError(f"cannot be written ({exc.strerror or exc})", source=str(self.stream_path)) from None

    @property
    def samples(self) -> int:
        """Samples recorded so far (in the file or about to be flushed)."""
        return self._written + self._pending

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
        if f is None or self._pending == 0:
            return
        f.write(self._samples(self._buf[: self._pending]))
        self._written += self._pending
        self._pending = 0
        end = f.tell()
        f.seek(0)
        f.write(self._header(self._written))
        f.seek(end)
        f.flush()

    def emit(self, volts) -> None:
        n = volts.shape[0]
        if self._cap is not None:
            total = self.samples
            if total + n >= self._cap_stop and not self.cap_reached:
                self.cap_reached = True
                self.engine.request_stop()  # the ramp goes into the file before the cap
                log.warning("file output %s reaches --max-seconds %g: the output ramps to 0 V and the recording "
                            "ends (later blocks are counted in capped_blocks)", self.path, self.max_seconds)
            if total + n > self._cap:
                n = self._cap - total
                self.capped_blocks += 1
                if n <= 0:
                    return
        k = self._pending
        self._buf[k : k + n] = volts[:n]
        self._pending = k + n
        if self._pending >= self._flush_every:
            self.flush()

    @property
    def recorded(self) -> np.ndarray:
        """The recording read back from the file, volts (a WAV holds float32 DAC units:
        volts / amp_gain, clipped to full scale). For checks, not for the real-time path."""
        if self._file is not None:
            return np.zeros(0)  # still running: read it after stop()
        if self.npz:
            if self.path.exists() and not self.stream_path.exists():
                with np.load(self.path) as z:
                    return np.asarray(z["drive"], dtype=float)
            return np.load(self.stream_path).astype(float) if self.stream_path.exists() else np.zeros(0)
        if not self.path.exists():
            return np.zeros(0)
        with open(self.path, "rb") as f:
            f.seek(44)
            return np.frombuffer(f.read(), dtype="<f4").astype(float) * self.amp_gain

    def close(self) -> None:
        if self._file is None or self.engine is None:
            return
        try:
            self.flush()
            self._file.close()
            self._file = None
            if self.npz:  # pack the streamed samples (read in chunks from a memory map)
                drive = np.load(self.stream_path, mmap_mode="r")
                np.savez_compressed(self.path, drive=drive, drive_rate=np.array(self._rate))
                del drive
                os.remove(self.stream_path)
            log.info("wrote %d drive samples to %s", self._written, self.path)
        except OSError as exc:
            self.error = f"file output failed: {exc}"
            self.engine.fail(self.error)
            log.error("%s", self.error)
        finally:
            self._file = None

    def info(self) -> dict:
        rate = self._rate or 1
        return {"name": self.name, "path": str(self.path), "seconds": self.samples / rate,
                "max_seconds": self.max_seconds, "cap_reached": self.cap_reached, "capped_blocks": self.capped_blocks}
