"""Streaming AR texture synthesis over a bank of models with one shared output history.

When the finger speed moves to another reference velocity the synthesiser switches model
between two samples but keeps its output history (the last ``p_max`` outputs), so the new
recursion continues from the old signal: no click, no reset (Otake et al. 2022 use the model
of the nearest reference velocity live). Noise comes from a seeded ``numpy.random.Generator``;
the same seed gives the same output whatever the block sizes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba
import numpy as np

if TYPE_CHECKING:
    from surfhap.models.texture import TextureBank

__all__ = ["ARSynthesizer", "ar_bank_block", "nearest_model"]

_POOL = 1024  # normal numbers drawn ahead


@numba.njit(cache=True, nogil=True)
def nearest_model(midpoints, speed, out):
    """out[i] = the model of the reference speed nearest |speed[i]| (a NaN speed: the slowest),
    given the sorted midpoints between reference speeds (what ``TextureBank.select`` returns)."""
    for i in range(speed.shape[0]):
        s = abs(speed[i])
        k = 0
        while k < midpoints.shape[0] and midpoints[k] < s:
            k += 1
        out[i] = k


@numba.njit(cache=True, nogil=True, fastmath=True)
def ar_bank_block(speed, noise, start, midpoints, model_idx, coefs, sigmas, buf, pmax, out):
    # n = speed.shape[0] samples driven by noise[start:start + n] (model_idx: >= n); buf: (pmax + n,),
    # buf[:pmax] holds the previous outputs, oldest first; coefs[m] = model m's coefficients reversed
    # and zero-padded in front to pmax (coefs[m, pmax - 1 - j] multiplies the output j + 1 back).
    # The older taps are one vectorised sum over the history (independent of the newest output);
    # the newest output, kept in a register, enters last: the recursion's chain is one multiply-add
    n = speed.shape[0]
    nearest_model(midpoints, speed, model_idx)
    last = buf[pmax - 1]
    for i in range(n):
        m = model_idx[i]
        h = coefs[m]
        w = buf[i:]  # w[k] = buf[pos - pmax + k], pos = pmax + i
        acc = 0.0
        for k in range(pmax - 1):
            acc += h[k] * w[k]
        acc = acc + sigmas[m] * noise[start + i] + h[pmax - 1] * last
        buf[pmax + i] = acc
        out[i] = acc
        last = acc
    for j in range(pmax):
        buf[j] = buf[n + j]


class ARSynthesizer:
    """Texture synthesis at the bank's control rate.

    ``process(speed, load=None)`` takes (n,) finger speeds (m/s) at the control rate (the load
    is accepted for the common synthesiser protocol and not used) and returns (n,) texture
    samples (the bank's quantity: mu_t, or acceleration in m/s^2); ``model_index`` (n,) tells
    which model produced each sample of the last call (a view, overwritten by the next call).
    """

    def __init__(self, bank: TextureBank, seed: int | np.random.Generator | None = 0, max_block: int = 1 << 16):
        self.bank = bank
        self._seed = seed
        m = len(bank.models)
        self.p_max = max(1, bank.max_order)
        self._coefs = np.zeros((m, self.p_max))  # reversed, zero-padded in front (ar_bank_block)
        self._sigmas = np.zeros(m)
        for i, model in enumerate(bank.models):
            self._coefs[i, self.p_max - model.order:] = np.asarray(model.coefficients)[::-1]
            self._sigmas[i] = np.sqrt(model.variance)
        self.max_block = int(max_block)
        self._buf = np.zeros(self.p_max + self.max_block)
        self._noise = np.empty(self.max_block)
        # a generator of its own is drawn ahead in batches (the same numbers, one call per batch
        # rather than per block); a shared Generator is drawn only as needed
        self._pool = np.empty(_POOL if not isinstance(seed, np.random.Generator) else 0)
        self._index = np.zeros(self.max_block, dtype=np.int64)
        self._mid = np.ascontiguousarray(bank.midpoints, dtype=np.float64)
        self._n = 0
        self.reset()

    model_index = property(lambda self: self._index[:self._n], doc="(n,) the model of each sample of the last call")

    def reset(self) -> None:
        """Clear the history and restart the noise generator from the seed."""
        seed = self._seed
        self._rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._buf[:] = 0.0
        self._pos = self._pool.shape[0]  # the pool is used up

    def process(self, speed: np.ndarray, load: np.ndarray | None = None) -> np.ndarray:
        speed = np.ascontiguousarray(speed, dtype=np.float64)
        out = np.empty(speed.shape[0])
        ar_bank_block(speed, *self.kernel_args(speed.shape[0]), out)
        return out

    def kernel_args(self, n: int) -> tuple:
        """The rest of :func:`ar_bank_block`'s arguments for the next ``n`` samples (their noise
        drawn): noise and its start, the bank and the history."""
        if n > self._noise.shape[0]:  # a long offline block: room for it, the history kept
            self._buf = np.concatenate([self._buf[:self.p_max], np.zeros(n)])
            self._noise, self._index = np.empty(n), np.zeros(n, dtype=np.int64)
        pool, pos = self._pool, self._pos
        size = pool.shape[0]
        if pos + n <= size:  # standard_normal draws one number after the other: a batch drawn
            noise = pool  # ahead gives the same sequence
            self._pos = pos + n
        elif n <= size:  # what is left moves to the front, the rest is drawn behind it
            pool[:size - pos] = pool[pos:]
            self._rng.standard_normal(out=pool[size - pos:])
            noise, pos, self._pos = pool, 0, n
        else:  # longer than the pool, or a shared generator (no pool): drawn as needed
            noise = self._noise
            noise[:size - pos] = pool[pos:]
            self._rng.standard_normal(out=noise[size - pos:n])
            pos, self._pos = 0, size
        self._n = n
        return noise, pos, self._mid, self._index, self._coefs, self._sigmas, self._buf, self.p_max
