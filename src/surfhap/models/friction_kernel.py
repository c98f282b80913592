"""The compiled kernel of the quasi-static friction law (:class:`surfhap.models.friction.QuasiStaticLaw`),
kept apart so that reading a material does not import numba."""

from __future__ import annotations

import numba

__all__ = ["quasi_static", "quasi_static_cof"]


@numba.njit(cache=True, nogil=True, inline="always")
def quasi_static_cof(f, v, a, b, c, d, q):
    """Eq. 3 of 003 for one sample: a f^b (1 + d |v|^q) / (1 + c |v|) when f > 0 N, else 0
    (no contact, or NaN). The one scalar form, used by :func:`quasi_static` and the drive law."""
    if f > 0.0:
        s = abs(v)
        return a * max(f, 1e-300) ** b * (1.0 + d * s ** q) / (1.0 + c * s)
    return 0.0


@numba.njit(cache=True, nogil=True)
def quasi_static(fn, v, out, a, b, c, d, q):
    """out[i] = quasi_static_cof(fn[i], v[i], ...) (all (n,) float)."""
    for i in range(fn.shape[0]):
        out[i] = quasi_static_cof(fn[i], v[i], a, b, c, d, q)
