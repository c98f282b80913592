"""``drive.wav``: mono float32 WAV (IEEE float, format 3) written as a stream: blocks are appended
and the header is rewritten every few seconds and at the end, so the file is valid up to the last
rewrite whatever happens afterwards. No extra chunks (no time stamps): the same samples give the
same bytes."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError, writing

__all__ = ["float_wav_header", "DriveWavWriter"]


def float_wav_header(rate: int, n: int) -> bytes:
    """The 44-byte header of a mono float32 WAV at ``rate`` Hz holding ``n`` samples."""
    data = 4 * int(n)
    return (b"RIFF" + struct.pack("<I", 36 + data) + b"WAVE"
            + b"fmt " + struct.pack("<IHHIIHH", 16, 3, 1, int(rate), 4 * int(rate), 4, 32)
            + b"data" + struct.pack("<I", data))


class DriveWavWriter:
    """``drive.wav`` written block by block: float32 DAC units (volts / ``amp_gain``, V per full
    scale) at ``rate`` Hz, the header brought up to date every 3 s of drive. A block beyond +-1
    full scale raises ConfigError (field amp_gain)."""

    def __init__(self, path: str | Path, rate: int, amp_gain: float):
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
        self.path, self.amp_gain, self.rate, self.n = Path(path), float(amp_gain), int(rate), 0
        self._next_flush = 3 * self.rate  # samples
        with writing(self.path):
            self._f = self.path.open("wb")
            self._f.write(float_wav_header(self.rate, 0))

    def __call__(self, drive: np.ndarray) -> None:
        units = (np.asarray(drive, dtype=float) / self.amp_gain).astype("<f4")
        peak = float(np.max(np.abs(units))) if units.size else 0.0
        if peak > 1.0:
            raise ConfigError(f"the drive reaches {peak:.3g} DAC full scales; raise the amplifier gain", field="amp_gain")
        with writing(self.path):
            self._f.write(units.tobytes())
        self.n += units.size
        if self.n >= self._next_flush:  # a crash leaves a file readable up to the last flush
            self._flush()
            self._next_flush = self.n + 3 * self.rate

    def _flush(self) -> None:
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
                self._flush()
            finally:
                with writing(self.path):
                    self._f.close()

    def abort(self) -> None:
        self.close()
        self.path.unlink(missing_ok=True)
