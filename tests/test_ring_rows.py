"""The live engine's rings against plain Python lists: ring_rows_since (the trace rings of the
live engine and of the force-feedback page, read through one function) and the compiled drive
FIFO and trace-row kernels."""

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


@settings(max_examples=200, deadline=None)
@given(chunks=st.lists(st.lists(st.floats(-300, 300), max_size=40), max_size=30), take=st.integers(1, 50))
def test_drive_fifo_kernels_match_a_plain_queue(chunks, take):
    """The engine's drive FIFO (compiled ring write with peak, ring read) against a Python list:
    same samples in the same order across wrap-arounds, and the peak of every chunk."""
    from surfhap.live.fifo_kernels import fifo_read, fifo_write_peak

    cap = 64
    fifo = np.full(cap, np.nan)
    queue: list[float] = []
    r = w = 0
    for chunk in chunks:
        drive = np.array(chunk, dtype=float)
        if w + drive.size - r > cap:
            break
        peak = fifo_write_peak(fifo, cap - 1, w, drive)
        assert peak == (np.abs(drive).max() if drive.size else 0.0)
        w += drive.size
        queue.extend(chunk)
        k = min(take, w - r)
        out = np.empty(k)
        fifo_read(fifo, cap - 1, r, out)
        r += k
        np.testing.assert_array_equal(out, queue[:k])
        del queue[:k]


def test_fifo_peak_is_nan_when_a_sample_is_and_trace_rows_wrap():
    from surfhap.live.engine import TRACE_FIELDS
    from surfhap.live.fifo_kernels import fifo_write_peak, mean_or_nan, record_chunk

    fifo = np.zeros(8)
    assert np.isnan(fifo_write_peak(fifo, 7, 6, np.array([1.0, np.nan, 400.0])))
    assert fifo[6] == 1.0 and np.isnan(fifo[7])
    assert fifo[0] == 400.0  # wrapped
    assert np.isnan(mean_or_nan(np.zeros(0))) and mean_or_nan(np.array([1.0, 2.0, 6.0])) == 3.0
    trace = np.zeros((4, len(TRACE_FIELDS)))
    inputs = np.array([[4.0, 9], [5, 9], [9, 9], [2, 9], [3, 9]])  # speed, load, touch time, x, y; 2 model samples
    lat, applied = np.zeros(4), np.array([[0.5, 0.25], [0.0, 1.0]])  # arrivals (s) at model samples 0 and 1
    record_chunk(np.zeros(8), 7, 0, np.array([-6.0, 0.0]), trace, 5, 1.0, inputs, np.array([7.0, 0.0]), np.array([6.0, 10.0]), lat, 3, applied, 2, 1.0, 10, 20.0)
    np.testing.assert_array_equal(trace[1], np.arange(1, 9))
    assert not trace[[0, 2, 3]].any()
    # emitted at 1 s + (10 + pos * 2 drive / 2 model samples) / 20 Hz; ring of 4 from write count 3
    np.testing.assert_allclose(lat[[3, 0]], [1.0 + 10 / 20 - 0.5, 1.0 + 11 / 20 - 0.25])
