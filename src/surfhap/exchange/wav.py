"""Mono float32 WAV (IEEE float, format 3) written as a stream: samples are appended and the
header is rewritten on :meth:`FloatWavStream.flush`, so the file is valid up to the last flush
whatever happens afterwards. No extra chunks (no time stamps): the same samples give the same
bytes."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from surfhap.errors import writing

__all__ = ["float_wav_header", "FloatWavStream"]


def float_wav_header(rate: int, n: int) -> bytes:
    """The 44-byte header of a mono float32 WAV at ``rate`` Hz holding ``n`` samples."""
    data = 4 * int(n)
    return (b"RIFF" + struct.pack("<I", 36 + data) + b"WAVE"
            + b"fmt " + struct.pack("<IHHIIHH", 16, 3, 1, int(rate), 4 * int(rate), 4, 32)
            + b"data" + struct.pack("<I", data))


class FloatWavStream:
    """Append float32 samples to ``path`` (created or truncated) at ``rate`` Hz."""

    def __init__(self, path: str | Path, rate: int):
        self.path, self.rate, self.n = Path(path), int(rate), 0
        with writing(self.path):
            self._f = self.path.open("wb")
            self._f.write(float_wav_header(self.rate, 0))

    def write(self, samples: np.ndarray) -> None:
        """Append ``samples`` ((n,) float, written as little-endian float32)."""
        data = np.asarray(samples, dtype="<f4")
        with writing(self.path):
            self._f.write(data.tobytes())
        self.n += data.size

    def flush(self) -> None:
        """Rewrite the header for the samples so far and flush to the operating system."""
        with writing(self.path):
            end = self._f.tell()
            self._f.seek(0)
            self._f.write(float_wav_header(self.rate, self.n))
            self._f.seek(end)
            self._f.flush()

    def close(self) -> None:
        if not self._f.closed:
            try:
                self.flush()
            finally:
                with writing(self.path):
                    self._f.close()
