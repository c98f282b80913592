"""The compiled kernel of the quasi-static friction law (:class:`surfhap.models.friction.QuasiStaticLaw`),
kept apart so that reading a material does not import numba."""

from __future__ import annotations

import numba

__all__ = ["quasi_static"]


@numba.njit(cache=True, nogil=True)
def quasi_static(fn, v, out, a, b, c, d, q):
    """out[i] = a fn^b (1 + d |v|^q) / (1 + c |v|) where fn[i] > 0, else 0 (all (n,) float)."""
    for i in range(fn.shape[0]):
        f = fn[i]
        if f > 0.0:
            s = abs(v[i])
            out[i] = a * max(f, 1e-300) ** b * (1.0 + d * s ** q) / (1.0 + c * s)
        else:
            out[i] = 0.0

