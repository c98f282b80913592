"""Polarity carrier: multiply the voltage envelope by a +-1 square wave at the drive rate.

Switching polarity keeps the electrostatic force (proportional to V^2) while stopping charge
from building up in the skin (Otake et al. 2021: 20 kHz; 2022: 2 kHz). A carrier of 0 Hz
means no switching (DC drive), useful to show the fading on the simulated display.
"""

from __future__ import annotations

import numba
import numpy as np

from surfhap.errors import ConfigError

__all__ = ["PolarityCarrier", "check_carrier", "polarity"]


def check_carrier(carrier: float, drive_rate: float) -> float:
    """Validate a carrier frequency (Hz): 0 (off) or 2 kHz .. 20 kHz and <= drive_rate / 2."""
    carrier = float(carrier)
    if carrier == 0.0:
        return carrier
    if not (np.isfinite(carrier) and 2000.0 <= carrier <= 20000.0):
        raise ConfigError(f"must be 0 (off) or within 2000-20000 Hz, got {carrier:g}", field="carrier")
    if carrier > drive_rate / 2.0:
        raise ConfigError(f"{carrier:g} Hz needs a drive rate of at least {2 * carrier:g} Hz (got {drive_rate:g})", field="carrier")
    return carrier


_SPAN = 1 << 20  # samples per int32-indexed inner loop


@numba.njit(cache=True, nogil=True)
def polarity(envelope, n0, step, out):
    """``out = +-envelope``: sign +1 during the first half of each carrier period, drive sample
    ``n0 + i`` at ``step`` (= carrier / drive rate, 0 = off) periods per sample."""
    for b in range(0, envelope.shape[0], _SPAN):
        e, o = envelope[b:b + _SPAN], out[b:b + _SPAN]
        n_b = n0 + b
        for i in range(np.int32(e.shape[0])):  # int32 -> float converts in vectors (int64 does not, before AVX-512)
            x = (n_b + np.float64(np.int32(i))) * step  # the same sum: integers, exact in float64
            phase = x - np.floor(x)  # = x % 1.0 exactly (x >= 0); a float floor, no float modulo or int round trip
            o[i] = e[i] if phase < 0.5 else -e[i]


class PolarityCarrier:
    """``process(envelope) -> drive``, both (n,) float V at the drive rate; ``step`` and the
    drive sample count ``n`` are what :func:`polarity` needs."""

    def __init__(self, carrier: float, drive_rate: float):
        self.frequency = check_carrier(carrier, drive_rate)
        self.drive_rate = float(drive_rate)
        self.step = self.frequency / self.drive_rate
        self.reset()

    def reset(self) -> None:
        self.n = 0

    def process(self, envelope: np.ndarray) -> np.ndarray:
        envelope = np.asarray(envelope, dtype=float)
        out = np.empty(envelope.shape[0])
        polarity(envelope, self.n, self.step, out)
        self.n += out.shape[0]
        return out
