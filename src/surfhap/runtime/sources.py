"""Replayed touch sources: a trajectory (or a recording's finger track) pushed into the engine
at its own stamps.

On a simulated clock :func:`surfhap.runtime.loop.run` calls :meth:`TrajectorySource.deliver`
before each block: every sample stamped at or before the horizon is handed over with its
stamp as arrival time, so it is in force from the model sample at its stamp on, exactly as
the offline hold does. On a wall clock the live :class:`surfhap.live.sources.ReplaySource`
sleeps until each stamp instead. The live sources (OSC, web page) implement the same
:class:`~surfhap.runtime.protocols.Source` protocol.
"""

from __future__ import annotations

import numpy as np

from surfhap.render.hold import TrajectoryRows
from surfhap.render.offline import model_samples

__all__ = ["TrajectorySource", "ReplayRows", "model_samples", "drive_frames"]


def drive_frames(n_model: int, control_rate: int, drive_rate: int) -> int:
    """Drive samples that ``n_model`` model samples give at ``drive_rate`` (whole model periods)."""
    return (int(n_model) * int(drive_rate)) // int(control_rate)


class TrajectorySource:
    """A :class:`~surfhap.models.trajectory.Trajectory` replayed at its stamps (s from its
    first sample) into ``sink.push_touch`` (the engine), then a lift one sample period after
    the last. ``source`` is the engine's source id."""

    def __init__(self, sink, trajectory, source: int = 1):
        self.sink = sink
        self.trajectory = trajectory
        self.source = int(source)
        self.t_rel = np.asarray(trajectory.t - trajectory.t[0], dtype=float)
        step = float(self.t_rel[-1] - self.t_rel[-2]) if self.t_rel.size > 1 else 1e-3
        self.t_lift = float(self.t_rel[-1]) + step
        self.sent = 0
        self.done = False

    @property
    def duration(self) -> float:
        return float(self.t_rel[-1])

    def start(self) -> None:
        self.sent = 0
        self.done = False

    def stop(self) -> None:
        self.done = True

    def deliver(self, until: float) -> None:
        """Push every sample stamped at or before ``until`` (s from the first sample), and the
        final lift when its time has come."""
        tr, t = self.trajectory, self.t_rel
        i = self.sent
        while i < t.size and t[i] <= until:
            ts = float(t[i])
            self.sink.push_touch(self.source, float(tr.x[i]), float(tr.y[i]), float(tr.load[i]), t_event=ts,
                                 t_arrival=ts)
            i += 1
        self.sent = i
        if i == t.size and not self.done and self.t_lift <= until:
            self.sink.push_touch(self.source, 0.0, 0.0, 0.0, t_event=self.t_lift, t_arrival=self.t_lift)
            self.done = True


class ReplayRows(TrajectoryRows):
    """A trajectory's rows (:class:`~surfhap.render.hold.TrajectoryRows`) released at their
    stamps: ``deliver(until)`` (the loop's :class:`~surfhap.runtime.loop.Replay`) makes every
    row stamped at or before ``until`` readable, vectorised (the offline render's source)."""

    def __init__(self, trajectory):
        super().__init__(trajectory)
        self.write = 0  # nothing released before the first delivery

    def deliver(self, until: float) -> None:
        self.write = max(self.write, int(np.searchsorted(self.rows[:, 2], until, side="right")))
