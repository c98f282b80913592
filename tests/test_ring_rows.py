"""ring_rows_since: the trace rings of the live engine and of the force-feedback page read
through one function; checked against a plain list of every row ever written."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from surfhap.live.queues import ring_rows_since


@settings(max_examples=300, deadline=None)
@given(writes=st.integers(0, 100), index=st.integers(0, 100), limit=st.one_of(st.none(), st.integers(0, 40)))
def test_rows_since_match_the_history(writes, index, limit):
    cap = 16
    ring = np.zeros((cap, 2))
    history = []
    for k in range(writes):
        ring[k & (cap - 1)] = (k, -k)
        history.append((k, -k))
    rows, end = ring_rows_since(ring, writes, index, limit)
    assert end == writes and rows.shape[1] == 2
    first = max(index, writes - cap + 1, 0 if limit is None else writes - limit)
    expected = np.array(history[first:writes], dtype=float).reshape(-1, 2)
    np.testing.assert_array_equal(rows, expected)
    rows[:] = 99.0  # a copy: the ring is untouched
    assert writes == 0 or ring[(writes - 1) & (cap - 1), 0] == writes - 1
