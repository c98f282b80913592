"""Line spectral frequencies (LSF): conversion to and from polynomials, stable interpolation.

A monic polynomial ``A(z) = 1 + a_1 z^-1 + ... + a_p z^-p`` (HaTT convention: the AR
denominator, or the MA numerator ``B(z)``) is split into the symmetric and antisymmetric
polynomials of degree p + 1::

    P(z) = A(z) + z^-(p+1) A(1/z),     Q(z) = A(z) - z^-(p+1) A(1/z).

When ``A`` is minimum phase, all roots of ``P`` and ``Q`` lie on the unit circle and
interlace; their angles in (0, pi), with the trivial roots at z = +-1 removed, are the p
line spectral frequencies ``0 < w_1 < w_2 < ... < w_p < pi`` (rad / sample). ``P`` owns
w_1, w_3, ... and ``Q`` owns w_2, w_4, ... . Conversely, *any* strictly increasing vector
in (0, pi) gives a minimum-phase ``A(z) = (P(z) + Q(z)) / 2``; a convex combination of two
increasing vectors is increasing, so linear interpolation of LSFs (HaTT, Culbertson et al.)
is stable by construction.

Roots are found on the Chebyshev form of the zero-phase trigonometric polynomial
``z^m P'(z)`` in ``x = cos w`` (all roots real, well conditioned) and polished by Newton
steps in ``w``, which makes ``lsf -> poly -> lsf`` exact to ~1e-13 rad.

Sign conventions: surfhap's AR prediction coefficients ``phi`` (``x[n] = sum phi_j x[n-j]
+ w``) relate to ``A`` by ``a = -phi``: use :func:`ar_to_lsf` / :func:`lsf_to_ar`.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.polynomial import chebyshev as _cheb

__all__ = [
    "poly_to_lsf",
    "lsf_to_poly",
    "ar_to_lsf",
    "lsf_to_ar",
    "lsf_is_valid",
    "interpolate_lsf",
]


def _deflate(c: np.ndarray, root_sign: float) -> np.ndarray:
    """Divide polynomial c (in z^-1) by (1 - root_sign z^-1); exact synthetic division."""
    out = np.empty(c.size - 1, dtype=np.longdouble)
    acc = np.longdouble(0.0)
    for k in range(c.size - 1):
        acc = c[k] + root_sign * acc
        out[k] = acc
    return out


def _symmetric_roots(g: np.ndarray) -> np.ndarray:
    """Angles in (0, pi) of the roots of a symmetric polynomial g of even degree 2m (all on
    the unit circle). Returns (m,) sorted ascending."""
    m = (g.size - 1) // 2
    if m == 0:
        return np.zeros(0)
    t = np.empty(m + 1, dtype=np.longdouble)
    t[0] = g[m]
    t[1:] = 2 * g[m - 1 :: -1][:m]
    x = _cheb.chebroots(t.astype(float))
    w = np.sort(np.arccos(np.clip(x.real, -1.0, 1.0))).astype(np.longdouble)
    k = np.arange(1, m + 1)
    coef = t[1:]
    for _ in range(4):  # Newton polish of T(w) = t0 + sum t_k cos(k w), in extended precision
        kw = np.outer(w, k)
        f = t[0] + np.cos(kw) @ coef
        df = -(np.sin(kw) @ (coef * k))
        step = np.where(np.abs(df) > 0, f / np.where(df == 0, 1.0, df), 0.0)
        w = np.clip(w - step, 0.0, np.pi)
    return np.sort(w.astype(float))


def poly_to_lsf(a: np.ndarray) -> np.ndarray:
    """LSFs (p,) rad of a minimum-phase monic polynomial a = [1, a_1, ..., a_p] (p + 1,).

    Raises ValueError when ``a[0] != 1`` or when ``A`` is not minimum phase (its LSFs would
    not interlace).
    """
    a = np.asarray(a, dtype=float).reshape(-1)
    if a.size == 0 or abs(a[0] - 1.0) > 1e-12:
        raise ValueError("polynomial must be monic: a[0] == 1")
    p = a.size - 1
    if p == 0:
        return np.zeros(0)
    ext = np.concatenate((a, [0.0])).astype(np.longdouble)
    rev = ext[::-1]
    P = ext + rev
    Q = ext - rev
    if p % 2 == 0:
        Pd = _deflate(P, -1.0)  # root at z = -1
        Qd = _deflate(Q, 1.0)  # root at z = +1
    else:
        Pd = P
        Qd = _deflate(_deflate(Q, 1.0), -1.0)
    wp = _symmetric_roots(Pd)
    wq = _symmetric_roots(Qd)
    lsf = np.empty(p)
    lsf[0::2] = wp
    lsf[1::2] = wq
    if not lsf_is_valid(lsf):
        raise ValueError("polynomial is not minimum phase: its line spectral frequencies do not interlace")
    return lsf


@numba.njit(cache=True, nogil=True)
def _lsf_to_poly_into(lsf, out, work_p, work_q):
    """lsf (p,) -> out (p + 1,) monic polynomial; work_p, work_q: (p + 3,) scratch."""
    p = lsf.shape[0]
    for i in range(p + 3):
        work_p[i] = 0.0
        work_q[i] = 0.0
    work_p[0] = 1.0
    work_q[0] = 1.0
    np_ = 0  # current degree of P
    nq = 0
    for i in range(p):
        c = -2.0 * np.cos(lsf[i])
        if i % 2 == 0:
            for k in range(np_ + 2, 1, -1):
                work_p[k] = work_p[k] + c * work_p[k - 1] + work_p[k - 2]
            work_p[1] = work_p[1] + c * work_p[0]
            np_ += 2
        else:
            for k in range(nq + 2, 1, -1):
                work_q[k] = work_q[k] + c * work_q[k - 1] + work_q[k - 2]
            work_q[1] = work_q[1] + c * work_q[0]
            nq += 2
    if p % 2 == 0:
        for k in range(np_ + 1, 0, -1):  # times (1 + z^-1)
            work_p[k] = work_p[k] + work_p[k - 1]
        for k in range(nq + 1, 0, -1):  # times (1 - z^-1)
            work_q[k] = work_q[k] - work_q[k - 1]
    else:
        for k in range(nq + 2, 1, -1):  # times (1 - z^-2)
            work_q[k] = work_q[k] - work_q[k - 2]
    for k in range(p + 1):
        out[k] = 0.5 * (work_p[k] + work_q[k])


def lsf_to_poly(lsf: np.ndarray) -> np.ndarray:
    """Monic polynomial [1, a_1, ..., a_p] (p + 1,) from LSFs (p,) rad (any increasing vector
    in (0, pi) gives a minimum-phase polynomial)."""
    lsf = np.ascontiguousarray(lsf, dtype=float).reshape(-1)
    p = lsf.size
    out = np.empty(p + 1)
    _lsf_to_poly_into(lsf, out, np.empty(p + 3), np.empty(p + 3))
    return out


def ar_to_lsf(phi: np.ndarray) -> np.ndarray:
    """LSFs (p,) of surfhap AR prediction coefficients phi (p,) (``A = [1, -phi]``)."""
    return poly_to_lsf(np.concatenate(([1.0], -np.asarray(phi, dtype=float).reshape(-1))))


def lsf_to_ar(lsf: np.ndarray) -> np.ndarray:
    """AR prediction coefficients phi (p,) from LSFs (p,)."""
    return -lsf_to_poly(lsf)[1:]


def lsf_is_valid(lsf: np.ndarray, margin: float = 0.0) -> bool:
    """True when lsf (p,) is strictly increasing inside (margin, pi - margin)."""
    w = np.asarray(lsf, dtype=float)
    if w.size == 0:
        return True
    return bool(np.all(np.isfinite(w)) and w[0] > margin and w[-1] < np.pi - margin and np.all(np.diff(w) > 0))


def interpolate_lsf(lsfs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Convex combination of LSF vectors: lsfs (k, p), weights (k,) >= 0 summing to 1 -> (p,).

    The result is increasing whenever every row is, so the polynomial is minimum phase.
    """
    lsfs = np.asarray(lsfs, dtype=float)
    w = np.asarray(weights, dtype=float)
    if np.any(w < -1e-12) or abs(w.sum() - 1.0) > 1e-9:
        raise ValueError("weights must be >= 0 and sum to 1")
    return w @ lsfs
