"""Hold the latest finger sample at the drive rate (one helper for every chain).

The texture chain (:mod:`surfhap.render.chain`), the offline shape render and the live shape
renderer (:mod:`surfhap.render.shape_renderer`) all turn finger samples that arrive at a slow
rate (touch or control rate) into drive-rate inputs of the safety stage: for each drive sample,
the load and the age of the freshest finger sample in force at its time. :func:`hold_latest`
is that zero-order hold.

Time base: drive sample ``J`` is emitted at ``t_J = J / drive_rate`` s on the chain's clock
(0 at reset); source sample ``k`` is in force from ``src_time[k]`` s on (times
non-decreasing). A source sample counts from ``src_time[k] <= t_J + tol``: ``tol`` absorbs
the rounding of the two time bases.

**The touch model** (:class:`TouchHold`): the latest touch sample, held from the model sample
at its arrival stamp on.

This is what a live engine can know: a sample cannot act before it arrived, and once in force
it holds until the next one. Offline (``surfhap render``) the samples of a trajectory arrive
at their stamps; live they arrive when the sensor delivers them, stamped by the engine
(:func:`surfhap.runtime.clock.arrival_stamp`). Both go through this one hold, so a simulated
run on a trajectory and its offline render give the same drive (tests/test_play_render_equality.py); the offline render
(:class:`surfhap.runtime.offline.OfflineEngine`) and the offline shape render feed it a
trajectory's rows directly (:class:`TrajectoryRows`).

Chain clock: model sample ``k`` of the renderer is at ``anchor + k / control_rate`` on the
engine clock. ``anchor`` follows the emission time: at each block it is raised so that the
chain never runs behind ``now`` (a stall or a late block re-anchors it), so a sample that has
arrived by ``now`` is in force at the latest from the next model sample computed. A sample
with a later stamp waits, unapplied, until the chain reaches it (a simulated clock delivers
samples ahead of the block; a live one may deliver a sample stamped after the block began).

Per sample, in order: arbitration (one finger at a time: another source may take over when
the owner has been silent ``takeover`` s), staleness (a non-finite, future or non-monotonic
stamp makes it stale: counted, never refreshes the watchdog; a stale lift still lifts), lift
(the predictor restarts; a lift applied late reports the model sample it belonged to, so the
engine silences the drive queued since), position and speed (``predictor``,
:class:`surfhap.render.kinematics.TouchPredictor`). ``touch_time`` handed to the renderer is the
stamp of the sample in force on the chain clock, so its watchdog sees how old the data is.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["hold_latest", "control_times", "TouchHold", "TrajectoryRows", "NO_TOUCH_TIME", "NO_LIFT"]

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
    k = -1
    for j in range(out_load.shape[0]):
        t = (n_drive0 + j) / drive_rate
        while k + 1 < n and src_time[k + 1] <= t + tol:
            k += 1
        if k < 0:
            out_load[j] = last_load
            out_age[j] = t - last_stamp
        else:
            out_load[j] = load[k]
            out_age[j] = t - stamp[k]
        out_index[j] = k


@numba.njit(cache=True, nogil=True)
def control_times(n_model0, control_rate, out):
    """Start times (s) of the model samples ``n_model0 .. n_model0 + n - 1`` at ``control_rate``
    Hz into ``out`` (n,) float: the ``src_time`` of :func:`hold_latest` for a chain that runs
    at a fixed control rate."""
    for k in range(out.shape[0]):
        out[k] = (n_model0 + k) / control_rate


class TouchHold:
    """Popped touch samples (rows ``source, t_event, t_arrival, x, y, load``) put in force at
    their stamps; ``counters`` is the engine's dict (touches, touches_ignored, stale_stamps)."""

    def __init__(self, ring, predictor, takeover: float, counters: dict, capacity: int = 256):
        self.ring = ring  # pop_into(rows) -> count: where the samples come from
        self.predictor = predictor
        self.takeover = float(takeover)
        self.counters = counters
        self.buf = np.zeros((capacity, 6))
        self.arrivals = np.zeros(capacity)  # samples put in force since the engine last read them
        self.positions = np.zeros(capacity)  # ... and their positions in the chunk (model samples)
        self.reset()

    def reset(self) -> None:
        self.predictor.reset()
        self.n_buf = 0
        self.i_buf = 0
        self._full = False
        self.n_applied = 0
        self.anchor = -math.inf
        self.owner = -1.0
        self.owner_active = False
        self.owner_arrival = -math.inf
        self.last_arrival = -math.inf
        self.last_source_time = math.nan
        self.load = 0.0

    def take(self, now: float, chain_seconds: float) -> None:
        """Pop the ring behind the samples not yet in force and anchor the chain clock
        (``chain_seconds``: the chain's next model sample time, s from its 0) to ``now``."""
        if self.i_buf or self.n_buf < self.buf.shape[0]:
            self._refill()
        behind = now - chain_seconds
        if behind > self.anchor:
            self.anchor = behind

    def _refill(self) -> None:
        buf = self.buf
        if self.i_buf:
            rest = self.n_buf - self.i_buf
            if rest:
                buf[:rest] = buf[self.i_buf:self.n_buf].copy()
            self.n_buf, self.i_buf = rest, 0
        self.n_buf += self.ring.pop_into(buf[self.n_buf:])
        self._full = self.n_buf == buf.shape[0]  # the ring may hold more than fitted

    def due(self, t_arr: float, k_min: int, rate: float) -> int:
        """The first model sample (>= ``k_min``) at which a sample stamped ``t_arr`` is in force."""
        x = (t_arr - _DUE_TOL - self.anchor) * rate
        if not (t_arr > _STALE and x > k_min):  # stale, NaN, or due already (also a stamp ages ago: -inf)
            return k_min
        k = max(k_min, int(math.ceil(x)) - 1)
        while not t_arr <= self.anchor + k / rate + _DUE_TOL:
            k += 1
        return k

    def fill(self, k0: int, rate: float, sp, ld, ti, xs, ys) -> int:
        """Fill the (n,) inputs of model samples ``k0 ..`` with the sample in force at each;
        returns the earliest model sample of a lift applied late (``NO_LIFT`` if none)."""
        pred = self.predictor
        if self.i_buf == self.n_buf and not self._full:  # nothing waiting (most live chunks): one run
            load = self.load
            sp.fill(pred.speed if load > 0.0 else 0.0)
            ld.fill(load)
            ti.fill(self.last_arrival - self.anchor if self.last_arrival > -math.inf else NO_TOUCH_TIME)
            xs.fill(pred.x)
            ys.fill(pred.y)
            return NO_LIFT
        n = sp.shape[0]
        buf = self.buf
        late_lift = NO_LIFT
        runs = r_end, r_sp, r_ld, r_ti, r_x, r_y = [], [], [], [], [], []  # offline: per run of one sample
        pos = 0
        while pos < n:
            t_k = self.anchor + (k0 + pos) / rate + _DUE_TOL
            while True:
                if self.i_buf == self.n_buf and self._full:
                    self._refill()  # the buffer ran dry: more is waiting in the ring
                if self.i_buf == self.n_buf:
                    nxt = math.inf
                    break
                row = buf[self.i_buf].tolist()  # Python floats: cheap arithmetic below
                nxt = row[2]
                if not nxt <= t_k:
                    break
                k_lift = self._apply(row, k0 + pos, pos, rate)
                if k_lift < late_lift:
                    late_lift = k_lift
                self.i_buf += 1
            end = n if nxt == math.inf else min(n, self.due(nxt, k0 + pos + 1, rate) - k0)
            load = self.load
            if n <= 64:  # a live chunk: fill the run at once
                sp[pos:end] = pred.speed if load > 0.0 else 0.0
                ld[pos:end] = load
                ti[pos:end] = self.last_arrival - self.anchor if self.last_arrival > -math.inf else NO_TOUCH_TIME
                xs[pos:end] = pred.x
                ys[pos:end] = pred.y
                pos = end
                continue
            r_end.append(end)
            r_sp.append(pred.speed if load > 0.0 else 0.0)
            r_ld.append(load)
            r_ti.append(self.last_arrival - self.anchor if self.last_arrival > -math.inf else NO_TOUCH_TIME)
            r_x.append(pred.x)
            r_y.append(pred.y)
            pos = end
        if runs[0]:  # an offline block: the runs recorded, one vectorised fill
            counts = np.diff(runs[0], prepend=0)
            for lst, out in zip(runs[1:], (sp, ld, ti, xs, ys)):
                out[:] = np.repeat(lst, counts)
        return late_lift

    def _apply(self, row: list, k: int, pos: int, rate: float) -> int:
        src, t_ev, t_arr, x, y, load = row
        pred = self.predictor
        c = self.counters
        if not t_arr > _STALE or (src == self.owner and t_arr < self.owner_arrival):
            c["stale_stamps"] += 1  # untrusted (future / non-finite) or non-monotonic stamp
            t_arr = _STALE
        if src != self.owner:
            if self.owner_active and t_arr - self.owner_arrival < self.takeover:
                c["touches_ignored"] += 1
                return NO_LIFT
            self.owner = src
            pred.reset()
            self.last_source_time = math.nan
        self.owner_arrival = t_arr
        self.last_arrival = t_arr
        c["touches"] += 1
        a = self.n_applied
        if a < self.arrivals.shape[0] and t_arr > _STALE:
            self.arrivals[a] = t_arr
            self.positions[a] = pos
            self.n_applied = a + 1
        if not load > 0.0:
            self.owner_active = False
            self.load = 0.0
            pred.reset()
            k_lift = self.due(t_arr, -NO_LIFT, rate)
            return k_lift if k_lift < k else NO_LIFT
        if t_arr == _STALE:  # data of unknown age: not used (the watchdog holds 0 V)
            return NO_LIFT
        self.owner_active = True
        self.load = load
        # the source's time stamps give the intervals when they are sane, else arrival
        ts = t_ev if (t_ev == t_ev and (self.last_source_time != self.last_source_time
                                        or t_ev >= self.last_source_time)) else math.nan
        if ts == ts:
            self.last_source_time = ts
            pred.update(ts, x, y)
        else:
            pred.update(t_arr, x, y)
        return NO_LIFT


class TrajectoryRows:
    """A trajectory's samples as touch rows (source, stamp, stamp, x, y, load), stamps in s
    from its first sample, popped in order (the ring of an offline :class:`TouchHold`)."""

    def __init__(self, trajectory):
        t = trajectory.t - trajectory.t[0]
        self.rows = np.column_stack([np.ones(t.size), t, t, trajectory.x, trajectory.y, trajectory.load])
        self.i = 0

    def pop_into(self, out: np.ndarray) -> int:
        k = min(out.shape[0], self.rows.shape[0] - self.i)
        out[:k] = self.rows[self.i:self.i + k]
        self.i += k
        return k
