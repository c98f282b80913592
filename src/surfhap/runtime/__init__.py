"""surfhap.runtime: the one runtime every command runs on.

A :class:`~surfhap.runtime.clock.Clock` (simulated, wall, audio callback), touch
:class:`~surfhap.runtime.protocols.Source` s, a :class:`~surfhap.runtime.protocols.Renderer`
with its :class:`~surfhap.runtime.protocols.Safety` stage, a
:class:`~surfhap.runtime.protocols.Sink`, typed engine commands, and
:func:`~surfhap.runtime.loop.run`, the one block loop (docs/architecture.md); replayed touch
sources are in :mod:`surfhap.runtime.sources`, the offline texture renders (``render``,
``stream_render``) in :mod:`surfhap.runtime.offline`.
"""

from surfhap.runtime.clock import AudioClock, Clock, SimClock, WallClock
from surfhap.runtime.commands import SetGain, Stop, SwapRenderer
from surfhap.runtime.loop import run
from surfhap.runtime.protocols import Renderer, Safety, Sink, Source

__all__ = ["Clock", "SimClock", "WallClock", "AudioClock", "Stop", "SetGain", "SwapRenderer", "run", "Renderer",
           "Safety", "Sink", "Source"]
