"""Segmentation of long recordings into stationary pieces (piecewise AR).

Zhao et al. segment their acceleration recordings with Auto-PARM (Davis, Lee and
Rodriguez-Yam 2006), which minimises the minimum description length (MDL) of a piecewise
AR model with a genetic algorithm. surfhap minimises the same criterion exactly, by
dynamic programming (optimal partitioning with PELT pruning, Killick et al. 2012) over
candidate change points on a grid of ``step`` samples::

    MDL = log m + (m + 1) log n + sum_j [ log p_j + (p_j + 2)/2 log n_j + n_j/2 log sigma2_j ]

(m + 1 segments of n_j samples, AR order p_j chosen per segment in 0..max_order, sigma2_j
the Yule–Walker innovation variance; the constant n/2 log 2 pi is dropped). Each segment's
autocovariance comes in O(max_order) from prefix sums of lagged products, so a candidate
segment costs one Levinson–Durbin recursion. On piecewise-AR test signals it returns the
true breaks to within one grid step; unlike the genetic search it is deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

__all__ = ["Segmentation", "segment_ar"]


@numba.njit(cache=True, nogil=True)
def _segment_cost(S, C, s, e, max_order, r, a, prev, n_total_log):
    n = e - s
    m = (C[e] - C[s]) / n
    P = min(max_order, n - 2)
    for k in range(P + 1):
        sk = S[k, e - k] - S[k, s]
        A = C[e - k] - C[s]
        B = C[e] - C[s + k]
        r[k] = (sk - m * (A + B) + (n - k) * m * m) / n
    if r[0] <= 0:
        return -1e300, 0
    var = r[0]
    logn = np.log(n)
    best = 0.5 * n * np.log(var) + 1.0 * logn  # p = 0: (0 + 2)/2 log n, log p_j taken as 0
    best_p = 0
    for j in range(P):
        a[j] = 0.0
    for k in range(1, P + 1):
        acc = r[k]
        for j in range(k - 1):
            acc -= a[j] * r[k - 1 - j]
        kk = acc / var if var > 0 else 0.0
        for j in range(k - 1):
            prev[j] = a[j]
        for j in range(k - 1):
            a[j] = prev[j] - kk * prev[k - 2 - j]
        a[k - 1] = kk
        var = var * (1.0 - kk * kk)
        if var <= 0:
            break
        c = 0.5 * n * np.log(var) + 0.5 * (k + 2) * logn + np.log(k)
        if c < best:
            best = c
            best_p = k
    return best, best_p


@numba.njit(cache=True, nogil=True)
def _pelt(S, C, grid, min_len, max_len, max_order, penalty, prune_margin):
    K = grid.shape[0]
    F = np.full(K, np.inf)
    F[0] = -penalty
    last = np.zeros(K, dtype=np.int64)
    cand = np.zeros(K, dtype=np.int64)
    ncand = 1
    cand[0] = 0
    r = np.zeros(max_order + 1)
    a = np.zeros(max_order + 1)
    prev = np.zeros(max_order + 1)
    costs = np.empty(K)
    n_total_log = np.log(grid[K - 1] - grid[0])
    for j in range(1, K):
        best = np.inf
        best_i = -1
        for ci in range(ncand):
            i = cand[ci]
            if grid[j] - grid[i] < min_len or grid[j] - grid[i] > max_len:
                costs[ci] = np.inf
                continue
            c, _ = _segment_cost(S, C, grid[i], grid[j], max_order, r, a, prev, n_total_log)
            costs[ci] = c
            v = F[i] + c + penalty
            if v < best:
                best = v
                best_i = i
        F[j] = best
        last[j] = best_i
        # prune candidates that can never be optimal again, then add j
        nn = 0
        for ci in range(ncand):
            i = cand[ci]
            if grid[j] - grid[i] >= max_len:
                continue  # too long already: never a valid start again
            if costs[ci] == np.inf or F[i] + costs[ci] - prune_margin <= F[j]:
                cand[nn] = i
                nn += 1
        cand[nn] = j
        ncand = nn + 1
    return F, last


@dataclass(frozen=True)
class Segmentation:
    """Result of :func:`segment_ar`.

    bounds : (m + 2,) int sample indices [0, b_1, ..., b_m, n]; segment j is
             ``x[bounds[j]:bounds[j + 1]]``.
    orders : (m + 1,) int, MDL-best AR order of each segment.
    mdl    : total description length.
    """

    bounds: np.ndarray
    orders: np.ndarray
    mdl: float

    @property
    def change_points(self) -> np.ndarray:
        return self.bounds[1:-1]

    @property
    def segments(self) -> list[tuple[int, int]]:
        return [(int(a), int(b)) for a, b in zip(self.bounds[:-1], self.bounds[1:])]


def segment_ar(x: np.ndarray, max_order: int = 20, min_length: int = 200, step: int = 25,
               max_length: int | None = None) -> Segmentation:
    """Split x (n,) into stationary AR pieces by exact MDL minimisation (module docstring).

    max_order : largest AR order per segment; min_length : shortest segment, samples;
    step : grid of candidate change points, samples (the resolution of the breaks);
    max_length : longest segment, samples (None: unlimited). The search costs
    O((n / step)^2) segment fits without it and O(n / step x max_length / step) with it;
    a stationary stretch longer than max_length is cut into similar pieces.
    """
    x = np.ascontiguousarray(x, dtype=float)
    n = x.size
    if not np.all(np.isfinite(x)):
        raise ValueError("signal contains NaN or inf")
    if n < 2 * max(min_length, max_order + 2):
        grid = np.array([0, n], dtype=np.int64)
    else:
        grid = np.unique(np.concatenate((np.arange(0, n, max(1, int(step))), [n]))).astype(np.int64)
    P = int(max_order)
    S = np.zeros((P + 1, n + 1))
    for k in range(P + 1):
        if k < n:
            S[k, 1 : n - k + 1] = np.cumsum(x[: n - k] * x[k:])
    C = np.concatenate(([0.0], np.cumsum(x)))
    penalty = float(np.log(n))
    margin = 0.5 * (P + 2) * np.log(n) + np.log(max(P, 1)) + penalty
    max_len = n if max_length is None else int(max(max_length, 2 * max(min_length, P + 2)))
    F, last = _pelt(S, C, grid, int(max(min_length, P + 2)), max_len, P, penalty, margin)
    # backtrack
    idx = [grid.size - 1]
    while idx[-1] > 0:
        idx.append(int(last[idx[-1]]))
        if idx[-1] < 0:
            raise RuntimeError("segmentation failed (signal shorter than min_length?)")
    bounds = grid[np.array(idx[::-1])]
    r = np.zeros(P + 1)
    a = np.zeros(P + 1)
    prev = np.zeros(P + 1)
    orders = np.array([_segment_cost(S, C, int(s), int(e), P, r, a, prev, 0.0)[1] for s, e in zip(bounds[:-1], bounds[1:])])
    m = bounds.size - 2
    mdl = float(F[-1] + penalty + (np.log(m) if m > 0 else 0.0))
    return Segmentation(bounds.astype(np.int64), orders.astype(np.int64), mdl)
