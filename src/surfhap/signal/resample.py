"""Streaming rational resampler (polyphase FIR), used control rate -> drive rate and back.

``RationalResampler(rate_in, rate_out)`` converts by ``L / M = rate_out / rate_in`` (integer
rates). The low-pass is a Kaiser-windowed FIR with ``taps_per_phase`` taps per polyphase
branch and its cut-off at 0.45 of the lower rate, so the band up to 0.25 x the lower rate
is flat within 0.01 dB (asserted in the tests). The group delay is :attr:`delay` seconds.
Integer up- and down-sampling have their own kernels (no integer division per sample).
"""

from __future__ import annotations

import functools
from fractions import Fraction

import numba
import numpy as np
from scipy.signal import firwin

__all__ = ["RationalResampler", "resample_block"]

_TAPS = 16  # taps per branch of the default design: the integer upsampler's vectorised path
_CHUNK = 256  # inputs per pass of that path (its scratch stays in the L1 cache)

# In the kernels, z is (>= K-1 + n_in,): the inputs from K-1 before the first window's start
# (the previous block's last K-1, then the block's, or the block itself); Hr[ph] is polyphase branch ph reversed, so that output = Hr[ph] . z[i : i+K]. The dot
# products index views (w = z[i:]) from 0: no negative-index check per tap, so the taps load as
# whole vectors (the same sums, three times faster).


@numba.njit(cache=True, nogil=True, fastmath=True)
def _polyphase(z, Hr, L, M, t0, n_in, out):
    # general L/M: output j sits at up-sampled time t0 + j*M
    K = Hr.shape[1]
    count = 0
    t = t0
    while True:
        i = t // L
        if i >= n_in:
            break
        ph = t - i * L
        acc = 0.0
        h = Hr[ph]
        w = z[i:]
        for k in range(K):
            acc += h[k] * w[k]
        out[count] = acc
        count += 1
        t += M
    return count, t - n_in * L


@numba.njit(cache=True, nogil=True, fastmath=True)
def _upsample(z, Hr, n_in, out, scratch):
    # integer factor L (M = 1): every input sample yields L outputs, one per branch
    L, K = Hr.shape
    if K == _TAPS:
        for i0 in range(0, n_in, _CHUNK):
            _upsample_taps(z[i0:], Hr, min(_CHUNK, n_in - i0), out[i0 * L:], scratch)
        return
    for i in range(n_in):
        for ph in range(L):
            acc = 0.0
            h = Hr[ph]
            w = z[i:]
            for k in range(K):
                acc += h[k] * w[k]
            out[i * L + ph] = acc


@numba.njit(cache=True, nogil=True)
def _upsample_taps(z, Hr, n, out, scratch):
    # _TAPS-tap branches: each branch vectorised over the n inputs (its taps in registers; four
    # partial sums in a fixed order, no fastmath: the same sums whatever the block split) into a
    # row of the (L, n) scratch (>= L _CHUNK: in the L1 cache), then interleaved into out
    L = Hr.shape[0]
    rows = scratch[:L * n].reshape((L, n))
    for ph in range(L):
        h = Hr[ph]
        h0, h1, h2, h3, h4, h5, h6, h7 = h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7]
        h8, h9, h10, h11, h12, h13, h14, h15 = h[8], h[9], h[10], h[11], h[12], h[13], h[14], h[15]
        r = rows[ph]
        for i in range(n):
            a = h0 * z[i] + h4 * z[i + 4] + h8 * z[i + 8] + h12 * z[i + 12]
            b = h1 * z[i + 1] + h5 * z[i + 5] + h9 * z[i + 9] + h13 * z[i + 13]
            c = h2 * z[i + 2] + h6 * z[i + 6] + h10 * z[i + 10] + h14 * z[i + 14]
            d = h3 * z[i + 3] + h7 * z[i + 7] + h11 * z[i + 11] + h15 * z[i + 15]
            r[i] = (a + b) + (c + d)
    for i in range(n):
        for ph in range(L):
            out[i * L + ph] = rows[ph, i]


@numba.njit(cache=True, nogil=True, fastmath=True)
def _downsample(z, h, M, t0, n_in, out):
    # integer factor M (L = 1): output j uses the window starting at input t0 + j*M; four outputs
    # at a time share the taps' loads (each sum vectorised as one alone: the same sums), those of
    # the last group past the block alone (their windows point past it: w = w0, not stored)
    K = h.shape[0]
    count = 0
    t = t0
    while t < n_in:
        a0 = a1 = a2 = a3 = 0.0
        w0 = z[t:]
        w1 = z[t + M:] if t + M < n_in else w0
        w2 = z[t + 2 * M:] if t + 2 * M < n_in else w0
        w3 = z[t + 3 * M:] if t + 3 * M < n_in else w0
        for k in range(K):
            c = h[k]
            a0 += c * w0[k]
            a1 += c * w1[k]
            a2 += c * w2[k]
            a3 += c * w3[k]
        for acc in (a0, a1, a2, a3):
            if t < n_in:
                out[count] = acc
                t += M
                count += 1
    return count, t - n_in


