"""Counterbalancing helpers: balanced Latin squares and balanced assignments (seeded)."""

from __future__ import annotations

import numpy as np

__all__ = ["balanced_latin_square", "participant_rng", "balanced_assignment"]


def balanced_latin_square(n: int) -> np.ndarray:
    """(n, n) int Williams design: every condition once per row and per column, and (n even)
    every ordered pair of neighbours exactly once. For odd n the square and its mirror (2n
    rows) are needed for that; this returns the first n rows (each condition once per position).
    Row r is the order for participant r (mod n)."""
    if n < 1:
        raise ValueError("n must be >= 1")
    j = np.arange(n)
    first = np.where(j % 2 == 1, (j + 1) // 2, (n - j // 2) % n)  # 0, 1, n-1, 2, n-2, ...
    return (first[None, :] + j[:, None]) % n


def participant_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of participant ``index`` in a study with ``seed``: independent streams."""
    return np.random.default_rng([int(seed), int(index)])


def balanced_assignment(n_items: int, n_values: int, rng: np.random.Generator) -> np.ndarray:
    """(n_items,) values 0..n_values-1, each used floor or ceil(n_items / n_values) times, in
    random order (which values get the extra use is random too)."""
    base = np.tile(np.arange(n_values), n_items // n_values + 1)[:n_items]
    extra = n_items % n_values
    if extra:
        base[-extra:] = rng.permutation(n_values)[:extra]
    return rng.permutation(base)
