"""Burg's AR estimator (maximum-entropy), for one signal or several segments at once.

Burg minimises the sum of forward and backward prediction-error powers at each order,
which keeps every model stable and, unlike Yule–Walker, does not window the data: it is
the better estimator on short records such as 100 ms splices. Several segments (the
spliced spans of one reference velocity) are fitted jointly by summing the error powers
over segments at every stage, so no artificial joint is created between them.

Convention as in :mod:`surfhap.signal.ar`: ``x[n] = sum phi_j x[n-j] + w[n]``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from surfhap.signal.ar import LevinsonResult, OrderSelection, check_criterion, order_selection

__all__ = ["burg", "burg_all_orders", "select_order_burg"]


def _as_segments(x) -> list[np.ndarray]:
    if isinstance(x, np.ndarray) and x.ndim == 1:
        segs = [x]
    else:
        segs = [np.asarray(s, dtype=float).reshape(-1) for s in x]
    return [np.asarray(s, dtype=float) for s in segs]


def burg_all_orders(x: np.ndarray | Sequence[np.ndarray], max_order: int, demean: bool = True) -> LevinsonResult:
    """Burg estimates for every order 0..max_order.

    x : (n,) float, or a sequence of 1-D segments fitted jointly (each demeaned on its own
    when ``demean``). Returns a :class:`~surfhap.signal.ar.LevinsonResult`: coefficients
    (P + 1, P), variances (P + 1,) (the mean forward-and-backward prediction-error
    power at each order, the statsmodels ``pacf_burg`` definition) and reflection coefficients (P,).
    """
    segs = _as_segments(x)
    if demean:
        segs = [s - s.mean() for s in segs]
    segs = [s for s in segs if s.size > max_order]
    if not segs:
        raise ValueError(f"need a segment longer than max_order={max_order}")
    n_total = sum(s.size for s in segs)
    energy = sum(float(s @ s) for s in segs) / n_total
    if not energy > 0:
        raise ValueError("signal has zero power")
    f = [s.copy() for s in segs]
    b = [s.copy() for s in segs]
    coefs = np.zeros((max_order + 1, max_order))
    variances = np.empty(max_order + 1)
    refl = np.zeros(max_order)
    variances[0] = energy
    a = np.zeros(max_order)
    for m in range(1, max_order + 1):
        num = 0.0
        den = 0.0
        for fi, bi in zip(f, b):
            ff = fi[m:]
            bb = bi[m - 1 : -1]
            num += float(ff @ bb)
            den += float(ff @ ff + bb @ bb)
        k = 2.0 * num / den if den > 0 else 0.0
        for i in range(len(f)):
            ff = f[i][m:].copy()
            bb = b[i][m - 1 : -1].copy()
            f[i][m:] = ff - k * bb
            b[i][m:] = bb - k * ff
        prev = a[: m - 1].copy()
        a[: m - 1] = prev - k * prev[::-1]
        a[m - 1] = k
        refl[m - 1] = k
        power = sum(float(fi[m:] @ fi[m:] + bi[m:] @ bi[m:]) for fi, bi in zip(f, b))
        variances[m] = power / (2.0 * sum(fi.size - m for fi in f))
        coefs[m, :m] = a[:m]
    return LevinsonResult(coefs, variances, refl)


def burg(x: np.ndarray | Sequence[np.ndarray], order: int, demean: bool = True) -> tuple[np.ndarray, float]:
    """Burg AR fit of one order: (phi (order,), sigma2). Matches ``statsmodels``
    ``regression.linear_model.burg`` on a single signal."""
    return burg_all_orders(x, order, demean=demean).order(order)


def select_order_burg(
    x: np.ndarray | Sequence[np.ndarray],
    max_order: int = 100,
    criterion: str = "aic",
    min_order: int = 1,
    demean: bool = True,
) -> OrderSelection:
    """Order by AIC (or BIC) with Burg estimates; same result type as
    :func:`surfhap.signal.ar.select_order`. ``n`` is the total number of samples."""
    check_criterion(criterion)
    segs = _as_segments(x)
    if any(not np.all(np.isfinite(s)) for s in segs):
        raise ValueError("signal contains NaN or inf")
    lev = burg_all_orders(segs, max_order, demean=demean)
    return order_selection(lev, sum(s.size for s in segs if s.size > max_order), criterion, min_order)