@numba.njit(cache=True, nogil=True)
def _windows(z, Hr, L, M, t0, n_in, out, scratch):
    # the outputs whose windows start at z[:n_in] (z: >= n_in + K - 1); returns the count, t0 updated
    if M == 1:
        _upsample(z, Hr, n_in, out, scratch)
        t0[0] = 0
        return n_in * L
    if L == 1:
        c, t0[0] = _downsample(z, Hr[0], M, t0[0], n_in, out)
    else:
        c, t0[0] = _polyphase(z, Hr, L, M, t0[0], n_in, out)
    return c


@numba.njit(cache=True, nogil=True)
def resample_block(x, z, Hr, L, M, t0, out):
    """One block x (n,) of any length through the resampler of ``z, Hr, L, M, t0``
    (:meth:`RationalResampler.kernel_args`) into ``out`` (>= n L / M + 2); returns the count.
    The windows that start in the previous block's last K - 1 inputs (z[:K-1]) come first, the
    rest read x in place (no copy of the block); z[2 (K-1):] is the upsampler's scratch."""
    K1 = Hr.shape[1] - 1
    n = x.shape[0]
    head = min(n, K1)
    scratch = z[2 * K1:]
    for i in range(head):
        z[K1 + i] = x[i]
    count = _windows(z, Hr, L, M, t0, head, out, scratch)
    if n > K1:
        count += _windows(x, Hr, L, M, t0, n - K1, out[count:], scratch)
        for i in range(K1):
            z[i] = x[n - K1 + i]
    else:
        for i in range(K1):
            z[i] = z[n + i]
    return count


@functools.lru_cache(maxsize=64)
def _branches(L: int, K: int, rate_in: int, rate_out: int) -> tuple[np.ndarray, np.ndarray]:
    # the low-pass's (L, K) polyphase branches (branch ph = h[ph::L]) and the same reversed, read-only:
    # designed once per conversion (firwin costs a millisecond; a batch makes many chains)
    h = firwin(L * K, 0.45 * min(rate_in, rate_out), window=("kaiser", 7.0), fs=L * rate_in) * L
    H = np.ascontiguousarray(h.reshape(K, L).T)
    Hr = np.ascontiguousarray(H[:, ::-1])
    H.flags.writeable = Hr.flags.writeable = False
    return H, Hr


class RationalResampler:
    """Stateful polyphase resampler from ``rate_in`` to ``rate_out`` Hz.

    ``process(x)`` takes (n,) float input samples and returns the (m,) output samples that
    became computable, m ~= n * rate_out / rate_in (exactly ``n * L`` when M = 1).
    """

    def __init__(self, rate_in: int, rate_out: int, taps_per_phase: int = 16):
        if int(rate_in) != rate_in or int(rate_out) != rate_out or rate_in <= 0 or rate_out <= 0:
            raise ValueError("resampler rates must be positive integers (Hz)")
        ratio = Fraction(int(rate_out), int(rate_in))
        self.L, self.M = ratio.numerator, ratio.denominator
        if self.L > 4096 or self.M > 4096:
            raise ValueError(f"rate ratio {rate_out}/{rate_in} is too irregular (L={self.L}, M={self.M})")
        self.rate_in, self.rate_out = int(rate_in), int(rate_out)
        K = int(taps_per_phase) if self.M == 1 else int(taps_per_phase) * max(1, -(-self.M // self.L))
        self.K = K
        self._H, self._Hr = _branches(self.L, K, self.rate_in, self.rate_out)
        self.delay = (self.L * K - 1) / 2.0 / (self.L * self.rate_in)
        # the last K - 1 inputs, room for the next block's first ones, the vectorised upsampler's scratch
        self._z = np.zeros(2 * (K - 1) + (self.L * _CHUNK if self.M == 1 and K == _TAPS else 0))
        self._t0 = np.zeros(1, dtype=np.int64)

    def reset(self) -> None:
        self._z[:] = 0.0
        self._t0[0] = 0

    def kernel_args(self) -> tuple:
        """(z, Hr, L, M, t0): this resampler's state for :func:`resample_block` (compiled callers)."""
        return self._z, self._Hr, self.L, self.M, self._t0

    def process(self, x: np.ndarray) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=np.float64)
        out = np.empty(x.shape[0] * self.L // self.M + 2)
        return out[:resample_block(x, *self.kernel_args(), out)]
