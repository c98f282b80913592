"""The one block loop: :func:`run` connects a touch source, an engine (a renderer behind its
safety stages), a clock and a sink.

``surfhap render`` (offline), ``play``, ``serve``, the study runner, ``ff simulate`` and
``ff run`` all go through it (the force-feedback loop is a block of one frame at its 1 kHz
tick rate, :class:`surfhap.live.ff_loop.FFLoop`); only the clock and the sink differ:

* a wall clock (:class:`~surfhap.runtime.clock.WallClock`) paces one block per block period on
  absolute deadlines (no drift), buffered like a sound card: a block later than
  ``max(buffer, period)`` counts the periods it skipped as underruns (missed ticks) and the
  schedule is re-anchored on the same phase instead of bursting; ``now`` is the actual render
  time;
* a simulated clock (:class:`~surfhap.runtime.clock.SimClock`) runs as fast as possible:
  block ``b`` is emitted at ``b * frames / drive_rate`` s, and before it a replayed source
  (:class:`Replay`) delivers every sample stamped up to ``lead`` s past the block (default: a
  horizon past everything a texture block can compute from, so each sample is in force from
  the model sample at its stamp; 0 for a force-feedback tick, which takes what has arrived);
* an audio callback (:class:`~surfhap.runtime.clock.AudioClock`) calls ``engine.render`` itself
  from PortAudio's thread with the DAC time (:mod:`surfhap.live.backends.sound`).
"""

from __future__ import annotations

from typing import Callable, Protocol, runtime_checkable

import numpy as np

from surfhap.runtime.clock import Clock

__all__ = ["run", "BlockEngine", "BlockSink", "Replay"]


class BlockEngine(Protocol):
    """What the loop drives (:class:`surfhap.live.engine.LiveEngine`)."""

    drive_rate: int
    block_frames: int
    counters: dict

    def render(self, frames: int, now: float | None = None) -> np.ndarray: ...


class BlockSink(Protocol):
    def emit(self, volts: np.ndarray) -> None: ...


@runtime_checkable
class Replay(Protocol):
    """A source replayed on the loop's simulated clock (:class:`~surfhap.runtime.sources.TrajectorySource`)."""

    def deliver(self, until: float) -> None: ...


def run(source, engine: BlockEngine, clock: Clock, sink: BlockSink, *, frames: int | None = None,
        total_frames: int | None = None, keep_running: Callable[[], bool] | None = None,
        buffer: float = 0.005, lead: float | None = None) -> int:
    """Render blocks of ``frames`` (default the engine's block) into ``sink.emit`` until
    ``total_frames`` have been emitted (the last block cut to fit) or ``keep_running()`` is
    False; returns the frames emitted. ``source``: a :class:`Replay` fed on a simulated
    clock (its stamps on the clock's time base), or None (live sources push from their own
    threads)."""
    frames = int(frames or engine.block_frames)
    rate = engine.drive_rate
    period = frames / rate
    slack = max(buffer, period)
    replay = source if clock.simulated and isinstance(source, Replay) else None
    if lead is None:
        lead = 2.0 * period + 0.005  # s: past the last model sample a block can compute from
    t0 = clock.now()
    deadline = t0
    emitted = 0
    while (total_frames is None or emitted < total_frames) and (keep_running is None or keep_running()):
        n = frames if total_frames is None else min(frames, total_frames - emitted)
        if clock.simulated:
            t = t0 + emitted / rate
            clock.wait_until(t + lead)
            if replay is not None:
                replay.deliver(t + lead)
        else:
            t = clock.wait_until(deadline)
            if t - deadline > slack:  # re-anchor on the same phase: the periods skipped are missed
                skipped = int((t - deadline) / period)
                engine.counters["underruns"] += skipped
                deadline += skipped * period
            deadline += period
        sink.emit(engine.render(n, t))
        emitted += n
    return emitted
