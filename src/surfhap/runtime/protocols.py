"""The contracts of the runtime: what :func:`surfhap.runtime.loop.run` connects.

* :class:`Renderer` - a block renderer (texture chain, shape chain): block in, block out,
  ``reset()``;
* :class:`Safety` - the safety contract every renderer's last stage and the engine's output
  pass keep (:mod:`surfhap.render.safety`: |V| <= v_max, rise limit, watchdog on the
  engine-stamped arrival, fail-to-zero ramp);
* :class:`Source` - where touch samples come from (a trajectory or a recording replayed at
  its stamps, OSC, the web page); it pushes them into a :class:`TouchSink` (the engine);
* :class:`Sink` - where the drive goes (simulated display, file, sound card, OSC): the
  backends of :mod:`surfhap.live.backends` and the offline recorders.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from surfhap.render.block import RenderBlock

__all__ = ["Renderer", "Safety", "TouchSink", "Source", "Sink", "ForceSensor"]


@runtime_checkable
class Safety(Protocol):
    """A safety stage: ``limits`` (:class:`~surfhap.render.safety.SafetyLimits`: v_max,
    rise rate, watchdog timeout, load limit), ``counters`` and ``reset()``."""

    @property
    def limits(self): ...

    @property
    def counters(self): ...

    def reset(self) -> None: ...


@runtime_checkable
class Renderer(Protocol):
    """A stateful block renderer for the runtime.

    control_rate, drive_rate : int Hz, rates of the inputs and of the drive.
    safety                 : its :class:`Safety` stage (the renderer's last processor).
    uses_position          : True when ``x``, ``y`` matter (shapes), False for textures.
    """

    control_rate: int
    drive_rate: int
    uses_position: bool

    @property
    def safety(self) -> Safety: ...

    def reset(self) -> None:
        """Back to silence with no finger; the sample clocks restart at 0."""

    def process(self, speed: np.ndarray, load: np.ndarray, touch_time: np.ndarray,
                x: np.ndarray | None = None, y: np.ndarray | None = None, display=None) -> RenderBlock:
        """One block: speed (n,) m/s, load (n,) N, touch_time (n,) s (time stamp of the
        freshest touch sample at each model sample, on the renderer's clock), x, y (n,) m
        finger position (page coordinates of the touch surface; ignored unless
        ``uses_position``). ``display``: a :class:`~surfhap.models.panel.SimulatedDisplay`
        fed with the block's drive and held load (inside the renderer's compiled call where
        it has one); its friction samples are the block's ``friction`` (None without)."""


class TouchSink(Protocol):
    """What a touch source pushes into (the engine): one validated sample, stamped by the
    receiver (``t_arrival`` may only make it older)."""

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan,
                   t_arrival: float | None = None) -> bool: ...


@runtime_checkable
class Source(Protocol):
    """A touch source. A live source (OSC, web page) runs its own thread between ``start()``
    and ``stop()``. The replay (:class:`~surfhap.runtime.sources.TrajectorySource`) also
    has ``deliver(until)``, pushing every sample stamped at or before ``until``, which
    :func:`~surfhap.runtime.loop.run` calls on a simulated clock."""

    def start(self) -> None: ...

    def stop(self) -> None: ...


@runtime_checkable
class Sink(Protocol):
    """Where the drive goes. ``start(engine)`` binds it; a sink driven by
    :func:`~surfhap.runtime.loop.run` gets every block through ``emit(volts)``; ``stop()``
    ramps and releases; ``info()`` a small dict for the status."""

    name: str
    drive_rate: int | None

    def start(self, engine) -> None: ...

    def stop(self, timeout: float = 1.0) -> None: ...

    def info(self) -> dict: ...


class ForceSensor(Protocol):
    """A force sensor the loop polls: ``read()`` returns the samples that arrived since the last call.

    Returns ``(t, normal, shear)``: three ``(n,) float`` arrays, ``t`` in s on the sensor's clock,
    ``normal`` and ``shear`` in N (``n`` may be 0).
    """

    name: str

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def close(self) -> None: ...
