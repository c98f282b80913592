"""Texture samples at the chain's control rate from a synthesiser running at its control rate.

A texture model runs at the rate it was fitted at (2 kHz for Otake's data, 1 kHz for HaTT,
100 Hz for the HapMat IMU). The friction law and the rest of the chain run at the control
rate (2 kHz by default), so the load and speed response keeps a few-ms latency whatever the
texture's rate. This processor synthesises at the control rate and resamples up; the texture
is stochastic, so the resampler's delay does not matter for it.
"""

from __future__ import annotations

import numpy as np

from surfhap.signal.resample import RationalResampler

__all__ = ["TextureSource"]


class TextureSource:
    """``process(speed, load) -> texture``: (n,) arrays at ``control_rate`` Hz.

    texture      : a texture model (``quantity``, ``sample_rate``, ``synthesizer(seed)``).
    control_rate : Hz, at least the texture's rate.
    """

    def __init__(self, texture, control_rate: int, seed=0, max_block: int = 1 << 16):
        self.texture = texture
        self.texture_rate = int(texture.sample_rate)
        self.control_rate = int(control_rate)
        if self.control_rate < self.texture_rate:
            raise ValueError("control rate below the texture's control rate")
        self.synth = texture.synthesizer(seed=seed)
        same = self.control_rate == self.texture_rate
        self.resampler = None if same else RationalResampler(self.texture_rate, self.control_rate)
        self.max_block = int(max_block)
        self._buf = np.zeros(0 if same else self.max_block + self.resampler.L + 8)
        self._fill = 0

    def reset(self) -> None:
        self.synth.reset()
        if self.resampler is not None:
            self.resampler.reset()
        self._fill = 0

    def process(self, speed: np.ndarray, load: np.ndarray) -> np.ndarray:
        n = speed.shape[0]
        if self.resampler is None:
            return self.synth.process(speed, load)
        if n > self.max_block:
            return np.concatenate([self.process(speed[i:i + self.max_block], load[i:i + self.max_block])
                                   for i in range(0, n, self.max_block)])
        L, M = self.resampler.L, self.resampler.M
        while self._fill < n:
            need = n - self._fill
            k = max(1, -(-need * M // L))  # control-rate samples that cover the shortfall
            if k == 1:  # the usual live case: one model sample, taken at the first uncovered sample
                p = min(self._fill, n - 1)
                sp, ld = speed[p : p + 1], load[p : p + 1]
            else:
                pos = np.minimum((np.arange(k) * L) // M + self._fill, n - 1)
                sp, ld = speed[pos], load[pos]
            fresh = self.resampler.process(self.synth.process(sp, ld))
            self._buf[self._fill:self._fill + fresh.shape[0]] = fresh
            self._fill += fresh.shape[0]
        out = self._buf[:n].copy()
        rest = self._fill - n
        self._buf[:rest] = self._buf[n:self._fill]
        self._fill = rest
        return out
