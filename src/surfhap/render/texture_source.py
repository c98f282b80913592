"""Texture samples at the chain's control rate from a synthesiser running at its control rate.

A texture model runs at the rate it was fitted at (2 kHz for Otake's data, 1 kHz for HaTT,
100 Hz for the HapMat IMU). The friction law and the rest of the chain run at the control
rate (2 kHz by default), so the load and speed response keeps a few-ms latency whatever the
texture's rate. This processor synthesises at the control rate and resamples up; the texture
is stochastic, so the resampler's delay does not matter for it.
"""

from __future__ import annotations

import numba
import numpy as np

from surfhap.models.synth import ARSynthesizer, ar_bank_block
from surfhap.signal.resample import RationalResampler, resample_block

__all__ = ["TextureSource", "texture_block"]

_GIVEN, _DIRECT, _UPSAMPLED = 0, 1, 2  # texture_block's modes
_NO_BRANCHES = np.zeros((1, 1))  # the upsampler's read-only branches where there is none (one compiled type)
_NO_BRANCHES.flags.writeable = False


@numba.njit(cache=True, nogil=True)
def texture_block(speed, tex, out):
    """The texture of the chain's speed (n,) m/s into ``out`` (n,) inside a compiled call; ``tex``
    = :meth:`TextureSource.kernel_args` (mode, ar_bank_block's arguments, k, the upsampler, its
    output buffer, fill (1,) int64, scratch (2, >= k)), or None (the texture is in ``out``: a
    compiled variant without synthesis). Mode direct: the AR bank at the control rate; upsampled: k new AR samples at the
    texture's rate (taken at the speed of the first uncovered sample and every L-th after it,
    as :meth:`TextureSource.process`) are resampled up behind the buffer, whose first n leave."""
    if tex is None:
        return
    mode, ar, k, up, buf, fill, scratch = tex
    n = speed.shape[0]
    if mode == _DIRECT:
        ar_bank_block(speed, *ar, out)
    elif mode == _UPSAMPLED:
        f = fill[0]
        L = up[2]
        # numba checks no bounds: k (from the fill kernel_args saw) must still cover the block
        # within the buffer, else the resampler would write past it
        if f < 0 or f + k * L < n or f + k * L > buf.shape[0] or scratch.shape[1] < k:
            raise ValueError("texture_block: the texture buffer's fill changed since kernel_args")
        if k:
            for i in range(k):
                scratch[0, i] = speed[min(i * L + f, n - 1)]
            ar_bank_block(scratch[0, :k], *ar, scratch[1, :k])
            f += resample_block(scratch[1, :k], *up, buf[f:])
        for i in range(n):
            out[i] = buf[i]
        for i in range(f - n):
            buf[i] = buf[n + i]
        fill[0] = f - n


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
        self._fill = np.zeros(1, dtype=np.int64)  # buffered samples (shared with texture_block)
        # the compiled form (texture_block): an AR bank at the control rate or an integer upsampling
        ar = isinstance(self.synth, ARSynthesizer)
        self._mode = _GIVEN if not ar else _DIRECT if same else _UPSAMPLED if self.resampler.M == 1 else _GIVEN
        up = self.resampler.kernel_args() if self._mode == _UPSAMPLED else (self._buf, _NO_BRANCHES, 0, 1, self._fill)
        self._scratch = np.zeros((2, 64))
        self._fixed = (up, self._buf, self._fill)

    def reset(self) -> None:
        self.synth.reset()
        if self.resampler is not None:
            self.resampler.reset()
        self._fill[0] = 0

    @property
    def compiled(self) -> bool:
        """Whether :func:`texture_block` synthesises this texture (else :meth:`process` does)."""
        return self._mode != _GIVEN

    def kernel_args(self, n: int) -> tuple:
        """:func:`texture_block`'s ``tex`` for the next ``n`` control-rate samples (their noise
        drawn), or None when the texture is not :attr:`compiled` (or the block is longer than
        ``max_block``): :meth:`process` gives it."""
        mode, k = self._mode, n
        if mode == _UPSAMPLED:
            if n > self.max_block:
                return None
            f = int(self._fill[0])
            k = 0 if f >= n else -(-(n - f) // self.resampler.L)  # one batch covers the shortfall
            if k > self._scratch.shape[1]:
                self._scratch = np.zeros((2, 2 * k))
        if mode == _GIVEN:
            return None
        return mode, self.synth.kernel_args(k) if k else _NO_AR, k, *self._fixed, self._scratch

    def process(self, speed: np.ndarray, load: np.ndarray) -> np.ndarray:
        n = speed.shape[0]
        if self.resampler is None:
            return self.synth.process(speed, load)
        if n > self.max_block:
            return np.concatenate([self.process(speed[i:i + self.max_block], load[i:i + self.max_block])
                                   for i in range(0, n, self.max_block)])
        L, M = self.resampler.L, self.resampler.M
        fill = int(self._fill[0])
        while fill < n:
            need = n - fill
            k = max(1, -(-need * M // L))  # control-rate samples that cover the shortfall
            if k == 1:  # the usual live case: one model sample, taken at the first uncovered sample
                p = min(fill, n - 1)
                sp, ld = speed[p : p + 1], load[p : p + 1]
            else:
                pos = np.minimum((np.arange(k) * L) // M + fill, n - 1)
                sp, ld = speed[pos], load[pos]
            fresh = self.resampler.process(self.synth.process(sp, ld))
            self._buf[fill:fill + fresh.shape[0]] = fresh
            fill += fresh.shape[0]
        out = self._buf[:n].copy()
        rest = fill - n
        self._buf[:rest] = self._buf[n:fill]
        self._fill[0] = rest
        return out


# ar_bank_block's arguments of a block that synthesises nothing (k = 0; the same compiled types)
_NO_AR = (np.zeros(0), -1, np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 0)), np.zeros(0), np.zeros(0), 0)
