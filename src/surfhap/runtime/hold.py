"""The touch model of the runtime: the latest touch sample, held from the model sample at its
arrival stamp on (:class:`TouchHold`).

This is what a live engine can know: a sample cannot act before it arrived, and once in force
it holds until the next one. Offline (``surfhap render``) the samples of a trajectory arrive
at their stamps; live they arrive when the sensor delivers them, stamped by the engine
(:func:`surfhap.runtime.clock.arrival_stamp`). Both go through this one hold, so a simulated
run on a trajectory and its offline render give the same drive (tests/test_play_render_equality.py).

Chain clock: model sample ``k`` of the renderer is at ``anchor + k / model_rate`` on the
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

import numpy as np

from surfhap.runtime.clock import STALE

__all__ = ["TouchHold", "NO_TOUCH_TIME", "NO_LIFT"]

NO_TOUCH_TIME = -1.0e6  # "touched long ago": the watchdog holds the output at zero
NO_LIFT = 1 << 62  # fill(): no late lift in this chunk
_DUE_TOL = 1e-12  # s: a sample stamped t is in force at model sample k when t <= t_k + tol (as offline)


class TouchHold:
    """Popped touch samples (rows ``source, t_event, t_arrival, x, y, load``) put in force at
    their stamps; ``counters`` is the engine's dict (touches, touches_ignored, stale_stamps)."""

    def __init__(self, predictor, takeover: float, counters: dict, capacity: int = 256):
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
        self.n_applied = 0
        self.anchor = -math.inf
        self.owner = -1.0
        self.owner_active = False
        self.owner_arrival = -math.inf
        self.last_arrival = -math.inf
        self.last_source_time = math.nan
        self.load = 0.0

    def take(self, ring, now: float, chain_seconds: float) -> None:
        """Pop ``ring`` behind the samples not yet in force and anchor the chain clock
        (``chain_seconds``: the chain's next model sample time, s from its 0) to ``now``."""
        buf = self.buf
        if self.i_buf:
            rest = self.n_buf - self.i_buf
            buf[:rest] = buf[self.i_buf:self.n_buf].copy()
            self.n_buf, self.i_buf = rest, 0
        self.n_buf += ring.pop_into(buf[self.n_buf:])
        behind = now - chain_seconds
        if behind > self.anchor:
            self.anchor = behind

    def due(self, t_arr: float, k_min: int, rate: float) -> int:
        """The first model sample (>= ``k_min``) at which a sample stamped ``t_arr`` is in force."""
        if not t_arr > STALE:
            return k_min
        k = max(k_min, int(math.ceil((t_arr - _DUE_TOL - self.anchor) * rate)) - 1)
        while not t_arr <= self.anchor + k / rate + _DUE_TOL:
            k += 1
        return k

    def fill(self, k0: int, rate: float, sp, ld, ti, xs, ys) -> int:
        """Fill the (n,) inputs of model samples ``k0 ..`` with the sample in force at each;
        returns the earliest model sample of a lift applied late (``NO_LIFT`` if none)."""
        n = sp.shape[0]
        buf = self.buf
        pred = self.predictor
        late_lift = NO_LIFT
        pos = 0
        while pos < n:
            t_k = self.anchor + (k0 + pos) / rate + _DUE_TOL
            while self.i_buf < self.n_buf and buf[self.i_buf, 2] <= t_k:
                k_lift = self._apply(self.i_buf, k0 + pos, pos, rate)
                if k_lift < late_lift:
                    late_lift = k_lift
                self.i_buf += 1
            end = n
            if self.i_buf < self.n_buf:
                end = min(n, self.due(buf[self.i_buf, 2], k0 + pos + 1, rate) - k0)
            sp[pos:end] = pred.speed if self.load > 0.0 else 0.0
            ld[pos:end] = self.load
            ti[pos:end] = self.last_arrival - self.anchor if self.last_arrival > -math.inf else NO_TOUCH_TIME
            xs[pos:end] = pred.x
            ys[pos:end] = pred.y
            pos = end
        return late_lift

    def _apply(self, i: int, k: int, pos: int, rate: float) -> int:
        buf = self.buf
        src, t_ev, t_arr, x, y, load = buf[i, 0], buf[i, 1], buf[i, 2], buf[i, 3], buf[i, 4], buf[i, 5]
        pred = self.predictor
        c = self.counters
        if not t_arr > STALE or (src == self.owner and t_arr < self.owner_arrival):
            c["stale_stamps"] += 1  # untrusted (future / non-finite) or non-monotonic stamp
            t_arr = STALE
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
        if a < self.arrivals.shape[0] and t_arr > STALE:
            self.arrivals[a] = t_arr
            self.positions[a] = pos
            self.n_applied = a + 1
        if not load > 0.0:
            self.owner_active = False
            self.load = 0.0
            pred.reset()
            k_lift = self.due(t_arr, -NO_LIFT, rate)
            return k_lift if k_lift < k else NO_LIFT
        if t_arr == STALE:  # data of unknown age: not used (the watchdog holds 0 V)
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
