"""Splicing: the continuous spans of a recording whose speed stays near a reference velocity.

Otake et al. (2022, Sec. II) keep "continuous regions of 100 ms or longer ... wherein the
actual velocity was within +-20 mm/s" of each reference velocity; the spans are then
analysed together. Spans never cross a gap in ``valid`` (no contact).
"""

from __future__ import annotations

import numpy as np

__all__ = ["true_runs", "speed_spans", "splice"]


def true_runs(mask: np.ndarray, min_length: int = 1, breaks: np.ndarray | None = None) -> np.ndarray:
    """Runs of True in mask (n,) bool as an (k, 2) int array of [start, stop) indices,
    keeping runs of at least ``min_length`` samples; a run is also cut at each index in
    ``breaks`` (the starts of concatenated pieces)."""
    m = np.asarray(mask, dtype=bool).astype(np.int8)
    if m.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    d = np.diff(np.concatenate(([0], m, [0])))
    starts = np.flatnonzero(d == 1)
    stops = np.flatnonzero(d == -1)
    if breaks is not None:
        b = np.asarray(breaks, dtype=np.int64)
        b = b[(b > 0) & (b < m.size)]
        b = b[(m[b] == 1) & (m[b - 1] == 1)]  # inside a run: one more stop and start there
        starts, stops = np.sort(np.concatenate((starts, b))), np.sort(np.concatenate((stops, b)))
    keep = (stops - starts) >= max(1, int(min_length))
    return np.stack([starts[keep], stops[keep]], axis=1).astype(np.int64)


def speed_spans(
    speed: np.ndarray,
    sample_rate: float,
    reference: float,
    tolerance: float = 0.020,
    min_duration: float = 0.100,
    valid: np.ndarray | None = None,
    breaks: np.ndarray | None = None,
) -> np.ndarray:
    """Spans where ``|speed - reference| <= tolerance`` for at least ``min_duration`` s.

    speed (n,) m/s (its magnitude is used); valid (n,) bool or None; tolerance m/s; no span
    crosses an index in ``breaks`` (see :func:`true_runs`); returns (k, 2) int [start, stop) indices.
    """
    v = np.abs(np.asarray(speed, dtype=float))
    ok = np.abs(v - reference) <= tolerance
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    return true_runs(ok, int(np.ceil(min_duration * sample_rate - 1e-9)), breaks)


def splice(x: np.ndarray, spans: np.ndarray) -> list[np.ndarray]:
    """The pieces of x (n,) over spans (k, 2): a list of k views."""
    x = np.asarray(x)
    return [x[a:b] for a, b in np.asarray(spans, dtype=np.int64)]
