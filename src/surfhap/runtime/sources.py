"""Replayed touch sources: a trajectory (or a recording's finger track) pushed into the engine
at its own stamps.

:class:`TrajectorySource` is the one replay of a trajectory into a touch sink. On a simulated
clock :func:`surfhap.runtime.loop.run` calls :meth:`TrajectorySource.deliver` before each
block: every sample stamped at or before the horizon is handed over with its stamp as arrival
time, so it is in force from the model sample at its stamp on, exactly as the offline hold
does. With ``wall_clock=True`` its own thread (between ``start()`` and ``stop()``) sleeps until
each stamp and delivers it with the receive time as arrival time, like a live source (OSC,
web page), which implement the same :class:`~surfhap.runtime.protocols.Source` protocol.
"""

from __future__ import annotations

import threading

import numpy as np

from surfhap.render.hold import TrajectoryRows
from surfhap.render.offline import model_samples
from surfhap.runtime.clock import now, sleep_until

__all__ = ["TrajectorySource", "ReplayRows", "model_samples", "drive_frames"]


def drive_frames(n_model: int, control_rate: int, drive_rate: int) -> int:
    """Drive samples that ``n_model`` model samples give at ``drive_rate`` (whole model periods)."""
    return (int(n_model) * int(drive_rate)) // int(control_rate)


class TrajectorySource:
    """A :class:`~surfhap.models.trajectory.Trajectory` replayed at its stamps (s from its
    first sample) into ``sink.push_touch`` (the engine), then a lift one sample period after
    the last (or at ``stop()``). ``source``: the engine's source id. ``loop`` repeats it every
    period (last stamp + one sample period) for at most ``max_seconds``. ``wall_clock``: its
    own thread replays it in real time from ``start()`` on; otherwise the caller's simulated
    clock calls :meth:`deliver`. ``sent`` counts the samples pushed; ``done`` is set by the lift."""

    def __init__(self, sink, trajectory, source: int = 1, *, loop: bool = False, max_seconds: float = 3600.0,
                 wall_clock: bool = False):
        self.sink, self.trajectory, self.source = sink, trajectory, int(source)
        self.loop, self.max_seconds, self.wall_clock = bool(loop), float(max_seconds), bool(wall_clock)
        self.t_rel = np.asarray(trajectory.t - trajectory.t[0], dtype=float)
        self.t_lift = float(self.t_rel[-1]) + (float(self.t_rel[-1] - self.t_rel[-2]) if self.t_rel.size > 1 else 1e-3)
        self.sent = 0
        self.done = threading.Event()
        self._run, self._thread = False, None

    @property
    def duration(self) -> float:
        return float(self.t_rel[-1])

    def deliver(self, until: float, stamped: bool = True) -> float:
        """Push every sample stamped at or before ``until`` (s from the first sample), and the
        final lift when its time has come; ``stamped``: the stamp is the arrival time too (a
        simulated clock), else the sink stamps the arrival. Returns the next stamp due."""
        tr, n = self.trajectory, self.t_rel.size
        while not self.done.is_set():
            lap, i = divmod(self.sent, n)
            end = lap > 0 and not self.loop
            ts = self.t_lift if end else lap * self.t_lift + float(self.t_rel[i])
            if ts > until:
                return ts
            arrival = ts if stamped else None
            if end or ts > self.max_seconds:
                self.sink.push_touch(self.source, 0.0, 0.0, 0.0, t_event=ts, t_arrival=arrival)
                self.done.set()
            else:
                self.sink.push_touch(self.source, float(tr.x[i]), float(tr.y[i]), float(tr.load[i]), t_event=ts,
                                     t_arrival=arrival)
                self.sent += 1
        return np.inf

    def start(self) -> None:
        self.sent = 0
        self.done.clear()
        if self.wall_clock:
            self._run = True
            self._thread = threading.Thread(target=self._play, name="surfhap-replay", daemon=True)
            self._thread.start()

    def _play(self) -> None:
        start, due = now(), 0.0
        try:
            while self._run and not self.done.is_set():
                sleep_until(start + due)
                if self._run:
                    due = self.deliver(due, stamped=False)
        finally:
            if not self.done.is_set():
                self.sink.push_touch(self.source, 0.0, 0.0, 0.0)
                self.done.set()

    def stop(self) -> None:
        self._run = False
        if self._thread is None:
            self.done.set()
        else:  # the thread pushes the lift as it ends
            self._thread.join(2.0)
            self._thread = None


class ReplayRows(TrajectoryRows):
    """A trajectory's rows (:class:`~surfhap.render.hold.TrajectoryRows`) released at their
    stamps: ``deliver(until)`` (the loop's :class:`~surfhap.runtime.loop.Replay`) makes every
    row stamped at or before ``until`` readable, vectorised (the offline render's source)."""

    def __init__(self, trajectory):
        super().__init__(trajectory)
        self.write = 0  # nothing released before the first delivery

    def deliver(self, until: float) -> None:
        self.write = max(self.write, int(np.searchsorted(self.rows[:, 2], until, side="right")))
