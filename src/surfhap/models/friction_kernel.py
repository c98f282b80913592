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


@numba.njit(cache=True, nogil=True)
def quasi_static_jacobian(mu, v, vq, log_fn, log_v, a, c, d, out):
    """out (n, 5) = d mu_p / d(a, b, c, d, q) of eq. 3 at mu = mu_p (n,), v (n,) m/s >= 0,
    vq = v^q, log_fn = log fn and log_v = log v (0 where v = 0), all (n,)."""
    for i in range(mu.shape[0]):
        m = mu[i]
        dlog = vq[i] / (1.0 + d * vq[i])  # d log(1 + d v^q) / dd
        out[i, 0] = m / a
        out[i, 1] = m * log_fn[i]
        out[i, 2] = -m * v[i] / (1.0 + c * v[i])
        out[i, 3] = m * dlog
        out[i, 4] = m * d * dlog * log_v[i]
