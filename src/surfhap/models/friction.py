"""Low-frequency friction laws, evaluated over arrays (SI: load in N, speed in m/s).

* Coulomb (Otake et al. 2021, eq. 1; Zhao et al. eq. 3): ``mu = mu0``.
* Quasi-static (Otake et al. 2022, eq. 3): ``mu_p(fn, v) = a fn^b (1 + d v^q) / (1 + c v)``
  with ``c, d >= 0`` and ``0 <= q <= 1``. Table I of that paper is consistent with fn in N
  and v in m/s: at fn = 1 N, v = 0.1 m/s it orders leather > cork > denim > wood.

The laws are pydantic dataclasses: their ranges are checked once, here, and the material file's
:class:`~surfhap.models.material.CoulombSpec` / ``QuasiStaticSpec`` are these laws plus provenance.
"""

from __future__ import annotations

import functools
from typing import Annotated

import numpy as np
from pydantic import ConfigDict, Field
from pydantic.dataclasses import dataclass

__all__ = ["CoulombLaw", "QuasiStaticLaw", "FrictionLaw", "LAW_CONFIG", "QUASI_STATIC_RANGES"]

LAW_CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)
# (low, high) of each quasi-static parameter: the law's validation and the fit's bounds
QUASI_STATIC_RANGES = {"a": (0.0, 5.0), "b": (-2.0, 2.0), "c": (0.0, float("inf")), "d": (0.0, float("inf")), "q": (0.0, 1.0)}


def _range(name: str) -> Field:
    lo, hi = QUASI_STATIC_RANGES[name]
    return Field(ge=lo, le=hi if np.isfinite(hi) else None)


@dataclass(frozen=True, config=LAW_CONFIG)
class CoulombLaw:
    """Constant coefficient of friction ``mu0`` (dimensionless, 0-5)."""

    mu0: Annotated[float, Field(ge=0, le=5, description="kinetic coefficient of friction")]

    def coefficient(self, load: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """CoF for load (n,) N and speed (n,) m/s; returns (n,) float."""
        load = np.asarray(load, dtype=float)
        return np.full(np.broadcast(load, np.asarray(speed)).shape, self.mu0)


@dataclass(frozen=True, config=LAW_CONFIG)
class QuasiStaticLaw:
    """``mu_p(fn, v) = a fn^b (1 + d v^q) / (1 + c v)`` (Otake et al. 2022, eq. 3), fn in N and
    v in m/s, with 0 <= a <= 5, -2 <= b <= 2, c, d >= 0 and 0 <= q <= 1 (finite)."""

    a: Annotated[float, _range("a")]
    b: Annotated[float, _range("b")]
    c: Annotated[float, _range("c")]
    d: Annotated[float, _range("d")]
    q: Annotated[float, _range("q")]

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


@functools.cache
def _quasi_static_kernel():
    """The compiled eq. 3 (numba), imported on the first evaluation rather than when a
    material is read (the CLI starts fast); later calls run no import statement."""
    from surfhap.models.friction_kernel import quasi_static

    return quasi_static


FrictionLaw = CoulombLaw | QuasiStaticLaw
