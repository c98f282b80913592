"""Low-frequency friction laws, evaluated over arrays (SI: load in N, speed in m/s).

* Coulomb (Otake et al. 2021, eq. 1; Zhao et al. eq. 3): ``mu = mu0``.
* Quasi-static (Otake et al. 2022, eq. 3): ``mu_p(fn, v) = a fn^b (1 + d v^q) / (1 + c v)``
  with ``c, d >= 0`` and ``0 <= q <= 1``. Table I of that paper is consistent with fn in N
  and v in m/s: at fn = 1 N, v = 0.1 m/s it orders leather > cork > denim > wood.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CoulombLaw", "QuasiStaticLaw", "FrictionLaw"]


@dataclass(frozen=True)
class CoulombLaw:
    """Constant coefficient of friction ``mu0`` (dimensionless)."""

    mu0: float

    def __post_init__(self):
        if not (np.isfinite(self.mu0) and self.mu0 >= 0):
            raise ValueError(f"mu0 must be finite and >= 0, got {self.mu0}")

    def coefficient(self, load: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """CoF for load (n,) N and speed (n,) m/s; returns (n,) float."""
        load = np.asarray(load, dtype=float)
        return np.full(np.broadcast(load, np.asarray(speed)).shape, self.mu0)


@dataclass(frozen=True)
class QuasiStaticLaw:
    """``mu_p(fn, v) = a fn^b (1 + d v^q) / (1 + c v)`` (Otake et al. 2022, eq. 3)."""

    a: float
    b: float
    c: float
    d: float
    q: float

    def __post_init__(self):
        vals = (self.a, self.b, self.c, self.d, self.q)
        if not all(np.isfinite(v) for v in vals):
            raise ValueError("quasi-static parameters must be finite")
        if self.a < 0 or self.c < 0 or self.d < 0 or not 0 <= self.q <= 1:
            raise ValueError("quasi-static law needs a >= 0, c >= 0, d >= 0 and 0 <= q <= 1")

    def coefficient(self, load: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """CoF for load (n,) N and speed (n,) m/s; returns (n,) float (arrays of another
        shape are broadcast, and the result has the broadcast shape).

        Loads <= 0 (no contact, or NaN) give 0; negative speeds are taken as their magnitude.
        One compiled pass: the live engine calls this for a few samples per block, where
        numpy's per-operation overhead would cost more than the arithmetic.
        """
        fn = np.asarray(load, dtype=np.float64)
        v = np.asarray(speed, dtype=np.float64)
        if fn.ndim != 1 or fn.shape != v.shape:
            fn, v = np.broadcast_arrays(fn, v)
        out = np.empty(fn.shape)
        _quasi_static_kernel()(np.ascontiguousarray(fn).reshape(-1), np.ascontiguousarray(v).reshape(-1), out.reshape(-1),
                      self.a, self.b, self.c, self.d, self.q)
        return out


_KERNEL = []


def _quasi_static_kernel():
    """The compiled eq. 3 (numba), imported on the first evaluation rather than when a
    material is read (the CLI starts fast); later calls run no import statement."""
    if not _KERNEL:
        from surfhap.models.friction_kernel import quasi_static

        _KERNEL.append(quasi_static)
    return _KERNEL[0]


FrictionLaw = CoulombLaw | QuasiStaticLaw
