"""``file``: record the live drive to a WAV (float32 DAC units, volts / amp_gain) or NPZ
(volts, with the drive rate) file, written on stop.

The recording buffer is allocated at start (``max_seconds``); blocks beyond it are counted
in ``dropped_blocks`` and not recorded.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.backends.base import PacedBackend

__all__ = ["FileBackend"]

log = logging.getLogger("surfhap.live")


class FileBackend(PacedBackend):
    name = "file"

    def __init__(self, path: str | Path, amp_gain: float = 250.0, max_seconds: float = 120.0, **_ignored):
        super().__init__()
        self.path = Path(path)
        if self.path.suffix.lower() not in (".wav", ".npz"):
            raise ConfigError("must end in .wav or .npz", source="--output", field="file")
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
        if not (np.isfinite(max_seconds) and 0 < max_seconds <= 3600):
            raise ConfigError("must be within 0-3600 s", field="max_seconds")
        self.amp_gain = float(amp_gain)
        self.max_seconds = float(max_seconds)
        self._buf = None
        self._n = 0
        self.dropped_blocks = 0

    def start(self, engine) -> None:
        self._buf = np.zeros(int(self.max_seconds * engine.drive_rate))
        self._buf.fill(0.0)  # commit the pages now, not block by block in the loop
        self._n = 0
        super().start(engine)

    def emit(self, volts) -> None:
        n = volts.shape[0]
        if self._n + n > self._buf.shape[0]:
            self.dropped_blocks += 1
            return
        self._buf[self._n : self._n + n] = volts
        self._n += n

    @property
    def recorded(self) -> np.ndarray:
        return self._buf[: self._n] if self._buf is not None else np.zeros(0)

    def close(self) -> None:
        if self._buf is None or self.engine is None:
            return
        rate = self.engine.drive_rate
        if self.path.suffix.lower() == ".npz":
            np.savez_compressed(self.path, drive=self.recorded, drive_rate=np.array(rate))
        else:
            from scipy.io import wavfile

            units = np.clip(self.recorded / self.amp_gain, -1.0, 1.0).astype(np.float32)
            wavfile.write(self.path, int(rate), units)
        log.info("wrote %d drive samples to %s", self._n, self.path)

    def info(self) -> dict:
        return {"name": self.name, "path": str(self.path), "seconds": self._n / self.engine.drive_rate if self.engine else 0.0}
