"""Hold the latest finger sample: at the drive rate (:func:`hold_latest`) and at the control
rate (:class:`TouchHold`), one helper for every chain.

:func:`hold_latest` turns slow finger samples into the drive-rate inputs of the safety stage
(the texture chain, the shape chains): for drive sample ``J`` at ``t_J = J / drive_rate`` s on
the chain's clock (0 at reset), the load and the touch age of the latest source sample ``k``
with ``src_time[k] <= t_J + tol`` (times non-decreasing; ``tol`` absorbs rounding).

**The touch model** (:class:`TouchHold`): the latest touch sample, in force from the model
sample at its arrival stamp on until the next one. That is what a live engine can know.
Offline the samples of a trajectory arrive at their stamps (:class:`TrajectoryRows`, fed by
:class:`surfhap.runtime.offline.OfflineEngine` and the offline shape render); live they arrive
when the sensor delivers them, stamped by the engine (:func:`surfhap.runtime.clock.arrival_stamp`).
Both run this one compiled hold (one call per chunk, the predictor step per sample), so a
simulated run on a trajectory and its offline render give the same drive
(tests/test_play_render_equality.py).

Chain clock: model sample ``k`` is at ``anchor + k / control_rate`` on the engine clock;
``anchor`` is raised at each block so that the chain never runs behind ``now`` (a stall
re-anchors it). A sample stamped later than the chain waits, unapplied, until the chain reaches it.

Per sample, in order: arbitration (one finger at a time: another source may take over when
the owner has been silent ``takeover`` s), staleness (a non-finite, future or non-monotonic
stamp makes it stale: counted, never refreshes the watchdog; a stale lift still lifts), lift
(the predictor restarts; a lift applied late reports the model sample it belonged to, so the
engine silences the drive queued since), position and speed
(:func:`surfhap.render.kinematics.predict`). The touch time handed to the renderer is the
stamp of the sample in force on the chain clock, so its watchdog sees how old the data is.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from surfhap.render.carrier import polarity
from surfhap.render.kinematics import _STARTED, _SPEED, _X, _Y, TouchPredictor, predict
from surfhap.render.safety import stage_block

__all__ = ["hold_latest", "control_times", "drive_tail", "tail_state", "TouchHold", "TrajectoryRows", "NO_TOUCH_TIME", "NO_LIFT", "COUNTERS"]

NO_TOUCH_TIME = -1.0e6  # "touched long ago": the watchdog holds the output at zero
NO_LIFT = 1 << 62  # TouchHold.fill(): no late lift in this chunk
_STALE = -math.inf  # the arrival stamp of an untrusted sample: surfhap.runtime.clock.STALE
_DUE_TOL = 1e-12  # s: a sample stamped t is in force at model sample k when t <= t_k + tol


@numba.njit(cache=True, nogil=True)
def hold_latest(n_drive0, drive_rate, src_time, tol, load, stamp, last_load, last_stamp, out_load, out_age, out_index):
    """Zero-order hold of source samples onto the drive samples ``J = n_drive0 .. n_drive0 + m - 1``.

    n_drive0 : int, index of the first drive sample; drive_rate: Hz.
    src_time : (n,) float s, when each source sample comes into force (non-decreasing).
    tol      : s, rounding tolerance of the comparison.
    load     : (n,) float N; stamp: (n,) float s, time stamp of the touch data behind each
               source sample.
    last_load, last_stamp : N and s, what holds before the first source sample (the previous
               block's last sample; 0 N and -inf s at the start).
    out_load, out_age : (m,) float, filled with the held load (N) and the touch age
               ``t_J - stamp`` (s; inf with no touch yet); out_index (m,) int64: the source
               sample held (-1 before the first).
    """
    n = src_time.shape[0]
    control_times(n_drive0, drive_rate, out_age)  # t_J, vectorised; the hold turns them into ages
    k = -1
    held, since = last_load, last_stamp  # of sample k, in registers while it holds
    nxt = src_time[0] if n > 0 else math.inf  # when sample k + 1 comes into force (inf: none left)
    for j in range(out_load.shape[0]):
        t = out_age[j]
        while nxt <= t + tol:
            k += 1
            held, since = load[k], stamp[k]
            nxt = src_time[k + 1] if k + 1 < n else math.inf
        out_load[j] = held
        out_age[j] = t - since
        out_index[j] = k


@numba.njit(cache=True, nogil=True)
def control_times(n_model0, control_rate, out):
    """Start times (s) of the model samples ``n_model0 .. n_model0 + n - 1`` at ``control_rate``
    Hz into ``out`` (n,) float: the ``src_time`` of :func:`hold_latest` for a chain that runs
    at a fixed control rate."""
    for b in range(0, out.shape[0], 1 << 20):
        o = out[b:b + (1 << 20)]
        n_b = n_model0 + b
        for k in range(np.int32(o.shape[0])):  # int32 -> float converts in vectors (int64 does not, before AVX-512)
            o[k] = (n_b + np.float64(np.int32(k))) / control_rate  # the same sum: integers, exact in float64


_TAIL_CHUNK = 1024  # drive samples per pass of the hold, carrier and safety: their arrays stay in the cache


@numba.njit(cache=True, nogil=True)
def drive_tail(m, load, touch_time, state, work, index, safety, drive, load_drive):
    """The tail every chain ends with, on ``drive[:m]`` (the envelope at the drive rate, V) in
    place: the finger of the model samples (load, touch_time (n,)) held at the drive rate
    (``load_drive``, touch ages in ``work[1]``), the polarity carrier, the safety stage (state,
    counters, limits of :meth:`~surfhap.render.safety.SafetyStage.kernel_args`). ``state``
    (float): model and drive samples so far, control and drive rate (Hz), carrier step, hold
    tolerance (s), the last load and touch time, advanced here; ``work`` (2, >= n + m), ``index``
    (>= m) scratch. Runs in chunks of drive samples (same samples as one pass). Returns m."""
    n = load.shape[0]
    if work.shape[1] < n + min(m, _TAIL_CHUNK) or index.shape[0] < m:  # numba checks no bounds: a short scratch would corrupt memory
        raise ValueError("drive_tail: work needs n + min(m, 1024) columns and index m")
    src = work[0, :n]
    control_times(state[0], state[2], src)
    age = work[1, :m]
    k0 = 0  # the model samples before k0 are in force (the latest: last_load, last_stamp)
    last_load, last_stamp = state[6], state[7]
    for j0 in range(0, m, _TAIL_CHUNK):
        j1 = min(j0 + _TAIL_CHUNK, m)
        hold_latest(state[1] + j0, state[3], src[k0:], state[5], load[k0:], touch_time[k0:], last_load, last_stamp,
                    load_drive[j0:j1], age[j0:j1], index[j0:j1])
        if index[j1 - 1] >= 0:
            k0 += index[j1 - 1]
            last_load, last_stamp = load[k0], touch_time[k0]
            k0 += 1
        carried = work[0, n:n + j1 - j0]  # not in place: the carrier's and the safety's loops vectorise
        polarity(drive[j0:j1], state[1] + j0, state[4], carried)
        stage_block(carried, load_drive[j0:j1], age[j0:j1], drive[j0:j1], *safety)
    state[0] += n
    state[1] += m
    if n:
        state[6], state[7] = load[n - 1], touch_time[n - 1]
    return m


def tail_state(control_rate: float, drive_rate: float, carrier_step: float) -> np.ndarray:
    """A fresh :func:`drive_tail` state (no sample yet: 0 N, touched never)."""
    return np.array([0.0, 0.0, control_rate, drive_rate, carrier_step, 1e-9 / control_rate, 0.0, -np.inf])


# H: the hold's float state; I: its int64 state and counters (``TouchHold.counts``)
_ANCHOR, _OWNER, _ACTIVE, _OWNER_ARR, _LAST_ARR, _LAST_SRC, _LOAD, _TAKEOVER = range(8)
_N_BUF, _I_BUF, _FULL, _N_APPLIED, _TOUCHES, _IGNORED, _STALE_N = range(7)
COUNTERS = ("touches", "touches_ignored", "stale_stamps")


@numba.njit(cache=True, nogil=True)
def _refill(src, r, w, buf, I):
    # compact the buffer, then pop source rows r.. (< w; ring index mod its length) behind it
    i, n = I[_I_BUF], I[_N_BUF] - I[_I_BUF]
    for j in range(n):
        buf[j] = buf[i + j]
    k = min(buf.shape[0] - n, w - r)
    for j in range(k):
        buf[n + j] = src[(r + j) % src.shape[0]]
    I[_N_BUF] = n + k
    I[_I_BUF] = 0
    I[_FULL] = n + k == buf.shape[0]  # the ring may hold more than fitted
    return k


@numba.njit(cache=True, nogil=True)
def _due(t_arr, k_min, rate, anchor):
    # the first model sample (>= k_min) at which a sample stamped t_arr is in force
    x = (t_arr - _DUE_TOL - anchor) * rate
    if not (t_arr > _STALE and x > k_min):  # stale, NaN, or due already (also a stamp ages ago: -inf)
        return k_min
    if x > 1e18:
        return NO_LIFT  # never within reach
    k = max(k_min, int(math.ceil(x)) - 1)
    while not t_arr <= anchor + k / rate + _DUE_TOL:
        k += 1
    return k


@numba.njit(cache=True, nogil=True)
def _apply(row, k, pos, rate, H, I, P, lat):
    # one popped sample: arbitration, staleness, lift, prediction; returns a late lift's model sample
    src, t_ev, t_arr, x, y, load = row[0], row[1], row[2], row[3], row[4], row[5]
    if not t_arr > _STALE or (src == H[_OWNER] and t_arr < H[_OWNER_ARR]):
        I[_STALE_N] += 1  # untrusted (future / non-finite) or non-monotonic stamp
        t_arr = _STALE
    if src != H[_OWNER]:
        if H[_ACTIVE] != 0.0 and t_arr - H[_OWNER_ARR] < H[_TAKEOVER]:
            I[_IGNORED] += 1
            return NO_LIFT
        H[_OWNER] = src
        P[_STARTED:] = 0.0
        H[_LAST_SRC] = math.nan
    H[_OWNER_ARR] = t_arr
    H[_LAST_ARR] = t_arr
    I[_TOUCHES] += 1
    a = I[_N_APPLIED]
    if a < lat.shape[1] and t_arr > _STALE:
        lat[0, a] = t_arr
        lat[1, a] = pos
        I[_N_APPLIED] = a + 1
    if not load > 0.0:
        H[_ACTIVE] = 0.0
        H[_LOAD] = 0.0
        P[_STARTED:] = 0.0
        k_lift = _due(t_arr, -NO_LIFT, rate, H[_ANCHOR])
        return k_lift if k_lift < k else NO_LIFT
    if t_arr == _STALE:  # data of unknown age: not used (the watchdog holds 0 V)
        return NO_LIFT
    H[_ACTIVE] = 1.0
    H[_LOAD] = load
    # the source's time stamps give the intervals when they are sane, else arrival
    last = H[_LAST_SRC]
    if t_ev == t_ev and (last != last or t_ev >= last):
        H[_LAST_SRC] = t_ev
        predict(P, t_ev, x, y)
    else:
        predict(P, t_arr, x, y)
    return NO_LIFT


@numba.njit(cache=True, nogil=True)
def _fill(src, r, w, refill, buf, H, I, P, lat, k0, rate, out):
    """Rows of ``out`` (5, n) = speed, load, touch time, x, y of model samples ``k0 ..``;
    returns (the earliest model sample of a lift applied late or NO_LIFT, rows popped)."""
    popped = 0
    if refill and (I[_I_BUF] or I[_N_BUF] < buf.shape[0]):
        popped += _refill(src, r, w, buf, I)
    n = out.shape[1]
    late_lift = NO_LIFT
    pos = 0
    while pos < n:
        t_k = H[_ANCHOR] + (k0 + pos) / rate + _DUE_TOL
        nxt = math.inf
        while True:
            if I[_I_BUF] == I[_N_BUF] and I[_FULL]:
                popped += _refill(src, r + popped, w, buf, I)  # the buffer ran dry: more is waiting
            if I[_I_BUF] == I[_N_BUF]:
                nxt = math.inf
                break
            nxt = buf[I[_I_BUF], 2]
            if not nxt <= t_k:
                break
            late_lift = min(late_lift, _apply(buf[I[_I_BUF]], k0 + pos, pos, rate, H, I, P, lat))
            I[_I_BUF] += 1
        end = n if nxt == math.inf else min(n, _due(nxt, k0 + pos + 1, rate, H[_ANCHOR]) - k0)
        load = H[_LOAD]
        last = H[_LAST_ARR]
        out[0, pos:end] = P[_SPEED] if load > 0.0 else 0.0
        out[1, pos:end] = load
        out[2, pos:end] = last - H[_ANCHOR] if last > -math.inf else NO_TOUCH_TIME
        out[3, pos:end] = P[_X]
        out[4, pos:end] = P[_Y]
        pos = end
    return late_lift, popped


class TouchHold:
    """Popped touch samples (rows ``source, t_event, t_arrival, x, y, load``) put in force at
    their stamps, in one compiled call per chunk (:meth:`fill`). ``ring`` is where they come
    from (``rows`` (cap, 6), ``read`` and ``write`` counters, ``consume(k)``: a
    :class:`~surfhap.live.queues.TouchRing` or :class:`TrajectoryRows`); ``counters`` (the
    engine's dict) receives :data:`COUNTERS` after each fill that applied samples; ``latencies`` (2, capacity): arrival stamp and position in
    the chunk (model samples) of the ``n_applied`` samples put in force since the engine last
    read them."""

    def __init__(self, ring, predictor: TouchPredictor, takeover: float, counters: dict | None = None,
                 capacity: int = 256):
        self.ring = ring
        self.counters = {} if counters is None else counters
        self.predictor = predictor
        self.buf = np.zeros((capacity, 6))
        self.H = np.zeros(8)
        self.I = np.zeros(7, dtype=np.int64)
        self.latencies = np.zeros((2, capacity))
        self.takeover = float(takeover)
        self._refill = False
        self.reset()

    def reset(self) -> None:
        self.predictor.reset()
        self.H[:] = (-math.inf, -1.0, 0.0, -math.inf, -math.inf, math.nan, 0.0, self.takeover)
        self.I[:] = 0

    anchor = property(lambda self: float(self.H[_ANCHOR]), lambda self, v: self.H.__setitem__(_ANCHOR, v),
                      doc="s, engine-clock time of the chain's model sample 0")
    last_arrival = property(lambda self: float(self.H[_LAST_ARR]), doc="s, stamp of the sample in force (-inf: none)")
    n_applied = property(lambda self: int(self.I[_N_APPLIED]), lambda self, v: self.I.__setitem__(_N_APPLIED, v))

    def take(self, now: float, chain_seconds: float) -> None:
        """Pop the ring behind the samples not yet in force (at the next :meth:`fill`) and
        anchor the chain clock (``chain_seconds``: the chain's next model sample time, s from
        its 0) to ``now``."""
        self._refill = True
        if now - chain_seconds > self.H[_ANCHOR]:
            self.H[_ANCHOR] = now - chain_seconds

    def fill(self, k0: int, rate: float, out: np.ndarray) -> int:
        """Fill ``out`` (5, n): speed (m/s), load (N), touch time (s on the chain clock), x, y
        (m) of model samples ``k0 ..`` with the sample in force at each; returns the earliest
        model sample of a lift applied late (``NO_LIFT`` if none)."""
        ring = self.ring
        late, popped = _fill(ring.rows, ring.read, ring.write, self._refill, self.buf, self.H, self.I,
                             self.predictor.state, self.latencies, k0, float(rate), out)
        self._refill = False
        if popped:
            ring.consume(popped)
        if self.I[_N_BUF]:  # samples were popped or wait in the buffer: the counters may have moved
            self.counters.update(zip(COUNTERS, self.I[_TOUCHES:].tolist()))
        return late


class TrajectoryRows:
    """A trajectory's samples as touch rows (source, stamp, stamp, x, y, load), stamps in s
    from its first sample, all pending at once (the ring of an offline :class:`TouchHold`)."""

    def __init__(self, trajectory):
        t = trajectory.t - trajectory.t[0]
        self.rows = np.column_stack([np.ones(t.size), t, t, trajectory.x, trajectory.y, trajectory.load])
        self.read = 0
        self.write = t.size

    def consume(self, k: int) -> None:
        self.read += k
